"""Strains, stresses and their resultants (``post.stress``) against closed forms, the elements' own
elastic force (virtual work) and rigid motions; and the VTK cell fields (``post.vtk.stress_fields``).

The models are tiny (a two-element tube beam, a four-triangle square plate) and shared through
``functools.cache``; everything runs in float64 (``conftest``)."""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import RTOL_ROUNDOFF

from nrrncf_jax.bodies.body import Body, beam_body, element_group
from nrrncf_jax.bodies.frame import Frame
from nrrncf_jax.bodies.mesh import arc_reference, straight_reference
from nrrncf_jax.bodies.plate_mesh import plate_body
from nrrncf_jax.elements import Bar, Material, TrianglePlate, TubeSection
from nrrncf_jax.elements.plate import THICKNESS_POINTS, THICKNESS_WEIGHTS, TRIANGLE_POINTS, TRIANGLE_WEIGHTS
from nrrncf_jax.post import (
    BEAM_RESULTANTS,
    PLATE_RESULTANTS,
    bar_strain_stress,
    beam_element_resultants,
    beam_resultants,
    beam_section_resultants,
    beam_strain_stress,
    element_vectors,
    plate_resultants,
    plate_section_resultants,
    plate_strain_stress,
    stress_fields,
)
from nrrncf_jax.post.vtk import write_frame_vtk, write_plate_vtk

E, RHO, NU = 2.0e11, 7800.0, 0.3
R_OUT, R_IN = 0.02, 0.01
LENGTH, N_EL = 1.0, 2
SEC = TubeSection(R_OUT, R_IN)
AREA, I2 = float(SEC.area), float(SEC.second_moment)

E_P, NU_P, H, SIDE = 70e9, 0.3, 0.01, 0.2
C_P = E_P / (1 - NU_P**2)
D_P = E_P * H**3 / (12 * (1 - NU_P**2))

TOL_RIGID = 1e-12
"""A rigid motion's strain, as a fraction of a unit strain: F = q_α g_αᵀ sums ~20 products of O(1)
nodal vectors (a translation of O(1)) and O(1/l) shape-function gradients, so its round-off is
~20 ε / l ≈ 1e-14; ×100 for the squares and the frame mapping. Stresses and resultants are held
to the same fraction of their value at a unit strain (E, E A, E I / r, E h, E h²)."""


@functools.cache
def beam():
    """Two straight C1 elements along x, tube section, the section axes y and z."""
    return beam_body(Material(E, RHO, NU), SEC, straight_reference(LENGTH, N_EL))


@functools.cache
def plate():
    """A square of side SIDE in the xy-plane, four triangles about its centre (cartesian slopes)."""
    V = SIDE * np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]])
    T = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    return plate_body(V, T, TrianglePlate(E_P, RHO, NU_P, H))


@functools.cache
def quarter_circle():
    """The same beam on a quarter circle (radius 2L/π, toward +y): its reference and body."""
    ref = arc_reference(LENGTH, 2 * LENGTH / np.pi, N_EL)
    return ref, beam_body(Material(E, RHO, NU), SEC, ref)


def _rotation(seed):
    R = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))[0]
    return R * np.sign(np.linalg.det(R))


def _rigid(body, q, seed):
    """q turned by a random rotation and its positions moved by a random O(1) translation."""
    q = np.asarray(q) @ _rotation(seed).T
    q[np.asarray(body.is_position)] += np.random.default_rng(seed + 1).normal(size=3)
    return q


@jax.jit
def _beam_points(body, q, s, lengths):
    """Strain and stress of every beam element at the stations s and the section's quadrature
    points: shapes (n_el, n_s, n_sec, 6) twice."""
    g = body.groups[0]
    ys, zs, _ = g.element.section.quadrature()

    def element(qh, qe, l):
        at = lambda si, y, z: beam_strain_stress(g.element, qh, qe, si, y, z, l)  # noqa: E731
        return jax.vmap(lambda si: jax.vmap(lambda y, z: at(si, y, z))(ys, zs))(s)

    return jax.vmap(element)(body.q_hat[g.elements], jnp.asarray(q)[g.elements], lengths)


