"""Generalized-α for constrained systems, index 3 (Arnold & Brüls 2007): the step of
``GeneralizedAlpha`` with the joints' equations C(q) = 0 imposed at the end of every step and their
multipliers λ in the state (docs/theory.md, §7 Jointed bodies and §8 Time integration;
docs/multibody-theory.md, §Index-3 constraints).

The unknowns of a step are the new acceleration a_{n+1} and λ_{n+1}; q_{n+1} and v_{n+1} follow
from a_{n+1} by the generalized-α kinematics (∂q/∂a = c_K, ∂v/∂a = c_C). Newton solves

    [S + c_K H_λ   C_qᵀ] [Δa]   [r(a, λ) = M a + g(q, v) + C_qᵀ λ]
    [C_q           0   ] [Δλ] = [C(q) / c_K                       ]

with S = M + c_C ∂g/∂v + c_K ∂g/∂q the unconstrained iteration matrix and H_λ = ∂(C_qᵀλ)/∂q.
Taking a (not q) as the unknown and dividing the constraint rows by c_K = βh²(1−α_f)/(1−α_m)
is the scaling of Bottasso, Dopico & Trainelli (2008): the matrix's condition number no longer
grows like h⁻⁴ as the step shrinks.

Velocity projection, for models that ask for it (``project_velocities = True``: the
floating-frame ``multibody.FloatingFrameSystem``). Index 3 imposes C(q) = 0 but not its
derivative C_q v = 0; the step's v_{n+1} keeps an O(h) violation, which the next step's
acceleration corrects, and a and λ oscillate from step to step (period 2, damped only by ρ∞).
After Newton, v_{n+1} is projected onto C_q v = 0 in the metric of the iteration matrix
(→ the mass matrix as h → 0):

    [S   C_qᵀ] [Δv]   [0         ]
    [C_q  0  ] [μ ] = [C_q v_{n+1}],     v_{n+1} ← v_{n+1} − Δv,

with S the step's iteration matrix: with modified Newton, the one Newton factored (at the
predictor), its bodies' factors reused and only the m × m Schur complement of C_q(q_{n+1})
refactored (``AugmentedFactor.with_constraints``; the constraint holds at q_{n+1} exactly, only
the metric is the predictor's): refactoring S at q_{n+1} instead costs far more and changes the
run by much less than its time-integration error. With Euler parameters (|e|² = 1 a
constraint) and joints on the bodies' nodal vectors, the oscillation is the largest part of the
step error estimate: without the projection the step-size control takes needlessly small steps,
and with ρ∞ = 1, which leaves the oscillation undamped, stalls. Every ``multibody.Mechanism``
asks for it (for a mechanism of inertial-frame ANCF bodies alone, whose velocities satisfy
C_q v = 0 to round-off already, it changes nothing beyond round-off).

Newton stops when its correction, or the error the correction leaves (estimated from the
observed contraction, ``integrate.newton``), is below the tolerance, with full and modified
Newton alike (the unconstrained ``GeneralizedAlpha`` uses the contraction test with full Newton
only). Modified Newton contracts fast on this step, so its second correction usually leaves far
less than the tolerance even when it is itself above it: the test saves iterations, and changes
a run by less than its own time-integration error.

With ``Newton(reuse=True)`` the matrix a step solved with is kept for the next one
(``AbstractGeneralizedAlpha._modified``): the bodies' factors with the Schur complement of
C_q(q_{n+1}) that the velocity projection formed, so that a kept matrix meets the joints where the
last step left them.

The step error estimate and the Newton stopping test measure q alone: the multipliers carry a
damped O(h) transient after every change of step size (which ρ∞ < 1 damps; index-3 constraints
with ρ∞ = 1 leave it undamped), and are out of the error norm (docs/multibody-theory.md, §Index-3
constraints). Exact reactions at any state come from ``AbstractConstrainedModel.reactions``.
"""

from collections.abc import Callable

import jax.numpy as jnp

from .._types import Array, Float, Scalar
from ..models.constrained import AbstractConstrainedModel
from .base import GeneralizedAlphaState, IterationMatrix, NewtonOptions
from .generalized_alpha import AbstractGeneralizedAlpha, _rho_inf
from .newton import NewtonSolution
from .newton import newton as newton_iteration


