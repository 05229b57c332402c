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

import jax.numpy as jnp

from .joints import AbstractAxisJoint, _vector
from .section_frame import dot

N_EQUATIONS = 4


class Cylindrical(AbstractAxisJoint):
    """A cylindrical joint (see the module docstring): ``normals`` a's n₁, n₂ (or fixed ones,
    ``body_a=None``, through ``point``), ``axis`` b's e (``joints.AbstractAxisJoint``). The
    prismatic joint (``prismatic.Prismatic``) is this one with more directions on b and one more
    equation."""

    n_equations = N_EQUATIONS
    name: ClassVar[str] = "a cylindrical joint"

    def _on_axis(self, xs):
        """The four equations of the module docstring, with a's normals n and b's directions."""
        r_b = _vector(xs, self.body_b, self.position_b)
        r_a = self.point if self.body_a is None else _vector(xs, self.body_a, self.position_a)
        n, d = self.normals(xs), self.axis(xs)
        return jnp.concatenate([dot(n, r_b - r_a), dot(n, d[0])]), n, d

    def __call__(self, xs, t=0.0):
        return self._on_axis(xs)[0]


__all__ = ["Cylindrical"]
