"""A triangular thin plate/membrane element with membrane and bending stiffness whose position field
is linear in its nodal vectors (docs/theory.md, §1 RNCF kinematics and §2 Elastic force), so that
its full Green-Lagrange strain energy is quartic in them and κ constant.

**Nodal layout (16 nodal vectors, 48 DOF per element).**
- Each of the three vertices carries ``[r, r_1, r_2, r_z]``: the mid-surface position, its
  derivatives along two in-plane material directions ``a_1, a_2`` of that vertex (e.g. x and y,
  or radial and tangential on a circular edge; the reference slope vectors ``r̂_1 = a_1``,
  ``r̂_2 = a_2`` say which), and the director (the thickness vector, unit normal in the
  reference).
- Each edge carries the director ``r_z`` at its midpoint; the face carries the mid-surface
  position ``r`` at its centroid.
- Element order: ``v0[r, r_1, r_2, r_z], v1[...], v2[...], d(01), d(12), d(20), r(centroid)``.
  Positions are vectors 0, 4, 8 and 15 (``POSITION_VECTORS``); the layout is not node by node,
  so the class constants describe it as 16 one-vector "nodes".
On a mesh, vertex vectors, edge directors and face centroids are shared by the elements that
touch them: 12 DOF a vertex, 3 an edge, 3 a face. The paper's 15-ring disk (721 vertices, 2070
edges, 1350 faces) gets 12·721 + 3·2070 + 3·1350 = 18,912 DOF.

**Position field.** With material coordinates X in the reference plane and the thickness
coordinate ζ ∈ [−h/2, h/2]:

    r(X, ζ) = r_m(X) + ζ d(X)

- ``r_m``: the cubic Hermite triangle (complete cubic: three vertex values and gradients plus
  the centroid value; Ciarlet's P3-Hermite, basis ``−2L_i³ + 3L_i² − 7L₁L₂L₃``,
  ``L_i²L_j − L₁L₂L₃`` along edge vectors, ``27L₁L₂L₃`` in barycentric L). The vertex
  derivatives along ``a_1, a_2`` are mapped to the edge derivatives by the 2 × 2 inverse of
  ``[a_1; a_2]``. Along an edge r_m is the cubic Hermite of the shared vertex data, so the
  mid-surface is C0 between elements and C1 at the vertices.
- ``d``: the quadratic Lagrange triangle on the vertex and mid-edge directors, C0.
So r = S_α(X, ζ) q_α with 16 scalar shape functions.

**Strains and constitutive law.** The full Green-Lagrange strain of this 3-D continuum,
``E = ½(FᵀF − F̂ᵀF̂)`` with F = ∂r/∂(X, ζ), mapped to a local orthonormal frame of the reference
(1, 2 in the plane, 3 the normal; ``E_loc = Tᵀ E_cov T``, T = J⁻¹R constant per point, as the
beam does). Through the thickness E = E⁰ + ζ E¹ + ζ² E²: membrane strain
``½(r_m,α·r_m,β − δ_αβ)``, bending strain ``sym(r_m,α·d,β)``, transverse shear ``½ r_m,α·d``
and the director's stretch ``½(d·d − 1)``. D (``plate_D``, Voigt
[E11, E22, E33, 2E23, 2E13, 2E12]) is the plane-stress law in the plane (E/(1−ν²), ν; G), the
stretch ``E33`` carries E alone, uncoupled, and the transverse shear ``k G`` (k = 5/6) with
the stabilisation below. κ^{αβμν} = ∫ B^a_{αβ} D_ab B^b_{μν} dV (docs/theory.md, §2 Elastic
force) by a degree-8 triangle rule (Dunavant, 16 points) times 3 Gauss points in ζ: exact for a
flat element (B is of degree 4 in X and 2 in ζ). M, ϱ, m by the same rule, with the director's
rotary inertia.

**Why it does not lock.**
- *Poisson (thickness) locking*: d is constant through the thickness, so the director cannot
  take the linear thickness strain that the Poisson effect produces in bending; with the
  3-D isotropic law bending would be (1−ν)²/(1−2ν) times too stiff (1.225 at ν = 0.3). The
  plane-stress law uncouples ``E33`` (as ``Material.beam_D`` does for the beam): the
  constant-curvature energy is then exactly ½ D κ² A with D = Eh³/12(1−ν²) (tested).
- *Membrane locking*: the mid-surface is a complete cubic; the flat element's membrane
  strains do not couple to bending in the linearisation, and a constant membrane strain of
  any size is represented exactly (tested).
- *Shear locking*: the shear-free state d = normal needs the P2 director to equal the
  gradient of the cubic deflection w: inside an element both are complete quadratics, so it
  can, and a thin plate is driven to a conforming C1 piecewise-cubic Kirchhoff plate. That
  limit still converges (O(ℓ²) in frequency on the meshes tested), but its error is larger than at
  moderate thickness. The element therefore uses the stabilised shear modulus of Pitkäranta and of
  Lyly, Stenberg and Vihinen, ``k G h²/(h² + α ℓ²)``, ℓ = √(2A) the element size,
  ``α = stabilization`` (default 0.02): the transverse shear stiffness of an element is then at
  most O(1/α) times its bending stiffness, the frequencies hardly depend on h/b (far less than the
  plain element's do; tested), and the change is consistent: it acts as an extra shear compliance
  O(α ℓ²/h²) that vanishes under refinement (an O(αℓ²/λ²) softening of a mode of wavelength λ).
  ``stabilization=0`` gives the plain element.

**Limits.** Straight-sided flat elements: a curved boundary is a polygon (an O(ℓ²) geometric
error in frequencies and displacements, the largest error in the annulus tests). The normal
slope of the mid-surface is not conforming between elements (only through the shared
directors and the shear energy). Shells with a curved reference are not covered (the
reference must be flat per element, the slope vectors and directors consistent with it).
κ has 16⁴ = 65,536 entries per element: 0.5 MB, 700 MB for the 1350-element disk.
"""

