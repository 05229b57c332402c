"""Scalar measures of a mechanism's configuration, g(x) on the bodies' nodal vectors: what a
force element acts along (``forces``) and what a driver prescribes (``drivers``).

- ``Distance``: |r_b − r_a| between two position vectors (or a fixed point);
- ``HingeAngle``: b's angle about a hinge's axis relative to a (or the ground): u_a, w_a =
  axis × u_a two of a's unit gradient vectors normal to the axis and u_b b's along u_a in the
  reference, φ = atan2(u_b·w_a, u_b·u_a) (``forces`` says why its gradient is a torque);
- ``Travel``: (r_b − r_a)·d_a along a's axis vector (or a fixed axis).
"""

import abc

import equinox as eqx
import jax.numpy as jnp

from .._types import Array, Float
from .joints import _vector


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
        sq = d @ d
        return jnp.where(sq > 0, jnp.sqrt(jnp.where(sq > 0, sq, 1.0)), 0.0)


class HingeAngle(AbstractMeasure):
    """b's angle about a hinge's axis relative to a (module docstring); ``body_a=None``: relative
    to the fixed directions ``ground`` (2 × 3: u and w = axis × u)."""

    body_a: int | None = eqx.field(static=True)
    u_a: int | None = eqx.field(static=True)
    w_a: int | None = eqx.field(static=True)
    body_b: int = eqx.field(static=True)
    u_b: int = eqx.field(static=True)
    ground: Float[Array, "2 3"]

    def __init__(self, body_a, u_a, w_a, body_b: int, u_b: int, ground=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))):
        self.body_a, self.u_a, self.w_a = (None, None, None) if body_a is None else (int(body_a), int(u_a), int(w_a))
        self.body_b, self.u_b = int(body_b), int(u_b)
        self.ground = jnp.asarray(ground, dtype=float).reshape(2, 3)

    def references(self):
        refs = [(self.body_b, self.u_b)]
        return refs + ([] if self.body_a is None else [(self.body_a, self.u_a), (self.body_a, self.w_a)])

    def turned(self, A):
        return eqx.tree_at(lambda m: m.ground, self, self.ground @ A.T)

    def directions(self, xs):
        """``(u_a, w_a, u_b)`` in the current configuration (u_a, w_a fixed for the ground)."""
        if self.body_a is None:
            u_a, w_a = self.ground[0], self.ground[1]
        else:
            u_a, w_a = _vector(xs, self.body_a, self.u_a), _vector(xs, self.body_a, self.w_a)
        return u_a, w_a, _vector(xs, self.body_b, self.u_b)

    def __call__(self, xs):
        u_a, w_a, u_b = self.directions(xs)
        return jnp.arctan2(u_b @ w_a, u_b @ u_a)


class Travel(AbstractMeasure):
    """(r_b − r_a)·d_a: b's position vector ``vector_b`` along a's axis vector ``axis_a`` from a's
    ``vector_a``, or along the fixed ``axis`` from the fixed ``point`` (``body_a=None``)."""

    body_a: int | None = eqx.field(static=True)
    vector_a: int | None = eqx.field(static=True)
    axis_a: int | None = eqx.field(static=True)
    body_b: int = eqx.field(static=True)
    vector_b: int = eqx.field(static=True)
    point: Float[Array, " 3"]
    axis: Float[Array, " 3"]

    def __init__(self, body_a, vector_a, axis_a, body_b: int, vector_b: int, point=(0.0, 0.0, 0.0),
                 axis=(1.0, 0.0, 0.0)):
        if body_a is None:
            self.body_a, self.vector_a, self.axis_a = None, None, None
        else:
            self.body_a, self.vector_a, self.axis_a = int(body_a), int(vector_a), int(axis_a)
        self.body_b, self.vector_b = int(body_b), int(vector_b)
        self.point = jnp.asarray(point, dtype=float).reshape(3)
        self.axis = jnp.asarray(axis, dtype=float).reshape(3)

    def references(self):
        refs = [(self.body_b, self.vector_b)]
        return refs + ([] if self.body_a is None else [(self.body_a, self.vector_a), (self.body_a, self.axis_a)])

    def turned(self, A):
        return eqx.tree_at(lambda m: (m.point, m.axis), self, (A @ self.point, A @ self.axis))

    def __call__(self, xs):
        if self.body_a is None:
            r_a, d = self.point, self.axis
        else:
            r_a, d = _vector(xs, self.body_a, self.vector_a), _vector(xs, self.body_a, self.axis_a)
        return (_vector(xs, self.body_b, self.vector_b) - r_a) @ d


__all__ = ["AbstractMeasure", "Distance", "HingeAngle", "Travel"]
