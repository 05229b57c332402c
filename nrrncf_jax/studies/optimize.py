"""The one quasi-Newton driver of the studies (identification, spin-up control): L-BFGS directions
from optax, step lengths by Armijo backtracking on the host.

Both studies minimise a loss whose every evaluation is a whole simulation with its reverse-mode
(or forward-mode) gradient, compiled once ahead of time (``jit(...).lower(...).compile()``). The
driver only ever calls that one compiled function, with concrete arrays:

- **Direction**: ``optax.scale_by_lbfgs`` (the two-loop recursion, its memory and its first-step
  scaling), used as is.
- **Step length**: hand-written Armijo backtracking (``armijo_backtracking``), for two things
  optax's line searches (``scale_by_backtracking_linesearch``, ``scale_by_zoom_linesearch``, and
  ``optax.lbfgs`` which chains the latter) do not offer here. (1) They call the loss inside their
  own ``lax.while_loop``, so the (long) simulation and its gradient would be traced and compiled
  again into each line search, not reused from the one ahead-of-time compiled function (which
  takes no tracers). (2) A trial point where the simulation fails (a much softer beam at the same
  tolerances: ``SimulationError``, equinox's runtime error from inside the compiled loss, or a
  non-finite loss) raises on the host; inside a compiled loop it would end the optimisation. Here
  such a trial counts as no decrease and the step is halved.
"""

import dataclasses
from collections.abc import Callable
from typing import Any

import jax.numpy as jnp
import numpy as np
import optax

Evaluate = Callable[[Any], tuple[float, Any, Any]]
"""``evaluate(x) -> (f(x), ∇f(x), aux)``: the loss as a Python float, its gradient (an array of
x's shape) and anything the caller wants back for an accepted point (e.g. the response)."""

FAILED_TRIAL = (RuntimeError, FloatingPointError)
"""What ``evaluate`` may raise at a trial point for the point to count as no decrease:
``SimulationError`` and ``jax.errors.JaxRuntimeError`` (equinox's runtime errors) are
``RuntimeError``; a caller raises ``FloatingPointError`` for a non-finite loss or gradient."""


@dataclasses.dataclass
class LbfgsRun:
    """Where ``lbfgs`` stopped: the last accepted point and how it got there.

    ``stop`` says why: ``"gtol"`` (‖∇f‖ below ``gtol``, or exactly zero), ``"ftol"`` (an iteration
    lowered f by at most ``ftol`` relative), ``"line search"`` (no trial of the last line search
    decreased f enough: converged as far as the loss is resolved), ``"iterations"``.
    ``evaluations`` counts the line searches' trials, failed ones included."""

    x: Any
    value: float
    grad: Any
    aux: Any
    iterations: int
    evaluations: int
    stop: str


