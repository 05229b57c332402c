"""Strains, stresses and their resultants from a body's nodal vectors, as the elements define them.

Every element of this library has the position field ``r = S_α(ξ) q_α`` and the Green-Lagrange
strain ``E_ij = B^{ij}_{αβ} Q_αβ`` (docs/theory.md, §2 Elastic force), mapped at each point to the
local orthonormal frame R of the reference (``elements.base.local_frame``; ``T = J⁻¹R``,
``J = ∂r̂/∂ξ``). With ``g_α = Tᵀ ∂S_α/∂ξ`` the local position gradient is ``F = q_α g_αᵀ`` (3 × 3,
F̂ = R for the reference) and

    E = ½(FᵀF − F̂ᵀF̂) = g_αᵢ g_βⱼ Q_αβ,

the same number as the element's ``B_{αβ} Q_αβ`` (``beam._voigt_B``, ``plate._voigt_B``) by
another operation order: F is formed first, so a rigid translation cancels in F (the position
shape functions' derivatives sum to zero) before anything is squared, and the strain of a rigid
motion is zero to the round-off of F. The second Piola-Kirchhoff stress is ``S = D E`` with the
element's own constitutive matrix (``Material.beam_D`` for beams, ``plate.plate_D`` with the
element's stabilised transverse shear for plates), so that the elastic energy density is
``½ Eᵀ D E`` and the virtual work ``∫ S·δE dV`` is the element's force ``F^α·δq_α`` (Eq. 9);
the tests check this identity.

Voigt order as in the elements: strains ``[E11, E22, E33, 2E23, 2E13, 2E12]`` (engineering shears),
stresses ``[S11, S22, S33, S23, S13, S12]``.

- **C1 beams** (``elements.C1Beam``): components in the element's local frame (1 the axis, 2-3 the
  reference section axes r̂_y, r̂_z); section resultants over the element's own section quadrature
  ``BEAM_RESULTANTS = (N, V2, V3, T, M2, M3)``: ``N = ∫ S11``, ``V2 = ∫ S12``, ``V3 = ∫ S13``,
  ``T = ∫ (X2 S13 − X3 S12)``, ``M2 = ∫ X3 S11``, ``M3 = −∫ X2 S11``, each ``dA`` weighted by the
  element's volume Jacobian (dV = det J dA dξ, 1 on a straight element), i.e. per unit reference
  axis length, so that ``∫ (N δE11 + …) dξ`` is the virtual work the element integrates.
- **Bars** (``elements.Bar``): the axial strain ``½(|r'|² − 1)`` and ``S11 = E E11``.
- **Triangle plates** (``elements.TrianglePlate``): components in the body's reference Cartesian
  axes (the plate lies in its body's xy-plane, ``bodies.plate_mesh``), ``R E_loc Rᵀ``; resultants
  through the thickness by the element's 3-point Gauss rule in ζ
  ``PLATE_RESULTANTS = (n_xx, n_yy, n_xy, m_xx, m_yy, m_xy, q_x, q_y)``: membrane forces per length
  ``n = ∫ S dζ``, bending moments per length ``m = ∫ ζ S dζ`` (Kirchhoff's sign: a plate bent to
  ``w = ½ κ x²`` has ``m_xx = −D κ``, D = E h³/12(1 − ν²)) and transverse shear forces
  ``q = ∫ S_{α3} dζ``. The strain is quadratic in ζ (E⁰ + ζE¹ + ζ²E², see the element), so these
  are exact.

Element-level functions take the element type, the element's stress-free nodal vectors
``q_hat_e`` and current ones ``q_e`` (n_e × 3, e.g. ``q[group.elements[e]]``) and a point; they
are pure jnp, so ``jax.jit`` and ``jax.vmap`` (over elements or points) pass through them.
Body-level functions evaluate them over a body's element group, compiled (``eqx.filter_jit``: a
Python number is a static argument, an array is traced).

**Element lengths.** An element group keeps no element lengths, and a beam's shape functions
need the parameter length l of its axis. The body-level beam functions take ``lengths`` (one per
beam element) and default to the distance between the element's end positions, as
``bodies.element_group`` does: exact on straight elements (``beam_body`` on a straight reference,
``frame_body``). A curved reference built with arc lengths (``bodies.arc_reference``) needs
``lengths=reference.lengths``: with another l the Hermite functions interpolate another curve
between the nodes than the one whose κ the element holds, and the strains inside an element are
measured from it (at the nodes they do not depend on l).

**In a mechanism's run**, ``SectionResultant(marker, quantity)`` is a sensor
(``multibody.sensors``): a beam's section resultants at a marker's node, recorded at the output
times and written by ``nrrncf run --out`` like any other sensor.
"""

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float
from ..bodies.body import Body
from ..elements.bar import Bar
from ..elements.base import local_frame
from ..elements.beam import C1Beam, beam_shape_functions
from ..elements.plate import THICKNESS_POINTS, THICKNESS_WEIGHTS, TrianglePlate, plate_D
from ..multibody.markers import Marker
from ..multibody.section_frame import triad
from ..multibody.sensors import _MarkerSensor, _node

