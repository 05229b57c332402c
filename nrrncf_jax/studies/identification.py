"""Parameter identification: fit E, a damping ratio and the spin-up (ωs, Ts) to a measured
response by gradient descent through the reduced simulation (optax Adam, then L-BFGS).

The model is a *family* (``families.py``): a function from parameters to a reduced model,
either with the basis held fixed or rebuilt through the offline stage. Reverse-mode gradients
run the checkpointed integrator (``simulate(adjoint="reverse")``): memory grows with the
number of checkpoints, not with the number of steps.
"""

import dataclasses
import time
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optax

from .._progress import note
from .._types import Array, Float
from ..integrate import AbstractStepSizeController, AdaptiveStepSize, GeneralizedAlpha, Newton
from ..integrate.simulate import simulate
from ..models.observe import beam_tip
from ..reduction.reduced_model import ReducedRotatingModel
from .families import OFFLINE_PARAMETERS, PARAMETERS, OfflineSpinupFamily, check_params
from .optimize import AdamLbfgs, lbfgs


class Measurement:
    """A measured response: sample times ``ts`` (strictly increasing, ≥ 0) and ``values``
    (first axis along ``ts``), checked before any tracing."""

    def __init__(self, ts, values):
        ts = np.asarray(ts, dtype=float)
        values = np.asarray(values, dtype=float)
        if ts.ndim != 1 or ts.size < 2:
            raise ValueError(f"measurement times must be a 1-D array of at least 2 samples, got shape {ts.shape}")
        if not np.all(np.isfinite(ts)):
            raise ValueError("measurement times contain NaN or Inf")
        if ts[0] < 0.0 or not np.all(np.diff(ts) > 0.0):
            raise ValueError("measurement times must start at t >= 0 and be strictly increasing")
        if values.ndim == 0 or values.shape[0] != ts.size:
            raise ValueError(f"measurement values must have {ts.size} samples along their first axis (one per "
                             f"time), got shape {values.shape}")
        if not np.all(np.isfinite(values)):
            raise ValueError("measurement values contain NaN or Inf")
        if not np.any(values != 0.0):
            raise ValueError("measurement values are all zero: nothing to fit")
        self.ts = ts
        self.values = values


class TipDeflection(eqx.Module):
    """One component of the tip displacement in the rotating frame (0 axial, 1 in-plane transverse,
    2 out of plane), from the displacements ``w = q − q̂`` (docs/theory.md, §9 Accuracy measures and
    checks)."""

    row: int = eqx.field(static=True)
    component: int = eqx.field(static=True)

    def __call__(self, w: Float[Array, "n 3"]) -> Float[Array, ""]:
        return w[self.row, self.component]


def tip_deflection(model: ReducedRotatingModel, component: int = 1) -> TipDeflection:
    """The tip's position vector (the last node's r) of a beam model, one component."""
    if component not in (0, 1, 2):
        raise ValueError(f"component must be 0, 1 or 2, got {component!r}")
    return TipDeflection(row=beam_tip(model), component=component)


class Observation(eqx.Module):
    """``observe(t, p, v)`` for ``simulate``: an observable of the displacements w = q − q̂."""

    model: ReducedRotatingModel
    observable: Callable

    def __call__(self, t, p, v):
        return self.observable(self.model.displacements(t, p))


@dataclasses.dataclass
class IdentificationResult:
    """What ``identify`` found: parameters, the loss history (one entry per iteration) and cost."""

    params: dict
    initial: dict
    loss_history: np.ndarray
    adam_iterations: int
    lbfgs_iterations: int
    loss_evaluations: int
    wall_s: float
    compile_s: float
    gradient: str

    @property
    def iterations(self) -> int:
        return self.adam_iterations + self.lbfgs_iterations


def misfit(family, params: dict, measurement: Measurement, *, observable: Callable | None = None,
           solver: GeneralizedAlpha | None = None, controller: AbstractStepSizeController | None = None,
           newton: Newton | None = None, max_steps: int = 100_000, adjoint: str = "reverse"):
    """The relative mean-square misfit ``Σ(y(tᵢ) − yᵢ)² / Σ yᵢ²`` of the model ``family(params)``
    against ``measurement``; differentiable in ``params`` (``jax.grad``; ``adjoint="reverse"``
    runs the checkpointed integrator). ``observable`` maps the displacements w = q − q̂ to one
    sample (default: the in-plane tip deflection). ``solver``, ``controller``, ``newton``:
    ``simulate``'s (default ``GeneralizedAlpha(0.9)``, ``AdaptiveStepSize(1e-6, 1e-9)``,
    ``Newton(1e-3)``); a ``ConstantStepSize`` takes fixed steps, so that finite differences of
    the misfit see no step-size changes."""
    solver = GeneralizedAlpha(0.9) if solver is None else solver
    controller = AdaptiveStepSize(1e-6, 1e-9) if controller is None else controller
    newton = Newton(1e-3) if newton is None else newton
    ts = measurement.ts  # NumPy: stays concrete inside a trace (the integrator checks it and sizes dt0 from it)
    data = jnp.asarray(measurement.values)
    observable = tip_deflection(family.template) if observable is None else observable
    model = family(params)
    y = simulate(model, solver, controller, ts, adjoint=adjoint, max_steps=max_steps, newton=newton,
                 observe=Observation(model, observable)).ys
    return jnp.sum((y - data) ** 2) / jnp.sum(data**2)


