"""The prismatic (sliding) joint (MULTIBODY.md: the translational joint), on section frames.

Body b's position vector r_b slides along an axis fixed in body a's section frame and keeps its
orientation relative to a. With n₁, n₂ two directions fixed in a's section frame normal to the
axis (fixed directions for the ground), e the axis and m = n₁ fixed in b's section frame
(``section_frame``: R_a, R_b the nodes' rotations from the reference):

    (r_b − r_a)·R_a n₁ = 0,   (r_b − r_a)·R_a n₂ = 0      (translation along the axis only)
    R_b e·R_a n₁ = 0,   R_b e·R_a n₂ = 0,   R_b m·R_a n₂ = 0     (no relative rotation)

five equations. The multipliers of the first two are the transverse reaction forces, of the last
three the reaction moments, which act on the section vectors (``section_frame`` says why not on a
beam's slope).
"""

import equinox as eqx
import jax.numpy as jnp

from .._types import Array, Float
from .joints import AbstractJoint, _vector
from .section_frame import Directions

N_EQUATIONS = 5


class Prismatic(AbstractJoint):
    """A slider (see the module docstring). ``normals``: a's directions n₁, n₂ (or fixed ones,
    ``body_a=None``: along a fixed line through ``point``); ``frame_b``: b's directions e and m."""

    body_a: int | None = eqx.field(static=True)
    position_a: int | None = eqx.field(static=True)
    body_b: int = eqx.field(static=True)
    position_b: int = eqx.field(static=True)
    normals: Directions
    frame_b: Directions
    point: Float[Array, " 3"]

    n_equations = N_EQUATIONS

    def __init__(self, body_a, position_a, normals: Directions, body_b: int, position_b: int, frame_b: Directions,
                 point=(0.0, 0.0, 0.0)):
        if (body_a is None) != (position_a is None) or normals.body != body_a or frame_b.body != int(body_b):
            raise ValueError("a slider's normals are body a's directions (fixed ones for the ground, body_a=None) and "
                             "its axis and reference direction body b's")
        if normals.local.shape[0] != 2 or frame_b.local.shape[0] != 2:
            raise ValueError("a slider takes two normal directions on body a and two directions (axis, normal) on b")
        self.body_a, self.position_a = (None, None) if body_a is None else (int(body_a), int(position_a))
        self.body_b, self.position_b = int(body_b), int(position_b)
        self.normals, self.frame_b = normals, frame_b
        self.point = jnp.asarray(point, dtype=float).reshape(3)

    def references(self):
        refs = [(self.body_b, self.position_b)] + self.frame_b.references() + self.normals.references()
        return refs + ([] if self.body_a is None else [(self.body_a, self.position_a)])

    def turned(self, A):
        return eqx.tree_at(lambda j: (j.point, j.normals), self, (A @ self.point, self.normals.turned(A)))

    def __call__(self, xs, t=0.0):
        r_b = _vector(xs, self.body_b, self.position_b)
        r_a = self.point if self.body_a is None else _vector(xs, self.body_a, self.position_a)
        n = self.normals(xs)
        e, m = self.frame_b(xs)
        return jnp.concatenate([n @ (r_b - r_a), n @ e, (n[1] @ m)[None]])


__all__ = ["Prismatic"]
