"""Joints of a multibody system: position-level constraints ``C(x) = 0`` on the bodies' nodal
vectors (an index-3 DAE with Lagrange multipliers λ, THEORY §7).

A joint refers to nodal vectors of its bodies by ``(body index, nodal-vector index)``; ``None``
as a body is the ground. Every equation is a polynomial of degree ≤ 2 in the nodal vectors, as
the gradient-based (ANCF) description makes natural: positions coincide, and an axis is kept
by the dot products of one body's axis vector with two vectors of the other that span the plane
normal to it (e.g. a C1 beam's section vector r_z against the slope r_x and section vector r_y
of the other beam's end; the MULTIBODY.md form with A_i e_z → the nodal vectors themselves).

The multipliers are the joints' reactions: with the equations of motion written
``M a + F(q) − Q + C_xᵀ λ = 0`` (THEORY §3), the force a joint applies to the nodal vectors of
its first body is ``−C_xᵀ λ``; for a position equation ``r_a − r_b = 0`` that is −λ on r_a and
+λ on r_b.
"""

import abc
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float

GROUND = None
"""The ground as a joint's body: fixed points and directions in space."""


def _normals(axis) -> np.ndarray:
    """Two unit vectors spanning the plane normal to ``axis`` (2 × 3)."""
    e = np.asarray(axis, dtype=float).reshape(3)
    if not np.all(np.isfinite(e)) or np.linalg.norm(e) == 0:
        raise ValueError(f"axis must be a finite nonzero 3-vector, got {axis!r}")
    e = e / np.linalg.norm(e)
    t = np.eye(3)[np.argmin(np.abs(e))]
    n1 = np.cross(e, t)
    n1 /= np.linalg.norm(n1)
    return np.stack([n1, np.cross(e, n1)])


class AbstractJoint(eqx.Module):
    """A joint: ``n_equations`` position-level equations on nodal vectors of its bodies."""

    n_equations: ClassVar[int]
    rheonomic: ClassVar[bool] = False
    """Whether the equations depend on time (``drivers``)."""

    @abc.abstractmethod
    def references(self) -> list[tuple[int, int]]:
        """The ``(body, nodal vector)`` pairs the equations read (ground excluded)."""

    @abc.abstractmethod
    def __call__(self, xs: tuple[Float[Array, "n 3"], ...], t=0.0) -> Float[Array, " m"]:
        """The equations' values for the bodies' nodal vectors ``xs`` (one (n, 3) array a body) at
        time ``t`` (read only by joints that prescribe a motion: ``drivers``)."""

    def bodies(self) -> set[int]:
        return {b for b, _ in self.references()}

    def turned(self, A: Float[Array, "3 3"]) -> "AbstractJoint":
        """The joint with its fixed data in space (ground points, axes, values) rotated by ``A``
        about the origin, for a system turned as a whole (``MultibodySystem.turned``,
        ``FloatingFrameSystem.turned``). A joint between bodies holds none: itself."""
        return self


def _vector(xs, body, vector):
    return xs[body][vector]


class Spherical(AbstractJoint):
    """A ball joint: body a's position vector ``vector_a`` coincides with body b's ``vector_b``, or
    with the fixed ``point`` when ``body_b`` is the ground (``None``). Three equations."""

    body_a: int = eqx.field(static=True)
    vector_a: int = eqx.field(static=True)
    body_b: int | None = eqx.field(static=True)
    vector_b: int | None = eqx.field(static=True)
    point: Float[Array, " 3"]

    n_equations: ClassVar[int] = 3

    def __init__(self, body_a: int, vector_a: int, body_b: int | None = GROUND, vector_b: int | None = None,
                 point=(0.0, 0.0, 0.0)):
        self.body_a, self.vector_a = int(body_a), int(vector_a)
        if (body_b is None) != (vector_b is None):
            raise ValueError("give body_b and vector_b together, or neither (a joint to the ground at point)")
        self.body_b, self.vector_b = (None, None) if body_b is None else (int(body_b), int(vector_b))
        self.point = jnp.asarray(point, dtype=float).reshape(3)

    def references(self):
        return [(self.body_a, self.vector_a)] + ([] if self.body_b is None else [(self.body_b, self.vector_b)])

    def turned(self, A):
        return eqx.tree_at(lambda j: j.point, self, A @ self.point)

    def __call__(self, xs, t=0.0):
        other = self.point if self.body_b is None else _vector(xs, self.body_b, self.vector_b)
        return _vector(xs, self.body_a, self.vector_a) - other


