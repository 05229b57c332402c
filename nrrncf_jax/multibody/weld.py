"""The weld: a rigid connection between the section frames of two nodes, or of a node to the
ground (``markers.clamp``).

The positions coincide and the relative rotation stays that of the reference: with R_a, R_b the
nodes' rotations from the reference (``section_frame``), S = R_aᵀ R_b is I in the reference and
I + [θ]× for a small relative rotation θ, so

    r_a − r_b = 0,      skew(S) = 0         (three equations: S₃₂ − S₂₃, S₁₃ − S₃₁, S₂₁ − S₁₂)

six equations, of full rank (skew(S) = 2θ to first order). The multipliers of the first three
are the reaction force, of the last three half the reaction moment in a's frame. The moment acts
on the section vectors: a beam's slope r_x and its stretch and shear stay free at the weld, as at
the clamped end of a shear-deformable (Timoshenko, Simo-Reissner) beam, so the clamp converges
under mesh refinement. ``joints.Fixed`` is the other kind of clamp: nodal vectors prescribed.
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float
from .joints import AbstractJoint, _vector
from .section_frame import Directions, dot

N_EQUATIONS = 6


class Weld(AbstractJoint):
    """b's node welded to a's (see the module docstring): ``frame_a``, ``frame_b`` the space's
    axes fixed in each node's section frame in the reference (3 × 3: rows R e_k, so that
    ``frame_a(xs) @ frame_b(xs).T`` is R_aᵀR_b). ``body_a=None``: to the ground at ``point``."""

    body_a: int | None = eqx.field(static=True)
    position_a: int | None = eqx.field(static=True)
    body_b: int = eqx.field(static=True)
    position_b: int = eqx.field(static=True)
    frame_a: Directions
    frame_b: Directions
    point: Float[Array, " 3"]

    n_equations = N_EQUATIONS

    def __init__(self, body_a, position_a, frame_a: Directions, body_b: int, position_b: int, frame_b: Directions,
                 point=(0.0, 0.0, 0.0)):
        if (body_a is None) != (position_a is None) or frame_a.body != body_a or frame_b.body != int(body_b):
            raise ValueError("a weld's frames are body a's (fixed axes for the ground, body_a=None) and body b's")
        if frame_a.local.shape[0] != 3 or frame_b.local.shape[0] != 3:
            raise ValueError("a weld takes the three axes in each node's frame")
        self.body_a, self.position_a = (None, None) if body_a is None else (int(body_a), int(position_a))
        self.body_b, self.position_b = int(body_b), int(position_b)
        self.frame_a, self.frame_b = frame_a, frame_b
        self.point = jnp.asarray(point, dtype=float).reshape(3)

    @staticmethod
    def axes(body, vectors, reference) -> Directions:
        """The space's axes fixed in a node's section frame (``reference``: its two section
        vectors' reference values), or in the ground (``body=None``)."""
        if body is None:
            return Directions.ground(np.eye(3))
        return Directions.in_section(body, vectors, reference, np.eye(3))

    def references(self):
        refs = [(self.body_b, self.position_b)] + self.frame_b.references() + self.frame_a.references()
        return refs + ([] if self.body_a is None else [(self.body_a, self.position_a)])

    def turned(self, A):
        return eqx.tree_at(lambda j: (j.point, j.frame_a), self, (A @ self.point, self.frame_a.turned(A)))

    def __call__(self, xs, t=0.0):
        r_a = self.point if self.body_a is None else _vector(xs, self.body_a, self.position_a)
        S = dot(self.frame_a(xs)[:, None, :], self.frame_b(xs)[None, :, :])  # frame_a @ frame_bᵀ
        skew = jnp.stack([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]])
        return jnp.concatenate([r_a - _vector(xs, self.body_b, self.position_b), skew])


__all__ = ["Weld"]
