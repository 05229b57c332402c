"""Mean-axis reference conditions of a free-free body (``multibody.reduce(...,
conditions="mean-axis")``, ``multibody.reduce.MeanAxisSpace``; issue 60).

Closed form: a free-free Euler-Bernoulli beam bends at ω_n = (β_n L)² √(EI/ρA) / L², β_n L =
4.730041, 7.853205, 10.995608. The C1 element is cubic (Hermite) along its axis, so its bending
frequencies converge as h⁴ (a conforming element of degree p for a problem of order 2m: eigenvalue
error O(h^(2(p+1−m))), p = 3, m = 2), not to Euler-Bernoulli's but to a shear-deformable beam's:
shear and rotary inertia lower the n-th frequency by about (β_n L)² (r_g/L)² (1 + E/κG)/2 (κ ≈ 0.9,
r_g = r/2), 1.1e-5, 3.0e-5 and 5.9e-5 of it on this slender tube (L/r = 1000; measured at 32
elements: 1.0e-5, 2.6e-5, 4.6e-5). So the test takes differences of successive meshes, which that
limit cancels: (ω₄ − ω₈)/(ω₈ − ω₁₆) is 2⁴ for an h⁴ rate (measured 20.5 and 21.4 on the first
two modes: a little above, the h⁶ term adding; the third is not yet asymptotic on 4 elements), and
the 16-element frequencies lie within the closed form plus that model error plus twice the
Richardson estimate of their remaining discretisation error, (ω₈ − ω₁₆)/15. A wrong condition
misses by factors (a clamped end: (1.875/4.730)²; a rigid mode left in: ω = 0).

The conditions, Rᵀ M w = 0 for the six rigid motions R: the deformation's linear momentum
Σ_w μ_w w_w (μ = M_b 1_pos) and its angular momentum Σ_vw M_vw q̂_v × w_w about the frame's origin
(the body's centre of mass), formed here independently of the library's code. The library builds
w in the orthonormal complement T of M R from a Householder QR, so (M Rₖ)ᵀ T is of the order
ε ‖M Rₖ‖ with a factor that grows mildly with the size n, and the product adds as much. In a plane
only the three in-plane conditions are imposed; the other three hold by the mirror symmetry, to
the round-off of the reference turned into the frame (its out-of-plane coordinates are ~ε, not 0),
which the section's tiny rotary inertia about the beam's axis does not scale down: so the bound is
√n ε ‖M‖ ‖Rₖ‖ ‖w‖ (measured below 0.15 of it on every column, in space and in the plane); the
clamped modes' momenta are 6e13 times larger (O(1) of ‖M Rₖ‖ ‖w‖).
"""

import jax.numpy as jnp
import numpy as np
import pytest

from nrrncf_jax.bodies import Material, TubeSection, beam_body, straight_reference
from nrrncf_jax.elements.beam import mirror_even
from nrrncf_jax.integrate import AdaptiveStepSize, GeneralizedAlphaIndex3, simulate
from nrrncf_jax.multibody import Mechanism, placed
from nrrncf_jax.multibody.error_estimate import full_counterpart
from nrrncf_jax.multibody.floating import rotation
from nrrncf_jax.multibody.reduce import MeanAxisSpace, centre_of_mass, modal_body, reduce
from nrrncf_jax.post.metrics import chi_rel
from nrrncf_jax.reduction.modes import frame_stiffened

EPS = float(np.finfo(np.float64).eps)
E, RHO, NU, R, L = 7.0e10, 2700.0, 0.3, 0.001, 1.0
BETA_L = np.array([4.730040745, 7.853204624, 10.99560784])
Z = (0.0, 0.0, 1.0)


def _beam(elements, turn=None, shift=(0.3, -0.2, 0.1), material=(E, RHO, NU), radius=R, length=L):
    body = beam_body(Material(*material), TubeSection(radius), straight_reference(length, elements))
    return placed(body, turn, shift)


def _turn(axis, deg):
    n = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0.0, -n[2], n[1]], [n[2], 0.0, -n[0]], [-n[1], n[0], 0.0]])
    t = np.radians(deg)
    return np.eye(3) + np.sin(t) * K + (1.0 - np.cos(t)) * K @ K