BEAM_RESULTANTS = ("N", "V2", "V3", "T", "M2", "M3")
"""Columns of the beam section resultants: axial force, shear forces along the section axes 2 and 3,
torque, bending moments about the section axes 2 and 3."""

PLATE_RESULTANTS = ("n_xx", "n_yy", "n_xy", "m_xx", "m_yy", "m_xy", "q_x", "q_y")
"""Columns of the plate resultants per length: membrane forces, bending moments, transverse shears."""


def _voigt_strain(E: Float[Array, "3 3"]) -> Float[Array, " 6"]:
    """[E11, E22, E33, 2E23, 2E13, 2E12] of a symmetric tensor (the elements' Voigt order)."""
    return jnp.stack([E[0, 0], E[1, 1], E[2, 2], 2.0 * E[1, 2], 2.0 * E[0, 2], 2.0 * E[0, 1]])


def _tensor_stress(S: Float[Array, " 6"]) -> Float[Array, "3 3"]:
    """The symmetric tensor of Voigt stresses [S11, S22, S33, S23, S13, S12]."""
    return jnp.stack([jnp.stack([S[0], S[5], S[4]]), jnp.stack([S[5], S[1], S[3]]), jnp.stack([S[4], S[3], S[2]])])


def _voigt_stress(S: Float[Array, "3 3"]) -> Float[Array, " 6"]:
    return jnp.stack([S[0, 0], S[1, 1], S[2, 2], S[1, 2], S[0, 2], S[0, 1]])


def _local_green_lagrange(q_hat_e, q_e, dS):
    """Green-Lagrange strain (3 × 3) in the reference's local orthonormal frame, that frame R
    (columns, reference coordinates), det J and the position gradient F (3 × 3: spatial rows, the
    local frame's columns) at a point whose shape-function derivatives ∂S_α/∂ξ are ``dS``
    (n_e × 3); the element's own mapping ``T = J⁻¹ R`` (module docstring)."""
    J = q_hat_e.T @ dS  # J[a, i] = ∂r̂_a/∂ξ_i
    R = local_frame(J)
    g = dS @ jnp.linalg.solve(J, R)  # g[α, k] = ∂S_α/∂x_k in the local frame
    F, F_hat = q_e.T @ g, q_hat_e.T @ g
    return 0.5 * (F.T @ F - F_hat.T @ F_hat), R, jnp.linalg.det(J), F


# --- C1 beams -------------------------------------------------------------------------------------


def _beam_point(element: C1Beam, q_hat_e, q_e, s, y, z, length):
    """Strain and stress (Voigt), det J, the position gradient F and the position r at a point
    of one C1 beam element (``beam_strain_stress``)."""
    shape, dS = beam_shape_functions(s, y, z, length)
    E_loc, _, det_J, F = _local_green_lagrange(q_hat_e, q_e, dS)
    E = _voigt_strain(E_loc)
    return E, element.material.beam_D() @ E, det_J, F, q_e.T @ shape


def beam_strain_stress(element: C1Beam, q_hat_e: Float[Array, "12 3"], q_e: Float[Array, "12 3"], s, y, z,
                       length) -> tuple[Float[Array, " 6"], Float[Array, " 6"]]:
    """Green-Lagrange strain and second Piola-Kirchhoff stress (Voigt, module docstring) of one C1
    beam element at the normalised axial coordinate ``s = ξ/l ∈ [0, 1]`` and the section point
    ``(y, z)`` (coordinates along the reference section vectors r̂_y, r̂_z), in the element's local
    frame (1 the axis); ``length`` the element's parameter length l. ``S = D E`` with
    ``Material.beam_D``: ``S11 = E E11`` whatever the section does (the element's Poisson-locking
    remedy), the section a plane-stress layer, the shears with G."""
    E, S = _beam_point(element, q_hat_e, q_e, s, y, z, length)[:2]
    return E, S


