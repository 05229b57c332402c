"""The weld: a rigid connection between two nodes whose directions are rigid (a rigid body's
node, a floating frame's node held in its frame), or of such a node to the ground.

A clamp on gradient vectors (``joints.Fixed``: position and three gradient vectors equal, twelve
equations) is right when one side's gradient vectors are free coordinates (an ANCF node). Where
both sides' directions only turn with their frames, nine equations on the directions hold three
rotational degrees of freedom and are redundant. The weld keeps the positions equal and the
relative rotation that of the reference with six: with the triads A = [u_a, w_a, u_a × w_a] and
B = [u_b, w_b, u_b × w_b] of two of each node's directions and R₀ = A₀ᵀB₀ from the reference,

    r_a − r_b = 0,      skew(Aᵀ B R₀ᵀ) = 0         (three equations: S₃₂ − S₂₃, S₁₃ − S₃₁, S₂₁ − S₁₂),

since S = Aᵀ B R₀ᵀ is I in the reference and I + [θ]× for a small relative rotation θ (its skew
part 2θ: full rank). The multipliers of the first three are the reaction force, of the last
three, half the reaction moment (in a's triad).
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float
from .joints import AbstractJoint, _vector

N_EQUATIONS = 6


def _triad(u, w):
    return jnp.stack([u, w, jnp.cross(u, w)], axis=1)


class Weld(AbstractJoint):
    """b's node welded to a's (see the module docstring): ``dirs_a``, ``dirs_b`` two direction
    vectors of each node, ``R0`` the triads' reference relation A₀ᵀB₀. ``body_a=None``: to the
    ground, at ``point`` with the fixed directions ``ground`` (2 × 3)."""

    body_a: int | None = eqx.field(static=True)
    position_a: int | None = eqx.field(static=True)
    dirs_a: tuple[int, int] | None = eqx.field(static=True)
    body_b: int = eqx.field(static=True)
    position_b: int = eqx.field(static=True)
    dirs_b: tuple[int, int] = eqx.field(static=True)
    point: Float[Array, " 3"]
    ground: Float[Array, "2 3"]
    R0: Float[Array, "3 3"]

    n_equations = N_EQUATIONS

    def __init__(self, body_a, position_a, dirs_a, body_b: int, position_b: int, dirs_b, R0,
                 point=(0.0, 0.0, 0.0), ground=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))):
        if body_a is None:
            self.body_a, self.position_a, self.dirs_a = None, None, None
        else:
            self.body_a, self.position_a = int(body_a), int(position_a)
            self.dirs_a = tuple(int(v) for v in dirs_a)
        self.body_b, self.position_b = int(body_b), int(position_b)
        self.dirs_b = tuple(int(v) for v in dirs_b)
        if (self.dirs_a is not None and len(self.dirs_a) != 2) or len(self.dirs_b) != 2:
            raise ValueError("a weld takes two direction vectors on each node")
        self.R0 = jnp.asarray(R0, dtype=float).reshape(3, 3)
        self.point = jnp.asarray(point, dtype=float).reshape(3)
        self.ground = jnp.asarray(ground, dtype=float).reshape(2, 3)

    @staticmethod
    def reference_relation(dirs_a: np.ndarray, dirs_b: np.ndarray) -> np.ndarray:
        """R₀ with A₀ᵀ B₀ R₀ᵀ = I for the reference directions (2 × 3 each)."""
        A0, B0 = (np.stack([d[0], d[1], np.cross(d[0], d[1])], axis=1) for d in (dirs_a, dirs_b))
        return np.linalg.inv(A0.T @ B0).T

    def references(self):
        refs = [(self.body_b, self.position_b)] + [(self.body_b, v) for v in self.dirs_b]
        if self.body_a is not None:
            refs += [(self.body_a, self.position_a)] + [(self.body_a, v) for v in self.dirs_a]
        return refs

    def turned(self, A):
        return eqx.tree_at(lambda j: (j.point, j.ground), self, (A @ self.point, self.ground @ A.T))

    def __call__(self, xs, t=0.0):
        if self.body_a is None:
            r_a, Ta = self.point, _triad(self.ground[0], self.ground[1])
        else:
            r_a = _vector(xs, self.body_a, self.position_a)
            Ta = _triad(*(_vector(xs, self.body_a, v) for v in self.dirs_a))
        Tb = _triad(*(_vector(xs, self.body_b, v) for v in self.dirs_b))
        S = Ta.T @ Tb @ self.R0.T
        skew = jnp.stack([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]])
        return jnp.concatenate([r_a - _vector(xs, self.body_b, self.position_b), skew])


__all__ = ["Weld"]
