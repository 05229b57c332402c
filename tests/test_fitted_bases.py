"""Bases fitted to a body's joints (``multibody.reduce``'s ``conditions``: pinned, bearing;
``reduction.craig_bampton``'s ``boundary_mds``).

Closed form: a simply supported Euler-Bernoulli beam bends at ω_n = (nπ/L)² √(EI/ρA). The test
beam is slender (L/r = 1000), so the element's shear moves the first bending frequencies by
(nπ r_g/L)²(1 + E/κG)/2 ~ 1e-5 relative, and 16 cubic elements by about 6e-6 n⁴ (5e-5 for the
third mode, 2e-4 for the fourth, which is left out): the bound 1e-4 on the first three sits
above both and below any wrong condition (a clamped end moves the first frequency by a factor
1.56², a free one makes it a rigid mode). The sliding pin's axial mode (ω = π/(2L) √(E/ρ), a
fixed-free bar) lies far above these on so slender a beam.
"""

import numpy as np
import pytest

from nrrncf_jax.bodies import Material, TubeSection, beam_body, straight_reference
from nrrncf_jax.elements.beam import NODAL_VECTORS_PER_NODE
from nrrncf_jax.multibody import placed
from nrrncf_jax.multibody.reduce import reduce
from nrrncf_jax.post.metrics import chi_rel
from nrrncf_jax.reduction import craig_bampton, vibration_modes
from nrrncf_jax.reduction.modal_derivatives import modal_derivatives

E, RHO, NU, R, L = 7.0e10, 2700.0, 0.3, 0.001, 1.0


def _beam(elements=16, turn=None):
    body = beam_body(Material(E, RHO, NU), TubeSection(R), straight_reference(L, elements))
    return placed(body, turn, (0.3, -0.2, 0.1))


def _rotation_z(deg):
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@pytest.mark.parametrize("deg", [0.0, 35.0])
def test_pinned_conditions_give_the_simply_supported_frequencies(deg):
    """In plane (``plane_normal``), turned in space or not: the three lowest bending modes at their
    closed form; the frame lies along the chord."""
    A = _rotation_z(deg)
    beam = _beam(turn=A)
    a, b = A @ np.zeros(3) + (0.3, -0.2, 0.1), A @ np.array([L, 0.0, 0.0]) + (0.3, -0.2, 0.1)
    body = reduce(beam, [a, b], vms=4, mds=[], conditions="pinned", plane_normal=A @ (0.0, 0.0, 1.0))
    assert np.allclose(np.asarray(body.R0), a) and np.allclose(body.basis.shape, (body.body.n_dof, 4))
    assert "pinned" in body.describe() and "4 VMs + 0 MDs" in body.describe()
    omega = np.sort(np.asarray(vibration_modes(body.body, body.free, 4).omega))
    area, inertia = np.pi * R**2, np.pi * R**4 / 4
    bending = [(n * np.pi / L) ** 2 * np.sqrt(E * inertia / (RHO * area)) for n in (1, 2, 3)]
    assert np.allclose(omega[:3], bending, rtol=1e-4), (omega, bending)
    # the frame's x axis along the chord a → b: the second pin's transverse coordinates are held
    q = np.asarray(body.body.q_hat)
    assert np.allclose(q[np.argmax(q[:, 0])], (L, 0.0, 0.0), atol=1e-12)


def test_pinned_conditions_in_space_hold_the_six_rigid_motions():
    """Without a plane: bending in both planes at the closed form (two of each frequency), no
    rigid mode left (the first pin's twist is held)."""
    body = reduce(_beam(elements=8), [(0.3, -0.2, 0.1), (L + 0.3, -0.2, 0.1)], vms=4, mds=[], conditions="pinned")
    omega = np.sort(np.asarray(vibration_modes(body.body, body.free, 4).omega))
    w1 = (np.pi / L) ** 2 * np.sqrt(E * np.pi * R**4 / 4 / (RHO * np.pi * R**2))
    assert np.allclose(omega[:2], w1, rtol=1e-4)
    with pytest.raises(ValueError, match="two interfaces"):
        reduce(_beam(elements=4), [(0.3, -0.2, 0.1)], conditions="pinned")
    with pytest.raises(ValueError, match="conditions must be"):
        reduce(_beam(elements=4), [(0.3, -0.2, 0.1), (L + 0.3, -0.2, 0.1)], conditions="hinged")
    with pytest.raises(ValueError, match="two interfaces"):
        reduce(_beam(elements=4), [(0.3, -0.2, 0.1)], conditions="bearing")


