"""The prismatic (sliding) joint on nodal vectors (MULTIBODY.md: the translational joint).

Body b's position vector r_b slides along body a's axis and keeps its orientation relative to
a. In nodal vectors, with n₁, n₂ two of a's gradient vectors normal to the axis at a's node
(or two fixed directions for the ground), d_b b's gradient vector along the axis and m_b the one
parallel to n₁ in the reference:

    (r_b − r_a)·n₁ = 0,   (r_b − r_a)·n₂ = 0      (translation along the axis only)
    d_b·n₁ = 0,   d_b·n₂ = 0,   m_b·n₂ = 0          (no relative rotation)

five equations, quadratic in the nodal vectors as every joint of ``joints``. The multipliers of
the first two are the transverse reaction forces, of the last three the reaction moments.
"""

import equinox as eqx
import jax.numpy as jnp

from .._types import Array, Float
from .joints import AbstractJoint, _vector

N_EQUATIONS = 5


class Prismatic(AbstractJoint):
    """A slider (see the module docstring). ``body_a=None``: along a fixed line through ``point``
    with the fixed normal directions ``normals`` (2 × 3), b's orientation kept against them."""

    body_a: int | None = eqx.field(static=True)
    position_a: int | None = eqx.field(static=True)
    normals_a: tuple[int, int] | None = eqx.field(static=True)
    body_b: int = eqx.field(static=True)
    position_b: int = eqx.field(static=True)
    axis_b: int = eqx.field(static=True)
    normal_b: int = eqx.field(static=True)
    point: Float[Array, " 3"]
    normals: Float[Array, "2 3"]

    n_equations = N_EQUATIONS

    def __init__(self, body_a, position_a, normals_a, body_b: int, position_b: int, axis_b: int, normal_b: int,
                 point=(0.0, 0.0, 0.0), normals=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))):
        if body_a is None:
            if position_a is not None or normals_a is not None:
                raise ValueError("a prismatic joint to the ground takes point and normals, not position_a and "
                                 "normals_a")
            self.body_a, self.position_a, self.normals_a = None, None, None
        else:
            normals_a = tuple(int(v) for v in normals_a)
            if len(normals_a) != 2 or position_a is None:
                raise ValueError("normals_a must be two nodal vectors of body a normal to the axis, and position_a "
                                 "its point on the axis")
            self.body_a, self.position_a, self.normals_a = int(body_a), int(position_a), normals_a
        self.body_b, self.position_b = int(body_b), int(position_b)
        self.axis_b, self.normal_b = int(axis_b), int(normal_b)
        self.point = jnp.asarray(point, dtype=float).reshape(3)
        self.normals = jnp.asarray(normals, dtype=float).reshape(2, 3)

    def references(self):
        refs = [(self.body_b, self.position_b), (self.body_b, self.axis_b), (self.body_b, self.normal_b)]
        if self.body_a is not None:
            refs += [(self.body_a, self.position_a)] + [(self.body_a, v) for v in self.normals_a]
        return refs

    def turned(self, A):
        return eqx.tree_at(lambda j: (j.point, j.normals), self, (A @ self.point, self.normals @ A.T))

    def __call__(self, xs, t=0.0):
        r_b, d_b, m_b = (_vector(xs, self.body_b, v) for v in (self.position_b, self.axis_b, self.normal_b))
        if self.body_a is None:
            r_a, n = self.point, self.normals
        else:
            r_a = _vector(xs, self.body_a, self.position_a)
            n = jnp.stack([_vector(xs, self.body_a, v) for v in self.normals_a])
        return jnp.concatenate([n @ (r_b - r_a), n @ d_b, (n[1] @ m_b)[None]])


__all__ = ["Prismatic"]
