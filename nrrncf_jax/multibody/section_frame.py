"""Section frames: the orientation of a node as joints see it, built from its two section
(director) vectors only, never from the centre-line tangent.

Why not the tangent. A C1 beam node carries the slope r_x and the section vectors r_y, r_z. A
joint that writes a moment through r_x loads the end element's local shear: r_x is the
centre-line slope, and a generalized force on it is resisted by the shear stiffness of one
element's length, so the compliance it adds grows like one over the element's length and the
answer moves away from the truth as the mesh is refined (``benchmarks/results/validation.md``).
A moment on the
section vectors is a moment on the cross-section, which is what the continuum and every
geometrically exact beam code (Exudyn, MBDyn, Simo-Reissner) apply it to: exact at every mesh.

The frame. From a node's two section vectors d₁, d₂ (a C1 beam's r_y, r_z; two of a rigid
body's unit axes), normalised to a, b, the symmetric orthonormalisation

    s = (a + b)/|a + b|,  d = (a − b)/|a − b|,  e₂ = (s + d)/√2,  e₃ = (s − d)/√2,  e₁ = e₂ × e₃

is a proper orthonormal triad T = [e₁, e₂, e₃] that treats both section vectors alike (a section's
in-plane shear r_y·r_z ≠ 0 tilts neither more than the other) and equals [a × b, a, b] when
a ⟂ b. With T₀ the triad of the reference configuration, R = T T₀ᵀ is the node's rotation from
the reference, I there; a direction v fixed in the section turns to R v = T (T₀ᵀ v). A joint
holds the constant components T₀ᵀ v of the directions it needs and evaluates T in the step:
``Directions``.

The ground is a frame that does not move: its directions are the fixed vectors themselves, which
``turned`` rotates with a system turned as a whole.
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float

_SQRT_HALF = 0.7071067811865476


def triad(d1: Float[Array, " 3"], d2: Float[Array, " 3"]) -> Float[Array, "3 3"]:
    """The section frame T = [e₁, e₂, e₃] (columns) of two section vectors (module docstring)."""
    a = d1 / jnp.linalg.norm(d1)
    b = d2 / jnp.linalg.norm(d2)
    s, d = a + b, a - b
    s = s / jnp.linalg.norm(s)
    d = d / jnp.linalg.norm(d)
    e2, e3 = _SQRT_HALF * (s + d), _SQRT_HALF * (s - d)
    return jnp.stack([jnp.cross(e2, e3), e2, e3], axis=1)


def reference_triad(d1, d2) -> np.ndarray:
    """``triad`` of reference vectors, in NumPy (resolution happens before anything is traced);
    refuses parallel or zero section vectors, which span no frame."""
    d1, d2 = np.asarray(d1, dtype=float), np.asarray(d2, dtype=float)
    n1, n2 = np.linalg.norm(d1), np.linalg.norm(d2)
    if n1 == 0 or n2 == 0 or np.linalg.norm(np.cross(d1 / n1, d2 / n2)) < 1e-6:
        raise ValueError(f"section vectors {tuple(d1)} and {tuple(d2)} span no frame (zero or parallel)")
    return np.asarray(triad(jnp.asarray(d1), jnp.asarray(d2)))


class Directions(eqx.Module):
    """Directions fixed in a node's section frame (k of them), or fixed in space (``body=None``).

    ``vectors``: the node's two section vectors (body indices); ``local``: k × 3, the directions'
    components in the reference triad, T₀ᵀ v (for the ground, the directions in space). Called on
    the bodies' nodal vectors it returns the current directions R v (k × 3), unit vectors where
    ``local``'s rows are."""

    body: int | None = eqx.field(static=True)
    vectors: tuple[int, int] | None = eqx.field(static=True)
    local: Float[Array, "k 3"]

    def __init__(self, body: int | None, vectors, local):
        if body is None:
            self.body, self.vectors = None, None
        else:
            self.body, self.vectors = int(body), tuple(int(v) for v in vectors)
            if len(self.vectors) != 2:
                raise ValueError("a section frame is read from two section vectors")
        self.local = jnp.asarray(local, dtype=float).reshape(-1, 3)

    @classmethod
    def ground(cls, directions) -> "Directions":
        """Directions fixed in space."""
        return cls(None, None, np.asarray(directions, dtype=float).reshape(-1, 3))

    @classmethod
    def in_section(cls, body: int, vectors, reference: np.ndarray, directions) -> "Directions":
        """``directions`` (k × 3, in space, in the reference configuration) fixed in the section
        frame of body ``body``'s section ``vectors``, whose reference values are ``reference``
        (2 × 3)."""
        T0 = reference_triad(*np.asarray(reference, dtype=float).reshape(2, 3))
        return cls(body, vectors, np.asarray(directions, dtype=float).reshape(-1, 3) @ T0)

    def references(self) -> list[tuple[int, int]]:
        return [] if self.body is None else [(self.body, v) for v in self.vectors]

    def turned(self, A: Float[Array, "3 3"]) -> "Directions":
        """Fixed directions rotated by A with a system turned as a whole; a node's turn with it."""
        return eqx.tree_at(lambda d: d.local, self, self.local @ A.T) if self.body is None else self

    def triad(self, xs) -> Float[Array, "3 3"]:
        """The node's current section frame T (identity for the ground)."""
        if self.body is None:
            return jnp.eye(3, dtype=self.local.dtype)
        return triad(xs[self.body][self.vectors[0]], xs[self.body][self.vectors[1]])

    def __call__(self, xs) -> Float[Array, "k 3"]:
        if self.body is None:
            return self.local
        return self.local @ self.triad(xs).T


__all__ = ["Directions", "reference_triad", "triad"]
