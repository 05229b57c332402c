"""What a body brings to a mechanism: the interface every body kind implements
(``AbstractBodyKind``), so that one system (``mechanism.Mechanism``) holds any mix of them.

A body kind maps its coordinates z_b to the nodal vectors x_b = f_b(z_b) in the inertial frame,
where joints, springs and sensors act, and supplies its part of the equations of motion
(docs/theory.md, §3 Equations of motion of one body and §7 Jointed bodies): the residual
J_bᵀ(M_b ẍ_b − Q_b) + ∂U_b/∂z_b, its block of the iteration matrix, its own constraints (the Euler
parameters' |e|² = 1 of a floating frame) and its energies. The kinds:

- ``floating.FloatingBody``: a frame (origin, Euler parameters) and the deformation in it on a
  basis: NR-RNCF (reduced), RNCF (``full_order_frame``, every free coordinate kept) and, with an
  empty basis, a rigid body (``rigid``);
- ``inertial.InertialBody``: an ANCF body whose coordinates are its nodal vectors in the inertial
  frame (z = x, J = I);
- ``point_mass.PointMass``: one position vector carrying a mass.

A new kind is one new file: a subclass implementing these methods.
"""

import abc
from typing import ClassVar

import equinox as eqx

from .._types import Array, Float
from ..linalg import factor_block
from .markers import BodyGeometry


class AbstractBodyKind(eqx.Module):
    """A body of a mechanism (see the module docstring). Methods take the body's own part z of
    the system's coordinates (and v = ż, a = z̈)."""

    n_own_equations: ClassVar[int] = 0
    """Constraints the body adds on its own coordinates (after the joints' in C)."""

    mass: eqx.AbstractVar[Float[Array, "nv nv"]]
    """The mass matrix on the body's nodal vectors (the same for each component), where its
    inertia lives in the inertial frame: ``Mechanism.masses`` and the momentum sensors read it. A
    field or a property of every kind."""

    kind: ClassVar[str]
    """``"rigid"``, ``"ancf"`` (inertial nodal vectors), ``"rncf"`` (floating frame, full-order
    deformation) or ``"nr-rncf"`` (floating frame, reduced deformation)."""

    @property
    def small_kernels(self) -> bool:
        """Whether the body's part of a step is a few small contractions (no element forces over a
        mesh): a mechanism of such bodies only is compiled as ``models.base.AbstractModel``'s
        ``small_kernels`` says. False unless a kind says so."""
        return False

    @property
    @abc.abstractmethod
    def n_z(self) -> int:
        """The body's number of coordinates."""

    def describe(self) -> str:
        """The body's kind and number of coordinates (a reduced body adds how its basis was chosen)."""
        return f"{self.kind}, {self.n_z} coordinates"

    @property
    @abc.abstractmethod
    def n_vectors(self) -> int:
        """The body's number of nodal vectors (what joints refer to)."""

    @abc.abstractmethod
    def initial(self) -> Float[Array, " nz"]:
        """The coordinates of the reference (stress-free, initial) configuration."""

    @abc.abstractmethod
    def geometry(self) -> BodyGeometry:
        """The reference nodal vectors in the system's frame, for resolving markers."""

    @abc.abstractmethod
    def nodal_vectors(self, z) -> Float[Array, "nv 3"]:
        """x = f(z) in the inertial frame."""

    @abc.abstractmethod
    def tangent(self, z, dz) -> Float[Array, "nv 3"]:
        """J dz, J = ∂f/∂z: the nodal velocities for dz = ż."""

    @abc.abstractmethod
    def jacobian(self, z, rows) -> Float[Array, "r 3 nz"]:
        """J's rows for the nodal vectors ``rows`` (the ones the joints read)."""

    @abc.abstractmethod
    def generalized(self, z, F: Float[Array, "nv 3"]) -> Float[Array, " nz"]:
        """J ᵀF: nodal forces F as generalized forces."""

    @abc.abstractmethod
    def residual(self, z, v, a, gravity) -> Float[Array, " nz"]:
        """J ᵀ(M ẍ − Q) + ∂U/∂z: inertia, weight and elastic force, without the joints'."""

    def loaded_residual(self, z, v, a, gravity, F: Float[Array, "nv 3"]) -> Float[Array, " nz"]:
        """``residual`` with the nodal forces ``F`` (the joints' reactions) added as J ᵀF. A
        kind whose residual is itself J ᵀ of nodal forces adds F to them instead: one J ᵀ."""
        return self.residual(z, v, a, gravity) + self.generalized(z, F)

    @abc.abstractmethod
    def mass_matrix(self, z) -> Float[Array, "nz nz"]:
        """J ᵀM J."""

    @abc.abstractmethod
    def block(self, z, c_M, c_K, gravity, state=None, c_C=0.0) -> Float[Array, "nz nz"]:
        """The body's block of the iteration matrix, c_M ∂r/∂a + c_C ∂r/∂v + c_K ∂r/∂z (to the
        terms the kind keeps; modified Newton converges with the rest left out). ``state``:
        ``(v, a, reaction)``, the step's velocity, acceleration and the joints' nodal forces on
        the body, for kinds whose block depends on them."""

    @property
    def structured(self) -> bool:
        """Whether the body factors its iteration block itself (``factor``), with a solver that
        knows its structure (a beam chain's block-tridiagonal matrix), instead of as a dense
        block. False unless a kind says so."""
        return False

    def factor(self, z, c_M, c_K, gravity, state=None, c_C=0.0):
        """The body's ``block`` factored for ``linalg.schur_factor``: dense (``linalg.factor_block``)
        unless the kind knows better (``structured``)."""
        return factor_block(self.block(z, c_M, c_K, gravity, state, c_C))

    @abc.abstractmethod
    def kinetic_energy(self, z, v) -> Float[Array, ""]:
        """½ ẋᵀ M ẋ."""

    @abc.abstractmethod
    def potential_energy(self, z, gravity) -> Float[Array, ""]:
        """Strain energy plus the gravity potential −Σ ϱ_α x_α·g."""

    @abc.abstractmethod
    def turned(self, e: Float[Array, " 4"], A: Float[Array, "3 3"]) -> "AbstractBodyKind":
        """The body turned as a whole about the origin by the rotation A (Euler parameters e)."""

    @abc.abstractmethod
    def rigid_velocity(self, z, velocity, omega) -> Float[Array, " nz"]:
        """ż for the rigid motion ẋ(p) = velocity + omega × p (both 3-vectors, in the inertial
        frame; velocity is that of the point at the origin): an initial velocity in physical
        terms."""

    def stiffened(self, s) -> "AbstractBodyKind":
        """The body with its stiffness times ``s`` (Young's modulus scaled at a fixed Poisson
        ratio: a material parameter that gradients reach); a body without deformation is itself."""
        return self

    def own_equations(self, z) -> Float[Array, " e"]:
        """The body's own constraints (none by default)."""
        return z[:0]

    def own_jacobian(self, z) -> Float[Array, "e nz"]:
        """Their Jacobian with respect to z."""
        return z[:0, None] * z[None, :]


__all__ = ["AbstractBodyKind"]