PLATE_L = np.array([[1 / 3, 1 / 3, 1 / 3], [0.6, 0.3, 0.1], [0.05, 0.15, 0.8]])


@jax.jit
def _plate_points(body, q, L, zeta):
    """Strain and stress of every triangle at the barycentric points L and thickness points zeta:
    shapes (n_tri, n_L, n_zeta, 6) twice."""
    g = body.groups[0]

    def element(qh, qe):
        at = lambda Li, z: plate_strain_stress(g.element, qh, qe, Li, z)  # noqa: E731
        return jax.vmap(lambda Li: jax.vmap(lambda z: at(Li, z))(zeta))(L)

    return jax.vmap(element)(body.q_hat[g.elements], jnp.asarray(q)[g.elements])


# --- rigid motions --------------------------------------------------------------------------------


def test_beam_zero_strain_at_reference_and_under_rigid_motion():
    """The stress-free reference, and a large rigid rotation and translation of it, give zero strain,
    stress and resultants (``TOL_RIGID``), at interior points of the section and along the axis (a
    curved reference: ``test_curved_beam_straightened_closed_form``)."""
    body = beam()
    straight = np.full(N_EL, LENGTH / N_EL)
    s = jnp.array([0.0, 0.2113, 0.5, 1.0])
    for q in (body.q_hat, _rigid(body, body.q_hat, 0)):
        strain, stress = _beam_points(body, q, s, straight)
        assert np.abs(np.asarray(strain)).max() < TOL_RIGID
        assert np.abs(np.asarray(stress)).max() < TOL_RIGID * E
        res = np.asarray(beam_resultants(body, q))
        assert res.shape == (N_EL + 1, len(BEAM_RESULTANTS))
        assert (np.abs(res) < TOL_RIGID * E * np.array([AREA] * 3 + [I2 / R_OUT] * 3)).all(), res


def test_plate_zero_strain_at_reference_and_under_rigid_motion():
    """As for the beam: zero strain, stress and resultants at the flat reference and after a large
    rigid motion, at three points of every triangle through the thickness."""
    pb = plate()
    zeta = jnp.array([-0.5 * H, 0.0, 0.3 * H])
    for q in (pb.body.q_hat, _rigid(pb.body, pb.body.q_hat, 3)):
        strain, stress = _plate_points(pb.body, q, PLATE_L, zeta)
        assert np.abs(np.asarray(strain)).max() < TOL_RIGID
        assert np.abs(np.asarray(stress)).max() < TOL_RIGID * E_P
        res = np.asarray(plate_resultants(pb, q))
        assert res.shape == (len(pb.triangles), len(PLATE_RESULTANTS))
        scale = E_P * np.array([H] * 3 + [H**2] * 3 + [H] * 2)
        assert (np.abs(res) < TOL_RIGID * scale).all(), res


# --- beams: closed forms --------------------------------------------------------------------------


