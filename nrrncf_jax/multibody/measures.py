"""Scalar measures of a mechanism's configuration, g(x) on the bodies' nodal vectors: what a
force element acts along (``forces``) and what a driver prescribes (``drivers``).

- ``Distance``: |r_b − r_a| between two position vectors (or a fixed point);
- ``HingeAngle``: b's angle about a hinge's axis relative to a (or the ground): u_a, w_a =
  axis × u_a two directions normal to the axis fixed in a's section frame and u_b the one fixed
  in b's that is u_a in the reference, φ = atan2(u_b·w_a, u_b·u_a) (``forces`` says why its
  gradient is a torque);
- ``Travel``: (r_b − r_a)·d along an axis d fixed in a's section frame (or a fixed axis).

Directions are read from the nodes' section frames (``section_frame``), never from a beam's
slope r_x: a moment through r_x loads one element's shear and does not converge with the mesh.
"""

import abc

import equinox as eqx
import jax.numpy as jnp

from .._types import Array, Float
from .joints import _vector
from .section_frame import Directions, dot


class AbstractMeasure(eqx.Module):
    """A scalar function g(xs) of the bodies' nodal vectors (see the module docstring)."""

    @abc.abstractmethod
    def references(self) -> list[tuple[int, int]]:
        """The ``(body, nodal vector)`` pairs it reads (ground excluded)."""

    @abc.abstractmethod
    def __call__(self, xs) -> Float[Array, ""]:
        """g for the bodies' nodal vectors ``xs``."""

    def turned(self, A: Float[Array, "3 3"]) -> "AbstractMeasure":
        """The measure with its fixed data in space rotated by A (a system turned as a whole)."""
        return self


class Distance(AbstractMeasure):
    """|r_b − r_a|: body b's position vector ``vector_b`` from body a's ``vector_a``, or from the
    fixed ``point`` when ``body_a`` is None."""

    body_a: int | None = eqx.field(static=True)
    vector_a: int | None = eqx.field(static=True)
    body_b: int = eqx.field(static=True)
    vector_b: int = eqx.field(static=True)
    point: Float[Array, " 3"]

    def __init__(self, body_a, vector_a, body_b: int, vector_b: int, point=(0.0, 0.0, 0.0)):
        self.body_a, self.vector_a = (None, None) if body_a is None else (int(body_a), int(vector_a))
        self.body_b, self.vector_b = int(body_b), int(vector_b)
        self.point = jnp.asarray(point, dtype=float).reshape(3)

    def references(self):
        return [(self.body_b, self.vector_b)] + ([] if self.body_a is None else [(self.body_a, self.vector_a)])

    def turned(self, A):
        return eqx.tree_at(lambda m: m.point, self, A @ self.point)

    def __call__(self, xs):
        r_a = self.point if self.body_a is None else _vector(xs, self.body_a, self.vector_a)
        d = _vector(xs, self.body_b, self.vector_b) - r_a
        # sqrt with a safe zero: a spring of zero length has no direction (its force is then zero)
        sq = dot(d, d)
        return jnp.where(sq > 0, jnp.sqrt(jnp.where(sq > 0, sq, 1.0)), 0.0)


class HingeAngle(AbstractMeasure):
    """b's angle about a hinge's axis relative to a (module docstring): ``frame_a`` holds u and
    w = axis × u fixed in a's section frame (fixed in space for the ground), ``u_b`` the
    direction fixed in b's section frame that is u in the reference (``section_frame``)."""

    frame_a: Directions
    u_b: Directions

    def __init__(self, frame_a: Directions, u_b: Directions):
        if frame_a.local.shape[0] != 2 or u_b.local.shape[0] != 1 or u_b.body is None:
            raise ValueError("a hinge angle reads two directions (u, w) on body a or the ground and one on body b")
        self.frame_a, self.u_b = frame_a, u_b

    def references(self):
        return self.u_b.references() + self.frame_a.references()

    def turned(self, A):
        return eqx.tree_at(lambda m: m.frame_a, self, self.frame_a.turned(A))

    def directions(self, xs):
        """``(u_a, w_a, u_b)`` in the current configuration."""
        u_a, w_a = self.frame_a(xs)
        return u_a, w_a, self.u_b(xs)[0]

    def __call__(self, xs):
        u_a, w_a, u_b = self.directions(xs)
        return jnp.arctan2(dot(u_b, w_a), dot(u_b, u_a))


class Travel(AbstractMeasure):
    """(r_b − r_a)·d: b's position vector ``vector_b`` along the axis d fixed in a's section frame
    (``axis``, ``section_frame``) from a's position vector ``vector_a``, or along a fixed axis
    from the fixed ``point`` (``body_a=None``, ``axis`` fixed in space)."""

    body_a: int | None = eqx.field(static=True)
    vector_a: int | None = eqx.field(static=True)
    body_b: int = eqx.field(static=True)
    vector_b: int = eqx.field(static=True)
    axis: Directions
    point: Float[Array, " 3"]

    def __init__(self, body_a, vector_a, axis: Directions, body_b: int, vector_b: int, point=(0.0, 0.0, 0.0)):
        if (body_a is None) != (vector_a is None) or axis.body != body_a or axis.local.shape[0] != 1:
            raise ValueError("a travel's axis is one direction of body a (a fixed one for the ground, body_a=None)")
        self.body_a, self.vector_a = (None, None) if body_a is None else (int(body_a), int(vector_a))
        self.body_b, self.vector_b = int(body_b), int(vector_b)
        self.axis = axis
        self.point = jnp.asarray(point, dtype=float).reshape(3)

    def references(self):
        refs = [(self.body_b, self.vector_b)] + self.axis.references()
        return refs + ([] if self.body_a is None else [(self.body_a, self.vector_a)])

    def turned(self, A):
        return eqx.tree_at(lambda m: (m.point, m.axis), self, (A @ self.point, self.axis.turned(A)))

    def __call__(self, xs):
        r_a = self.point if self.body_a is None else _vector(xs, self.body_a, self.vector_a)
        return dot(_vector(xs, self.body_b, self.vector_b) - r_a, self.axis(xs)[0])


__all__ = ["AbstractMeasure", "Distance", "HingeAngle", "Travel"]