def beam_section_resultants(element: C1Beam, q_hat_e: Float[Array, "12 3"], q_e: Float[Array, "12 3"], s,
                            length) -> Float[Array, " 6"]:
    """``BEAM_RESULTANTS`` (N, V2, V3, T, M2, M3) of one element at ``s = ξ/l``: the stresses of
    ``beam_strain_stress`` integrated over the section by the element's own quadratures
    (``quadrature``, and ``shear_quadrature`` with its moduli factors for the shear forces and the
    torque where the section has one) with its volume Jacobian, so that they are the element's
    force resultants (module docstring)."""
    def stresses(quadrature):
        ys, zs, w = quadrature
        _, S, det_J, _, _ = jax.vmap(lambda y, z: _beam_point(element, q_hat_e, q_e, s, y, z, length))(ys, zs)
        return ys, zs, w * det_J, S

    y, z, w, S = stresses(element.section.quadrature())
    S11 = S[:, 0]
    shear = element.section.shear_quadrature()
    if shear is not None:  # the shear stresses where the element integrates them (``RectangleSection``)
        y, z, w_s, S = stresses(shear)
        S = S.at[:, 3:].multiply(element.section.shear_moduli_factors())
    else:
        w_s = w
    y_n, z_n, _ = element.section.quadrature()
    S13, S12 = S[:, 4], S[:, 5]
    return jnp.stack([w @ S11, w_s @ S12, w_s @ S13, w_s @ (y * S13 - z * S12), w @ (z_n * S11), -(w @ (y_n * S11))])


def beam_section_forces(element: C1Beam, q_hat_e: Float[Array, "12 3"], q_e: Float[Array, "12 3"], s,
                        length) -> Float[Array, " 6"]:
    """``BEAM_RESULTANTS`` (N, V2, V3, T, M2, M3) of the force and the moment that the section at
    ``s = ξ/l`` carries in the deformed state, resolved in its deformed frame: what a
    geometrically exact beam code (and a force balance on a cut) reports.

    The traction on the section per reference area is the first Piola-Kirchhoff stress on the
    axis's normal, t = P e₁ = F S e₁ = F (S11, S12, S13); the force is n = ∫ t dA and the moment
    about the centre line m = ∫ (r(y, z) − r(0, 0)) × t dA, each over the element's quadratures as
    ``beam_section_resultants`` (the shears on the shear quadrature with its moduli factors); the
    frame (e₁, e₂, e₃) is the orthonormal triad of the section vectors F e₂, F e₃ at the centre
    line (``multibody.section_frame.triad``). Then N = n·e₁, V2 = n·e₂, V3 = n·e₃, T = m·e₁,
    M2 = m·e₂, M3 = m·e₃: the same signs as ``beam_section_resultants``, whose ∫ S11 they equal to
    first order. They differ where the strain is not small against one: a bar stretched by ε
    carries N = (1 + ε) ∫ S11, and a bent one N ≈ ∫ S11 + κ M (κ its curvature), the difference
    between the work-conjugate resultant of the Green-Lagrange strain and the force."""
    def force_and_moment(quadrature, traction):
        """n and m of the tractions ``traction(S)`` (the stress components that act) on the points."""
        ys, zs, w = quadrature
        _, S, det_J, F, r = jax.vmap(lambda y, z: _beam_point(element, q_hat_e, q_e, s, y, z, length))(ys, zs)
        t = jnp.einsum("pij,pj->pi", F, traction(S)) * (w * det_J)[:, None]
        return t.sum(0), jnp.cross(r - r_c, t).sum(0)

    _, _, _, F_c, r_c = _beam_point(element, q_hat_e, q_e, s, 0.0, 0.0, length)  # the centre line
    e = triad(F_c[:, 1], F_c[:, 2])  # columns e₁, e₂, e₃
    shear = element.section.shear_quadrature()
    if shear is None:  # one quadrature for every component
        n, m = force_and_moment(element.section.quadrature(), lambda S: S[:, jnp.array([0, 5, 4])])
    else:  # the shears where the element integrates them, with its moduli factors (``RectangleSection``)
        k = element.section.shear_moduli_factors()  # on (2E23, 2E13, 2E12)
        n_1, m_1 = force_and_moment(element.section.quadrature(), lambda S: S[:, [0]] * jnp.array([1.0, 0.0, 0.0]))
        n_s, m_s = force_and_moment(shear, lambda S: jnp.stack([0.0 * S[:, 0], k[2] * S[:, 5], k[1] * S[:, 4]], -1))
        n, m = n_1 + n_s, m_1 + m_s
    return jnp.concatenate([e.T @ n, e.T @ m])


