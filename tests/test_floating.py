"""Floating-frame bodies with reduced deformation (``multibody.floating``): NR-RNCF of jointed
systems.

- Euler parameters: the rotation matrix is proper, normalised, and inverted by
  ``euler_parameters``.
- A free, stiff beam thrown spinning keeps its linear and angular momentum and its energy
  (ρ∞ = 1) to its integration error, and its frame's Euler parameters stay normalised.
- A stiff beam hinged at one end swings with the compound pendulum's exact period.
- The generalized forces at rest are the gradient of the full strain energy of x = f(z): the
  reduced force is the projected one, and the frame's coordinates feel none.

- The full-order floating-frame body (``multibody.full_order_frame``) is the ANCF body in
  other coordinates: its residual is J ᵀ of the ANCF residual at x = f(z), ẋ = J ż,
  ẍ = J z̈ + J̇ ż, and its elements' force is the reduced cubic one on the identity basis
  (round-off). Its pendulum runs with the ANCF one in ``test_multibody.py``.
- Hinged, with ρ∞ = 1, it conserves its energy to its integration error thanks to the velocity
  projection, without which its step size stalls.

The three-beam pendulum's NR-RNCF against the full model is ``benchmarks/pendulum.py``'s (a
simulation of it costs about a minute of compilation).
"""

import copy

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import EPS, RTOL_RESIDUAL
from scipy.spatial.transform import Rotation
from scipy.special import ellipk

from nrrncf_jax.bodies.body import beam_body
from nrrncf_jax.bodies.mesh import straight_reference
from nrrncf_jax.elements.material import Material
from nrrncf_jax.elements.section import TubeSection
from nrrncf_jax.integrate import (
    AdaptiveStepSize,
    GeneralizedAlphaIndex3,
    Newton,
    simulate,
)
from nrrncf_jax.models import RotatingFrameModel
from nrrncf_jax.motion import Stationary
from nrrncf_jax.multibody import FloatingBody, FloatingFrameSystem, Marker, Spherical, hinge
from nrrncf_jax.multibody.floating import euler_parameters, rotation
from nrrncf_jax.reduction import elastic_tensors, excited_modes, plane_loads, vibration_modes
from nrrncf_jax.scenarios.pendulum import REFERENCE_CONDITIONS, PendulumBasis

G = 9.81


def test_euler_parameters_and_rotation():
    for k, R in enumerate(Rotation.random(5, random_state=3).as_matrix()):
        e = euler_parameters(R)
        assert abs(np.linalg.norm(e) - 1.0) < 1e-14 and e[0] >= 0
        np.testing.assert_allclose(np.asarray(rotation(jnp.asarray(e))), R, atol=1e-14)
        # a scaled e is the same rotation
        np.testing.assert_allclose(np.asarray(rotation(jnp.asarray((2.0 + k) * e))), R, atol=1e-14)
    with pytest.raises(ValueError, match="proper"):
        euler_parameters(np.diag([1.0, 1.0, -1.0]))


def _stiff_floating_beam(R0=(0.0, 0.0, 0.0), n_vms=2):
    """A 1 m steel-stiff rod (2 C1 elements) in its floating frame, two bending modes."""
    beam = beam_body(Material(5e10, 1100.0, 0.3), TubeSection(0.005), straight_reference(1.0, 2))
    free = RotatingFrameModel(beam, Stationary(), clamped=list(REFERENCE_CONDITIONS)).free_mask()
    phi = vibration_modes(beam, free, n_vms).phi
    return FloatingBody(beam, phi, elastic_tensors(beam, beam.q_hat, phi), R0=R0)


@pytest.mark.slow
def test_free_body_keeps_its_momenta_and_energy():
    """No joints, no gravity: thrown with a velocity and a spin about a skew axis, the body keeps
    its linear momentum p = Σ ϱ_β ẋ_β, its angular momentum H = Σ_αβ M_αβ x_α × ẋ_β (about the
    origin) and its energy (ρ∞ = 1), and |e| stays 1 (its constraint). In the frame's coordinates
    generalized-α conserves none of them exactly: their drift is the integration error, which for
    a second-order method falls like h² ∝ rtol^(2/3) (measured: 8e-5, 2e-5, 3e-6 of each at rtol
    1e-6, 1e-7, 1e-8). A drift from the equations themselves would not fall."""
    body = _stiff_floating_beam()
    system = FloatingFrameSystem([body], [])
    z0 = system.reference()
    w = np.array([0.3, -1.0, 2.0])  # spin [rad/s]
    e0 = np.asarray(z0[3:7])
    edot = 0.5 * np.concatenate([[-w @ e0[1:]], e0[0] * w + np.cross(w, e0[1:])])  # ė = ½ (0, ω) ⊗ e
    v0 = jnp.asarray(np.concatenate([[0.2, 0.1, -0.3], edot, np.zeros(body.k)]))
    M = system.masses[0]

    def observe(t, z, v):
        x, xv = jax.jvp(lambda y: body.nodal_vectors(y).reshape(-1), (z,), (v,))
        # r(ξ) = Σ S_α(ξ) x_α over all nodal vectors: p = ∫ρṙ = Σ ϱ_β ẋ_β, H = ∫ρ r × ṙ
        p = jnp.asarray(body.body.varrho()) @ xv.reshape(-1, 3)
        H = jnp.sum(jnp.cross(x.reshape(-1, 3), M @ xv.reshape(-1, 3)), axis=0)
        return p, H, system.energy(z, v), z[3:7] @ z[3:7]

    ts = jnp.linspace(0.0, 1.0, 11)
    drift = {}
    for rtol in (1e-6, 1e-8):
        sol = simulate(system, GeneralizedAlphaIndex3(1.0), AdaptiveStepSize(rtol, 1e-2 * rtol), ts, y0=(z0, v0),
                       observe=observe)
        p, H, E, enorm = (np.asarray(y) for y in sol.ys)
        drift[rtol] = np.array([np.abs(y - y[0]).max() / np.abs(y[0]).max() for y in (p, H, E)])
        # the constraint: closed to Newton's tolerance on the step's error scale
        assert np.abs(enorm - 1.0).max() < 1e-2 * rtol
    assert np.all(drift[1e-8] < 1e-5), drift
    assert np.all(drift[1e-8] < drift[1e-6] / 10.0), drift  # (100)^(2/3) = 21.5


