"""A point mass as a mechanism's body: one position vector with a mass, its three coordinates
the position itself (x = z). Attached to a flexible or rigid body by a ball joint at a node
(``markers.ball``), it is the lumped mass of a tip, a bolt or a sensor; on its own it is a
particle (a slider's mass on a line, a pendulum bob)."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float
from .kinds import AbstractBodyKind
from .markers import BodyGeometry


class PointMass(AbstractBodyKind):
    """A particle of ``mass_value`` [kg] at ``point`` in the reference configuration."""

    mass_value: Float[Array, ""]
    point: Float[Array, " 3"]

    kind = "point"

    @property
    def small_kernels(self) -> bool:  # type: ignore[override]
        """Three coordinates, no deformation."""
        return True

    def __init__(self, mass, point):
        m = float(mass)
        if not np.isfinite(m) or m <= 0:
            raise ValueError(f"a point mass must be finite and > 0, got {mass!r}")
        p = np.asarray(point, dtype=float).reshape(-1)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ValueError(f"a point mass's point must be a finite 3-vector, got {point!r}")
        self.mass_value, self.point = jnp.asarray(m), jnp.asarray(p)

    @property
    def mass(self) -> Float[Array, "1 1"]:
        return self.mass_value.reshape(1, 1)

    @property
    def n_z(self) -> int:
        return 3

    @property
    def n_vectors(self) -> int:
        return 1

    def initial(self):
        return self.point

    def geometry(self) -> BodyGeometry:
        return BodyGeometry(np.asarray(self.point)[None], np.array([True]), 1)

    def nodal_vectors(self, z):
        return z[None]

    def tangent(self, z, dz):
        return dz[None]

    def jacobian(self, z, rows):
        return jnp.broadcast_to(jnp.eye(3, dtype=z.dtype)[None], (len(rows), 3, 3))

    def generalized(self, z, F):
        return F[0]

    def residual(self, z, v, a, gravity):
        return self.mass_value * (a - gravity)

    def mass_matrix(self, z):
        return self.mass_value * jnp.eye(3, dtype=z.dtype)

    def block(self, z, c_M, c_K, gravity, state=None, c_C=0.0):
        return c_M * self.mass_matrix(z)

    def kinetic_energy(self, z, v):
        return 0.5 * self.mass_value * (v @ v)

    def potential_energy(self, z, gravity):
        return -self.mass_value * (z @ gravity)

    def turned(self, e, A) -> "PointMass":
        return eqx.tree_at(lambda b: b.point, self, A @ self.point)

    def rigid_velocity(self, z, velocity, omega):
        return jnp.asarray(velocity, dtype=float).reshape(3) + jnp.cross(jnp.asarray(omega, dtype=float).reshape(3), z)


__all__ = ["PointMass"]