def _group(body, kind):
    """The body's first element group of element type ``kind``."""
    for g in body.groups:
        if isinstance(g.element, kind):
            return g
    raise ValueError(f"the body has no {kind.__name__} elements (its groups: "
                     f"{[type(g.element).__name__ for g in body.groups]})")


def _beam_lengths(group, q_hat, lengths):
    if lengths is not None:
        lengths = jnp.asarray(lengths, dtype=float)
        if lengths.shape != (group.n_elements,):
            raise ValueError(f"lengths: one per beam element, ({group.n_elements},), got {lengths.shape}")
        return lengths
    el = group.element
    first, last = el.position_slots[0], (el.nodes - 1) * el.vectors_per_node
    qh = q_hat[group.elements]
    return jnp.linalg.norm(qh[:, last] - qh[:, first], axis=-1)  # bodies.element_group's default


@eqx.filter_jit
def beam_element_resultants(body, q: Float[Array, "n 3"], s=0.5, lengths=None) -> Float[Array, "n_el ... 6"]:
    """``BEAM_RESULTANTS`` of every element of the body's C1 beam group at the normalised stations
    ``s`` (a number or an array of them, the same in every element): ``(n_el, *shape(s), 6)``.
    ``lengths``: the elements' parameter lengths (module docstring; default their chords)."""
    g = _group(body, C1Beam)
    q = jnp.asarray(q).reshape(body.n_vectors, 3)
    lengths = _beam_lengths(g, body.q_hat, lengths)
    s = jnp.asarray(s, dtype=float)

    def element(qh, qe, l):
        at = jax.vmap(lambda si: beam_section_resultants(g.element, qh, qe, si, l))(s.reshape(-1))
        return at.reshape(*s.shape, 6)

    return jax.vmap(element)(body.q_hat[g.elements], q[g.elements], lengths)


@eqx.filter_jit
def beam_resultants(body, q: Float[Array, "n 3"], lengths=None) -> Float[Array, "nodes 6"]:
    """``BEAM_RESULTANTS`` at the nodes of a chain beam body (``bodies.beam_body``), one row a node
    from root to tip: the end nodes from their element, each interior node the mean of its two
    elements' ends (the C1 element's curvature, and so its moment, jumps between elements by the
    discretisation error)."""
    if not body.chain:
        raise ValueError("beam_resultants needs a chain beam body (bodies.beam_body); for other bodies use "
                         "beam_element_resultants")
    ends = beam_element_resultants(body, q, jnp.array([0.0, 1.0]), lengths)  # (n_el, 2, 6)
    left = jnp.concatenate([ends[:1, 0], ends[:, 1]])  # node i from element i − 1 (node 0: element 0)
    right = jnp.concatenate([ends[:, 0], ends[-1:, 1]])  # node i from element i (the tip: the last)
    return 0.5 * (left + right)


# --- bars -----------------------------------------------------------------------------------------


def bar_strain_stress(element: Bar, q_hat_e: Float[Array, "2 3"], q_e: Float[Array, "2 3"]
                      ) -> tuple[Float[Array, ""], Float[Array, ""]]:
    """Axial Green-Lagrange strain ``E11 = ½(|r₂ − r₁|²/L² − 1)`` (L = |r̂₂ − r̂₁|) and stress
    ``S11 = E E11`` of a bar (``elements.Bar``); its axial force is ``element.area · S11``."""
    L2 = jnp.sum((q_hat_e[1] - q_hat_e[0]) ** 2)
    E11 = 0.5 * (jnp.sum((q_e[1] - q_e[0]) ** 2) - L2) / L2
    return E11, element.E * E11


# --- triangle plates ------------------------------------------------------------------------------


def _plate_D(element: TrianglePlate, q_hat_e):
    """The element's constitutive matrix, as ``TrianglePlate.integrals`` forms it (the element has
    no accessor for it): ``plate_D`` with the stabilised transverse shear k G h²/(h² + α ℓ²),
    ℓ² = 2A."""
    h = element.thickness
    area = element.geometry(q_hat_e)[0]
    G = element.E / (2.0 * (1.0 + element.nu))
    return plate_D(element.E, element.nu, element.shear_factor * G * h**2 / (h**2 + element.stabilization * 2.0 * area))