def _momenta(body, X):
    """The momenta of each column w of ``X`` as a deformation rate of ``body`` (in its frame),
    6 × m: the linear momentum Σ_w μ_w w_w (μ = M_b 1_pos) and the angular momentum Σ_vw M_vw q̂_v ×
    w_w about the frame's origin, as (M Rₖ)ᵀ w with Rₖ the unit translations (on the position
    vectors) and rotations e_k × q̂ (on all nodal vectors); and the bound on their round-off,
    √n ε ‖M‖ ‖Rₖ‖ ‖w‖ (module docstring)."""
    q, pos = np.asarray(body.q_hat), np.asarray(body.is_position)
    e = np.eye(3)
    rigid = np.concatenate([np.where(pos[None, :, None], e[:, None, :], 0.0),
                            np.cross(e[:, None, :], q[None])]).reshape(6, -1).T
    M = np.kron(np.asarray(body.mass_matrix()), e)
    X = np.asarray(X).reshape(body.n_dof, -1)
    bound = _bound_factor(body) * EPS * np.linalg.norm(M, 2) * np.outer(np.linalg.norm(rigid, axis=0),
                                                                          np.linalg.norm(X, axis=0))
    MR = M @ rigid
    return MR.T @ X, bound


def _worst(body, X):
    """max over the columns and the six momenta of |momentum| / bound: below 1 when the columns
    satisfy the mean-axis conditions to round-off."""
    m, bound = _momenta(body, X)
    return float(np.max(np.abs(m) / bound))


def _bound_factor(body) -> float:
    """c = √n (n the body's nodal coordinates) in the round-off bound c ε ‖M‖ ‖Rₖ‖ ‖w‖."""
    return float(np.sqrt(body.n_dof))


@pytest.fixture(scope="module")
def spatial():
    """A 4-element beam turned about a skew axis, reduced in space: 4 VMs, all their MDs."""
    A = _turn((1.0, 2.0, 0.5), 40.0)
    beam = _beam(4, A)
    ends = [A @ np.zeros(3) + (0.3, -0.2, 0.1), A @ np.array([L, 0.0, 0.0]) + (0.3, -0.2, 0.1)]
    return beam, ends, reduce(beam, ends, vms=4, mds="all", conditions="mean-axis")


def test_free_free_frequencies_converge_to_the_closed_form():
    """In plane: meshes of 4, 8, 16 elements (module docstring)."""
    c = np.sqrt(E * R**2 / 4 / RHO) / L**2
    rel = {}
    for n in (4, 8, 16):
        beam = _beam(n, shift=(0.0, 0.0, 0.0))
        rel[n] = np.asarray(MeanAxisSpace(beam, mirror_even(n + 1, "z")).modes(3).omega) / (c * BETA_L**2) - 1.0
    d1, d2 = rel[4] - rel[8], rel[8] - rel[16]
    ratio = d1[:2] / d2[:2]
    assert np.all((ratio > 0.75 * 16) & (ratio < 2.0 * 16)), ratio  # order 3.6 to 5
    model = BETA_L**2 * (0.5 * R / L) ** 2 * (1.0 + 2.0 * (1.0 + NU) / 0.9) / 2.0
    assert np.all(np.abs(rel[16]) < 2.0 * np.abs(d2) / 15.0 + model), (rel[16], d2, model)
    assert np.all(np.abs(rel[16]) < 2e-4)
    # reduce records these modes: the 16-element body's, turned and placed elsewhere in its plane
    A = _turn(Z, 35.0)
    beam = _beam(16, A)
    body = reduce(beam, [A @ np.zeros(3) + (0.3, -0.2, 0.1)], vms=3, mds=[], conditions="mean-axis",
                  plane_normal=Z)
    phi = np.asarray(body.modes)
    K = np.asarray(frame_stiffened(body.body, body.body.q_hat))
    M = np.kron(np.asarray(body.body.mass_matrix()), np.eye(3))
    np.testing.assert_allclose(phi.T @ M @ phi, np.eye(3), atol=1e-10)
    omega = np.sqrt(np.einsum("ik,ij,jk->k", phi, K, phi))
    np.testing.assert_allclose(omega / (c * BETA_L**2) - 1.0, rel[16], atol=1e-5)  # the element's round-off
    # the frame: its origin at the centre of mass, its x axis along the beam
    np.testing.assert_allclose(np.asarray(body.R0), centre_of_mass(beam), atol=1e-14)
    np.testing.assert_allclose(np.asarray(body.R0), A @ np.array([L / 2, 0.0, 0.0]) + (0.3, -0.2, 0.1), atol=1e-12)
    np.testing.assert_allclose(np.asarray(rotation(body.e0)), A, atol=1e-12)
    assert "mean axes" in body.describe() and "centre of mass" in body.describe() and "3 VMs + 0 MDs" in body.describe()


