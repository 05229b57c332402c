"""Joints of a multibody system: position-level constraints ``C(x) = 0`` on the bodies' nodal
vectors (an index-3 DAE with Lagrange multipliers λ; docs/theory.md, §7 Jointed bodies;
docs/multibody-theory.md, §Joints).

A joint refers to nodal vectors of its bodies by ``(body index, nodal-vector index)``; ``None``
as a body is the ground. Positions coincide as nodal vectors; orientations are compared through
each node's *section frame* (``section_frame``): the orthonormal triad of its two section vectors
(a C1 beam's r_y, r_z; a rigid body's axes), never the centre-line slope r_x, so that a reaction
moment acts on the cross-section as in the continuum and the joint converges under mesh
refinement. A hinge keeps an axis fixed in body b's section normal to two directions fixed in
a's (``Revolute``); ``weld.Weld``, ``prismatic.Prismatic``, ``universal.Universal`` and the
``drivers`` are written the same way. ``Fixed`` prescribes nodal vectors themselves (a
boundary condition of a full-order model), and ``Spherical`` positions only.

The multipliers are the joints' reactions: with the equations of motion written
``M a + F(q) − Q + C_xᵀ λ = 0`` (docs/theory.md, §3 Equations of motion of one body), the force a
joint applies to the nodal vectors of its first body is ``−C_xᵀ λ``; for a position equation
``r_a − r_b = 0`` that is −λ on r_a and +λ on r_b.
"""

import abc
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float
from .section_frame import Directions, dot

GROUND = None
"""The ground as a joint's body: fixed points and directions in space."""


def normals(axis) -> np.ndarray:
    """Two unit vectors n₁, n₂ = e × n₁ spanning the plane normal to ``axis`` e (2 × 3)."""
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


class AbstractAxisJoint(AbstractJoint):
    """A joint between a point and an axis: two directions ``normals`` fixed in body a's section
    frame (fixed ones for the ground, ``body_a=None``, through ``point``) and directions ``axis``
    fixed in body b's (its axis first), at the nodes of the position vectors ``position_a`` and
    ``position_b`` (``section_frame``). ``Revolute``, ``cylindrical.Cylindrical`` and
    ``prismatic.Prismatic`` differ in their equations and in how many directions b holds
    (``b_count``); the data, the references and the turn are this class's."""

    body_a: int | None = eqx.field(static=True)
    position_a: int | None = eqx.field(static=True)
    body_b: int = eqx.field(static=True)
    position_b: int = eqx.field(static=True)
    normals: Directions
    axis: Directions
    point: Float[Array, " 3"]

    name: ClassVar[str]  # "a hinge", for the errors
    b_directions: ClassVar[str] = "one axis"  # what ``axis`` holds on body b, in words ...
    b_count: ClassVar[int] = 1  # ... and in number

    def __init__(self, body_a: int | None, position_a: int | None, normals: Directions, body_b: int,
                 position_b: int, axis: Directions, point=(0.0, 0.0, 0.0)):
        if (body_a is None) != (position_a is None) or normals.body != body_a or axis.body != int(body_b):
            raise ValueError(f"{self.name}'s normals are body a's directions (fixed ones for the ground, body_a=None) "
                             f"and its {self.b_directions} body b's")
        if normals.local.shape[0] != 2 or axis.local.shape[0] != self.b_count:
            raise ValueError(f"{self.name} takes two normal directions on body a and {self.b_directions} on body b")
        self.body_a, self.position_a = (None, None) if body_a is None else (int(body_a), int(position_a))
        self.body_b, self.position_b = int(body_b), int(position_b)
        self.normals, self.axis = normals, axis
        self.point = jnp.asarray(point, dtype=float).reshape(3)

    def references(self):
        refs = [(self.body_b, self.position_b)] + self.axis.references() + self.normals.references()
        return refs + ([] if self.body_a is None else [(self.body_a, self.position_a)])

    def turned(self, A):
        return eqx.tree_at(lambda j: (j.point, j.normals), self, (A @ self.point, self.normals.turned(A)))


class Revolute(AbstractAxisJoint):
    """A hinge: the positions coincide (``Spherical``) and the hinge's axis, fixed in body b's
    section frame, stays normal to two directions fixed in body a's that span the plane normal to
    it in the reference (``section_frame``): (R_a n_i)·(R_b e) = 0, i = 1, 2. Body a the ground
    (``body_a=None``): b's position stays at ``point`` and its axis normal to the fixed ``normals``.
    Five equations; their multipliers are the reaction force and the two reaction moments normal to
    the axis, which act on the section vectors (never on a beam's slope r_x, whose moment loads one
    element's shear: ``section_frame``)."""

    n_equations: ClassVar[int] = 5
    name: ClassVar[str] = "a hinge"

    def __call__(self, xs, t=0.0):
        r_b = _vector(xs, self.body_b, self.position_b)
        gap = r_b - self.point if self.body_a is None else _vector(xs, self.body_a, self.position_a) - r_b
        return jnp.concatenate([gap, dot(self.normals(xs), self.axis(xs)[0])])


class Fixed(AbstractJoint):
    """Nodal vectors prescribed: body a's ``vectors_a`` equal body b's ``vectors_b`` (with
    ``mixing``, k × k: ``mixing`` times them), or their values ``values`` in space when body b is
    the ground. Three equations per vector. A boundary condition on a model's coordinates (a
    full-order cantilever's clamped nodal vectors, a shared node); a rigid connection between
    bodies in physical terms is ``markers.clamp`` (``weld.Weld``, on section frames)."""

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


__all__ = ["GROUND", "AbstractAxisJoint", "AbstractJoint", "Fixed", "Revolute", "Spherical", "normals"]
