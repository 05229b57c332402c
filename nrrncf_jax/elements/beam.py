"""The spatial C1 ANCF beam element ("fully parameterised" with cross-section gradient
derivatives), as used by the paper's RNCF examples.

Each node carries six nodal vectors ``[r, r_x, r_y, r_xy, r_z, r_xz]`` (18 DOF). Along the axis
every field is a cubic Hermite interpolation, so the element is C1 in position *and* in the
cross-section vectors; across the section the field is linear:

    r(ξ, y, z) = Σ_nodes h_r r + h_x r_x + y (h_r r_y + h_x r_xy) + z (h_r r_z + h_x r_xz)

so ``r = S_α(ξ, y, z) q_α`` with 12 scalar shape functions per element (docs/theory.md, §1 RNCF kinematics).

**Why it does not lock.**
- *Shear locking* comes from interpolating the centreline slope and the cross-section rotation
  inconsistently. Here r_y and r_z are cubic Hermite in ξ, exactly as r is, so the pure
  bending state of an Euler-Bernoulli beam (r_y ⟂ r_x, i.e. zero transverse shear) is
  representable for every cubic deflection; the shear strain is not forced to be non-zero.
- *Poisson locking* is removed in the constitutive matrix (see ``Material.beam_D``): the axial
  strain is uncoupled from the cross-section strains.
The closed-form frequency and elastica tests check both.

κ and the inertia integrals come from the Green-Lagrange strain of the continuum (docs/theory.md, §2 Elastic force),
with the covariant strain mapped to a local orthonormal frame (axis, section y, section z) of
the *reference* geometry at every quadrature point, so curved reference geometry is exact:
``E_loc = Tᵀ E_cov T`` with ``T = J⁻¹ R``, ``J = ∂r̂/∂(ξ, y, z)`` and ``R`` the orthonormalised
columns of J. T is constant, so κ stays constant.
"""

from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float
from .base import AbstractElement, ElementIntegrals, local_frame
from .material import Material
from .section import AbstractSection

NODAL_VECTORS_PER_NODE = 6
"""Per node: r, r_x, r_y, r_xy, r_z, r_xz."""


def mirror_even(n_nodes: int, normal: str = "z") -> np.ndarray:
    """The coordinates of a chain of ``n_nodes`` C1 beam nodes (n_nodes·18, node by node) that a
    reflection through the plane normal to the global axis ``normal`` ("y" or "z") leaves
    unchanged, for a reference along x whose section axes are the global y and z.

    The reflection maps a deformed state r(ξ, y, z) to S r(ξ, y, −z) (normal z; S = diag(1, 1, −1)),
    so each nodal vector becomes S times itself, with a minus sign more on the derivatives across
    the plane (r_z and r_xz; for normal y, r_y and r_xy). K and M commute with this map, so the
    modes and modal derivatives computed with the odd coordinates held at zero are exactly the
    symmetric (in-plane) ones of the whole beam: where the eigensolver on all coordinates returns
    them only to its round-off, eps (ω_max/ω_gap)² (about 1e-8 of a mode for a 2-element tube), a
    seed that the motion can amplify."""
    axis = {"y": 1, "z": 2}.get(normal)
    if axis is None:
        raise ValueError(f"normal must be 'y' or 'z', got {normal!r}")
    across = [2, 3] if axis == 1 else [4, 5]  # r_y, r_xy or r_z, r_xz (see beam_shape_functions)
    sign = np.ones((NODAL_VECTORS_PER_NODE, 3))
    sign[:, axis] = -1.0
    sign[across] *= -1.0
    return np.tile(sign > 0, (int(n_nodes), 1)).reshape(-1)


def _hermite(s: Float[Array, ""], l: Float[Array, ""]):
    """Cubic Hermite functions on ξ = s·l, s ∈ [0, 1], and their ξ-derivatives."""
    h = jnp.stack([1 - 3 * s**2 + 2 * s**3, l * (s - 2 * s**2 + s**3), 3 * s**2 - 2 * s**3, l * (-(s**2) + s**3)])
    dh = jnp.stack([(-6 * s + 6 * s**2) / l, 1 - 4 * s + 3 * s**2, (6 * s - 6 * s**2) / l, -2 * s + 3 * s**2])
    return h, dh


def beam_shape_functions(
    s: Float[Array, ""], y: Float[Array, ""], z: Float[Array, ""], l: Float[Array, ""]
) -> tuple[Float[Array, " 12"], Float[Array, "12 3"]]:
    """Shape functions S_α(ξ, y, z) of one element and their derivatives ∂S_α/∂(ξ, y, z).

    ``s`` is the normalised axial coordinate ξ/l ∈ [0, 1], ``l`` the element length.
    """
    h, dh = _hermite(s, l)
    zero = jnp.zeros_like(s)
    one = jnp.ones_like(s)
    S, dS = [], []
    for node in range(2):
        hr, hx = h[2 * node], h[2 * node + 1]
        dhr, dhx = dh[2 * node], dh[2 * node + 1]
        # r, r_x, r_y, r_xy, r_z, r_xz
        S += [hr, hx, y * hr, y * hx, z * hr, z * hx]
        dS += [
            [dhr, zero, zero],
            [dhx, zero, zero],
            [y * dhr, hr * one, zero],
            [y * dhx, hx * one, zero],
            [z * dhr, zero, hr * one],
            [z * dhx, zero, hx * one],
        ]
    return jnp.stack(S), jnp.stack([jnp.stack(row) for row in dS])