def test_modes_and_derivatives_carry_no_momentum_relative_to_the_frame(spatial):
    """In space (six conditions) and in a plane (three, the other three by symmetry): every VM,
    every MD and the deflated basis have zero linear and angular momentum relative to the frame,
    to round-off; the clamped body's modes do not (so the check can fail). The body's inertia
    invariants say the same: C = Σ μ Ψ (the frame's translation coupled to the deformation) and
    c₀ = Σ μ q̂ (the origin off the centre of mass) vanish."""
    beam, ends, body = spatial
    space = MeanAxisSpace(body.body, body.free)
    assert space.rigid.shape[1] == 6 and body.k == 4 + 10
    vms, mds = np.asarray(body.modes), np.asarray(space.modal_derivatives(body.modes).theta)
    for X in (vms, mds, np.asarray(body.basis)):
        assert _worst(body.body, X) < 1.0, _worst(body.body, X)
    assert np.abs(np.asarray(body.c0)).max() < 1e-13 * float(body.m_total) * L  # Σ μ q̂ = m (centre − origin)
    clamped = reduce(beam, ends, vms=4, mds=[], conditions="clamped")
    assert _worst(clamped.body, np.asarray(clamped.modes)) > 1e12  # O(1) of ‖M R‖ ‖w‖, not of ε
    # in a plane, with the interfaces' inertia-relief attachment modes (both ends' in-plane forces)
    planar = reduce(beam, ends, vms=2, mds="all", conditions="mean-axis", plane_normal=_turn((1.0, 2.0, 0.5), 40.0) @ Z,
                    interface_modes=True)
    assert MeanAxisSpace(planar.body, planar.free).rigid.shape[1] == 3
    assert _worst(planar.body, np.asarray(planar.basis)) < 1.0
    assert "inertia-relief attachment modes" in planar.describe()
    # a mean-axis body rebuilt with other pairs (modal_interaction.select_modal_derivatives does this
    # for mds="mmi") keeps the conditions
    rebuilt = modal_body(body.body, np.asarray(body.free), vms[:, :2], [(0, 0), (0, 1)], body.R0,
                         np.asarray(rotation(body.e0)))
    assert rebuilt.k == 4 and _worst(rebuilt.body, np.asarray(rebuilt.basis)) < 1.0


def test_inertia_relief_attachment_modes_are_the_constrained_static_deflections(spatial):
    """``MeanAxisSpace.solve``: K w + M R λ = F with Rᵀ M w = 0 (the Lagrange-multiplier form of
    inertia relief) holds to round-off for a force on an end node, and the modal derivatives are
    that solve of −(∂K/∂η_j) φ_i."""
    _, _, body = spatial
    space = MeanAxisSpace(body.body, body.free)
    F = np.zeros((body.body.n_dof, 1))
    F[3 * (body.body.n_vectors - 6) + 1] = 1.0  # the far end's position, y
    w = space.solve(F)
    K = np.asarray(frame_stiffened(body.body, body.body.q_hat))
    MR = space.mass @ space.rigid
    lam = np.linalg.lstsq(MR, F - K @ w, rcond=None)[0]  # the residual K w − F lies in the span of M R
    assert np.linalg.norm(K @ w + MR @ lam - F) < 1e-8 * np.linalg.norm(F)
    assert _worst(body.body, w) < 1.0
    # the modal derivatives: the same solve of the Eq. 35 right-hand side
    from nrrncf_jax.reduction.modal_derivatives import dK_deta_times

    phi = np.asarray(body.modes)
    shape = body.body.q_hat.shape
    f = np.asarray(dK_deta_times(body.body, body.body.q_hat, jnp.asarray(phi[:, 1].reshape(shape)),
                                 jnp.asarray(phi[:, 0].reshape(shape)))).reshape(-1, 1)
    theta = np.asarray(space.modal_derivatives(phi, [(0, 1)]).theta)
    np.testing.assert_allclose(theta, space.solve(-f), rtol=0, atol=1e-12 * np.abs(theta).max())
    lam = np.linalg.lstsq(MR, -f - K @ theta, rcond=None)[0]
    assert np.linalg.norm(K @ theta + MR @ lam + f) < 1e-8 * np.linalg.norm(f)