from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from .. import _validate
from .._types import Array, Float, ScalarLike
from .base import AbstractElement, ElementIntegrals, local_frame

N_VECTORS = 16
"""Nodal vectors of one element."""
VERTEX_SLOTS = ("r", "r_1", "r_2", "r_z")
"""The four nodal vectors of a vertex, in order."""
POSITION_VECTORS = (0, 4, 8, 15)
"""The element's position vectors: the vertex positions and the centroid."""

_HERMITE_SLOTS = np.array([0, 1, 2, 4, 5, 6, 8, 9, 10, 15])  # r_m's 10 functions, in element order
_DIRECTOR_SLOTS = np.array([3, 7, 11, 12, 13, 14])  # d's 6 functions: vertices, edges 01, 12, 20
_ORDER = np.argsort(np.concatenate([_HERMITE_SLOTS, _DIRECTOR_SLOTS]))


def _dunavant8() -> tuple[np.ndarray, np.ndarray]:
    """Dunavant's degree-8 rule on a triangle: 16 barycentric points, weights summing to 1."""
    pts, ws = [(1 / 3, 1 / 3, 1 / 3)], [0.144315607677787]
    for w, a in ((0.095091634267285, 0.459292588292723), (0.103217370534718, 0.170569307751760),
                 (0.032458497623198, 0.050547228317031)):
        b = 1 - 2 * a
        pts += [(a, a, b), (a, b, a), (b, a, a)]
        ws += [w] * 3
    a, b = 0.008394777409958, 0.263112829634638
    c = 1 - a - b
    pts += [(a, b, c), (a, c, b), (b, a, c), (b, c, a), (c, a, b), (c, b, a)]
    ws += [0.027230314174435] * 6
    return np.array(pts), np.array(ws)


TRIANGLE_POINTS, TRIANGLE_WEIGHTS = _dunavant8()
"""The in-plane quadrature (barycentric points, weights of the mean over the triangle)."""
THICKNESS_POINTS, THICKNESS_WEIGHTS = np.polynomial.legendre.leggauss(3)