@pytest.mark.slow
def test_stiff_floating_beam_has_the_compound_pendulums_exact_period():
    """Hinged at its left end (the frame's origin), released horizontally: T = 4 √(2L/3g) K(1/2),
    as the ANCF version in test_multibody. ρ∞ = 1, rtol 1e-6: 5.9e-5 (1.7e-4, 5.9e-5, 3.1e-5 at
    rtol 1e-5, 1e-6, 1e-7: the integration error, falling with the tolerance)."""
    body = _stiff_floating_beam(n_vms=1)
    system = FloatingFrameSystem([body], [hinge(None, Marker(0, (0.0, 0.0, 0.0)), (0.0, 0.0, 1.0))],
                                 gravity=(0.0, -G, 0.0))
    tip = body.body.n_vectors - 6
    ts = jnp.linspace(0.0, 1.6, 1601)
    sol = simulate(system, GeneralizedAlphaIndex3(1.0), AdaptiveStepSize(1e-6, 1e-6), ts,
                   observe=lambda t, z, v: body.nodal_vectors(z)[tip])
    x = np.asarray(sol.ys)[:, 0]
    t = np.asarray(ts)
    i = np.flatnonzero(np.diff(np.sign(x)) != 0)
    crossings = t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])
    T = 2.0 * (crossings[1] - crossings[0])
    T_exact = 4.0 * np.sqrt(2.0 / (3.0 * G)) * ellipk(0.5)
    assert len(crossings) == 2 and abs(T / T_exact - 1.0) < 2e-4, (T, T_exact)


@pytest.mark.slow
def test_hinged_floating_body_conserves_energy_with_rho_inf_1(monkeypatch):
    """The stiff beam on its ground hinge, released horizontally, ρ∞ = 1 (no numerical damping):
    with the velocity projection (``GeneralizedAlphaIndex3``, ``project_velocities``) it swings
    in 41 and 188 steps at rtol 1e-4 and 1e-6, and its energy drift, the integration error, falls
    like h² ∝ rtol^(2/3) (measured 8.0e-3 and 3.8e-4 of the peak kinetic energy). Without the
    projection the index-3 oscillation of its accelerations stalls the step size: at rtol 1e-6
    it needed 27,495 steps, and 2000 do not reach the end."""
    from nrrncf_jax.integrate.simulate import SimulationError

    body = _stiff_floating_beam(n_vms=1)
    system = FloatingFrameSystem([body], [hinge(None, Marker(0, (0.0, 0.0, 0.0)), (0.0, 0.0, 1.0))],
                                 gravity=(0.0, -G, 0.0))
    ts = jnp.linspace(0.0, 1.0, 101)

    def run(rtol):
        sol = simulate(system, GeneralizedAlphaIndex3(1.0), AdaptiveStepSize(rtol, rtol), ts, max_steps=2000,
                       observe=lambda t, z, v: (system.energy(z, v), system.kinetic_energy(z, v)))
        E, K = (np.asarray(y) for y in sol.ys)
        return np.abs(E - E[0]).max() / K.max()

    drift = {rtol: run(rtol) for rtol in (1e-4, 1e-6)}
    assert drift[1e-6] < 1e-3 and drift[1e-6] < drift[1e-4] / 10.0, drift  # 100^(2/3) = 21.5
    monkeypatch.setattr(FloatingFrameSystem, "project_velocities", False)
    with pytest.raises(SimulationError, match="max_steps"):
        run(1e-6)


