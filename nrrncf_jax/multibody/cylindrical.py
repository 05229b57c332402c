"""The cylindrical joint (a bearing that lets its journal slide), on section frames: body b's
point stays on an axis fixed in body a's section frame and b's axis stays along it; b turns about
the axis and slides along it freely. With n₁, n₂ two directions normal to the axis e fixed in a's
section frame (fixed ones for the ground) and e fixed in b's (``section_frame``):

    (r_b − r_a)·R_a n₁ = 0,   (r_b − r_a)·R_a n₂ = 0,   R_b e·R_a n₁ = 0,   R_b e·R_a n₂ = 0

four equations: the transverse reaction forces and the two reaction moments normal to the axis,
the moments on the cross-sections. A prismatic joint (``prismatic``) is this one with the turn
about the axis held too.
"""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp

from .._types import Array, Float
from .joints import AbstractJoint, _vector
from .section_frame import Directions

N_EQUATIONS = 4


class Cylindrical(AbstractJoint):
    """A cylindrical joint (see the module docstring): ``normals`` a's n₁, n₂ (or fixed ones,
    ``body_a=None``, through ``point``), ``axis`` b's e. A joint that holds a point on a line and
    an axis along it and more (``prismatic.Prismatic``) is this one with more directions on b and
    more equations."""

    body_a: int | None = eqx.field(static=True)
    position_a: int | None = eqx.field(static=True)
    body_b: int = eqx.field(static=True)
    position_b: int = eqx.field(static=True)
    normals: Directions
    axis: Directions
    point: Float[Array, " 3"]

    n_equations = N_EQUATIONS
    name: ClassVar[str] = "a cylindrical joint"
    b_directions: ClassVar[str] = "one axis"  # what ``axis`` holds on body b, in words and in count below
    b_count: ClassVar[int] = 1

    def __init__(self, body_a, position_a, normals: Directions, body_b: int, position_b: int, axis: Directions,
                 point=(0.0, 0.0, 0.0)):
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

    def _on_axis(self, xs):
        """The four equations of the module docstring, with a's normals n and b's directions."""
        r_b = _vector(xs, self.body_b, self.position_b)
        r_a = self.point if self.body_a is None else _vector(xs, self.body_a, self.position_a)
        n, d = self.normals(xs), self.axis(xs)
        return jnp.concatenate([n @ (r_b - r_a), n @ d[0]]), n, d

    def __call__(self, xs, t=0.0):
        return self._on_axis(xs)[0]


__all__ = ["Cylindrical"]