def _voigt_B(g: Float[Array, "12 3"]) -> Float[Array, "6 12 12"]:
    """Voigt rows [E11, E22, E33, 2E23, 2E13, 2E12] of the local strain: E = B_{αβ} Q_αβ.

    ``g[α, k]`` is ∂S_α/∂x_k in the local orthonormal frame; each row is symmetric in (α, β).
    """

    def sym(a, b):
        return jnp.outer(g[:, a], g[:, b]) + jnp.outer(g[:, b], g[:, a])

    return jnp.stack(
        [
            jnp.outer(g[:, 0], g[:, 0]),
            jnp.outer(g[:, 1], g[:, 1]),
            jnp.outer(g[:, 2], g[:, 2]),
            sym(1, 2),
            sym(0, 2),
            sym(0, 1),
        ]
    )


def beam_element_integrals(
    q_hat: Float[Array, "12 3"],
    length: Float[Array, ""],
    material: Material,
    section: AbstractSection,
    n_axial: int = 5,
) -> tuple[Float[Array, "12 12 12 12"], Float[Array, "12 12"], Float[Array, " 12"], Float[Array, ""]]:
    """κ^{αβμν}, M_αβ, ϱ_α and m of one element (docs/theory.md, §1 RNCF kinematics and §2 Elastic
    force) by Gauss quadrature.

    ``q_hat`` is the element's stress-free configuration. 5 axial points integrate the straight
    element's κ (degree 8 in ξ) and mass (degree 6) exactly.
    Returns ``(kappa, M, varrho, m)``.
    """
    xs, wxs = np.polynomial.legendre.leggauss(n_axial)
    s_pts = jnp.asarray(0.5 * (xs + 1.0))
    w_ax = jnp.asarray(0.5 * wxs) * length
    D = material.beam_D()

    def at_point(s, y, z):
        S, dS = beam_shape_functions(s, y, z, length)
        J = q_hat.T @ dS  # J[a, i] = ∂r̂_a/∂ξ_i
        T = jnp.linalg.solve(J, local_frame(J))
        return S, _voigt_B(dS @ T), jnp.linalg.det(J)

    def over(quadrature):
        ys, zs, w_sec = quadrature
        S, B, detJ = jax.vmap(lambda s: jax.vmap(lambda y, z: at_point(s, y, z))(ys, zs))(s_pts)
        W = (w_ax[:, None] * w_sec[None, :] * detJ).reshape(-1)  # dV weights
        return S.reshape(-1, 12), B.reshape(-1, 6, 12, 12), W

    S, B, W = over(section.quadrature())
    shear = section.shear_quadrature()
    if shear is None:
        # κ^{αβμν} = ∫ B^a_{αβ} D_ab B^b_{μν} dV   (docs/theory.md, §2 Elastic force)
        kappa = jnp.einsum("q,qaij,ab,qbkl->ijkl", W, B, D, B)
    else:
        # the normal strains over the section, the shear strains over the section's shear
        # quadrature with its moduli factors (``section.RectangleSection``); D has no coupling
        # between the two (``Material.beam_D``)
        _, B_s, W_s = over(shear)
        D_s = D[3:, 3:] * section.shear_moduli_factors()[:, None]
        kappa = jnp.einsum("q,qaij,ab,qbkl->ijkl", W, B[:, :3], D[:3, :3], B[:, :3]) + \
            jnp.einsum("q,qaij,ab,qbkl->ijkl", W_s, B_s[:, 3:], D_s, B_s[:, 3:])
    rho = material.rho
    M = rho * jnp.einsum("q,qi,qj->ij", W, S, S)  # M_αβ = ∫ρ S_α S_β
    varrho = rho * jnp.einsum("q,qi->i", W, S)  # ϱ_α = ∫ρ S_α
    m = rho * jnp.sum(W)
    return kappa, M, varrho, m


class C1Beam(AbstractElement):
    """The C1 spatial ANCF beam of this module as an element type: two nodes of six nodal vectors
    ``[r, r_x, r_y, r_xy, r_z, r_xz]``, of which r is the position; ``material`` and
    ``section`` (``TubeSection``, ``RectangleSection``) define it, ``n_axial`` Gauss points along
    the axis (5 integrate the straight element exactly)."""

    material: Material
    section: AbstractSection
    n_axial: int = eqx.field(static=True, default=5)

    nodes: ClassVar[int] = 2
    vectors_per_node: ClassVar[int] = NODAL_VECTORS_PER_NODE
    position_slots: ClassVar[tuple[int, ...]] = (0,)
    section_slots: ClassVar[tuple[int, ...]] = (2, 4)  # r_y, r_z

    def integrals(self, q_hat: Float[Array, "12 3"], length: Float[Array, ""]) -> ElementIntegrals:
        return ElementIntegrals(*beam_element_integrals(q_hat, length, self.material, self.section, self.n_axial))
