"""The prismatic (sliding) joint (docs/multibody-theory.md, §Joints: the prismatic joint), on section frames.

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

from typing import ClassVar

import jax.numpy as jnp

from .cylindrical import Cylindrical
from .section_frame import dot

N_EQUATIONS = 5


class Prismatic(Cylindrical):
    """A slider (see the module docstring): a cylindrical joint (``cylindrical``) whose turn about
    the axis is held too. ``normals``: a's directions n₁, n₂ (or fixed ones, ``body_a=None``:
    along a fixed line through ``point``); ``axis``: b's directions e and m."""

    n_equations = N_EQUATIONS
    name: ClassVar[str] = "a slider"
    b_directions: ClassVar[str] = "two directions (axis, normal)"
    b_count: ClassVar[int] = 2

    def __call__(self, xs, t=0.0):
        on_axis, n, (_, m) = self._on_axis(xs)
        return jnp.concatenate([on_axis, dot(n[1], m)[None]])


__all__ = ["Prismatic"]
