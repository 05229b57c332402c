"""Rayleigh damping of the elastic motion: ``D = α M + β K̂`` (off by default).

K̂ is the tangent stiffness at the stress-free reference q̂ and M the mass matrix, so the
damping ratio of an undamped mode of frequency ω is ``ζ(ω) = α/(2ω) + βω/2``. The force ``D q̇``
acts on the velocity *relative to the reference frame* — in the RNCF (Eq. 41) that is q̇
itself, so a rigid spin is never damped. In the reduced model (docs/theory.md, §4 Reduction) it becomes
``D̄ = α Ī + β K̄`` with ``K̄ = Ψᵀ K̂ Ψ``: the Galerkin projection of the same D.
"""

import equinox as eqx
import jax.numpy as jnp

from .. import _validate
from .._types import Array, Float, ScalarLike


class RayleighDamping(eqx.Module):
    """``D = alpha · M + beta · K̂`` [α in 1/s, β in s]; fields are arrays (differentiable)."""

    alpha: Float[Array, ""]
    beta: Float[Array, ""]

    def __init__(self, alpha: ScalarLike = 0.0, beta: ScalarLike = 0.0):
        _validate.non_negative("alpha (mass-proportional damping)", alpha)
        _validate.non_negative("beta (stiffness-proportional damping)", beta)
        self.alpha = jnp.asarray(alpha, dtype=float)
        self.beta = jnp.asarray(beta, dtype=float)

    @classmethod
    def from_ratio(cls, zeta: ScalarLike, omega_a: ScalarLike, omega_b: ScalarLike | None = None) -> "RayleighDamping":
        """The damping with ratio ``zeta`` at the two frequencies ``omega_a`` and ``omega_b``
        [rad/s]: ``α = 2ζ ωa ωb / (ωa + ωb)``, ``β = 2ζ / (ωa + ωb)``. With ``omega_b`` omitted,
        stiffness-proportional damping (α = 0) with ratio ``zeta`` at ``omega_a``."""
        _validate.non_negative("zeta (damping ratio)", zeta)
        _validate.positive("omega_a", omega_a)
        zeta = jnp.asarray(zeta, dtype=float)
        if omega_b is None:
            return cls(0.0 * zeta, 2.0 * zeta / omega_a)
        _validate.positive("omega_b", omega_b)
        return cls(2.0 * zeta * omega_a * omega_b / (omega_a + omega_b), 2.0 * zeta / (omega_a + omega_b))

    def ratio(self, omega: Float[Array, "..."]) -> Float[Array, "..."]:
        """ζ(ω) = α/(2ω) + βω/2 of an undamped mode of angular frequency ω."""
        omega = jnp.asarray(omega, dtype=float)
        return self.alpha / (2.0 * omega) + 0.5 * self.beta * omega