def test_beam_axial_stretch_closed_form():
    """Uniform stretch λ along the axis (positions x ↦ λx, r_x ↦ λ e_x), the sections contracted by μ
    (r_y, r_z ↦ μ e_y, μ e_z), then turned rigidly: E11 = ½(λ² − 1), E22 = E33 = ½(μ² − 1), no shear.
    The element's law (``Material.beam_D``) uncouples the axial strain from the section's (its
    Poisson-locking remedy), so S11 = E E11 whatever μ, N = E A E11 over the reference area, and
    S22 = S33 = E/(1 − ν²) (E22 + ν E33) = E/(1 − ν) E22; no moments, torque or shear forces.
    Round-off (``RTOL_ROUNDOFF``), at every node, the section's quadrature points and a chosen
    point of an element (a sensor)."""
    body = beam()
    lam, mu = 1.2, 0.97
    q = np.asarray(body.q_hat).copy().reshape(-1, 6, 3)
    q[:, 0] *= lam  # r: positions along x
    q[:, 1] *= lam  # r_x = e_x
    q[:, 2] *= mu  # r_y = e_y
    q[:, 4] *= mu  # r_z = e_z
    q = _rigid(body, q.reshape(-1, 3), 4)
    E11, E22 = 0.5 * (lam**2 - 1), 0.5 * (mu**2 - 1)
    strain_exact = np.array([E11, E22, E22, 0.0, 0.0, 0.0])
    stress_exact = np.array([E * E11, E / (1 - NU) * E22, E / (1 - NU) * E22, 0.0, 0.0, 0.0])
    strain, stress = _beam_points(body, q, jnp.array([0.0, 0.37, 1.0]), np.full(N_EL, LENGTH / N_EL))
    np.testing.assert_allclose(np.asarray(strain).reshape(-1, 6), np.broadcast_to(strain_exact, (len(
        np.asarray(strain).reshape(-1, 6)), 6)), rtol=RTOL_ROUNDOFF, atol=TOL_RIGID)
    np.testing.assert_allclose(np.asarray(stress).reshape(-1, 6)[:, :3], np.broadcast_to(stress_exact[:3], (len(
        np.asarray(stress).reshape(-1, 6)), 3)), rtol=RTOL_ROUNDOFF)
    res = np.asarray(beam_resultants(body, q))
    np.testing.assert_allclose(res[:, 0], E * AREA * E11, rtol=RTOL_ROUNDOFF)
    assert np.abs(res[:, 1:]).max() < TOL_RIGID * E * I2 / R_OUT
    # A sensor: element 1 at ξ = 0.8 l, section point (0.7 r_o, −0.2 r_o), compiled.
    qh_e, q_e = element_vectors(body, q, 1)
    e, s = jax.jit(beam_strain_stress)(body.groups[0].element, qh_e, q_e, 0.8, 0.7 * R_OUT, -0.2 * R_OUT, 0.5)
    np.testing.assert_allclose(np.asarray(e), strain_exact, rtol=RTOL_ROUNDOFF, atol=TOL_RIGID)
    np.testing.assert_allclose(np.asarray(s)[:3], stress_exact[:3], rtol=RTOL_ROUNDOFF)


def _arc(kappa, toward="+y"):
    """Nodal vectors of the straight beam bent into a circular arc of curvature κ: the arc's own
    reference vectors, c, c', the section vectors turned along and their derivatives, exact at the
    nodes (``arc_reference``)."""
    return np.asarray(arc_reference(LENGTH, 1.0 / kappa, N_EL, toward=toward).q_hat).reshape(-1, 3)


def test_beam_pure_bending_closed_form():
    """A beam bent into an arc of curvature κ toward +y: r_ξ = (1 − κ X₂) t, so E11 = −κX₂ + ½κ²X₂²
    and, the section's quadrature integrating polynomials exactly, M3 = −∫ X₂ S11 dA = E I κ and
    N = E I κ²/2 (the Green-Lagrange strain's second-order part); bending toward +z gives
    M2 = −E I κ. At the nodes the nodal vectors are exact, so these hold to round-off. Inside an
    element the cubic Hermite interpolation of the arc errs by O((κl)⁴): measured 3.7e-3 (κl)⁴ at
    the quarter points and 1.0e-3 (κl)⁴ at the midpoint (κl = 0.5); bound 1e-2 (κl)⁴, and halving κ
    divides the error by 16 ± 10 % (fourth order), so it is the interpolation's and not an offset."""
    body = beam()
    l = LENGTH / N_EL
    kappa = 1.0
    EI = E * I2
    res = np.asarray(beam_resultants(body, _arc(kappa)))
    np.testing.assert_allclose(res[:, 5], EI * kappa, rtol=RTOL_ROUNDOFF)
    np.testing.assert_allclose(res[:, 0], 0.5 * EI * kappa**2, rtol=RTOL_ROUNDOFF)
    assert np.abs(res[:, 1:5]).max() < TOL_RIGID * EI / R_OUT
    res_z = np.asarray(beam_resultants(body, _arc(kappa, "+z")))
    np.testing.assert_allclose(res_z[:, 4], -EI * kappa, rtol=RTOL_ROUNDOFF)
    assert np.abs(res_z[:, 5]).max() < TOL_RIGID * EI / R_OUT

    def interior_error(k):
        M3 = np.asarray(beam_element_resultants(body, _arc(k), jnp.array([0.25, 0.5])))[..., 5]
        return M3 / (EI * k) - 1

    err, err_half = interior_error(kappa), interior_error(kappa / 2)
    assert np.abs(err).max() < 1e-2 * (kappa * l) ** 4, err
    np.testing.assert_allclose(err / err_half, 16.0, rtol=0.1)


