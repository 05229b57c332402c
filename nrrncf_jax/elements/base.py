"""What a body needs from an element type: its nodal layout and its constant integrals.

Every element of this library has a position field linear in its nodal vectors,
``r(x) = S_α(x) q_α`` (docs/theory.md, §1 RNCF kinematics), and a Green-Lagrange strain quadratic
in them, so that its elastic energy is ``U = ½ κ^{αβμν} Q_αβ Q_μν`` with
``Q_αβ = ½(q_α·q_β − q̂_α·q̂_β)`` and a constant 4th-order tensor κ (docs/theory.md, §2 Elastic
force, Eqs. 9-11). An element type is therefore fully described by the integrals over one element
of its reference configuration:

- ``kappa`` κ^{αβμν} (n_e⁴ numbers),
- ``M`` the scalar mass matrix ``M_αβ = ∫ρ S_α S_β``, ``varrho`` ``ϱ_α = ∫ρ S_α`` and the
  mass ``m = ∫ρ``,

and of the layout of its nodal vectors: how many a node carries and which of them are
positions (a rigid translation moves those only). Force, tangent stiffness and mass are then
assembled by ``body.ElementGroup`` for any element type alike; a new element is one new file
with a subclass of ``AbstractElement``. Material and section belong to the element.
"""

import abc
from typing import ClassVar, NamedTuple

import equinox as eqx
import jax.numpy as jnp

from .._types import Array, Float


class ElementIntegrals(NamedTuple):
    """The integrals of one element (docs/theory.md, §1 RNCF kinematics and §2 Elastic force)."""

    kappa: Float[Array, "ne ne ne ne"]
    M: Float[Array, "ne ne"]
    varrho: Float[Array, " ne"]
    m: Float[Array, ""]


class AbstractElement(eqx.Module):
    """An element type: nodal layout (class constants) and ``integrals`` of one element.

    ``nodes``: nodes per element; ``vectors_per_node``: nodal vectors a node carries (each a
    3-vector); ``position_slots``: which of a node's vectors are positions; ``section_slots``:
    which two span its cross-section, if it has one. An element's nodal
    vectors are ordered node by node, ``nodes × vectors_per_node`` of them.
    """

    nodes: ClassVar[int]
    vectors_per_node: ClassVar[int]
    position_slots: ClassVar[tuple[int, ...]]
    section_slots: ClassVar[tuple[int, ...]] = ()
    """Which two of a node's vectors span its cross-section (a beam's r_y, r_z): the section frame
    that joints hold a node by (``multibody.section_frame``); empty for a node without one."""

    @property
    def vectors(self) -> int:
        """n_e, the nodal vectors of one element."""
        return self.nodes * self.vectors_per_node

    @abc.abstractmethod
    def integrals(self, q_hat: Float[Array, "ne 3"], length: Float[Array, ""]) -> ElementIntegrals:
        """κ, M, ϱ and m of one element whose stress-free nodal vectors are ``q_hat`` and whose
        reference length (the parameter length of its axis; for a bar |r̂₂ − r̂₁|) is ``length``."""


def local_frame(J: Float[Array, "3 3"]) -> Float[Array, "3 3"]:
    """The orthonormal frame (columns) of a reference Jacobian's first two columns by Gram-Schmidt:
    the first direction, the second made orthogonal to it, and their cross product (a beam's
    axis and section; a plate's two in-plane directions and its normal). Elements map their
    covariant strain to it at every quadrature point (``E_loc = Tᵀ E_cov T``, T = J⁻¹R), which
    keeps κ constant for any reference geometry."""
    t = J[:, 0] / jnp.linalg.norm(J[:, 0])
    n1 = J[:, 1] - (J[:, 1] @ t) * t
    n1 = n1 / jnp.linalg.norm(n1)
    return jnp.stack([t, n1, jnp.cross(t, n1)], axis=1)


__all__ = ["AbstractElement", "ElementIntegrals", "local_frame"]
