"""The joint cell: the stiffness of a rigid joint's own small solid, on the joint's position gradient.

A joint node of a frame (``frame.frame_body``) carries the full position gradient
``F = [r_X, r_Y, r_Z]``, to which every member that meets there is linked in rotation and shear
(``elements.JointLink``), not in stretch. F's stretches, and its distortions between two members
at an angle, need a stiffness of their own that does not depend on the mesh: a point constraint
on a shear-deformable beam's slope costs nothing in the continuum limit, so with the members
alone the joint would turn into a hinge under refinement (its compliance growing with each
refinement).

The joint cell is the elastic energy of the joint's own material, a small isotropic solid of
volume V (default: a cube of the members' outer diameter, the size of a welded or bolted node)
whose deformation gradient is F:

    U = ½ V E_ij C_ijkl E_kl,   E_ij = ½(r_i·r_j − δ_ij) = Q_ij,

so κ^{ijkl} = V C_ijkl (symmetrised), constant, with the three gradient vectors as the element's
nodal vectors. It carries no position vector and no mass (the truss's joints have none), only the
second moments of its solid's mass, ``∫ρ X_i X_j dV = ρ V d² / 12 δ_ij`` for a cube of side
``d = V^{1/3}`` about its centre, on the gradient vectors: the rotary inertia of the joint, which
keeps the mass matrix regular (nothing else gives F inertia; a massless F would make M singular,
and the dense eigensolver and the integrator's initial accelerations need M⁻¹). For the default
cube of a Ø20 × 2 mm tube's diameter it equals the rotary inertia of 6 cm of the tube. A rigid
rotation of F costs nothing; any distortion of the joint costs at least ``2μV`` per unit strain²,
independent of the mesh, so the joint's stiffness converges under refinement.
"""

from typing import ClassVar

import jax.numpy as jnp

from .. import _validate
from .._types import Array, Float, ScalarLike
from .base import AbstractElement, ElementIntegrals
from .material import Material


class JointCell(AbstractElement):
    """A joint's solid of ``material`` and ``volume`` [m³] on its gradient vectors (r_X, r_Y, r_Z)."""

    material: Material
    volume: Float[Array, ""]

    nodes: ClassVar[int] = 1
    vectors_per_node: ClassVar[int] = 3
    position_slots: ClassVar[tuple[int, ...]] = ()

    def __init__(self, material: Material, volume: ScalarLike):
        _validate.positive("volume (joint cell volume)", volume)
        self.material = material
        self.volume = jnp.asarray(volume, dtype=float)

    def integrals(self, q_hat: Float[Array, "3 3"], length: Float[Array, ""]) -> ElementIntegrals:
        E, nu = self.material.E, self.material.nu
        lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
        mu = E / (2.0 * (1.0 + nu))
        d = jnp.eye(3)
        C = (lam * jnp.einsum("ij,kl->ijkl", d, d)
             + mu * (jnp.einsum("ik,jl->ijkl", d, d) + jnp.einsum("il,jk->ijkl", d, d)))
        # In the reference F̂ = I the gradient vectors are the global axes, so E_ij = Q_ij directly;
        # for another reference F̂ (not used by frames) E = F̂⁻ᵀ Q F̂⁻¹.
        Fi = jnp.linalg.inv(q_hat.T)
        kappa = self.volume * jnp.einsum("ai,bj,ck,dl,ijkl->abcd", Fi, Fi, Fi, Fi, C)
        # ∫ρ X_i X_j over a cube of side d about its centre (the joint's rotary inertia), no mass.
        d2 = self.volume ** (2.0 / 3.0)
        M = self.material.rho * self.volume * d2 / 12.0 * jnp.eye(3)
        return ElementIntegrals(kappa=kappa, M=M, varrho=jnp.zeros(3), m=jnp.zeros(()))


__all__ = ["JointCell"]