def _plate_points(element: TrianglePlate, q_hat_e, q_e, L, zeta):
    """Strain and stress tensors (reference Cartesian axes) and det J at barycentric ``L`` (3,) and
    the thickness coordinates ``zeta`` (z,): shapes (z, 3, 3), (z, 3, 3), (z,)."""
    _, dS = element.shape_functions(q_hat_e, jnp.asarray(L, dtype=float)[None], jnp.asarray(zeta, dtype=float))
    D = _plate_D(element, q_hat_e)

    def at(dS):
        E_loc, R, det_J, _ = _local_green_lagrange(q_hat_e, q_e, dS)
        S_loc = _tensor_stress(D @ _voigt_strain(E_loc))
        return R @ E_loc @ R.T, R @ S_loc @ R.T, det_J

    return jax.vmap(at)(dS[0])


def plate_strain_stress(element: TrianglePlate, q_hat_e: Float[Array, "16 3"], q_e: Float[Array, "16 3"],
                        L: Float[Array, " 3"], zeta) -> tuple[Float[Array, " 6"], Float[Array, " 6"]]:
    """Green-Lagrange strain and second Piola-Kirchhoff stress (Voigt, module docstring) of one
    triangle at the barycentric point ``L`` (weights of vertices 0, 1, 2) and the thickness
    coordinate ``zeta`` ∈ [−h/2, h/2] (0: the mid-surface, the membrane part), in the body's
    reference Cartesian axes. ``S = D E`` with the element's law (plane stress in the plane, the
    director stretch with E alone, the stabilised transverse shear)."""
    E, S, _ = _plate_points(element, q_hat_e, q_e, L, jnp.reshape(jnp.asarray(zeta, dtype=float), (1,)))
    return _voigt_strain(E[0]), _voigt_stress(S[0])


def plate_section_resultants(element: TrianglePlate, q_hat_e: Float[Array, "16 3"], q_e: Float[Array, "16 3"],
                             L: Float[Array, " 3"]) -> Float[Array, " 8"]:
    """``PLATE_RESULTANTS`` at the barycentric point ``L`` of one triangle: membrane forces
    ``n = ∫ S dζ`` and bending moments ``m = ∫ ζ S dζ`` per length (in-plane components) and the
    transverse shear forces ``q = ∫ S_{α3} dζ``, by the element's Gauss rule in ζ with its volume
    Jacobian (exact: the strain is quadratic in ζ). For a linear distribution through the
    thickness the surface stresses are ``n/h ∓ 6 m/h²`` at ζ = ∓h/2."""
    half = 0.5 * element.thickness
    zeta = half * jnp.asarray(THICKNESS_POINTS)
    _, S, det_J = _plate_points(element, q_hat_e, q_e, L, zeta)
    w = half * jnp.asarray(THICKNESS_WEIGHTS) * det_J
    n = jnp.einsum("z,zij->ij", w, S)
    m = jnp.einsum("z,zij->ij", w * zeta, S)
    return jnp.stack([n[0, 0], n[1, 1], n[0, 1], m[0, 0], m[1, 1], m[0, 1], n[0, 2], n[1, 2]])


def plate_resultants(plate, q: Float[Array, "n 3"], L=(1 / 3, 1 / 3, 1 / 3)) -> Float[Array, "n_tri 8"]:
    """``PLATE_RESULTANTS`` of every triangle of a plate (a ``plate_mesh.PlateBody`` or its body) at
    the barycentric point ``L`` (default the centroid), one row a triangle in the mesh's order."""
    return _plate_resultants(getattr(plate, "body", plate), q, jnp.asarray(L, dtype=float))


@eqx.filter_jit
def _plate_resultants(body, q, L):
    g = _group(body, TrianglePlate)
    q = jnp.asarray(q).reshape(body.n_vectors, 3)
    return jax.vmap(lambda qh, qe: plate_section_resultants(g.element, qh, qe, L))(body.q_hat[g.elements],
                                                                                   q[g.elements])


def element_vectors(body, q: Float[Array, "n 3"], element: int, kind=None) -> tuple[Float[Array, "ne 3"],
                                                                                     Float[Array, "ne 3"]]:
    """``(q_hat_e, q_e)`` of element number ``element`` of the body's first group of element type
    ``kind`` (default: its first group), for the element-level functions (a sensor at a chosen
    point)."""
    g = body.groups[0] if kind is None else _group(body, kind)
    idx = jnp.asarray(g.elements)[element]
    return body.q_hat[idx], jnp.asarray(q).reshape(body.n_vectors, 3)[idx]


