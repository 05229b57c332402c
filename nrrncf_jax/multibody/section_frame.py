"""Section frames: the orientation of a node as joints see it, built from its two section
(director) vectors only, never from the centre-line tangent.

Why not the tangent. A C1 beam node carries the slope r_x and the section vectors r_y, r_z. A
joint that writes a moment through r_x loads the end element's local shear: r_x is the
centre-line slope, and a generalized force on it is resisted by the shear stiffness of one
element's length, so the compliance it adds grows like one over the element's length and the answer
moves away from the truth as the mesh is refined. A moment on the section vectors is a moment on
the cross-section, which is what the continuum and every geometrically exact beam code (Exudyn,
MBDyn, Simo-Reissner) apply it to: exact at every mesh.

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
import jax
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float


def dot(a: Float[Array, "... 3"], b: Float[Array, "... 3"]) -> Float[Array, "..."]:
    """a·b over the vectors' last axis (broadcast over the others): the joints' products of
    directions and positions, as element-wise products and a sum. As a ``dot_general``
    (``a @ b``) each product of 3-vectors is a kernel of its own to XLA, compiled on its own, and
    a mechanism's joints and their derivatives hold hundreds of them; the sum is fused with the
    products (written component by component it takes more operations and more kernels)."""
    return jnp.sum(a * b, axis=-1)


def _scalars(d1, d2) -> tuple:
    """The frame's scalars from the section vectors' components: ``(r1, r2, c, s)``, the inverse
    lengths 1/|d₁|, 1/|d₂|, the cosine c = a·b of the unit vectors and s = √(1 − c²)."""
    x1, y1, z1 = d1[..., 0], d1[..., 1], d1[..., 2]
    x2, y2, z2 = d2[..., 0], d2[..., 1], d2[..., 2]
    r1 = jax.lax.rsqrt(x1 * x1 + y1 * y1 + z1 * z1)
    r2 = jax.lax.rsqrt(x2 * x2 + y2 * y2 + z2 * z2)
    c = (x1 * x2 + y1 * y2 + z1 * z2) * r1 * r2
    return r1, r2, c, jnp.sqrt(1.0 - c * c)


def _frame(d1, d2):
    """``triad``'s closed form, as plain operations (``triad`` adds its derivative's rule): for
    concrete vectors it evaluates at once, also inside a transformation (``reference_triad``)."""
    x1, y1, z1 = d1[..., 0], d1[..., 1], d1[..., 2]
    x2, y2, z2 = d2[..., 0], d2[..., 1], d2[..., 2]
    r1, r2, c, s = _scalars(d1, d2)
    inv_s = 1.0 / s
    k = jax.lax.rsqrt(2.0 + 2.0 * s) * inv_s  # 1/(t s)
    p, q = (1.0 + s) * k * r1, c * k * r2  # e₂ = p d₁ − q d₂
    u, w = (1.0 + s) * k * r2, c * k * r1  # e₃ = u d₂ − w d₁
    n = r1 * r2 * inv_s  # e₁ = n d₁ × d₂
    e1 = jnp.stack([n * (y1 * z2 - z1 * y2), n * (z1 * x2 - x1 * z2), n * (x1 * y2 - y1 * x2)], axis=-1)
    e2 = jnp.stack([p * x1 - q * x2, p * y1 - q * y2, p * z1 - q * z2], axis=-1)
    e3 = jnp.stack([u * x2 - w * x1, u * y2 - w * y1, u * z2 - w * z1], axis=-1)
    return jnp.stack([e1, e2, e3], axis=-1)


@jax.custom_jvp
def triad(d1: Float[Array, " 3"], d2: Float[Array, " 3"]) -> Float[Array, "3 3"]:
    """The section frame T = [e₁, e₂, e₃] (columns) of two section vectors (module docstring).

    Written as the closed form of the same frame: with a, b the unit section vectors and c = a·b,
    the symmetric orthonormalisation of (a, b) is their polar factor [a, b] G^(-1/2), G = [[1, c],
    [c, 1]] their Gram matrix, which for 2 × 2 is (G + s I)⁻¹ t with s = √(1 − c²) = √det G and
    t = √(2 + 2s) = √(tr G + 2s):

        e₂ = ((1 + s) a − c b)/(t s),  e₃ = ((1 + s) b − c a)/(t s),  e₁ = e₂ × e₃ = a × b / s.

    Every operation is element-wise on the vectors' components (no reductions, no norms): XLA
    fuses the frame, its derivatives and a joint's equations into a few kernels, where the
    normalise-four-times form cost a reduced pendulum's step many more operations. Its
    derivative is the frame's turn in closed form (``_triad_jvp``)."""
    return _frame(d1, d2)


