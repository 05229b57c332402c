"""The generalized-α method (docs/theory.md, §8 Time integration): coefficients, kinematics, and the step.

Arnold-Brüls form: the equations hold at t_{n+1} with the true acceleration a_{n+1}; an
auxiliary acceleration ā carries the α-weighting,

    (1 − α_m) ā_{n+1} + α_m ā_n = (1 − α_f) a_{n+1} + α_f a_n
    q_{n+1} = q_n + h v_n + h²(½ − β) ā_n + h² β ā_{n+1}
    v_{n+1} = v_n + h(1 − γ) ā_n + h γ ā_{n+1}

so that with a_{n+1} as the Newton unknown, ∂q/∂a = h²β(1−α_f)/(1−α_m) and
∂v/∂a = hγ(1−α_f)/(1−α_m). Second order for every ρ∞ ∈ [0, 1]; for ρ∞ = 1 and linear
problems it conserves energy exactly.

As a solver of the adaptive loop (``base.AbstractSolver``): ``init`` finds the
consistent initial acceleration, ``step`` solves for a_{n+1} by Newton and returns the new
state with the local error estimate of q.
"""

from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
from jax import lax

from .._types import Array, Float, Scalar
from ..models.constrained import AbstractConstrainedModel
from .base import AbstractSolver, GeneralizedAlphaState, IterationMatrix, NewtonOptions
from .newton import NewtonResult, NewtonSolution
from .newton import newton as newton_iteration


def _rho_inf(rho_inf) -> Float[Array, ""]:
    if not isinstance(rho_inf, jax.core.Tracer) and not (0.0 <= float(rho_inf) <= 1.0):
        raise ValueError(f"rho_inf must lie in [0, 1], got rho_inf={float(rho_inf)!r}")
    return jnp.asarray(rho_inf, dtype=float)


KEPT_MAX_RATE = 0.5
"""A solve with a kept iteration matrix (``Newton(reuse=True)``) gives up when a correction is
more than this fraction of the one before: the matrix is factored afresh instead of iterating on.
(Fixed-step runs allow 50 corrections: without the limit a kept matrix that no longer fits could
spend them all before the step is solved afresh.)"""


def _not_run(shapes) -> NewtonSolution:
    """A ``NewtonSolution`` of the given structure that did not converge (a solve not tried)."""
    sol = jax.tree_util.tree_map(lambda x: jnp.zeros(x.shape, x.dtype), shapes)
    return eqx.tree_at(lambda s: s.result, sol, NewtonResult.max_iterations)