# --- as a sensor of a mechanism's run --------------------------------------------------------------


class SectionResultant(_MarkerSensor):
    """A mechanism's sensor (``multibody.sensors``): a C1 beam body's section resultant at the
    marker's node, at an interior node the mean of its two elements' ends (as
    ``beam_resultants``): ``quantity`` one of
    ``post.stress.BEAM_RESULTANTS`` ("N", "V2", "V3", "T", "M2", "M3"), "V" or "M" (the shear
    force's or the bending moment's magnitude), or None for all six. ``kind``: ``"force"`` (the
    default) the force and moment the section carries, in its deformed frame
    (``beam_section_forces``), as a geometrically exact beam code or a force balance reports
    them; ``"conjugate"`` the integrals of the second Piola-Kirchhoff stress
    (``beam_section_resultants``), work-conjugate to the element's strains, equal to first order.
    The strain is the Green-Lagrange strain of the inertial nodal vectors against the body's
    stress-free ones (rigid motion of the body or its frame drops out), so full-order (ANCF) and
    floating-frame (RNCF, NR-RNCF) bodies read alike. The elements' lengths are their chords
    (exact on straight beams; see **Element lengths** above)."""

    marker: Marker = eqx.field(static=True)
    quantity: str | None = eqx.field(static=True, default=None)
    kind: str = eqx.field(static=True, default="force", kw_only=True)
    stations: tuple[tuple[int, float], ...] | None = eqx.field(static=True, default=None, kw_only=True)

    def __check_init__(self):
        if self.quantity is not None and self.quantity not in BEAM_RESULTANTS + ("V", "M"):
            raise ValueError(f"quantity must be one of {BEAM_RESULTANTS + ('V', 'M')} or None, got "
                             f"{self.quantity!r}")
        if self.kind not in ("force", "conjugate"):
            raise ValueError(f"kind must be 'force' or 'conjugate', got {self.kind!r}")

    @staticmethod
    def _beam(system, b):
        body = system.bodies[b]
        body = body if isinstance(body, Body) else getattr(body, "body", None)
        groups = [g for g in getattr(body, "groups", ()) if isinstance(g.element, C1Beam)]
        if not groups:
            raise ValueError(f"SectionResultant: body {b} has no C1 beam elements")
        return body, groups[0]

    def resolve(self, system) -> "SectionResultant":
        node = _node(system, self.marker)
        _, g = self._beam(system, self.marker.body)
        el = g.element
        ends = np.asarray(g.elements)[:, [el.position_slots[0], (el.nodes - 1) * el.vectors_per_node]]
        stations = tuple((int(e), float(side)) for side in (0, 1) for e in np.flatnonzero(ends[:, side] == node))
        if not stations:
            raise ValueError(f"SectionResultant: the marker's node is not an end of body {self.marker.body}'s beam "
                             "elements")
        return dataclasses.replace(self, nodes=(node,), stations=stations)

    def __call__(self, system, t, z, v) -> Float[Array, "..."]:
        if self.stations is None:
            raise ValueError("a sensor on markers must be resolved against its system first (sensors.observe)")
        body, g = self._beam(system, self.marker.body)
        x = system.nodal_vectors(z)[self.marker.body]
        idx, lengths = np.asarray(g.elements), _beam_lengths(g, body.q_hat, None)
        resultants = beam_section_forces if self.kind == "force" else beam_section_resultants
        r = sum(resultants(g.element, body.q_hat[idx[e]], x[idx[e]], s, lengths[e])
                for e, s in self.stations) / len(self.stations)
        if self.quantity in ("V", "M"):  # the magnitude of the shear force or the bending moment
            k = 1 if self.quantity == "V" else 4
            return jnp.hypot(r[k], r[k + 1])
        return r if self.quantity is None else r[BEAM_RESULTANTS.index(self.quantity)]


__all__ = ["BEAM_RESULTANTS", "PLATE_RESULTANTS", "SectionResultant", "bar_strain_stress",
           "beam_element_resultants", "beam_resultants", "beam_section_forces", "beam_section_resultants",
           "beam_strain_stress", "element_vectors", "plate_resultants", "plate_section_resultants",
           "plate_strain_stress"]
