"""A rigid body in a mechanism: a floating frame (origin, Euler parameters) with no deformation
coordinates, its nodal vectors those of ``bodies.rigid.RigidBody`` (its centre of mass and
attachment points with the body's axes). The frame's equations are ``floating``'s with the basis
empty: the rotation is handled as the floating frames' is, and the inertia invariants reduce to
the rigid body's mass and second moments (the Newton-Euler equations in Euler parameters;
``tests/test_mechanism.py`` checks them against the rigid body's angular momentum)."""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp

from .._types import Array, Float
from ..bodies.rigid import RigidBody
from .floating import FloatingBody


class NoDeformation(eqx.Module):
    """The elastic force of a body with no deformation coordinates (the interface of
    ``reduction.ElasticTensors``): empty, and no strain energy."""

    full_order: ClassVar[bool] = False

    @property
    def n_coordinates(self) -> int:
        return 0

    def force(self, p: Float[Array, " 0"]) -> Float[Array, " 0"]:
        return p

    def energy(self, p) -> Float[Array, ""]:
        return jnp.zeros((), p.dtype)

    def force_and_jacobian(self, p):
        return p, jnp.zeros((0, 0), p.dtype)


def rigid_floating_body(body: RigidBody) -> FloatingBody:
    """``body`` as a mechanism's body: a floating frame at its centre of mass, axes of the system,
    and an empty deformation basis."""
    if not isinstance(body, RigidBody):
        raise ValueError(f"expected a bodies.RigidBody, got {type(body).__name__}")
    return FloatingBody(body, jnp.zeros((body.n_dof, 0)), NoDeformation(), R0=body.com)


__all__ = ["NoDeformation", "rigid_floating_body"]