def test_curved_beam_straightened_closed_form():
    """The quarter-circle beam (curvature κ) straightened: at a node the reference's r̂_ξ is
    (1 − κX₂) t̂ and the current r_ξ = e_x, so in the local frame E11 = ½((1 − κX₂)⁻² − 1), the rest
    zero, and with the volume Jacobian 1 − κX₂ the moment is M3 = −(E/2) ∫ X₂ ((1 − κX₂)⁻¹ − (1 − κX₂)) dA
    = −E I κ (1 + κ² (r_o⁶ − r_i⁶)/(4(r_o⁴ − r_i⁴)) + …): to 1e-6, the series' next term O((κr_o)⁴)
    and the section quadrature's error on this non-polynomial integrand (measured 1.6e-7). Inside an
    element the Hermite interpolation of the arc errs by O((κl)⁴) (measured 9.8e-4 at the midpoint,
    κl = π/4; bound 1e-2 (κl)⁴ = 3.8e-3) given the elements' arc lengths; with their chords (the
    default) the interpolated reference is another curve and the midpoint moment is off by 3.6e-2
    (bound: more than 1e-2): the lengths matter on a curved reference."""
    ref, arc = quarter_circle()
    kappa, l = np.pi / (2 * LENGTH), LENGTH / N_EL
    exact = -E * I2 * kappa * (1 + kappa**2 * (R_OUT**6 - R_IN**6) / (4 * (R_OUT**4 - R_IN**4)))
    q = np.asarray(straight_reference(LENGTH, N_EL).q_hat).reshape(-1, 3)
    res = np.asarray(beam_resultants(arc, q, ref.lengths))
    np.testing.assert_allclose(res[:, 5], exact, rtol=1e-6)
    mid = np.asarray(beam_element_resultants(arc, q, 0.5, ref.lengths))[:, 5]
    assert np.abs(mid / exact - 1).max() < 1e-2 * (kappa * l) ** 4
    chords = np.linalg.norm(np.diff(np.asarray(ref.q_hat)[:, 0], axis=0), axis=1)
    mid_chords = np.asarray(beam_element_resultants(arc, q, 0.5, chords))[:, 5]
    assert np.abs(mid_chords / exact - 1).min() > 1e-2


