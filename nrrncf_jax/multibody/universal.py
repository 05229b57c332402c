"""The universal (Cardan, Hooke) joint, on section frames: the positions coincide, and an axis
fixed in body a's section frame stays normal to an axis fixed in body b's (the cross's two
pins, normal to each other in the reference):

    r_a − r_b = 0,      R_a e_a · R_b e_b = 0

four equations (``section_frame``: R the nodes' rotations from the reference). The last
multiplier is the reaction moment about e_a × e_b, the one moment a Cardan cross transmits
besides the torque it drives. To the ground (``body_a=None``), e_a is fixed in space.
"""

import equinox as eqx
import jax.numpy as jnp

from .._types import Array, Float
from .joints import AbstractJoint, _vector
from .section_frame import Directions, dot

N_EQUATIONS = 4


class Universal(AbstractJoint):
    """A universal joint (see the module docstring): ``axis_a`` on body a (or fixed, with
    ``body_a=None``, at ``point``), ``axis_b`` on body b."""

    body_a: int | None = eqx.field(static=True)
    position_a: int | None = eqx.field(static=True)
    body_b: int = eqx.field(static=True)
    position_b: int = eqx.field(static=True)
    axis_a: Directions
    axis_b: Directions
    point: Float[Array, " 3"]

    n_equations = N_EQUATIONS

    def __init__(self, body_a, position_a, axis_a: Directions, body_b: int, position_b: int, axis_b: Directions,
                 point=(0.0, 0.0, 0.0)):
        if (body_a is None) != (position_a is None) or axis_a.body != body_a or axis_b.body != int(body_b):
            raise ValueError("a universal joint's first axis is body a's (a fixed one for the ground, body_a=None), "
                             "its second body b's")
        if axis_a.local.shape[0] != 1 or axis_b.local.shape[0] != 1:
            raise ValueError("a universal joint takes one axis on each body")
        self.body_a, self.position_a = (None, None) if body_a is None else (int(body_a), int(position_a))
        self.body_b, self.position_b = int(body_b), int(position_b)
        self.axis_a, self.axis_b = axis_a, axis_b
        self.point = jnp.asarray(point, dtype=float).reshape(3)

    def references(self):
        refs = [(self.body_b, self.position_b)] + self.axis_b.references() + self.axis_a.references()
        return refs + ([] if self.body_a is None else [(self.body_a, self.position_a)])

    def turned(self, A):
        return eqx.tree_at(lambda j: (j.point, j.axis_a), self, (A @ self.point, self.axis_a.turned(A)))

    def __call__(self, xs, t=0.0):
        r_a = self.point if self.body_a is None else _vector(xs, self.body_a, self.position_a)
        return jnp.concatenate([r_a - _vector(xs, self.body_b, self.position_b),
                                dot(self.axis_a(xs)[0], self.axis_b(xs)[0])[None]])


__all__ = ["Universal"]