def hermite_triangle(L: Float[Array, "p 3"], dL: Float[Array, "3 2"], X: Float[Array, "3 2"],
                     Ainv: Float[Array, "3 2 2"]) -> tuple[Float[Array, "p 10"], Float[Array, "p 10 2"]]:
    """The cubic Hermite triangle's 10 functions at barycentric points L and their in-plane
    gradients. DOF order ``[r_0, ∂_1 r_0, ∂_2 r_0, r_1, …, r_2's, r_centroid]``; ``dL`` the
    gradients of L, ``X`` the vertices, ``Ainv[i]`` the inverse of vertex i's rows ``[a_1; a_2]``
    (so that ∇r = A⁻¹ [∂_1 r, ∂_2 r])."""
    b = L[:, 0] * L[:, 1] * L[:, 2]
    db = ((L[:, 1] * L[:, 2])[:, None] * dL[0] + (L[:, 0] * L[:, 2])[:, None] * dL[1]
          + (L[:, 0] * L[:, 1])[:, None] * dL[2])
    N, dN = [], []
    for i in range(3):
        Li = L[:, i]
        N.append((-2 * Li**3 + 3 * Li**2 - 7 * b)[:, None])
        dN.append(((-6 * Li**2 + 6 * Li)[:, None] * dL[i] - 7 * db)[:, None])
        slope = jnp.zeros((L.shape[0], 2))
        dslope = jnp.zeros((L.shape[0], 2, 2))
        for j in range(3):
            if j != i:
                # ψ_ij = L_i² L_j − L₁L₂L₃ carries the derivative along the edge vector X_j − X_i,
                # which is c · (∂_1 r, ∂_2 r) at vertex i.
                Lj = L[:, j]
                c = (X[j] - X[i]) @ Ainv[i]
                slope = slope + (Li**2 * Lj - b)[:, None] * c
                dpsi = (2 * Li * Lj)[:, None] * dL[i] + (Li**2)[:, None] * dL[j] - db
                dslope = dslope + c[None, :, None] * dpsi[:, None, :]
        N.append(slope)
        dN.append(dslope)
    N.append(27 * b[:, None])
    dN.append(27 * db[:, None])
    return jnp.concatenate(N, axis=1), jnp.concatenate(dN, axis=1)


def quadratic_triangle(L: Float[Array, "p 3"], dL: Float[Array, "3 2"]) -> tuple[Float[Array, "p 6"],
                                                                                  Float[Array, "p 6 2"]]:
    """The quadratic Lagrange triangle (vertices, then mid-edges 01, 12, 20) and its gradients."""
    Lr, dLr = jnp.roll(L, -1, axis=1), jnp.roll(dL, -1, axis=0)
    P = jnp.concatenate([L * (2 * L - 1), 4 * L * Lr], axis=1)
    dP = jnp.concatenate([(4 * L - 1)[:, :, None] * dL[None],
                          4 * (L[:, :, None] * dLr[None] + Lr[:, :, None] * dL[None])], axis=1)
    return P, dP


def plate_D(E: Float[Array, ""], nu: Float[Array, ""], G_shear: Float[Array, ""]) -> Float[Array, "6 6"]:
    """Constitutive matrix for Voigt strains ``[E11, E22, E33, 2E23, 2E13, 2E12]`` in the plate's
    local orthonormal frame (1, 2 in the plane, 3 the normal): plane stress in the plane, the
    thickness stretch E33 with E alone (uncoupled: no Poisson locking, see the module), the
    transverse shear with ``G_shear``."""
    c = E / (1.0 - nu**2)
    G = E / (2.0 * (1.0 + nu))
    z = jnp.zeros(())
    rows = [
        [c, c * nu, z, z, z, z],
        [c * nu, c, z, z, z, z],
        [z, z, E, z, z, z],
        [z, z, z, G_shear, z, z],
        [z, z, z, z, G_shear, z],
        [z, z, z, z, z, G],
    ]
    return jnp.stack([jnp.stack(r) for r in rows])


def _inv3(J: Float[Array, "3 3"]) -> Float[Array, "3 3"]:
    """3 × 3 inverse by cross products (cheaper to compile than an LU solve inside the element's
    quadrature kernel)."""
    c0, c1, c2 = J[:, 0], J[:, 1], J[:, 2]
    return jnp.stack([jnp.cross(c1, c2), jnp.cross(c2, c0), jnp.cross(c0, c1)]) / jnp.dot(c0, jnp.cross(c1, c2))


