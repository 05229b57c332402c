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
generalized-α at ρ∞ = 0.9 barely damps, under a large step) can wander, its corrections growing
and shrinking, before it converges quadratically. The test "a correction grew" fails such a step,
and a fixed-step integrator then splits it (h/4, h/2, h); the changed step sizes stir those
undamped stiff modes, the next predictors are worse, and one failure leads to more. Which
iteration first trips the test is decided by round-off, so the step sequence, and with it the
result, would depend on the CPU's floating-point arithmetic and would not be a smooth function of
the parameters. Without the test such steps converge. In an adaptive run the test stays on: a
step whose Newton wanders is usually too large for the error tolerance too, and a smaller step is
cheaper than the wander; there the step sequence is a tolerance-controlled choice anyway.
"""

from collections.abc import Callable
from typing import Any

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
    """A solve's result: the solution ``x``, the corrections computed, how it ended, and the
    last observed contraction ``rate`` = ‖Δ_k‖/‖Δ_{k−1}‖ (0 after a single correction). A
    stepping method adds how many iteration matrices it factored for the solve and, when it
    keeps one for the next step (``Newton(reuse=True)``), the ``IterationMatrix``."""

    x: Float[Array, " n"]
    iterations: Int[Array, ""]  # corrections computed (calls of ``update``)
    result: NewtonResult
    rate: Float[Array, ""]
    factorizations: Int[Array, ""] | int = 0
    matrix: Any = None

    @property
    def converged(self):
        return self.result == NewtonResult.converged


_CODES = (NewtonResult.converged, NewtonResult.max_iterations, NewtonResult.diverged, NewtonResult.nonfinite)


def newton(update: Callable, norm: Callable, x0, tol, max_iter: int, *, contraction_test: bool = False,
           divergence_test: bool = False, max_rate: float | None = None, prepare: Callable | None = None
           ) -> NewtonSolution:
    """Solve r(x) = 0 from ``x0`` (see the module docstring). Works under ``jit``, ``vmap`` and
    forward-mode differentiation. ``max_rate``: also fail (as diverged) when a correction is more
    than this fraction of the one before (a kept iteration matrix that no longer fits).

    ``prepare``: what the residual needs of x (a step's positions and velocities from its
    acceleration), computed once after each correction and carried by the loop; ``update`` is
    then called as ``update(x, prepare(x))``. Carried, it is an array in memory that the
    residual's kernels read; computed inside them, XLA's CPU backend recomputes it in each
    kernel that reads it, once for every element read (the packed cubic force reads each modal
    coordinate hundreds of times)."""

    def cond(s):
        return s[3] == 0

    def body(s):
        (x, aux), prev, i, _, _ = s
        d = update(x) if prepare is None else update(x, aux)
        x = x - d
        aux = None if prepare is None else prepare(x)
        n = norm(d)
        theta = n / prev
        done = n < tol
        if contraction_test:
            left = theta / jnp.maximum(1.0 - theta, 1e-16) * n  # the error this correction leaves
            done = done | ((i >= 1) & (theta < 1.0) & (left < tol))
        i = i + 1
        diverged = ((i >= 3) & (theta > 1.0)) if divergence_test else False
        if max_rate is not None:
            diverged = diverged | ((i >= 2) & (theta > max_rate) & ~done)
        # status: 0 iterating, then 1 + the index of the ending in _CODES
        status = jnp.where(done, 1, jnp.where(~jnp.isfinite(n), 4, jnp.where(diverged, 3,
                                                                             jnp.where(i >= max_iter, 2, 0))))
        return (x, aux), n, i, status, theta

    inf = jnp.asarray(jnp.inf, x0.dtype)
    s0 = ((x0, None if prepare is None else prepare(x0)), inf, jnp.array(0), jnp.array(0), jnp.zeros((), x0.dtype))
    (x, _), _, iters, status, rate = lax.while_loop(cond, body, s0)
    result = NewtonResult.converged
    for k, code in enumerate(_CODES):
        result = NewtonResult.where(status == k + 1, code, result)
    return NewtonSolution(x=x, iterations=iters, result=result, rate=jnp.where(jnp.isfinite(rate), rate, 0.0))


__all__ = ["NewtonResult", "NewtonSolution", "newton"]