class AbstractGeneralizedAlpha(AbstractSolver):
    """Chung-Hulbert parameters from the spectral radius at infinity ρ∞ ∈ [0, 1] and the
    generalized-α kinematics (docs/theory.md, §8 Time integration), shared by the unconstrained step
    (``GeneralizedAlpha``) and the index-3 step of constrained systems (``GeneralizedAlphaIndex3``).

    ρ∞ is an array, so runs with different ρ∞ share one compilation (and can be vmapped).
    """

    rho_inf: eqx.AbstractVar[Float[Array, ""]]

    @property
    def alpha_m(self) -> float:
        r = self.rho_inf
        return (2.0 * r - 1.0) / (r + 1.0)

    @property
    def alpha_f(self) -> float:
        r = self.rho_inf
        return r / (r + 1.0)

    @property
    def gamma(self) -> float:
        return 0.5 + self.alpha_f - self.alpha_m

    @property
    def beta(self) -> float:
        return 0.25 * (self.gamma + 0.5) ** 2

    def kinematics(self, h, q, v, a, abar, a1):
        """``(q1, v1, abar1)`` given the new true acceleration ``a1``."""
        am, af, g, b = self.alpha_m, self.alpha_f, self.gamma, self.beta
        abar1 = ((1.0 - af) * a1 + af * a - am * abar) / (1.0 - am)
        q1 = q + h * v + h**2 * ((0.5 - b) * abar + b * abar1)
        v1 = v + h * ((1.0 - g) * abar + g * abar1)
        return q1, v1, abar1

    def derivatives(self, h):
        """``(∂v/∂a, ∂q/∂a)`` of the step: the iteration matrix weights c_C and c_K."""
        s = (1.0 - self.alpha_f) / (1.0 - self.alpha_m)
        return h * self.gamma * s, h**2 * self.beta * s

    def error_estimate(self, h, a, a1):
        """Local error of q, Zienkiewicz-Xie: ``h²(β − 1/6)(a_{n+1} − a_n)``."""
        return h**2 * (self.beta - 1.0 / 6.0) * (a1 - a)

    @staticmethod
    def _modified(newton: NewtonOptions, matrix: IterationMatrix | None, h, build: Callable, solve: Callable):
        """Modified Newton's solve: ``(solution, factor, fresh)``. ``build()`` factors the step's
        iteration matrix; ``solve(factor, max_rate)`` runs Newton with it (``newton.newton``).

        Without reuse: one factorisation, one solve. With ``Newton(reuse=True)``, where
        ``newton.keep`` allows: first the solve with the kept factor, which gives up as soon as
        a correction contracts by less than ``KEPT_MAX_RATE``; if it does not converge, the
        matrix is factored at the predictor and the step solved again from the start, so that
        the step's result does not depend on whether a kept matrix was tried. ``lax.cond``: a
        kept factor skips the assembly and factorisation (under ``vmap`` both branches run, so
        a batch gains nothing from reuse)."""
        if not newton.reuse or matrix is None:
            fac = build()
            return solve(fac, None), fac, jnp.asarray(True)
        keep = newton.keep(matrix, h)
        tried = lax.cond(keep, lambda: solve(matrix.factor, KEPT_MAX_RATE),
                         lambda: _not_run(jax.eval_shape(lambda: solve(matrix.factor, KEPT_MAX_RATE))))
        fresh = ~tried.converged
        fac = lax.cond(fresh, build, lambda: matrix.factor)
        sol = lax.cond(fresh, lambda: solve(fac, None), lambda: tried)
        sol = eqx.tree_at(lambda s: s.iterations, sol, sol.iterations + jnp.where(fresh, tried.iterations, 0))
        return sol, fac, fresh

    @staticmethod
    def _account(sol: NewtonSolution, newton: NewtonOptions, matrix: IterationMatrix | None, factor, fresh, h
                 ) -> NewtonSolution:
        """The solve's factorisations, and with reuse the ``IterationMatrix`` for the next step:
        ``factor`` (which may be the kept one updated, e.g. with the step's new constraints),
        valid while its solve converged at a contraction no worse than ``newton.reuse_rate``."""
        if newton.variant == "full":
            return eqx.tree_at(lambda s: s.factorizations, sol, sol.iterations)
        nfac = fresh.astype(int)
        if not newton.reuse:
            return eqx.tree_at(lambda s: s.factorizations, sol, nfac)
        h_fac = h if matrix is None else jnp.where(fresh, h, matrix.h)
        valid = sol.converged & (sol.rate <= newton.reuse_rate)
        kept = IterationMatrix(factor, jnp.asarray(h_fac, float), valid)
        return eqx.tree_at(lambda s: (s.factorizations, s.matrix), sol, (nfac, kept),
                           is_leaf=lambda x: x is None)

    def matrix_shape(self, model, t, state: GeneralizedAlphaState):
        """The structure (``jax.ShapeDtypeStruct`` leaves) of the factored iteration matrix a
        step builds, for the loop's first carry with ``Newton(reuse=True)``."""
        return jax.eval_shape(lambda: self._build(model, t, state, 1.0, 1.0))

    def _build(self, model, t, state, c_C, c_K):
        return model.factor_iteration_matrix(t, state.q, state.v, 1.0, c_C, c_K)

    def _stage(self, model, t1, h, state: GeneralizedAlphaState) -> Callable:
        """(q1, v1, a1, ā1) of the step as functions of the new acceleration a1."""
        q, v, a, abar = state.q, state.v, state.a, state.abar

        def stage(a1):
            q1, v1, abar1 = self.kinematics(h, q, v, a, abar, a1)
            q1, v1, a1 = model.constrain(t1, q1, v1, a1)
            return q1, v1, a1, abar1

        return stage


