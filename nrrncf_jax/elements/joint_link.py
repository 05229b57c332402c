"""The joint link: a member end's gradient triad tied to its joint's in direction, not in length.

A member that leaves a rigid joint (``frame.frame_body``) keeps its own end triad
``G = [g₁, g₂, g₃]`` (its slope r_ξ and section vectors r_η, r_ζ) and the joint carries its
full position gradient F, seen along the member's directions as ``F_m = [F d, F e₂, F e₃]``. In
the reference both are the member's orthonormal directions, so ``Ĝᵀ F̂_m = I``.

A rigid joint must turn the member's end with the joint and keep its angles (no relative rotation,
no relative shear), but must leave the member's own stretches alone: making G equal to F_m
(Shabana & Mikkola's gradient transformation, where the members *share* F) also makes a batten's
section strain along the truss axis equal to the longeron's axial strain at the joint, an
over-stiffening that the element next to the joint carries over its length, O(element length),
which refinement removes only slowly.

The link penalises the axis–section entries of ``GᵀF_m`` and the section's relative twist:

    U = ½ k [ (g₁·f₂)² + (g₂·f₁)² + (g₁·f₃)² + (g₃·f₁)² + ½ (g₂·f₃ − g₃·f₂)² ].

With G = R_G(I + ε_G) and F_m = R_F(I + ε_F) (rotations times symmetric stretches, in the member's
basis), ``GᵀF_m = I + ε_G + ε_F + W + O(2)``, ``W = R_Gᵀ R_F − I`` skew: the four axis–section
entries are the relative rotation about the section axes plus the axis–section shears, the twist
term is the relative rotation about the axis, and the diagonal (the stretches) and the section's
own in-plane shear are not penalised. The energy is the same for any choice of section axes
(e₂, e₃) (a circular tube has none preferred: penalising the in-plane shear g₂·f₃ + g₃·f₂ as well
would depend on that choice and split a circular member's degenerate bending pairs). A common
rotation of both triads leaves GᵀF_m, and so U, unchanged (rigid motion costs nothing). A
relative rotation θ about any of the member's axes costs ``U = k sin²θ`` (a rotational spring of
stiffness 2k), an axis–section shear γ costs ``k γ²/4``.

Each ``g_i·f_j`` (i ≠ j) is ``2 Q_{i,3+j}`` with ``Q_αβ = ½(q_α·q_β − q̂_α·q̂_β)`` of the six
vectors [g₁, g₂, g₃, f₁, f₂, f₃] (the reference value is 0), so ``U = ½ κ Q Q`` with the constant
``κ = k Σ_n B⁽ⁿ⁾ ⊗ B⁽ⁿ⁾`` over the five rows of ``_link_rows``: the body's cubic elastic force and
the reduction's tensors take it like any element. The link carries no mass.
"""

from typing import ClassVar

import jax.numpy as jnp
import numpy as np

from .. import _validate
from .._types import Array, Float, ScalarLike
from .base import AbstractElement, ElementIntegrals


def _link_rows() -> np.ndarray:
    """The five rows B⁽ⁿ⁾ (symmetric in αβ) with ``B⁽ⁿ⁾_αβ Q_αβ``: g₁·f₂, g₂·f₁, g₁·f₃, g₃·f₁ and
    (g₂·f₃ − g₃·f₂)/√2, in that order (g₁, f₁ along the member's axis)."""
    def row(i, j):
        B = np.zeros((6, 6))
        B[i, 3 + j] = B[3 + j, i] = 1.0
        return B

    return np.stack([row(0, 1), row(1, 0), row(0, 2), row(2, 0), (row(1, 2) - row(2, 1)) / np.sqrt(2.0)])


class JointLink(AbstractElement):
    """A link of stiffness ``k`` [N m] between a member end's triad (g₁, g₂, g₃) and its joint's
    gradient along the member's directions (f₁, f₂, f₃): relative rotation (2k about any axis)
    and axis–section shear cost, stretches and the section's own distortion nothing."""

    k: Float[Array, ""]

    nodes: ClassVar[int] = 1
    vectors_per_node: ClassVar[int] = 6
    position_slots: ClassVar[tuple[int, ...]] = ()

    def __init__(self, k: ScalarLike):
        _validate.positive("k (joint link stiffness)", k)
        self.k = jnp.asarray(k, dtype=float)

    def integrals(self, q_hat: Float[Array, "6 3"], length: Float[Array, ""]) -> ElementIntegrals:
        B = jnp.asarray(_link_rows())
        kappa = self.k * jnp.einsum("nab,ncd->abcd", B, B)
        return ElementIntegrals(kappa=kappa, M=jnp.zeros((6, 6)), varrho=jnp.zeros(6), m=jnp.zeros(()))


__all__ = ["JointLink"]
