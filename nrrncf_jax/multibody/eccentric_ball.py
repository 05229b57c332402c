"""The eccentric ball: a spherical joint whose point is fixed in one node's section frame at an
offset from it (``markers.ball(a, b, eccentric=True)``; MBDyn's spherical hinge with an offset).

With R_a the rotation of a's node from the reference (``section_frame``) and d the offset in the
reference, the point a carries is r_a + R_a d, and b's node keeps to it:

    r_a + R_a d − r_b = 0        (three equations)

Their multipliers are the reaction force; its moment about a's node, d × f, acts on a's section
vectors, through which it converges under mesh refinement (as every joint here). A plain
``joints.Spherical`` is the case d = 0.
"""

from typing import ClassVar

import equinox as eqx

from .joints import AbstractJoint
from .section_frame import Directions


class EccentricBall(AbstractJoint):
    """b's position vector ``position_b`` kept at the point of a's node ``position_a`` that lies at
    ``offset`` (one direction fixed in the node's section frame, unnormalised: the offset itself
    in the reference)."""

    body_a: int = eqx.field(static=True)
    position_a: int = eqx.field(static=True)
    offset: Directions
    body_b: int = eqx.field(static=True)
    position_b: int = eqx.field(static=True)

    n_equations: ClassVar[int] = 3

    def __init__(self, body_a: int, position_a: int, offset: Directions, body_b: int, position_b: int):
        self.body_a, self.position_a = int(body_a), int(position_a)
        self.offset = offset
        self.body_b, self.position_b = int(body_b), int(position_b)

    def references(self):
        return [(self.body_a, self.position_a)] + self.offset.references() + [(self.body_b, self.position_b)]

    def __call__(self, xs, t=0.0):
        return xs[self.body_a][self.position_a] + self.offset(xs)[0] - xs[self.body_b][self.position_b]


__all__ = ["EccentricBall"]