def test_bearing_conditions_give_the_clamped_clamped_frequencies():
    """``conditions="bearing"`` (clamped, then held in a bearing that lets the shaft slide and
    twist): the first two bending frequencies of a beam clamped at both ends, (β L)² = 4.73004²
    and 7.85320², twice each (both planes), and no rigid mode."""
    body = reduce(_beam(), [(0.3, -0.2, 0.1), (L + 0.3, -0.2, 0.1)], vms=4, mds=[], conditions="bearing")
    omega = np.sort(np.asarray(vibration_modes(body.body, body.free, 4).omega))
    c = np.sqrt(E * R**2 / 4 / RHO) / L**2
    assert np.allclose(omega, c * np.repeat([4.730040745, 7.853204624], 2) ** 2, rtol=1e-4), omega


def test_craig_bampton_holds_the_constraint_modes_derivatives():
    """``boundary_mds``: the basis spans the constraint modes' modal derivatives (their projection
    residual at round-off); without them it does not (the residual of order one)."""
    beam = placed(beam_body(Material(E, RHO, NU), TubeSection(0.005), straight_reference(0.3, 4)))
    free = np.ones((beam.n_vectors, 3), bool)
    free[[0, *beam.section_slots]] = False  # clamped at the first node: r, r_y, r_z held
    free = free.reshape(-1)
    tip = 3 * (beam.n_vectors - NODAL_VECTORS_PER_NODE)  # the last node's position
    boundary = [tip, tip + 1]
    with_mds = np.asarray(craig_bampton(beam, free, boundary, 2).basis)
    without = np.asarray(craig_bampton(beam, free, boundary, 2, boundary_mds=False).basis)
    interior = free.copy()
    interior[boundary] = False
    theta = np.asarray(modal_derivatives(beam, interior, with_mds[:, :2], [(0, 0), (0, 1), (1, 1)]).theta)

    def residual(basis):
        Q, _ = np.linalg.qr(basis)
        return np.linalg.norm(theta - Q @ (Q.T @ theta)) / np.linalg.norm(theta)

    assert residual(with_mds) < 1e-8
    assert residual(without) > 1e-2
    assert with_mds.shape[1] > without.shape[1]


@pytest.mark.slow
def test_jointed_bases_follow_the_full_slider_crank():
    """The slider-crank over one crank turn: the rod pinned (one simply supported mode and its
    derivative) and Craig-Bampton (one fixed-interface mode, the slider pin's boundary
    coordinates and their derivatives) follow the full ANCF rod's midpoint deflection to a few
    per cent, where one cantilever mode cannot meet the second pin (tens of per cent)."""
    from nrrncf_jax.examples.slider_crank import mechanism
    from nrrncf_jax.scenarios.mechanism_file import run_setup

    def w_mid(**kw):
        setup = mechanism(elements=4, **kw)
        return run_setup(setup, t_end=0.042, n_out=85, controller=setup.controller(1e-4)).series["w_mid"]

    ref = w_mid(formulation="ancf")
    pinned = w_mid(formulation="nr-rncf", vms=1, conditions="pinned")
    cb = w_mid(formulation="nr-rncf", vms=1, basis="craig-bampton")
    cantilever = w_mid(formulation="nr-rncf", vms=1, conditions="clamped")
    assert float(chi_rel(ref, pinned)) < 3.0
    assert float(chi_rel(ref, cb)) < 3.0
    assert float(chi_rel(ref, cantilever)) > 20.0