def _voigt_B(g: Float[Array, "16 3"]) -> Float[Array, "6 16 16"]:
    """Voigt rows [E11, E22, E33, 2E23, 2E13, 2E12] of the local strain, E = B_{αβ} Q_αβ, from
    ``g[α, k] = ∂S_α/∂x_k`` in the local orthonormal frame (as the beam's)."""

    def sym(a, b):
        return jnp.outer(g[:, a], g[:, b]) + jnp.outer(g[:, b], g[:, a])

    return jnp.stack([jnp.outer(g[:, 0], g[:, 0]), jnp.outer(g[:, 1], g[:, 1]), jnp.outer(g[:, 2], g[:, 2]),
                      sym(1, 2), sym(0, 2), sym(0, 1)])


class TrianglePlate(AbstractElement):
    """The triangular plate/membrane element of this module: Young's modulus ``E`` [Pa], density
    ``rho`` [kg/m³], Poisson's ratio ``nu``, ``thickness`` h [m]; ``shear_factor`` k of the
    transverse shear (5/6) and its ``stabilization`` α (see the module; 0 for none).

    Its reference must be flat: the three vertex positions, the centroid at their mean, slope
    vectors in the plane (any two independent directions per vertex), unit normal directors.
    The ``length`` argument of ``integrals`` is not used: a triangle has no axis, and its size
    ℓ = √(2A) comes from its vertices.
    """

    E: Float[Array, ""]
    rho: Float[Array, ""]
    nu: Float[Array, ""]
    thickness: Float[Array, ""]
    shear_factor: Float[Array, ""]
    stabilization: Float[Array, ""]

    nodes: ClassVar[int] = N_VECTORS
    vectors_per_node: ClassVar[int] = 1
    position_slots: ClassVar[tuple[int, ...]] = (0,)

    def __init__(self, E: ScalarLike, rho: ScalarLike, nu: ScalarLike, thickness: ScalarLike,
                 shear_factor: ScalarLike = 5.0 / 6.0, stabilization: ScalarLike = 0.02):
        _validate.positive("E (Young's modulus)", E)
        _validate.positive("rho (density)", rho)
        _validate.positive("thickness", thickness)
        _validate.positive("shear_factor", shear_factor)
        _validate.non_negative("stabilization", stabilization)
        if _validate.is_concrete(nu):
            v = float(np.asarray(nu))
            if not (-1.0 < v < 0.5):
                raise ValueError(f"nu (Poisson's ratio) must lie in (-1, 0.5), got nu={v!r}")
        self.E = jnp.asarray(E, dtype=float)
        self.rho = jnp.asarray(rho, dtype=float)
        self.nu = jnp.asarray(nu, dtype=float)
        self.thickness = jnp.asarray(thickness, dtype=float)
        self.shear_factor = jnp.asarray(shear_factor, dtype=float)
        self.stabilization = jnp.asarray(stabilization, dtype=float)

    @property
    def bending_stiffness(self) -> Float[Array, ""]:
        """D = E h³ / 12(1 − ν²)."""
        return self.E * self.thickness**3 / (12.0 * (1.0 - self.nu**2))

    def geometry(self, q_hat: Float[Array, "16 3"]):
        """The flat reference triangle: area A, vertices X (3 × 2) and ∇L (3 × 2) in its plane,
        the vertices' inverse slope matrices (3 × 2 × 2) and the frame [e1, e2, n] (3 × 3)."""
        P = q_hat[jnp.array(POSITION_VECTORS[:3])]
        e1 = (P[1] - P[0]) / jnp.linalg.norm(P[1] - P[0])
        n = jnp.cross(P[1] - P[0], P[2] - P[0])
        area = 0.5 * jnp.linalg.norm(n)
        n = n / (2.0 * area)
        R0 = jnp.stack([e1, jnp.cross(n, e1), n], axis=1)
        X = (P - P[0]) @ R0[:, :2]
        # ∇L_i is the inward normal of the edge opposite vertex i over 2A (counter-clockwise X).
        opp = jnp.stack([X[2] - X[1], X[0] - X[2], X[1] - X[0]])
        dL = jnp.stack([-opp[:, 1], opp[:, 0]], axis=1) / (2.0 * area)
        A = q_hat[jnp.array([[1, 2], [5, 6], [9, 10]])] @ R0[:, :2]  # rows a_1, a_2 of each vertex
        det = A[:, 0, 0] * A[:, 1, 1] - A[:, 0, 1] * A[:, 1, 0]
        Ainv = jnp.stack([jnp.stack([A[:, 1, 1], -A[:, 0, 1]], -1),
                          jnp.stack([-A[:, 1, 0], A[:, 0, 0]], -1)], 1) / det[:, None, None]
        return area, X, dL, Ainv, R0

    def shape_functions(self, q_hat: Float[Array, "16 3"], L: Float[Array, "p 3"], zeta: Float[Array, " z"]):
        """S_α and ∂S_α/∂(x_1, x_2, ζ) (in the element's in-plane frame ``geometry()[4]``) at the
        barycentric points L and thickness coordinates ζ: shapes ``(p, z, 16)``, ``(p, z, 16, 3)``."""
        area, X, dL, Ainv, _ = self.geometry(q_hat)
        N, dN = hermite_triangle(L, dL, X, Ainv)
        P, dP = quadratic_triangle(L, dL)
        p, nz = L.shape[0], zeta.shape[0]
        S = jnp.concatenate([jnp.broadcast_to(N[:, None], (p, nz, 10)), zeta[None, :, None] * P[:, None]], axis=2)
        dS_m = jnp.broadcast_to(jnp.concatenate([dN, jnp.zeros((p, 10, 1))], axis=2)[:, None], (p, nz, 10, 3))
        dS_d = jnp.concatenate([zeta[None, :, None, None] * dP[:, None],
                                jnp.broadcast_to(P[:, None, :, None], (p, nz, 6, 1))], axis=3)
        dS = jnp.concatenate([dS_m, dS_d], axis=2)
        return S[:, :, _ORDER], dS[:, :, _ORDER]

    def integrals(self, q_hat: Float[Array, "16 3"], length: Float[Array, ""] | None = None) -> ElementIntegrals:
        h = self.thickness
        area = self.geometry(q_hat)[0]
        G = self.E / (2.0 * (1.0 + self.nu))
        # Stabilised transverse shear k G h²/(h² + α ℓ²), ℓ² = 2A (see the module: shear locking).
        D = plate_D(self.E, self.nu, self.shear_factor * G * h**2 / (h**2 + self.stabilization * 2.0 * area))
        S, dS = self.shape_functions(q_hat, jnp.asarray(TRIANGLE_POINTS), 0.5 * h * jnp.asarray(THICKNESS_POINTS))
        S, dS = S.reshape(-1, N_VECTORS), dS.reshape(-1, N_VECTORS, 3)
        J = jnp.einsum("ai,qaj->qij", q_hat, dS)  # ∂r̂/∂(x_1, x_2, ζ) per point: R0 for a flat reference
        detJ = jnp.einsum("qi,qi->q", J[:, :, 0], jnp.cross(J[:, :, 1], J[:, :, 2]))
        T = jax.vmap(lambda J: _inv3(J) @ local_frame(J))(J)
        B = jax.vmap(_voigt_B)(jnp.einsum("qak,qkl->qal", dS, T))
        W = (np.asarray(TRIANGLE_WEIGHTS)[:, None] * np.asarray(THICKNESS_WEIGHTS)[None, :]).reshape(-1)
        W = W * area * 0.5 * h * detJ  # dV
        # κ^{αβμν} = ∫ B^a_{αβ} D_ab B^b_{μν} dV   (docs/theory.md, §2 Elastic force)
        kappa = jnp.einsum("qaij,qakl->ijkl", W[:, None, None, None] * B, jnp.einsum("ab,qbkl->qakl", D, B))
        M = self.rho * jnp.einsum("q,qi,qj->ij", W, S, S)  # M_αβ = ∫ρ S_α S_β
        varrho = self.rho * jnp.einsum("q,qi->i", W, S)  # ϱ_α = ∫ρ S_α
        return ElementIntegrals(kappa=kappa, M=M, varrho=varrho, m=self.rho * jnp.sum(W))


__all__ = ["N_VECTORS", "POSITION_VECTORS", "VERTEX_SLOTS", "TrianglePlate", "plate_D"]