class GeneralizedAlphaIndex3(AbstractGeneralizedAlpha):
    """Generalized-α (the coefficients from ρ∞) for a model with joint constraints, any
    ``models.constrained.AbstractConstrainedModel`` (``multibody.MultibodySystem``,
    ``multibody.FloatingFrameSystem``). Forward mode only: differentiating a run goes through the
    Newton iterations (``jax.jacfwd``/``jvp``)."""

    rho_inf: Float[Array, ""]

    def __init__(self, rho_inf=0.9):
        self.rho_inf = _rho_inf(rho_inf)

    def check(self, model) -> None:
        if not isinstance(model, AbstractConstrainedModel):
            raise ValueError("GeneralizedAlphaIndex3 runs constrained models (models.constrained."
                             f"AbstractConstrainedModel, e.g. a multibody.MultibodySystem); got {type(model).__name__}")

    def init(self, model, t0: Scalar, q0: Float[Array, " n"], v0: Float[Array, " n"]) -> GeneralizedAlphaState:
        """The state at ``t0`` with the consistent (a0, λ0) (``consistent_accelerations``)."""
        self.check(model)
        a0, lam0 = model.consistent_accelerations(t0, q0, v0)
        return GeneralizedAlphaState(q0, v0, a0, a0, lam0)

    def _build(self, model, t, state, c_C, c_K):
        return model.factor_augmented(t, state.q, state.v, state.lam, c_C, c_K, a=state.a)

    def step(self, model, t0: Scalar, t1: Scalar, state: GeneralizedAlphaState, newton: NewtonOptions,
             norm: Callable[[Float[Array, " n"]], Scalar], *, h: Scalar | None = None,
             matrix: IterationMatrix | None = None) -> tuple[GeneralizedAlphaState, Float[Array, " n"], NewtonSolution]:
        """One step to ``t1`` (see the module docstring and ``base.AbstractSolver``)."""
        if newton.implicit:
            raise ValueError("constrained runs are differentiated in forward mode (adjoint='forward')")
        h = t1 - t0 if h is None else h
        c_C, c_K = self.derivatives(h)
        stage = self._stage(model, t1, h, state)
        n = state.q.shape[0]

        def kinematics(z):  # carried by Newton's loop (``newton.newton``'s ``prepare``)
            return stage(z[:n])[:3]

        def equations(z, kin):
            r, C = model.dae_residual(t1, *kin, z[n:])
            return jnp.concatenate([r, C / c_K])

        z0 = jnp.concatenate([state.a, state.lam])

        # The contraction test in both variants (module docstring): modified Newton converges
        # linearly, and the error its last correction leaves is known from the observed rate.
        def solve(update, max_rate=None):
            return newton_iteration(update, lambda dz: norm(c_K * dz[:n]), z0, newton.tol, newton.max_iter,
                                    contraction_test=True, divergence_test=newton.divergence_test,
                                    max_rate=max_rate, prepare=kinematics)

        fac = fresh = None
        if newton.variant == "full":
            def update(z, kin):
                q1, v1, a1 = kin
                return model.factor_augmented(t1, q1, v1, z[n:], c_C, c_K, a=a1).solve(equations(z, kin))

            sol = solve(update)
        else:
            q1p, v1p, a1p = kinematics(z0)
            sol, fac, fresh = self._modified(
                newton, matrix, h, lambda: model.factor_augmented(t1, q1p, v1p, state.lam, c_C, c_K, a=a1p),
                lambda fac, max_rate: solve(lambda z, kin: fac.solve(equations(z, kin)), max_rate))
        a1, lam1 = sol.x[:n], sol.x[n:]
        q1, v1, a1, abar1 = stage(a1)
        if model.project_velocities:
            dv, projected = self._velocity_correction(model, t1, q1, v1, lam1, c_C, c_K, fac)
            v1 = v1 - dv
            # The bodies' factors with the constraints at q_{n+1}: a kept matrix's next use
            # starts from the joints where this step left them.
            fac = fac if projected is None else projected
        sol = self._account(sol, newton, matrix, fac, fresh, h)
        return GeneralizedAlphaState(q1, v1, a1, abar1, lam1), self.error_estimate(h, state.a, a1), sol

    @staticmethod
    def _velocity_correction(model, t1, q1, v1, lam1, c_C, c_K, reuse=None):
        """``(Δv, factor)``: Δv with C_q (v1 − Δv) + C_t = 0, in the iteration matrix's metric
        (module docstring; C_t, the drivers' rate, is zero without drivers), and the
        factorisation it solved with when that is ``reuse``'s bodies with C_q(q1) (else None)."""
        if reuse is not None and reuse.bodies is not None:
            B, C_t = model.constraint_jacobian_and_rate(q1, t1)
            fac = kept = reuse.with_constraints(B)
        else:
            fac, kept = model.factor_augmented(t1, q1, v1, lam1, c_C, c_K), None
            B = getattr(fac, "B", None)
            B, C_t = model.constraint_jacobian_and_rate(q1, t1) if B is None else (B, model.constraint_rate(q1, t1))
        violation = B @ v1 + C_t if model.rheonomic else B @ v1
        return fac.solve_constraint_rows(violation)[:v1.shape[0]], kept


__all__ = ["GeneralizedAlphaIndex3"]
