"""Newton's method inside ``jit``: the solve of each integrator step, with its result codes.

The caller gives ``update(x)``, the Newton correction Δ at x (the next iterate is ``x − Δ``;
full Newton: ``J(x)⁻¹ r(x)``, modified Newton: ``J₀⁻¹ r(x)`` with J₀ factored once), and
``norm(Δ)``, the correction's size in units of the step's error tolerance.

Stopping: the applied correction's size below ``tol``; with ``contraction_test`` also, from the
second correction on, the error that the last correction leaves, estimated from the observed
contraction θ = ‖Δ_k‖/‖Δ_{k−1}‖ as θ/(1 − θ)·‖Δ_k‖ (Hairer & Wanner, *Solving ODEs II*, §IV.8).
Failure: ``max_iter`` corrections, a non-finite correction, or, with ``divergence_test``, a
correction larger than the one before from the third on. Each ending has a ``NewtonResult``.

Why ``divergence_test`` is a choice, and off in fixed-step runs: Newton from a predictor outside
its region of fast convergence (the stiff cross-section and axial modes of a beam, which
generalized-α at ρ∞ = 0.9 barely damps, under a large step) wanders before it converges: on the
2-element beam spun to 3 rad/s in 2 s at h = 0.05 s, corrections such as 4785, 1011, 763, 321,
959, … in units of the tolerance, then quadratic convergence, up to 20 corrections in a step.
The test "a correction grew" failed such steps, and the integrator split them (h/4, h/2, h).
The splitting changed the step sizes, which stirred those undamped stiff modes: the next
predictors were worse (first corrections of 146 and 203 after the split at t = 0.85 s, against 30
and 75 without it), so one failure led to more. Which iteration first tripped the test was decided
by round-off: the same run took 121 steps, 42 rejected and 730 Newton iterations with AVX-512
arithmetic, and 590-808 steps, 278-388 rejected and 4124-5882 iterations with AVX2 (FMA) or
SSE arithmetic (``XLA_FLAGS=--xla_cpu_max_isa=...``), varying with the spin rate in its sixth
digit; its loss was not a smooth function of the spin rate. Without the test, every step of
that run converges with each of those arithmetics (60 steps, none rejected). In an adaptive run
the test stays on: a step whose Newton wanders is usually too large for the error tolerance
too, and a smaller step is cheaper than the wander; there the step sequence is a
tolerance-controlled choice anyway.
"""

from collections.abc import Callable

import equinox as eqx
import jax.numpy as jnp
from jax import lax

from .._types import Array, Float, Int


class NewtonResult(eqx.Enumeration):
    """How a Newton solve ended."""

    converged = ""
    max_iterations = "Newton did not converge within its maximum number of corrections"
    diverged = "Newton's corrections grew from the third on"
    nonfinite = "Newton met a non-finite correction"


class NewtonSolution(eqx.Module):
    x: Float[Array, " n"]
    iterations: Int[Array, ""]  # corrections computed (calls of ``update``)
    result: NewtonResult

    @property
    def converged(self):
        return self.result == NewtonResult.converged


_CODES = (NewtonResult.converged, NewtonResult.max_iterations, NewtonResult.diverged, NewtonResult.nonfinite)


def newton(update: Callable, norm: Callable, x0, tol, max_iter: int, *, contraction_test: bool = False,
           divergence_test: bool = False) -> NewtonSolution:
    """Solve r(x) = 0 from ``x0`` (see the module docstring). Works under ``jit``, ``vmap`` and
    forward-mode differentiation."""

    def cond(s):
        return s[3] == 0

    def body(s):
        x, prev, i, _ = s
        d = update(x)
        x = x - d
        n = norm(d)
        theta = n / prev
        done = n < tol
        if contraction_test:
            left = theta / jnp.maximum(1.0 - theta, 1e-16) * n  # the error this correction leaves
            done = done | ((i >= 1) & (theta < 1.0) & (left < tol))
        i = i + 1
        diverged = ((i >= 3) & (theta > 1.0)) if divergence_test else False
        # status: 0 iterating, then 1 + the index of the ending in _CODES
        status = jnp.where(done, 1, jnp.where(~jnp.isfinite(n), 4, jnp.where(diverged, 3,
                                                                             jnp.where(i >= max_iter, 2, 0))))
        return x, n, i, status

    s0 = (x0, jnp.asarray(jnp.inf, x0.dtype), jnp.array(0), jnp.array(0))
    x, _, iters, status = lax.while_loop(cond, body, s0)
    result = NewtonResult.converged
    for k, code in enumerate(_CODES):
        result = NewtonResult.where(status == k + 1, code, result)
    return NewtonSolution(x=x, iterations=iters, result=result)


__all__ = ["NewtonResult", "NewtonSolution", "newton"]