def test_beam_resultants_virtual_work():
    """The resultants are the element's force resultants.

    - Axial: r = (X + u(X)) e_x with u = aX² + bX³ (each element represents it exactly), the
      sections unchanged; under the virtual stretch δr = δλ X e_x the strain varies by
      δE11 = (1 + u') δλ, uniform over the section, so F·δq = ∫ N (1 + u') dX. The integrand is a
      polynomial of degree 6 per element, integrated exactly by 5 Gauss points: round-off.
    - Every component: at a random state near the reference and a random δq, F·δq equals
      Σ w S·δE over the element's own quadrature (5 axial points × the section's; det J = 1 on
      the straight reference), with δE the derivative of ``beam_strain_stress``'s strain along δq:
      the stress is the one whose virtual work is the element's force, round-off."""
    body = beam()
    g = body.groups[0]
    l = LENGTH / N_EL
    a, b = 0.05, -0.03
    X = np.asarray(body.q_hat)[0::6, 0]
    q = np.asarray(body.q_hat).copy().reshape(-1, 6, 3)
    q[:, 0, 0] = X + a * X**2 + b * X**3
    q[:, 1, 0] = 1 + 2 * a * X + 3 * b * X**2
    dq = np.zeros_like(q)
    dq[:, 0, 0] = X
    dq[:, 1, 0] = 1.0
    q, dq = q.reshape(-1, 3), dq.reshape(-1, 3)
    virtual = float(jnp.sum(body.elastic_force(jnp.asarray(q)) * dq))
    xs, ws = np.polynomial.legendre.leggauss(5)
    s = 0.5 * (xs + 1)
    N = np.asarray(beam_element_resultants(body, q, jnp.asarray(s)))[..., 0]  # (n_el, 5)
    Xg = (np.arange(N_EL)[:, None] + s[None, :]) * l
    integral = float(np.sum(0.5 * ws * l * N * (1 + 2 * a * Xg + 3 * b * Xg**2)))
    assert integral == pytest.approx(virtual, rel=RTOL_ROUNDOFF)

    rng = np.random.default_rng(5)
    q = np.asarray(body.q_hat) + 0.01 * rng.normal(size=body.q_hat.shape)
    dq = rng.normal(size=body.q_hat.shape)
    ys, zs, w_sec = g.element.section.quadrature()
    w = (0.5 * ws[:, None] * l) * np.asarray(w_sec)[None, :]

    @jax.jit
    def work(qe, dqe, qh):
        def at(si, y, z):
            strain = lambda x: beam_strain_stress(g.element, qh, x, si, y, z, l)[0]  # noqa: E731
            return jnp.dot(beam_strain_stress(g.element, qh, qe, si, y, z, l)[1], jax.jvp(strain, (qe,), (dqe,))[1])

        return jnp.sum(w * jax.vmap(lambda si: jax.vmap(lambda y, z: at(si, y, z))(ys, zs))(jnp.asarray(s)))

    el = np.asarray(g.elements)
    total = sum(float(work(q[e], dq[e], body.q_hat[e])) for e in el)
    assert total == pytest.approx(float(jnp.sum(body.elastic_force(jnp.asarray(q)) * dq)), rel=RTOL_ROUNDOFF)


# --- plates: closed forms -------------------------------------------------------------------------


def _homogeneous(pb, Fm, d):
    """Nodal vectors of the mid-surface map x ↦ Fm x (3 × 2) with the constant director d."""
    q = np.asarray(pb.body.q_hat).copy()
    lay = pb.layout
    mid = ~lay.is_director
    q[mid] = q[mid, :2] @ Fm.T
    q[lay.is_director] = d
    return q


def test_plate_uniform_in_plane_stretch_closed_form():
    """A large homogeneous in-plane deformation Fm (stretches 1.2 and 0.9 with shear), turned out of
    the plane, the director the unit normal: every element represents it exactly, so the strain is
    ε = ½(FmᵀFm − I) in the body's x, y at every point through the thickness, the membrane forces
    per length are plane stress, n = h [[c, cν, 0], [cν, c, 0], [0, 0, G]] ε (c = E/(1 − ν²)),
    and the moments and transverse shears vanish; round-off."""
    pb = plate()
    R = _rotation(6)
    Fm = R[:, :2] @ np.array([[1.2, 0.15], [-0.05, 0.9]])
    q = _homogeneous(pb, Fm, R[:, 2])
    C = Fm.T @ Fm
    eps = 0.5 * np.array([C[0, 0] - 1, C[1, 1] - 1, 2 * C[0, 1]])
    G_P = E_P / (2 * (1 + NU_P))
    n_exact = H * np.array([[C_P, C_P * NU_P, 0], [C_P * NU_P, C_P, 0], [0, 0, G_P]]) @ eps
    res = np.asarray(plate_resultants(pb, q))
    np.testing.assert_allclose(res[:, :3], np.broadcast_to(n_exact, (len(res), 3)), rtol=RTOL_ROUNDOFF,
                               atol=RTOL_ROUNDOFF * np.abs(n_exact).max())
    assert np.abs(res[:, 3:6]).max() < TOL_RIGID * E_P * H**2
    assert np.abs(res[:, 6:]).max() < TOL_RIGID * E_P * H
    strain, stress = _plate_points(pb.body, q, PLATE_L, jnp.array([-0.5 * H, 0.1 * H]))
    strain, stress = np.asarray(strain).reshape(-1, 6), np.asarray(stress).reshape(-1, 6)
    np.testing.assert_allclose(strain[:, [0, 1, 5]], np.broadcast_to(eps, (len(strain), 3)), rtol=RTOL_ROUNDOFF,
                               atol=TOL_RIGID)
    assert np.abs(strain[:, 2:5]).max() < TOL_RIGID
    np.testing.assert_allclose(stress[:, [0, 1, 5]] * H, np.broadcast_to(n_exact, (len(stress), 3)),
                               rtol=RTOL_ROUNDOFF, atol=RTOL_ROUNDOFF * np.abs(n_exact).max())