class GeneralizedAlpha(AbstractGeneralizedAlpha):
    """The generalized-α step (docs/theory.md, §8 Time integration) for unconstrained models
    (prescribed coordinates only): ``init`` finds the consistent initial acceleration, ``step``
    solves for a_{n+1} by Newton."""

    rho_inf: Float[Array, ""]

    def __init__(self, rho_inf=0.9):
        self.rho_inf = _rho_inf(rho_inf)

    def check(self, model) -> None:
        if isinstance(model, AbstractConstrainedModel):
            raise ValueError(f"{type(model).__name__} has joint constraints: it needs a constrained solver "
                             "(GeneralizedAlphaIndex3); GeneralizedAlpha would ignore its joints")

    def init(self, model, t0: Scalar, q0: Float[Array, " n"], v0: Float[Array, " n"]) -> GeneralizedAlphaState:
        """The state at ``t0``: prescribed coordinates imposed, and the consistent acceleration
        M a0 = −g(t0, q0, v0) (so ā0 = a0); no multipliers."""
        q0, v0, _ = model.constrain(t0, q0, v0, jnp.zeros_like(q0))
        z = jnp.zeros_like(q0)
        fac0 = model.factor_iteration_matrix(t0, q0, v0, 1.0, 0.0, 0.0)
        a0 = -fac0.solve(model.residual(t0, q0, v0, z))
        _, _, a0 = model.constrain(t0, q0, v0, a0)
        return GeneralizedAlphaState(q0, v0, a0, a0)

    def step(self, model, t0: Scalar, t1: Scalar, state: GeneralizedAlphaState, newton: NewtonOptions,
             norm: Callable[[Float[Array, " n"]], Scalar], *, h: Scalar | None = None,
             matrix: IterationMatrix | None = None) -> tuple[GeneralizedAlphaState, Float[Array, " n"], NewtonSolution]:
        """One step to ``t1`` of size ``h`` (default ``t1 − t0``): Newton on r(a_{n+1}) = 0 with
        the equations at ``t1``, from the predictor a_{n+1} = a_n. Returns ``(state1, error,
        solution)``: the state at ``t1``, the local error estimate of q (``error_estimate``) and
        the Newton solution (see ``base.AbstractSolver`` for the contract and ``matrix``).

        Under ``newton.implicit`` (reverse mode) the solve runs on stop-gradient inputs and the
        solution gets the implicit derivative: the tangent of one Newton update at the solution,
        with the gradient of the residual with respect to the parameters and the previous state
        and the iteration matrix at the solution (da1/dθ = −J⁻¹ ∂r/∂θ). Only its tangent is
        added (δ − sg(δ) is exactly zero), so the values equal those of the plain step.
        """
        h = t1 - t0 if h is None else h
        if newton.implicit:
            sg = lax.stop_gradient
            sol, _, c_C, c_K = self._solve(sg(model), t1, h, sg(state), newton, norm, None)
            a1 = sg(sol.x)
            stage = self._stage(model, t1, h, state)
            q1s, v1s, _, _ = stage(a1)
            fac_star = sg(model).factor_iteration_matrix(t1, sg(q1s), sg(v1s), 1.0, c_C, c_K)
            delta = fac_star.solve(model.residual(t1, q1s, v1s, a1))
            a1 = a1 + (sg(delta) - delta)
        else:
            sol, stage, _, _ = self._solve(model, t1, h, state, newton, norm, matrix)
            a1 = sol.x
        q1, v1, a1, abar1 = stage(a1)
        state1 = GeneralizedAlphaState(q1, v1, a1, abar1, state.lam)
        return state1, self.error_estimate(h, state.a, a1), sol

    def _solve(self, model, t1, h, state: GeneralizedAlphaState, newton: NewtonOptions, norm: Callable,
               matrix: IterationMatrix | None):
        """Solve r(a1) = 0 for the step's true acceleration by damped Newton (``newton.py``),
        modified or full, from the predictor a1 = a; returns ``(solution, stage, c_C, c_K)``.

        Modified: the iteration matrix is factored once, at the predictor (or kept from the
        last step, ``Newton(reuse=True)``). Full: each
        correction comes from one ``model.newton_update`` call (residual and factor at the
        iterate), and the solve also stops on the error its last correction leaves, estimated
        from the observed contraction (23-DOF reduced spin-up at 40 rad/s: fewer iterations,
        same steps). Modified Newton keeps the plain test: its contraction from the predictor's
        large first correction is no guide to the later ones. A correction Δa is measured as
        the correction ∂q/∂a·Δa of q it makes (``norm``).
        """
        c_C, c_K = self.derivatives(h)
        stage = self._stage(model, t1, h, state)

        def kinematics(a1):  # carried by Newton's loop (``newton.newton``'s ``prepare``)
            return stage(a1)[:3]

        def solve(update, max_rate=None):
            return newton_iteration(update, lambda da: norm(c_K * da), state.a, newton.tol, newton.max_iter,
                                    contraction_test=newton.variant == "full",
                                    divergence_test=newton.divergence_test, max_rate=max_rate, prepare=kinematics)

        if newton.variant == "full":
            def update(_, kin):
                return model.newton_update(t1, *kin, 1.0, c_C, c_K)

            return self._account(solve(update), newton, matrix, None, None, h), stage, c_C, c_K

        def modified_update(fac):
            def update(_, kin):
                return fac.solve(model.residual(t1, *kin))
            return update

        q1p, v1p, _ = kinematics(state.a)
        sol, fac, fresh = self._modified(newton, matrix, h,
                                         lambda: model.factor_iteration_matrix(t1, q1p, v1p, 1.0, c_C, c_K),
                                         lambda fac, max_rate: solve(modified_update(fac), max_rate))
        return self._account(sol, newton, matrix, fac, fresh, h), stage, c_C, c_K


def hermite_interpolate(s, h, q0, v0, q1, v1):
    """Cubic Hermite interpolation of (q, v) at the fraction s ∈ [0, 1] of a step of size h."""
    s2, s3 = s * s, s * s * s
    q = (2 * s3 - 3 * s2 + 1) * q0 + (s3 - 2 * s2 + s) * h * v0 + (-2 * s3 + 3 * s2) * q1 + (s3 - s2) * h * v1
    v = (6 * s2 - 6 * s) / h * (q0 - q1) + (3 * s2 - 4 * s + 1) * v0 + (3 * s2 - 2 * s) * v1
    return q, v


__all__ = ["AbstractGeneralizedAlpha", "GeneralizedAlpha", "hermite_interpolate"]