@pytest.mark.slow
def test_mmi_per_body_ranks_each_beams_pairs():
    """Maximum modal interaction per beam of the pendulum (``scenarios.pendulum.mmi_per_body``,
    the paper's Fig. 16), 2 elements a beam, 3 VMs, 0-0.4 s: each beam's W is symmetric and
    non-negative, its 2 pairs are its largest W_ij (i ≤ j), the beams' W differ (the beams move
    differently), and the system built with one basis a beam (``body_pairs``) has each beam's
    VMs and its MDs; bad ``body_pairs`` are refused."""
    from nrrncf_jax.scenarios.pendulum import PendulumSpec, build_reduced_pendulum, mmi_per_body

    spec = PendulumSpec(elements=2)
    sels = mmi_per_body(spec, n_vms=3, n_mds=2, t_end=0.4, n_samples=81)
    cand = [(i, j) for i in range(3) for j in range(i, 3)]
    for sel in sels:
        W = np.asarray(sel.W)
        assert W.shape == (3, 3) and np.allclose(W, W.T) and W.min() >= 0.0 and sel.vms == (0, 1, 2)
        assert list(sel.pairs) == sorted(cand, key=lambda p: -W[p])[:2]
    assert not np.allclose(sels[0].W, sels[2].W, rtol=1e-2)
    system, info = build_reduced_pendulum(spec, PendulumBasis(3, body_pairs=[s.pairs for s in sels]))
    assert [b.k for b in system.bodies] == info["k"] and all(3 < k <= 5 for k in info["k"])
    with pytest.raises(ValueError, match="one list of MD pairs"):
        build_reduced_pendulum(spec, PendulumBasis(3, body_pairs=[[(0, 0)]]))
    with pytest.raises(ValueError, match="0 <= i <= j < vms"):
        build_reduced_pendulum(spec, PendulumBasis(3, body_pairs=[[(0, 3)], [], []]))
    # the candidates of a basis chosen to a tolerance: W summed over the beams ranks them, the
    # joint's static modes right after the first VM (the same run: compiled once)
    from nrrncf_jax.reduction.basis_to_tolerance import greedy_order
    from nrrncf_jax.scenarios.pendulum import JOINT_MODES, build_from_candidates, candidate_order

    order = candidate_order(spec, 3, t_end=0.4, n_samples=81)
    ranked = greedy_order(sum(np.asarray(s.W) for s in sels), range(3))
    assert order == ranked[:1] + [JOINT_MODES] + ranked[1:] and len(order) == 1 + 3 + 6
    assert isinstance(order[0], int) and candidate_order(spec, 3, t_end=0.4, n_samples=81) == order
    assert build_from_candidates(spec, [0]).n_dof == 3 * (7 + 1)  # frame + one VM a beam
    assert build_from_candidates(spec, [0, JOINT_MODES, (0, 0)]).n_dof == 3 * (7 + 1 + 2 + 1)  # + in-plane joint modes
    with pytest.raises(ValueError, match="at least one vibration mode"):
        build_from_candidates(spec, [JOINT_MODES])


def test_floating_system_refuses_bad_input():
    body = _stiff_floating_beam(n_vms=1)
    with pytest.raises(ValueError, match="basis must be"):
        FloatingBody(body.body, body.basis[:-1], body.tensors)
    M_e = body.body.groups[0].M_e
    skew = eqx.tree_at(lambda b: b.groups[0].M_e, body.body, M_e.at[:, 0, 1].add(1e-6 * jnp.abs(M_e).max()))
    with pytest.raises(ValueError, match="must be symmetric"):
        FloatingBody(skew, body.basis, body.tensors)
    with pytest.raises(ValueError, match="refers to nodal vector 99"):
        FloatingFrameSystem([body], [Spherical(0, 99)])
    with pytest.raises(ValueError, match="violates joint equations"):
        FloatingFrameSystem([body], [Spherical(0, 0, point=(0.0, 1.0, 0.0))])
    from nrrncf_jax.scenarios.pendulum import run_chain

    with pytest.raises(ValueError, match="must be a jointed system"):
        run_chain(body)