@dataclasses.dataclass(frozen=True)
class AdamLbfgs:
    """The gradient studies' optimiser (``identification.identify``, ``control.optimal_spinup``):
    ``adam_steps`` of optax's Adam at learning rate ``adam_lr``, then up to ``lbfgs_steps`` of
    L-BFGS (``lbfgs``: optax's direction, Armijo backtracking), which stops when ‖∇x‖ < ``gtol``,
    when an iteration lowers the loss by less than ``ftol`` (relative; None: never), or when no
    step along its direction lowers it. Checked when made."""

    adam_steps: int = 20
    adam_lr: float = 0.05
    lbfgs_steps: int = 30
    gtol: float = 1e-10
    ftol: float | None = 1e-7

    def __post_init__(self):
        for name in ("adam_steps", "lbfgs_steps"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
                raise ValueError(f"AdamLbfgs.{name} must be an integer >= 0, got {value!r}")
        if not (np.isfinite(self.adam_lr) and self.adam_lr > 0):
            raise ValueError(f"AdamLbfgs.adam_lr must be finite and > 0, got {self.adam_lr!r}")
        for name in ("gtol", "ftol"):
            value = getattr(self, name)
            if not (value is None and name == "ftol") and not (np.isfinite(value) and value >= 0):
                raise ValueError(f"AdamLbfgs.{name} must be finite and >= 0, got {value!r}")


def armijo_backtracking(evaluate: Evaluate, x, value: float, step, slope: float, *, c1: float = 1e-4,
                        shrink: float = 0.5, max_tries: int = 20):
    """The step length of a line search by Armijo backtracking: the first ``α = shrink^k``
    (k = 0, 1, ...) with ``f(x + α·step) ≤ f(x) + c1·α·slope``, where ``slope = ∇f(x)·step < 0``.
    Returns ``((x_try, f(x_try), ∇f(x_try), aux), tries)``, or ``(None, max_tries)`` when no trial
    decreases f enough.

    A trial point where ``evaluate`` raises one of ``FAILED_TRIAL`` (a simulation that stops early,
    a non-finite loss), or returns a non-finite loss, counts as no decrease: the step is shortened
    instead of ending the optimisation."""
    alpha = 1.0
    for tries in range(1, max_tries + 1):
        x_try = x + alpha * step
        try:
            v_try, g_try, aux = evaluate(x_try)
        except FAILED_TRIAL:
            v_try, g_try, aux = np.inf, None, None
        if v_try <= value + c1 * alpha * slope:  # False for NaN and inf
            return (x_try, v_try, g_try, aux), tries
        alpha *= shrink
    return None, max_tries


def lbfgs(evaluate: Evaluate, x, value: float, grad, aux=None, *, max_iterations: int, gtol: float = 0.0,
          ftol: float | None = None, max_tries: int = 20, c1: float = 1e-4, shrink: float = 0.5,
          on_step: Callable | None = None) -> LbfgsRun:
    """Minimise f from ``x`` (an array of any shape), where ``value``, ``grad`` (and ``aux``) are
    ``evaluate(x)``, by up to ``max_iterations`` L-BFGS iterations.

    Each iteration stops first if ‖∇f‖ < ``gtol``; takes the direction of ``optax.scale_by_lbfgs``
    (default memory 10; its first step is steepest descent of length at most 1); should that not be
    a descent direction (the curvature pairs of a non-convex loss can make it so), clears the memory
    and takes that first step instead; finds the step length by ``armijo_backtracking`` (at most
    ``max_tries`` trials, ``c1``, ``shrink``), ending the run when none is found; accepts the point,
    calls ``on_step(iteration, x, value, grad, aux)`` (iteration counts from 1), and ends the run if
    f fell by at most ``ftol``·f (relative; ``None``: no such test).
    """
    direction_of = optax.scale_by_lbfgs()
    state = direction_of.init(x)
    iterations = evaluations = 0
    stop = "iterations"
    for _ in range(int(max_iterations)):
        gnorm = float(jnp.linalg.norm(grad))
        if gnorm < gtol or gnorm == 0.0:
            stop = "gtol"
            break
        direction, state = direction_of.update(grad, state, x)
        step = -direction
        slope = float(jnp.vdot(grad, step))
        if not slope < 0.0:
            # Restart: fresh memory, and the step optax takes first (steepest descent scaled by
            # min(1, 1/‖∇f‖)); the memory fills again from the next iteration on.
            state = direction_of.init(x)
            step = -grad * min(1.0, 1.0 / gnorm)
            slope = float(jnp.vdot(grad, step))
        found, tries = armijo_backtracking(evaluate, x, value, step, slope, c1=c1, shrink=shrink,
                                           max_tries=max_tries)
        evaluations += tries
        if found is None:
            stop = "line search"
            break
        previous = value
        x, value, grad, aux = found
        iterations += 1
        if on_step is not None:
            on_step(iterations, x, value, grad, aux)
        if ftol is not None and previous - value <= ftol * previous:
            stop = "ftol"
            break
    return LbfgsRun(x=x, value=value, grad=grad, aux=aux, iterations=iterations, evaluations=evaluations,
                    stop=stop)