def test_a_free_flying_beam_follows_the_full_one():
    """A slider-crank rod (0.304 m, E = 1e10 Pa, r = 5 mm; 4 elements) thrown with a velocity, a
    spin of 150 rad/s about the plane's normal and a bending velocity along its first free-free
    mode (about 4 mm of deflection), 0-20 ms (3.6 bending periods, 3 rad of turn): its midpoint's
    deflection from the chord of its ends follows the full ANCF beam's, started from the same
    nodal state, to χ_rel < 1 % (measured 0.18 %: the spin's centrifugal stiffening lies in the
    modal derivatives; both runs at rtol 1e-5, whose integration error is ~0.1 %). The frame's
    origin, the centre of mass, moves uniformly to round-off: with C = 0 and c₀ = 0 its equation
    decouples from the rotation and the deformation (R̈ = 0), which a frame at an end node's would
    not."""
    length, n = 0.304, 4
    start = np.array([0.1, 0.2, 0.0])
    beam = _beam(n, shift=start, material=(1e10, 2770.0, 0.3), radius=0.005, length=length)
    body = reduce(beam, [start, start + (length, 0.0, 0.0)], vms=2, mds="all", conditions="mean-axis",
                  plane_normal=Z)
    system = Mechanism([body])
    z0 = system.reference()
    velocity = np.array([0.5, -0.3, 0.0])
    v0 = system.rigid_velocity(velocity=velocity, omega=(0.0, 0.0, 150.0))
    phi = np.asarray(body.modes)[:, 0]
    p_dot = np.linalg.lstsq(np.asarray(body.basis), phi, rcond=None)[0]
    v0 = v0.at[7:].set(0.004 * 1150.0 / np.abs(phi.reshape(-1, 3)[::6]).max() * p_dot)
    x0, xv0 = (np.asarray(y).reshape(-1) for y in (body.nodal_vectors(z0), body.tangent(z0, v0)))
    np.testing.assert_allclose(x0, np.asarray(beam.q_hat).reshape(-1), atol=1e-15)
    ts = np.linspace(0.0, 0.02, 81)
    controller = AdaptiveStepSize(1e-5, 1e-6)
    reduced = simulate(system, GeneralizedAlphaIndex3(0.9), controller, ts, y0=(z0, v0),
                       observe=lambda t, z, v: (system.nodal_vectors(z)[0], z[:3]))
    full_system = Mechanism([beam])
    full = simulate(full_system, GeneralizedAlphaIndex3(0.9), controller, ts, y0=(jnp.asarray(x0), jnp.asarray(xv0)),
                    observe=lambda t, z, v: full_system.nodal_vectors(z)[0])

    def w_mid(x):
        pos = np.asarray(x)[:, ::6]
        a, b, m = pos[:, 0], pos[:, -1], pos[:, n // 2]
        d = (b - a) / np.linalg.norm(b - a, axis=1, keepdims=True)
        return (m - a)[:, 0] * d[:, 1] - (m - a)[:, 1] * d[:, 0]

    x_red, R = (np.asarray(y) for y in reduced.ys)
    ref = w_mid(full.ys)
    assert np.abs(ref).max() > 3e-3  # it bends
    assert float(chi_rel(ref, w_mid(x_red))) < 1.0
    centre = start + (length / 2, 0.0, 0.0)  # rigid_velocity turns about the origin: the centre moves at v + ω × c
    uniform = centre + np.outer(ts, velocity + np.cross((0.0, 0.0, 150.0), centre))
    np.testing.assert_allclose(R, uniform, rtol=0, atol=1e-12)  # measured 1.3e-15: the decoupled R̈ = 0 is exact

    # The full-order counterpart (every nodal coordinate, the frame held by G p = 0 instead of
    # held coordinates; error_estimate.full_counterpart) from the same state: the same motion as
    # the full ANCF beam, to the two runs' integration error (rtol 1e-5: ~0.1 %, bound 5x), its
    # conditions held to round-off, and its frame at the centre of mass (the linear momentum's
    # condition is exact), moving uniformly.
    counterpart = full_counterpart(system)
    cb = counterpart.bodies[0]
    assert cb.tensors.full_order and cb.n_own_equations == 1 + 3  # |e| = 1 and the three in-plane conditions
    lift = np.asarray(cb.basis).T @ np.asarray(body.basis)
    zc0, vc0 = (jnp.concatenate([y[:7], jnp.asarray(lift) @ y[7:]]) for y in (z0, v0))
    mean = simulate(counterpart, GeneralizedAlphaIndex3(0.9), controller, ts, y0=(zc0, vc0),
                    observe=lambda t, z, v: (counterpart.nodal_vectors(z)[0], z[:3], cb.own_equations(z)[1:]))
    x_full, R_full, conditions = (np.asarray(y) for y in mean.ys)
    assert float(chi_rel(ref, w_mid(x_full))) < 0.5
    assert np.abs(conditions).max() < 1e-12 * np.abs(x_full).max()
    np.testing.assert_allclose(R_full, uniform, rtol=0, atol=1e-12)


def test_mean_axis_refuses_what_it_cannot_build(spatial):
    """Craig-Bampton (its boundary coordinates are held) and the full-order body (the conditions
    are no selection of held coordinates) are refused by name; so is a full-order frame whose free
    coordinates leave rigid motions unless the mean-axis conditions hold them (it would be
    singular), and a ``MeanAxisSpace`` of a clamped body."""
    from nrrncf_jax.multibody.full_order_frame import full_floating_body

    beam, ends, body = spatial
    for kwargs, match in [({"basis": "craig-bampton"}, "mean-axis.*goes with basis='free'"),
                          ({"basis": "full"}, "mean-axis.*goes with basis='free'"),
                          ({"conditions": "mean_axis"}, "conditions must be")]:
        with pytest.raises(ValueError, match=match):
            reduce(beam, ends, **({"conditions": "mean-axis"} | kwargs))
    with pytest.raises(ValueError, match="must hold its frame"):
        full_floating_body(body.body, np.asarray(body.free))
    assert full_floating_body(body.body, np.asarray(body.free), mean_axis=True).n_own_equations == 1 + 6
    # the static error estimate holds each body's frame, which no joint holds under mean axes
    from nrrncf_jax.multibody.error_estimate import estimate_mechanism_error

    system = Mechanism([body])
    zs = np.tile(np.asarray(system.reference()), (2, 1))
    with pytest.raises(ValueError, match="method='dynamic'"):
        estimate_mechanism_error(full_counterpart(system), system, [0.0, 1.0], zs, 0 * zs)
    from nrrncf_jax.reduction import ErrorEstimator
    from nrrncf_jax.scenarios.pendulum import PendulumBasis, PendulumSpec, run_pendulum

    with pytest.raises(ValueError, match=r"estimator=ErrorEstimator\(method='dynamic'\)"):
        run_pendulum(PendulumSpec(elements=2), formulation="nr-rncf", basis=PendulumBasis(1, conditions="mean-axis"),
                     estimator=ErrorEstimator())
    clamped_free = np.ones((beam.n_vectors, 3), bool)
    clamped_free[[0, 2, 4]] = False  # the first node's position and section vectors
    with pytest.raises(ValueError, match="not free-free"):
        MeanAxisSpace(beam, clamped_free.reshape(-1))
    # one interface suffices (it gives the axes; the frame sits at the centre of mass)
    assert reduce(beam, ends[:1], vms=1, mds=[], conditions="mean-axis").k == 1