def _cylinder(pb, kappa):
    """The flat plate wrapped onto a cylinder of radius 1/κ about an axis along y (w ≈ ½κx²): every
    nodal vector exact (positions on the cylinder, r_1 its unit tangent, r_2 = e_y, the directors its
    unit normal at their points)."""
    lay = pb.layout
    qh = np.asarray(pb.body.q_hat)
    q = qh.copy()
    V = lay.vertex_vectors

    def normal(x):
        return np.stack([-np.sin(kappa * x), 0 * x, np.cos(kappa * x)], axis=-1)

    pos = lay.is_position
    x, y = qh[pos, 0], qh[pos, 1]
    q[pos] = np.stack([np.sin(kappa * x) / kappa, y, (1 - np.cos(kappa * x)) / kappa], axis=-1)
    xv = qh[V[:, 0], 0]
    q[V[:, 1]] = np.stack([np.cos(kappa * xv), 0 * xv, np.sin(kappa * xv)], axis=-1)
    q[V[:, 2]] = [0.0, 1.0, 0.0]
    q[V[:, 3]] = normal(xv)
    mid = 0.5 * (qh[V[lay.edges[:, 0], 0]] + qh[V[lay.edges[:, 1], 0]])
    q[lay.edge_vectors] = normal(mid[:, 0])
    return q