def test_generalized_forces_are_the_strain_energys_gradient():
    """At rest and without gravity the residual is ∂U/∂z with U the full body's strain energy of
    x = f(z): the reduced cubic force (p rows) is the projected full force, and U does not change
    with the frame (R and e rows zero), for a rotated, displaced and deformed state with |e| = 1.
    Along e itself Â(e) = |e|² A scales the body, and that part of ∂U/∂e is the normalisation
    constraint's reaction (its row is 2eᵀ), so it is projected out. Round-off."""
    body = _stiff_floating_beam(n_vms=2)
    system = FloatingFrameSystem([body], [])
    rng = np.random.default_rng(0)
    e = rng.normal(size=4)
    z = jnp.asarray(np.concatenate([rng.normal(size=3), e / np.linalg.norm(e), [0.02, -0.01]]))  # |e| = 1
    r = np.asarray(system.residual(0.0, z, jnp.zeros_like(z), jnp.zeros_like(z)))
    g = np.array(jax.grad(lambda y: body.body.strain_energy(body.nodal_vectors(y)))(z))
    scale = np.abs(g).max()
    assert scale > 0
    e1 = np.asarray(z[3:7])
    g[3:7] -= (g[3:7] @ e1) * e1  # the part along e is the normalisation constraint's (its multiplier's)
    np.testing.assert_allclose(r, g, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(r[:7], 0.0, atol=1e-9 * scale)


def test_full_order_frame_is_the_ancf_body_in_other_coordinates():
    """``full_floating_body``: with Ψ = I[:, free] the floating body's equations are the inertial
    ANCF body's, mapped: r_z(z, ż, z̈) = J ᵀ r_x(f(z), J z̈ + J̇ ż), r_x = M ẍ + F(x) − ϱ g, at a random
    rotated, displaced, deformed and moving state with |e| = 1 (the part of the e rows along e
    projected out: the normalisation constraint's reaction, as in the test above). And
    ``NodalElasticForce`` (the elements' force, gathered) equals the reduced cubic force of
    ``elastic_tensors`` on the same identity basis, force and Jacobian: for a constant κ the cubic
    form is exact (Eq. 24). Round-off."""
    from nrrncf_jax.multibody import NodalElasticForce, full_floating_body
    from nrrncf_jax.scenarios.pendulum import LEFT_END_FRAME

    beam = beam_body(Material(5e6, 1100.0, 0.3), TubeSection(0.005), straight_reference(1.0, 1))
    free = np.ones(beam.n_dof, bool)
    free[[3 * v + i for v, i in LEFT_END_FRAME]] = False
    gravity = (0.0, -G, 0.0)
    body = full_floating_body(beam, free)
    floating = FloatingFrameSystem([body], [], gravity)

    assert floating.n_dof == 7 + beam.n_dof - 6
    rng = np.random.default_rng(2)
    e = rng.normal(size=4)
    z = jnp.asarray(np.concatenate([rng.normal(size=3), e / np.linalg.norm(e), 0.05 * rng.normal(size=body.k)]))
    v, a = (jnp.asarray(rng.normal(size=floating.n_dof)) for _ in range(2))
    tensors = elastic_tensors(beam, beam.q_hat, body.basis)
    r, mapped, (F, K, U), (F3, K3, U3, gradU3) = (
        jax.tree_util.tree_map(np.array, x)
        for x in _full_frame_parts(floating, NodalElasticForce(beam, free), tensors, z, v, a, jnp.asarray(gravity)))
    e1 = np.asarray(z[3:7])
    for y in (r, mapped):
        y[3:7] -= (y[3:7] @ e1) * e1
    np.testing.assert_allclose(r, mapped, rtol=0, atol=RTOL_RESIDUAL * np.abs(mapped).max())
    np.testing.assert_allclose(F, F3, rtol=0, atol=RTOL_RESIDUAL * float(np.abs(F3).max()))
    np.testing.assert_allclose(K, K3, rtol=0, atol=RTOL_RESIDUAL * float(np.abs(K3).max()))
    # The strain energy: the cubic force's potential equals the elements' energy (quartic in q for
    # constant κ), and its gradient is the force. U ~ |κ| ε² with the Green strain ε = (|r_x|² − 1)/2
    # formed by cancellation: U carries a relative round-off of a few eps/|ε| (|p| ~ 0.05 here, so
    # |ε| ~ 0.05: ~1e-14; measured 3.5e-16); 1e-11 holds down to strains of ~1e-4.
    assert U > 0.0
    np.testing.assert_allclose(U3, U, rtol=1e-11)
    np.testing.assert_allclose(gradU3, F3, rtol=0, atol=1e-12 * float(np.abs(F3).max()))
    with pytest.raises(ValueError, match="mask of the body's 36"):
        full_floating_body(beam, free[:-1])
    with pytest.raises(ValueError, match="distinct coordinate indices"):
        NodalElasticForce(beam, [3, 3, 4])
    with pytest.raises(ValueError, match="tensors are for 29 coordinates, the basis has 30"):
        FloatingBody(beam, body.basis, NodalElasticForce(beam, np.flatnonzero(free)[:-1]))


@eqx.filter_jit
def _full_frame_parts(floating, nodal, tensors, z, v, a, gravity):
    """One compiled kernel (op by op the test took 20 s): the floating body's residual r_z and the
    ANCF residual mapped, J ᵀ r_x(f(z), J z̈ + J̇ ż); the elements' force, its Jacobian and energy
    at p = z[7:], and the same of the cubic tensors, with the gradient of their energy."""
    body = floating.bodies[0]
    beam = body.body
    J = jax.jacfwd(body.nodal_vectors)(z).reshape(beam.n_dof, -1)
    x, xdd = body.nodal_vectors(z), body.acceleration(z, v, a)
    r_x = beam.mass_matrix() @ xdd + beam.elastic_force(x) - beam.varrho()[:, None] * gravity  # M ẍ + F(x) − ϱ g
    p = z[7:]
    return (floating.residual(0.0, z, v, a), J.T @ r_x.reshape(-1), (*nodal.force_and_jacobian(p), nodal.energy(p)),
            (*tensors.force_and_jacobian(p), tensors.energy(p), jax.grad(tensors.energy)(p)))


def test_closed_form_kinematics_are_the_maps_derivatives():
    """J, J z̈ + J̇ż, J ᵀF, the mass matrix from the inertia invariants, the inertia terms' derivatives
    with respect to p and ṗ (``deformation_tangent``), the joints' C_z and C_zᵀλ, written in closed
    form, against automatic differentiation of x = f(z) and C(f(z)) (and J ᵀM J), at a
    random state off the constraints (round-off); and the stacked (vmapped) evaluation of equal
    bodies against the loop over them."""
    from nrrncf_jax.scenarios.pendulum import PendulumSpec, build_reduced_pendulum

    system, _ = build_reduced_pendulum(PendulumSpec(elements=2), PendulumBasis(2, pairs=[(0, 0)]))
    # equal beams: their basis and tensors kept once (not mapped), their frames' origins stacked
    assert system.stacked.basis.ndim == 2 and system.stacked.tensors.N3.ndim == 2
    assert system.stacked.R0.shape == (3, 3)
    # a stiffness changed on one beam only: its tensors differ, and the run stacks them
    assert system.stiffened(2.0, bodies=[1]).stacked.tensors.N3.ndim == 3
    rng = np.random.default_rng(1)
    z = system.reference() + 0.1 * rng.normal(size=system.n_dof)
    v, a = rng.normal(size=(2, system.n_dof))
    F = rng.normal(size=(system.bodies[1].body.n_vectors, 3))
    lam = rng.normal(size=system.n_constraints)
    looped = copy.copy(system)  # the same system evaluated body by body: each body a run of its own
    object.__setattr__(looped, "runs", ((0, 1), (1, 1), (2, 1)))
    object.__setattr__(looped, "stacks", (None,) * 3)
    got = jax.tree_util.tree_map(np.asarray, _kinematics(system, looped, *map(jnp.asarray, (z, v, a, F, lam))))
    scale = float(np.abs(got["J"][1]).max())
    for name, rel in (("J", 1e-14), ("acceleration", 1e-13), ("mass", 1e-13), ("deformation_tangent", 1e-13),
                      ("residual", 1e-13), ("iteration_matrix", 1e-13)):
        closed, exact = got[name]
        np.testing.assert_allclose(closed, exact, rtol=0, atol=rel * float(np.abs(exact).max()), err_msg=name)
    np.testing.assert_allclose(*got["generalized"], rtol=0, atol=1e-13 * scale)
    np.testing.assert_allclose(*got["C_z"], rtol=0, atol=1e-14 * scale)
    np.testing.assert_allclose(*got["C_z_lambda"], rtol=0, atol=1e-13 * scale * float(np.abs(lam).sum()))


@eqx.filter_jit
def _kinematics(system, looped, z, v, a, F, lam):
    """Pairs (closed form, automatic differentiation) on the second body and the system, in one
    compiled kernel (op by op the test took half a minute)."""
    body, zb, vb, ab = system.bodies[1], *(system.split(y)[1] for y in (z, v, a))
    J = jax.jacfwd(body.nodal_vectors)(zb)
    Jdv = jax.jvp(lambda y: jax.jvp(body.nodal_vectors, (y,), (vb,))[1], (zb,), (vb,))[1]
    # the inertia terms' p columns (deformation_tangent) against differentiating the body's residual
    c_C, c_K = 0.3, 0.02

    def body_residual(y, w):
        return body.generalized(y, body.nodal_force(y, w, ab, system.gravity))

    exact = c_K * jax.jacfwd(body_residual)(zb, vb)[:, 7:] + c_C * jax.jacfwd(body_residual, 1)(zb, vb)[:, 7:]
    F_body = body.nodal_force(zb, vb, ab, system.gravity)
    return {
        "J": (body.jacobian(zb), J),
        "acceleration": (body.acceleration(zb, vb, ab), jnp.einsum("vik,k->vi", J, ab) + Jdv),
        # the inertia invariants' mass matrix against J ᵀM J
        "mass": (body.mass_matrix(zb), jnp.einsum("vik,vw,wil->kl", J, body.mass, J)),
        "generalized": (body.generalized(zb, F), jnp.einsum("vik,vi->k", J, F)),
        "C_z": (system.constraint_jacobian(z), jax.jacfwd(system.constraints)(z)),
        "C_z_lambda": (system.constraint_force(z, lam), system.constraint_jacobian(z).T @ lam),
        "deformation_tangent": (body.deformation_tangent(zb, vb, ab, F_body, c_C, c_K), exact),
        # the stacked (vmapped) evaluation against the loop over the bodies
        "residual": (looped.residual(0.0, z, v, a), system.residual(0.0, z, v, a)),
        "iteration_matrix": (looped.iteration_matrix(0.0, z, v, 1.0, 0.1, 1e-3),
                             system.iteration_matrix(0.0, z, v, 1.0, 0.1, 1e-3)),
    }


def test_joint_modes_give_the_cantilevers_tip_flexibility():
    """``reduction.static_modes``: the static deflections of a beam held at its left end
    under unit forces at its right end have the Euler-Bernoulli cantilever's tip flexibilities,
    L³/(3EI) transversely and L/(EA) axially (a slender rod: shear and the section's Poisson
    contraction change them by about (r/L)² ~ 1e-4 and ν²(r/L)², and the C1 element's cubic
    interpolation is exact for a tip load)."""
    from nrrncf_jax.reduction import static_modes
    from nrrncf_jax.scenarios.pendulum import PendulumSpec, _beam

    spec = PendulumSpec(elements=2)
    beam = _beam(spec)
    free = RotatingFrameModel(beam, Stationary(), clamped=list(REFERENCE_CONDITIONS)).free_mask()
    tip = 6 * spec.elements  # the right end's position vector
    psi = static_modes(beam, free, 3 * tip + np.arange(3))
    flex = psi[3 * tip:3 * tip + 3, :]  # tip displacement (rows) per unit tip force (columns)
    area, inertia = np.pi * spec.radius**2, np.pi * spec.radius**4 / 4
    np.testing.assert_allclose(flex[0, 0], spec.length / (spec.E * area), rtol=1e-3)
    for k in (1, 2):
        np.testing.assert_allclose(flex[k, k], spec.length**3 / (3 * spec.E * inertia), rtol=1e-3)
    np.testing.assert_allclose(flex, flex.T, rtol=0, atol=1e-10 * np.abs(flex).max())  # Maxwell-Betti
    # in the in-plane pendulum the out-of-plane force's mode is zero and left out: 2 VMs + 2 joint modes
    from nrrncf_jax.scenarios.pendulum import build_reduced_pendulum

    _, info = build_reduced_pendulum(spec, PendulumBasis(2, pairs=(), joint_modes=True))
    assert info["k"] == 4


def test_excited_modes_keep_the_plane_of_the_swing():
    """``reduction.excited_modes`` with ``plane_loads`` about Z, on the pendulum's cantilevered round
    tube (bending modes in equal-frequency pairs): the modes kept are eigenvectors with no
    out-of-plane part, and they are the in-plane member of each bending pair, in order.

    Out of plane means odd under the mirror z → −z: the z component of r, r_x, r_y, r_xy and the x
    and y components of r_z, r_xz (derivatives across z change sign). The bound is the eigensolver's
    round-off in a mode, eps ‖A‖/gap: eps (ω_max/ω_gap)², ω_gap the distance from the pair to the
    next frequency. The same modes come exactly in-plane from the beam's odd coordinates held at
    zero (``elements.beam.mirror_even``), as ``build_reduced_pendulum`` computes them."""
    from nrrncf_jax.elements.beam import mirror_even
    from nrrncf_jax.scenarios.pendulum import PendulumSpec, _beam

    spec = PendulumSpec(elements=2)
    beam = _beam(spec)
    free = RotatingFrameModel(beam, Stationary(), clamped=list(REFERENCE_CONDITIONS)).free_mask()
    every = vibration_modes(beam, free)
    omega = np.asarray(every.omega)
    kept, phi = excited_modes(every.phi, every.omega, plane_loads(beam, normal=(0.0, 0.0, 1.0)), 4)
    phi = np.asarray(phi)
    # the lowest frequencies come in pairs (equal to the eigensolver's relative round-off in a low
    # eigenvalue, eps ‖A‖/λ): the kept modes are one of each of the first three pairs
    eps = EPS
    np.testing.assert_allclose(omega[[0, 2, 4]], omega[[1, 3, 5]], rtol=100 * eps * (omega[-1] / omega[0]) ** 2)
    assert all(kept[i] in (2 * i, 2 * i + 1) for i in range(3))
    odd = ~mirror_even(spec.elements + 1, "z")
    np.testing.assert_array_equal(odd, np.tile(np.array([[0, 0, 1]] * 4 + [[1, 1, 0]] * 2, bool),
                                               (spec.elements + 1, 1)).reshape(-1))
    bound = 100 * eps * (omega[-1] / (omega[2] - omega[1])) ** 2
    assert np.abs(phi[odd]).max() <= bound * np.abs(phi).max()
    assert np.abs(phi[~odd]).max() > 0.1 * np.abs(phi).max()
    K = np.asarray(beam.stiffness_matrix(beam.q_hat))
    M = np.kron(np.asarray(beam.mass_matrix()), np.eye(3))
    w2 = omega[kept] ** 2
    residual = (K @ phi - M @ phi * w2)[np.asarray(free)]
    # an eigenvector to the solver's round-off, eps ‖K‖‖φ‖ against |Kφ| = ω²|Mφ|: eps (ω_max/ω_0)²
    assert np.abs(residual).max() <= 100 * eps * (omega[-1] / omega[0]) ** 2 * np.abs(K @ phi).max()
    # the same modes, exactly in-plane, from the odd coordinates held at zero (elements.beam.mirror_even)
    planar = vibration_modes(beam, free & jnp.asarray(~odd), 4)
    np.testing.assert_allclose(np.asarray(planar.omega), omega[kept], rtol=100 * eps * (omega[-1] / omega[0]) ** 2)
    assert np.all(np.asarray(planar.phi)[odd] == 0.0)
    signs = np.sign(np.sum(np.asarray(planar.phi) * phi, axis=0))
    np.testing.assert_allclose(np.asarray(planar.phi) * signs, phi, rtol=0, atol=bound * np.abs(phi).max())
    with pytest.raises(ValueError, match="excited"):
        excited_modes(every.phi[:, :4], every.omega[:4], plane_loads(beam), 3)
    with pytest.raises(ValueError, match="normal"):
        mirror_even(3, "x")


@pytest.mark.slow
def test_turned_systems_keep_their_joints_and_turn_every_vector():
    """``turned(axis, angle)``: the reference state of the floating-frame and of the ANCF pendulum
    (and of a body held by a fixed joint to the ground) is the old one rotated as a rigid whole,
    its joints still closed (round-off), the stacked bodies turned with the listed ones, and the
    frame's Euler parameters still normalised."""
    from nrrncf_jax.motion import rotation_about
    from nrrncf_jax.multibody import Fixed, MultibodySystem
    from nrrncf_jax.scenarios.pendulum import PendulumSpec, build_pendulum, build_reduced_pendulum

    axis, angle = np.array([1.0, 2.0, 2.0]) / 3.0, 0.7
    A = np.asarray(rotation_about(jnp.asarray(axis), angle))
    floating, _ = build_reduced_pendulum(PendulumSpec(elements=2), PendulumBasis(2, pairs=[(0, 0)]))
    ancf = build_pendulum(PendulumSpec(elements=2))
    beam = ancf.bodies[0].body
    clamped = MultibodySystem([beam], [Fixed(0, [0, 1, 2], values=np.asarray(beam.q_hat)[:3])])
    for system, vectors in ((floating, floating.nodal_vectors), (ancf, ancf.nodal_vectors),
                            (clamped, clamped.nodal_vectors)):
        turned = system.turned(3.0 * axis, angle)  # any length of axis
        x0, x1 = (np.concatenate([np.asarray(x) for x in vectors(s.reference())]) for s in (system, turned))
        np.testing.assert_allclose(x1, x0 @ A.T, rtol=0, atol=1e-14 * np.abs(x0).max())
        assert np.abs(np.asarray(turned.constraints(turned.reference()))).max() < 1e-14 * np.abs(x0).max()
    turned = floating.turned(axis, angle)
    # Rodrigues' A against the Euler parameters' product, and the stacked (vmapped) turn against
    # the loop: different operations on numbers of order 1, so a few tens of eps apart at most.
    # The beams' origins differ, so R0 is stacked; their orientations are one, so e0 is kept once.
    assert turned.stacked.R0.shape == (3, 3) and turned.stacked.e0.shape == (4,)
    for k, b in enumerate(turned.bodies):
        np.testing.assert_allclose(np.asarray(rotation(b.e0)), A @ np.asarray(rotation(floating.bodies[k].e0)),
                                   atol=1e-14)
        assert abs(float(b.e0 @ b.e0) - 1.0) < 1e-14
        np.testing.assert_allclose(np.asarray(turned.stacked.R0)[k], np.asarray(b.R0), rtol=0, atol=1e-14)
        np.testing.assert_allclose(np.asarray(turned.stacked.e0), np.asarray(b.e0), rtol=0, atol=1e-14)
    assert eqx.tree_equal(floating.turned(axis, 0.0).bodies[0].body, floating.bodies[0].body)


@pytest.mark.slow
@pytest.mark.xdist_group("release")
def test_release_sweep_runs_each_angle_as_its_own_run():
    """A vmapped batch of pendulums released at −0.2, θ and π − θ (``release_sweep``, which queues
    the highest release first and returns the results in the angles' order: each member's first
    output is its released chain): the third is the second's mirror image in the Y axis (gravity
    along −Y, hinges about Z: the system is symmetric), and the second is the single run of the
    turned system. Every step decision of these runs is the same in exact arithmetic; round-off
    could flip one at its threshold and move a run by about its error tolerance, so the bound is
    atol (1e-6 m). Bad angles are refused before tracing."""
    from nrrncf_jax.scenarios.pendulum import PendulumSpec, build_reduced_pendulum, release_sweep

    system, _ = build_reduced_pendulum(PendulumSpec(elements=2), PendulumBasis(2, pairs=[(0, 0)]))
    theta, atol = 0.3, 1e-6
    kw = dict(t_end=0.3, dt_out=0.01, solver=GeneralizedAlphaIndex3(1.0), controller=AdaptiveStepSize(1e-5, atol))
    angles = [-0.2, theta, np.pi - theta]
    sweep = release_sweep(system, angles, **kw)
    assert sweep.ok.all() and sweep.tips.shape == (3, 31, 3, 3)
    for tips, a in zip(sweep.tips, angles):
        np.testing.assert_allclose(tips[0, :, :2], np.outer([1.0, 2.0, 3.0], [np.cos(a), np.sin(a)]), atol=1e-14)
    mirror = sweep.tips[2] * np.array([-1.0, 1.0, 1.0])
    assert np.abs(mirror - sweep.tips[1]).max() < atol
    assert np.ptp(sweep.tips[1, :, 2, 1]) > 0.2  # it swings: the tip falls by decimetres
    tip = system.bodies[0].body.n_vectors - 6
    single = simulate(system.turned((0.0, 0.0, 1.0), theta), GeneralizedAlphaIndex3(1.0),
                      AdaptiveStepSize(1e-5, 1e-6), jnp.asarray(sweep.ts), newton=Newton(1e-2),
                      observe=lambda t, x, v: jnp.stack([xb[tip] for xb in system.nodal_vectors(x)]))
    assert np.abs(np.asarray(single.ys) - sweep.tips[1]).max() < atol
    # the same steps but for a decision that round-off might flip (306 here, equal)
    assert abs(int(single.num_steps) - int(sweep.steps[1])) <= 0.02 * int(single.num_steps)
    for bad in ([], [0.1, np.nan]):
        with pytest.raises(ValueError, match="angles"):
            release_sweep(system, bad, **kw)
    with pytest.raises(ValueError, match="small_kernels"):
        release_sweep(system, [theta], small_kernels="yes", **kw)


@pytest.mark.slow
def test_a_system_mixes_full_order_and_reduced_bodies():
    """One ``FloatingFrameSystem`` with a full-order RNCF beam (``full_floating_body``) and two
    NR-RNCF beams: each body's equations are those it has in its own kind's system (the residual
    of a body depends on its own coordinates alone; identity up to round-off of the same
    operations), the joints act on the nodal vectors of either kind alike, and the mixed chain
    integrates with its joints closed and, with ρ∞ = 1, its energy kept."""
    from nrrncf_jax.scenarios.pendulum import PendulumSpec, build_reduced_pendulum, build_rncf_pendulum, run_chain

    spec = PendulumSpec(elements=2)
    full = build_rncf_pendulum(spec)
    reduced, _ = build_reduced_pendulum(spec, PendulumBasis(3))
    mixed = FloatingFrameSystem((full.bodies[0],) + reduced.bodies[1:], full.joints, gravity=full.gravity)
    assert mixed.stacked is None and mixed.formulation == "nr-rncf"
    assert mixed.runs == ((0, 1), (1, 2)) and mixed.stacks[1] is not None  # the two reduced beams vmapped
    assert mixed.body_sizes() == (full.body_sizes()[0],) + reduced.body_sizes()[1:]
    # A state with every body deformed and moving: the full body's part from the full system's
    # coordinates, the reduced bodies' from the reduced system's.
    rng = np.random.default_rng(0)

    def deformed(system):  # each body's deformation coordinates (after its 7 frame coordinates) moved
        return jnp.concatenate([zb.at[7:].add(1e-3 * rng.standard_normal(zb.shape[0] - 7))
                                for zb in system.split(system.reference())])

    z_f, z_r = deformed(full), deformed(reduced)
    v_f, v_r = (jnp.asarray(rng.standard_normal(z.shape)) for z in (z_f, z_r))
    a_f, a_r = (jnp.asarray(rng.standard_normal(z.shape)) for z in (z_f, z_r))
    n0 = full.body_sizes()[0]
    o1 = reduced.offsets[1]
    z, v, a = (jnp.concatenate([x[:n0], y[o1:]]) for x, y in ((z_f, z_r), (v_f, v_r), (a_f, a_r)))
    r = mixed.residual(0.0, z, v, a)
    r_f, r_r = full.residual(0.0, z_f, v_f, a_f), reduced.residual(0.0, z_r, v_r, a_r)
    scale = float(jnp.abs(r).max())
    np.testing.assert_allclose(r[:n0], r_f[:n0], rtol=0, atol=RTOL_RESIDUAL * scale)
    np.testing.assert_allclose(r[n0:], r_r[o1:], rtol=0, atol=RTOL_RESIDUAL * scale)
    xs = mixed.nodal_vectors(z)
    for x_mixed, x_own in zip(xs, full.nodal_vectors(z_f)[:1] + reduced.nodal_vectors(z_r)[1:]):
        np.testing.assert_array_equal(x_mixed, x_own)
    np.testing.assert_allclose(mixed.constraints(z)[:mixed.n_joint_equations], mixed.joint_equations(xs),
                               rtol=0, atol=RTOL_RESIDUAL)
    run = run_chain(mixed, t_end=0.2, dt_out=0.01, solver=GeneralizedAlphaIndex3(1.0),
                    controller=AdaptiveStepSize(1e-5, 1e-6))
    assert run.constraint_max < 1e-8
    assert np.abs(run.energy - run.energy[0]).max() < 1e-3 * run.kinetic.max()
    assert run.kinetic[-1] > 0.1 * run.kinetic.max()  # it swings
