"""The 3-D bar (truss) element: two nodes, one position vector each, axial strain only.

The position along the axis is linear, ``r(s) = (1 − s) r₁ + s r₂`` with s = ξ/L ∈ [0, 1], so
the axial Green-Lagrange strain is ``ε = ½(|r'|² − 1) = B_αβ Q_αβ`` with ``B = [[1, −1], [−1,
1]]/L²`` (r' = (r₂ − r₁)/L) and ``Q_αβ = ½(q_α·q_β − q̂_α·q̂_β)``. With the axial stiffness EA
the energy is ``U = ½ EA L ε²``, so in closed form (docs/theory.md, §2 Elastic force)

    κ^{αβμν} = EA L B_αβ B_μν,   M = ρAL/6 [[2, 1], [1, 2]],   ϱ = ρAL/2 [1, 1],   m = ρAL.

A bar carries no bending and no torsion: a node joined only by bars has no stiffness against
rotating the bars about each other, so a truss needs enough bars (or other elements) to be
stable. Used alone (pin-jointed trusses) or on the position vectors of beam nodes (the
beamlike truss of the paper's Sec. 4.5).
"""

from typing import ClassVar

import jax.numpy as jnp

from .. import _validate
from .._types import Array, Float, ScalarLike
from .base import AbstractElement, ElementIntegrals


class Bar(AbstractElement):
    """Bar of Young's modulus ``E`` [Pa], density ``rho`` [kg/m³] and cross-section ``area`` [m²]."""

    E: Float[Array, ""]
    rho: Float[Array, ""]
    area: Float[Array, ""]

    nodes: ClassVar[int] = 2
    vectors_per_node: ClassVar[int] = 1
    position_slots: ClassVar[tuple[int, ...]] = (0,)

    def __init__(self, E: ScalarLike, rho: ScalarLike, area: ScalarLike):
        _validate.positive("E (Young's modulus)", E)
        _validate.positive("rho (density)", rho)
        _validate.positive("area (cross-section area)", area)
        self.E = jnp.asarray(E, dtype=float)
        self.rho = jnp.asarray(rho, dtype=float)
        self.area = jnp.asarray(area, dtype=float)

    def integrals(self, q_hat: Float[Array, "2 3"], length: Float[Array, ""]) -> ElementIntegrals:
        L = jnp.asarray(length, dtype=float)
        B = jnp.array([[1.0, -1.0], [-1.0, 1.0]]) / L**2
        kappa = self.E * self.area * L * jnp.einsum("ab,mn->abmn", B, B)
        m = self.rho * self.area * L
        M = m / 6.0 * jnp.array([[2.0, 1.0], [1.0, 2.0]])
        return ElementIntegrals(kappa=kappa, M=M, varrho=0.5 * m * jnp.ones(2), m=m)


__all__ = ["Bar"]