def test_plate_bending_closed_form():
    """Bending per length against Kirchhoff's plate, m = ∫ ζ S dζ: m_xx = −D κ, m_yy = −ν D κ,
    m_xy = 0 (D = E h³/12(1 − ν²)) for w_xx = κ.

    - The quadratic field r_m = (x, y, ½κx²), director (−κx, 0, 1) (shear-free, the element's exact
      constant-curvature state): the ζ-linear strain is exactly −ζκ along x, so round-off.
    - The plate wrapped onto a cylinder of radius 1/κ (``_cylinder``): the cubic mid-surface and the
      quadratic director interpolate the circle, an O((κa)²) error at the centroids for the mesh
      size a: measured 8.3e-4 at κa = 0.2; bound 2e-3, and doubling κ multiplies it by 4 ± 10 %
      (second order)."""
    pb = plate()
    lay = pb.layout
    qh = np.asarray(pb.body.q_hat)
    kappa = 1.0
    q = qh.copy()
    pos = lay.is_position
    q[pos, 2] = 0.5 * kappa * qh[pos, 0] ** 2
    V = lay.vertex_vectors
    q[V[:, 1], 2] = kappa * qh[V[:, 0], 0]  # r_1 = (1, 0, κx)
    q[V[:, 3], 0] = -kappa * qh[V[:, 0], 0]
    mid = 0.5 * (qh[V[lay.edges[:, 0], 0]] + qh[V[lay.edges[:, 1], 0]])
    q[lay.edge_vectors, 0] = -kappa * mid[:, 0]
    res = np.asarray(plate_resultants(pb, q))
    np.testing.assert_allclose(res[:, 3], -D_P * kappa, rtol=RTOL_ROUNDOFF)
    np.testing.assert_allclose(res[:, 4], -NU_P * D_P * kappa, rtol=RTOL_ROUNDOFF)
    assert np.abs(res[:, 5]).max() < TOL_RIGID * E_P * H**2
    # at another point of a triangle, the element-level function
    qh_e, q_e = element_vectors(pb.body, q, 2)
    r = np.asarray(jax.jit(plate_section_resultants)(pb.body.groups[0].element, qh_e, q_e, jnp.array([0.7, 0.2, 0.1])))
    np.testing.assert_allclose(r[3:5], [-D_P * kappa, -NU_P * D_P * kappa], rtol=RTOL_ROUNDOFF)

    def errors(k):
        res = np.asarray(plate_resultants(pb, _cylinder(pb, k)))
        return res[:, 3] / (-D_P * k) - 1, res[:, 4] / (-NU_P * D_P * k) - 1

    (err_xx, err_yy), (err_xx2, _) = errors(kappa), errors(2 * kappa)
    assert max(np.abs(err_xx).max(), np.abs(err_yy).max()) < 2e-3, (err_xx, err_yy)
    np.testing.assert_allclose(err_xx2 / err_xx, 4.0, rtol=0.1)


@pytest.mark.slow
def test_plate_stress_virtual_work():
    """At a random state near the reference and a random δq, F·δq equals Σ w S·δE over the
    element's own quadrature (16 Dunavant points × 3 in ζ, w = weight × A × h/2; det J = 1 on the
    flat reference): the stress, its stabilised transverse shear included, is the one whose
    virtual work is the element's force; round-off."""
    pb = plate()
    body = pb.body
    g = body.groups[0]
    rng = np.random.default_rng(7)
    q = np.asarray(body.q_hat) + 0.01 * rng.normal(size=body.q_hat.shape)
    dq = rng.normal(size=body.q_hat.shape)
    zeta = 0.5 * H * jnp.asarray(THICKNESS_POINTS)
    w_pt = np.asarray(TRIANGLE_WEIGHTS)[:, None] * np.asarray(THICKNESS_WEIGHTS)[None, :] * 0.5 * H

    @jax.jit
    def work(qe, dqe, qh):
        area = g.element.geometry(qh)[0]

        def at(L, z):
            strain = lambda x: plate_strain_stress(g.element, qh, x, L, z)[0]  # noqa: E731
            return jnp.dot(plate_strain_stress(g.element, qh, qe, L, z)[1], jax.jvp(strain, (qe,), (dqe,))[1])

        pts = jax.vmap(lambda L: jax.vmap(lambda z: at(L, z))(zeta))(jnp.asarray(TRIANGLE_POINTS))
        return area * jnp.sum(w_pt * pts)

    el = np.asarray(g.elements)
    total = sum(float(work(q[e], dq[e], body.q_hat[e])) for e in el)
    assert total == pytest.approx(float(jnp.sum(body.elastic_force(jnp.asarray(q)) * dq)), rel=RTOL_ROUNDOFF)


# --- VTK ------------------------------------------------------------------------------------------