@triad.defjvp
def _triad_jvp(primals, tangents):
    """The frame's derivative as its turn, dT = T [ω]×, with ω's components in the frame from the
    tangents' components P_i = Tᵀ dd_i / |d_i| (the polar factor's derivative, which for two
    vectors is closed-form):

        ω₁ = ((1 + s)(P₁₃ − P₂₂) − c (P₁₂ − P₂₃)) / (2t),
        ω₂ = ((1 + s) P₂₁ − c P₁₁) / (t s),   ω₃ = (c P₂₁ − (1 + s) P₁₁) / (t s)

    (ω₁ the turn in the section's plane, shared by both vectors; ω₂, ω₃ the turns of its normal
    e₁ toward e₃ and e₂). Equal to the derivative of ``triad``'s closed form to round-off, in
    fewer operations than differentiating that takes: the frame enters every joint's
    derivatives (the constraint Jacobian, the reactions, the constraints' second derivative).
    The frame itself is ``triad``'s, so a second derivative turns it by this rule again."""
    d1, d2 = primals
    dd1, dd2 = tangents
    T = triad(d1, d2)
    r1, r2, c, s = _scalars(d1, d2)
    g = jax.lax.rsqrt(2.0 + 2.0 * s)  # 1/t
    k = g / s
    P1 = r1[..., None] * jnp.sum(T * dd1[..., :, None], axis=-2)  # (e₁, e₂, e₃)·dd₁/|d₁|
    P2 = r2[..., None] * jnp.sum(T * dd2[..., :, None], axis=-2)
    w1 = 0.5 * g * ((1.0 + s) * (P1[..., 2] - P2[..., 1]) - c * (P1[..., 1] - P2[..., 2]))
    w2 = k * ((1.0 + s) * P2[..., 0] - c * P1[..., 0])
    w3 = k * (c * P2[..., 0] - (1.0 + s) * P1[..., 0])
    # column j of T [ω]×: ω_{j+2} e_{j+1} − ω_{j+1} e_{j+2} (indices mod 3)
    W1 = jnp.stack([w3, w1, w2], axis=-1)[..., None, :]
    W2 = jnp.stack([w2, w3, w1], axis=-1)[..., None, :]
    return T, jnp.roll(T, -1, axis=-1) * W1 - jnp.roll(T, -2, axis=-1) * W2


def reference_triad(d1, d2) -> np.ndarray:
    """``triad`` of reference vectors, in NumPy (resolution happens before anything is traced);
    refuses parallel or zero section vectors, which span no frame."""
    d1, d2 = np.asarray(d1, dtype=float), np.asarray(d2, dtype=float)
    n1, n2 = np.linalg.norm(d1), np.linalg.norm(d2)
    if n1 == 0 or n2 == 0 or np.linalg.norm(np.cross(d1 / n1, d2 / n2)) < 1e-6:
        raise ValueError(f"section vectors {tuple(d1)} and {tuple(d2)} span no frame (zero or parallel)")
    return np.asarray(_frame(jnp.asarray(d1), jnp.asarray(d2)))


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

    @staticmethod
    def frame_key(vectors) -> tuple:
        """The key under which a body's dict of nodal vectors may hold the frame of ``vectors``
        computed already (``Mechanism._joints_on_rows`` computes all of a mechanism's at once)."""
        return ("frame", *vectors)

    def triad(self, xs) -> Float[Array, "3 3"]:
        """The node's current section frame T (identity for the ground); read from ``xs`` where
        its body's entry is a dict that holds it (``frame_key``)."""
        if self.body is None:
            return jnp.eye(3, dtype=self.local.dtype)
        x = xs[self.body]
        if isinstance(x, dict) and self.frame_key(self.vectors) in x:
            return x[self.frame_key(self.vectors)]
        return triad(x[self.vectors[0]], x[self.vectors[1]])

    def __call__(self, xs) -> Float[Array, "k 3"]:
        if self.body is None:
            return self.local
        return dot(self.local[:, None, :], self.triad(xs)[None, :, :])  # local @ Tᵀ


__all__ = ["Directions", "reference_triad", "triad"]