def identify(family, measurement: Measurement, initial: dict, *, observable: Callable | None = None,
             optimizer: AdamLbfgs = AdamLbfgs(), progress: bool = False, **simulation) -> IdentificationResult:
    """Fit the parameters named in ``initial`` (a dict, e.g. ``{"E": 9e10, "zeta": 0.03}``) by
    minimising ``misfit`` (``simulation``: its keyword arguments, e.g. ``controller``).

    Parameters are optimised as ``u = log(x / x_initial)`` (positive by construction, all of
    order one) by ``optimizer`` (an ``AdamLbfgs``: Adam, then L-BFGS whose trial points where the
    simulation fails shorten the step). ``wall_s`` includes ``compile_s``. Gradients are
    reverse-mode through the checkpointed integrator; the step-size control is not
    differentiated (each step's Newton solve is, implicitly).
    A non-finite loss or gradient stops it with ``FloatingPointError`` naming the parameters
    (at an L-BFGS trial point it shortens the step instead).
    ``progress=True`` prints the compilation and each iteration (loss, parameters) on stderr.
    """
    if not isinstance(optimizer, AdamLbfgs):
        raise ValueError(f"optimizer must be an AdamLbfgs, got {type(optimizer).__name__}")
    adam_steps, lbfgs_steps = optimizer.adam_steps, optimizer.lbfgs_steps
    if not isinstance(measurement, Measurement):
        raise ValueError("measurement must be a Measurement(ts, values)")
    if not initial:
        raise ValueError("initial must name at least one parameter to identify")
    allowed = OFFLINE_PARAMETERS if isinstance(family, OfflineSpinupFamily) else PARAMETERS
    check_params(initial, allowed)
    names = tuple(sorted(initial))
    x0 = jnp.asarray([float(initial[k]) for k in names])
    data = jnp.asarray(measurement.values)
    observable = tip_deflection(family.template) if observable is None else observable
    y_probe = jax.eval_shape(lambda: observable(jnp.zeros_like(family.template.q_hat))).shape
    if tuple(y_probe) != data.shape[1:]:
        raise ValueError(f"the observable gives shape {tuple(y_probe)} per sample, the measurement "
                         f"{data.shape[1:]}")

    def loss(u):
        return misfit(family, dict(zip(names, x0 * jnp.exp(u))), measurement, observable=observable, **simulation)

    # One compiled loss-and-gradient serves every Adam step and every L-BFGS line-search trial
    # (``optimize.lbfgs``: optax's L-BFGS direction, Armijo backtracking on the host).
    value_and_grad = eqx.filter_jit(jax.value_and_grad(loss))
    t0 = time.perf_counter()
    u = jnp.zeros(len(names))
    note(progress, f"identify {', '.join(names)}: compiling the loss and its reverse-mode gradient ...")
    tc = time.perf_counter()
    value_and_grad = value_and_grad.lower(u).compile()
    compile_s = time.perf_counter() - tc
    note(progress, f"compiled in {compile_s:.1f} s; {int(adam_steps)} Adam steps, then up to {int(lbfgs_steps)} L-BFGS")

    def evaluate(u):
        value, grad = value_and_grad(u)
        value = float(value)
        _check_finite(value, grad, names, x0 * jnp.exp(u))
        return value, grad, None

    history, evals = [], 0
    adam = optax.adam(optimizer.adam_lr)
    state = adam.init(u)
    for i in range(int(adam_steps)):
        value, grad, _ = evaluate(u)
        evals += 1
        history.append(value)
        updates, state = adam.update(grad, state, u)
        u = optax.apply_updates(u, updates)
        note(progress, f"adam  {i + 1:3d}  loss {value:.4e}  " + _fmt(names, x0 * jnp.exp(u)))

    def on_step(iteration, u, value, grad, aux):
        history.append(value)
        note(progress, f"lbfgs {iteration:3d}  loss {value:.4e}  " + _fmt(names, x0 * jnp.exp(u)))

    value, grad, _ = evaluate(u)
    evals += 1
    run = lbfgs(evaluate, u, value, grad, max_iterations=int(lbfgs_steps), gtol=optimizer.gtol, ftol=optimizer.ftol,
                on_step=on_step)
    u, evals, n_lbfgs = run.x, evals + run.evaluations, run.iterations
    x = np.asarray(x0 * jnp.exp(u))
    return IdentificationResult(
        params={k: float(v) for k, v in zip(names, x)}, initial={k: float(initial[k]) for k in names},
        loss_history=np.asarray(history), adam_iterations=int(adam_steps), lbfgs_iterations=n_lbfgs,
        loss_evaluations=evals, wall_s=time.perf_counter() - t0, compile_s=compile_s,
        gradient="offline" if isinstance(family, OfflineSpinupFamily) else "fixed_basis",
    )


def _fmt(names, x) -> str:
    return "  ".join(f"{k} {float(v):.6g}" for k, v in zip(names, x))


def _check_finite(value, grad, names, x) -> None:
    if not np.isfinite(value) or not bool(jnp.all(jnp.isfinite(grad))):
        raise FloatingPointError(f"non-finite loss or gradient at {_fmt(names, x)} (loss {value}, gradient "
                                 f"{np.asarray(grad)}): the simulation or its derivative broke down")