@pytest.mark.slow
def test_stress_fields_in_vtk_files(tmp_path):
    """``stress_fields`` of a plate and of a frame (beams and bars) go into the writers' files as cell
    data, and meshio reads them back: the plate's in-plane stretch gives its plane-stress membrane
    forces on every triangle; a frame of two beam elements and two bars (a triangle), every member
    stretched by λ along its axis, gives N = E A ½(λ² − 1) on the beams' line cells and the bars'
    own E A ½(λ² − 1) on theirs (so the cells are matched to the right elements)."""
    meshio = pytest.importorskip("meshio")
    pb = plate()
    q = _homogeneous(pb, np.array([[1.05, 0.0], [0.0, 1.0], [0.0, 0.0]]), [0.0, 0.0, 1.0])
    fields = stress_fields(pb, q)
    assert set(fields) == set(PLATE_RESULTANTS)
    (path,) = write_plate_vtk(str(tmp_path / "plate"), pb, {"stretch": q - np.asarray(pb.body.q_hat)},
                              cell_data={"stretch": fields})
    back = meshio.read(path)
    n_xx = H * C_P * 0.5 * (1.05**2 - 1)
    np.testing.assert_allclose(back.cell_data["n_xx"][0], n_xx, rtol=RTOL_ROUNDOFF)
    np.testing.assert_allclose(back.cell_data["n_yy"][0], NU_P * n_xx, rtol=RTOL_ROUNDOFF)
    with pytest.raises(ValueError, match="one value a cell"):
        write_plate_vtk(str(tmp_path / "bad"), pb, {"x": q}, cell_data={"x": {"n_xx": np.ones(3)}})

    # A frame by hand: the beam body's two elements along x and two bars to an apex (0.5, 0.5, 0).
    body = beam()
    bar = Bar(7e10, 2700.0, 1e-4)
    q_hat = np.vstack([np.asarray(body.q_hat), [[0.5, 0.5, 0.0]]])
    apex = len(q_hat) - 1
    groups = [body.groups[0], element_group(bar, q_hat, np.array([[0, apex], [apex, 12]]))]
    is_pos = np.append(np.asarray(body.is_position), True)
    frame = Frame(body=Body(q_hat, groups, is_position=is_pos), joint_vectors=np.zeros((0, 4), int),
                  member_positions=(np.array([0, 6, 12]),), n_beams=N_EL, n_bars=2)
    lam = 1.1
    q = q_hat.copy()
    q[is_pos] *= lam
    q[[1, 7, 13]] *= lam  # the beam's r_x
    fields = stress_fields(frame, q)
    (path,) = write_frame_vtk(str(tmp_path / "frame"), frame, {"stretch": q - q_hat}, cell_data={"stretch": fields})
    back = meshio.read(path)
    e11 = 0.5 * (lam**2 - 1)
    np.testing.assert_allclose(back.cell_data["N"][0], [E * AREA * e11] * 2 + [7e10 * 1e-4 * e11] * 2,
                               rtol=RTOL_ROUNDOFF)
    assert np.abs(back.cell_data["M3"][0]).max() < TOL_RIGID * E * I2 / R_OUT
    _, stress = bar_strain_stress(bar, jnp.asarray(q_hat[[0, apex]]), jnp.asarray(q[[0, apex]]))
    assert float(stress) == pytest.approx(7e10 * e11, rel=RTOL_ROUNDOFF)
    # a chain beam body: one cell an element, its midpoint resultants
    chain = stress_fields(body, q[:-1])
    np.testing.assert_allclose(chain["N"], E * AREA * e11, rtol=RTOL_ROUNDOFF)


@pytest.mark.slow
def test_element_functions_jit_and_vmap():
    """The element-level functions compiled and vmapped over elements give the eager values."""
    body = beam()
    g = body.groups[0]
    q = np.asarray(body.q_hat) + 0.01 * np.random.default_rng(8).normal(size=body.q_hat.shape)
    qh_e, q_e = body.q_hat[g.elements], jnp.asarray(q)[g.elements]
    batched = jax.jit(jax.vmap(beam_section_resultants, in_axes=(None, 0, 0, None, None)))(
        g.element, qh_e, q_e, 0.3, LENGTH / N_EL)
    single = [np.asarray(beam_section_resultants(g.element, qh_e[e], q_e[e], 0.3, LENGTH / N_EL))
              for e in range(N_EL)]
    np.testing.assert_allclose(np.asarray(batched), np.stack(single), rtol=RTOL_ROUNDOFF,
                               atol=RTOL_ROUNDOFF * np.abs(np.stack(single)).max())
