"""Linear-elastic isotropic material and the beam's constitutive matrix D (docs/theory.md, §2 Elastic force)."""

import equinox as eqx
import jax.numpy as jnp

from .. import _validate
from .._types import Array, Float, ScalarLike


class Material(eqx.Module):
    """Isotropic material: Young's modulus ``E`` [Pa], density ``rho`` [kg/m³], Poisson ``nu``.

    Fields are arrays so that ``jax.grad`` can differentiate with respect to them.
    """

    E: Float[Array, ""]
    rho: Float[Array, ""]
    nu: Float[Array, ""]

    def __init__(self, E: ScalarLike, rho: ScalarLike, nu: ScalarLike = 0.3):
        _validate.positive("E (Young's modulus)", E)
        _validate.positive("rho (density)", rho)
        if _validate.is_concrete(nu):
            v = float(nu)
            if not (-1.0 < v < 0.5):
                raise ValueError(f"nu (Poisson's ratio) must lie in (-1, 0.5), got nu={v!r}")
        self.E = jnp.asarray(E, dtype=float)
        self.rho = jnp.asarray(rho, dtype=float)
        self.nu = jnp.asarray(nu, dtype=float)

    @property
    def G(self) -> Float[Array, ""]:
        return self.E / (2.0 * (1.0 + self.nu))

    def beam_D(self) -> Float[Array, "6 6"]:
        """Constitutive matrix for Voigt strains ``[E11, E22, E33, 2E23, 2E13, 2E12]`` in the
        beam's local orthonormal frame (1 = axis, 2-3 = cross-section).

        **Why it is not the 3-D isotropic matrix (Poisson locking).** The beam element's
        cross-section field is linear in (y, z), so it cannot take the quadratic
        cross-section distortion that the Poisson effect produces in bending. With the full 3-D
        matrix that missing freedom stiffens bending by (1-ν)/((1+ν)(1-2ν)) (35 % at ν = 0.3).
        The remedy used here (as in structural-mechanics based ANCF beams) uncouples the axial
        strain from the cross-section strains: E11 carries E alone, so EA and EI are exact; the
        cross-section (E22, E33, E23) is a plane-stress layer with (E, ν); the transverse shear
        strains carry G (no shear-correction factor: for the slender beams here its effect on
        bending is O((r/L)²) < 1e-4, and it keeps the torsional stiffness G·J exact for
        circular sections, which have no warping).
        """
        E, nu, G = self.E, self.nu, self.G
        c = E / (1.0 - nu**2)
        z = jnp.zeros(())
        rows = [
            [E, z, z, z, z, z],
            [z, c, c * nu, z, z, z],
            [z, c * nu, c, z, z, z],
            [z, z, z, G, z, z],
            [z, z, z, z, G, z],
            [z, z, z, z, z, G],
        ]
        return jnp.stack([jnp.stack(r) for r in rows])