class Revolute(AbstractJoint):
    """A hinge: the position vectors coincide (``Spherical``) and body b's axis vector ``axis_b``
    stays normal to the two vectors ``normals_a`` of body a (e.g. the slope r_x and section
    vector r_y at a beam's end, for a hinge about that end's section vector r_z). With body a the
    ground (``body_a=None``), body b's position vector stays at ``point`` and its axis vector
    along ``axis``. Five equations."""

    body_a: int | None = eqx.field(static=True)
    position_a: int | None = eqx.field(static=True)
    normals_a: tuple[int, int] | None = eqx.field(static=True)
    body_b: int = eqx.field(static=True)
    position_b: int = eqx.field(static=True)
    axis_b: int = eqx.field(static=True)
    point: Float[Array, " 3"]
    ground_normals: Float[Array, "2 3"]

    n_equations: ClassVar[int] = 5

    def __init__(self, body_a: int | None, position_a: int | None, normals_a, body_b: int, position_b: int,
                 axis_b: int, point=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0)):
        if body_a is None:
            if position_a is not None or normals_a is not None:
                raise ValueError("a hinge to the ground takes point and axis, not position_a and normals_a")
            self.body_a, self.position_a, self.normals_a = None, None, None
        else:
            normals_a = tuple(int(v) for v in normals_a)
            if len(normals_a) != 2 or position_a is None:
                raise ValueError("normals_a must be two nodal vectors of body a, and position_a its joint point")
            self.body_a, self.position_a, self.normals_a = int(body_a), int(position_a), normals_a
        self.body_b, self.position_b, self.axis_b = int(body_b), int(position_b), int(axis_b)
        self.point = jnp.asarray(point, dtype=float).reshape(3)
        self.ground_normals = jnp.asarray(_normals(axis))

    def references(self):
        refs = [(self.body_b, self.position_b), (self.body_b, self.axis_b)]
        if self.body_a is not None:
            refs += [(self.body_a, self.position_a)] + [(self.body_a, v) for v in self.normals_a]
        return refs

    def turned(self, A):
        return eqx.tree_at(lambda j: (j.point, j.ground_normals), self, (A @ self.point, self.ground_normals @ A.T))

    def __call__(self, xs, t=0.0):
        d = _vector(xs, self.body_b, self.axis_b)
        r_b = _vector(xs, self.body_b, self.position_b)
        if self.body_a is None:
            return jnp.concatenate([r_b - self.point, self.ground_normals @ d])
        n = jnp.stack([_vector(xs, self.body_a, v) for v in self.normals_a])
        return jnp.concatenate([_vector(xs, self.body_a, self.position_a) - r_b, n @ d])


class Fixed(AbstractJoint):
    """A rigid joint: body a's nodal vectors ``vectors_a`` (a position and the gradient vectors
    at it) equal body b's ``vectors_b`` (with ``mixing``, k × k: ``mixing`` times them, for nodes
    whose gradient vectors point different ways in the reference), or their reference values
    ``values`` in space when body b is the ground (a clamp). Three equations per vector."""

    body_a: int = eqx.field(static=True)
    vectors_a: tuple[int, ...] = eqx.field(static=True)
    body_b: int | None = eqx.field(static=True)
    vectors_b: tuple[int, ...] | None = eqx.field(static=True)
    values: Float[Array, "k 3"] | None
    mixing: Float[Array, "k k"] | None

    def __init__(self, body_a: int, vectors_a, body_b: int | None = GROUND, vectors_b=None, values=None,
                 mixing=None):
        self.body_a, self.vectors_a = int(body_a), tuple(int(v) for v in vectors_a)
        if not self.vectors_a:
            raise ValueError("a fixed joint needs at least one nodal vector")
        if body_b is None:
            if values is None:
                raise ValueError("a fixed joint to the ground needs the vectors' values in space")
            self.body_b, self.vectors_b = None, None
            self.values = jnp.asarray(values, dtype=float).reshape(len(self.vectors_a), 3)
        else:
            self.body_b, self.vectors_b = int(body_b), tuple(int(v) for v in vectors_b)
            if len(self.vectors_b) != len(self.vectors_a):
                raise ValueError("vectors_a and vectors_b must pair up one to one")
            self.values = None
        k = len(self.vectors_a)
        self.mixing = None if mixing is None else jnp.asarray(mixing, dtype=float).reshape(k, k)

    @property
    def n_equations(self) -> int:  # type: ignore[override]
        return 3 * len(self.vectors_a)

    def references(self):
        refs = [(self.body_a, v) for v in self.vectors_a]
        return refs + ([] if self.body_b is None else [(self.body_b, v) for v in self.vectors_b])

    def turned(self, A):
        # a position and gradient vectors alike: v → A v (a rotation about the origin is linear)
        return self if self.values is None else eqx.tree_at(lambda j: j.values, self, self.values @ A.T)

    def __call__(self, xs, t=0.0):
        a = jnp.stack([_vector(xs, self.body_a, v) for v in self.vectors_a])
        b = self.values if self.body_b is None else jnp.stack([_vector(xs, self.body_b, v) for v in self.vectors_b])
        if self.mixing is not None:
            b = self.mixing @ b
        return (a - b).reshape(-1)


__all__ = ["GROUND", "AbstractJoint", "Fixed", "Revolute", "Spherical"]
