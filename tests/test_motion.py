"""Prescribed frame motion (``motion.AbstractMotion``): ω and ω̇ against the rotation they belong
to, and the general-motion equations of the RNCF, ANCF and reduced models against each other.

Round-off: every quantity compared here is a short chain of float64 operations on O(1) numbers
(rotations, rates ≤ 10 rad/s), or a residual of the paper beam whose terms are bounded by the
largest force in it; the bounds are 1e-12 relative to that scale, ~4500 ε, which leaves room for
the few hundred additions of an assembled row and the ~10 operations of each inertia term.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import RTOL_RESIDUAL, paper_body

from nrrncf_jax import (
    ComposedMotion,
    FourierSpinUp,
    HarmonicTranslation,
    InertialFrameModel,
    Loads,
    RotatingFrameModel,
    SpinUp,
    Stationary,
)
from nrrncf_jax.motion import HalfCosine, skew
from nrrncf_jax.reduction import vibration_modes
from nrrncf_jax.reduction.reduced_model import reduce_rotating_model

TOL = RTOL_RESIDUAL

# A spin-up about a tilted axis, carried by a precession about Z, on a hub that oscillates:
# every term of Eq. 8 and the origin's acceleration are non-zero and change with time.
SPIN = SpinUp(6.0, 1.5, axis=(0.3, -0.4, 0.866))
PRECESSION = SpinUp(2.0, 1.0, axis=(0.0, 0.0, 1.0))
GENERAL = ComposedMotion(outer=ComposedMotion(HarmonicTranslation([0.01, -0.02, 0.03], 1.3), PRECESSION),
                         inner=SPIN)
MOTIONS = {
    "spin-up": SPIN,
    "fourier": FourierSpinUp(3.0, 2.0, coeffs=[[0.5, -0.2], [0.1, 0.3]], axis=(1.0, 1.0, 0.0)),
    "composed": GENERAL,
}


@pytest.mark.parametrize("name", list(MOTIONS))
def test_rates_belong_to_the_rotation(name):
    """Ȧ = A ω̃ and ω̇ = dω/dt, by forward-mode differentiation of A(t) and ω(t), at times in the
    spin-up and after it."""
    m = MOTIONS[name]
    for t in (0.2, 0.77, 1.4, 2.5):
        A, A_dot, w, wd, dw = (np.asarray(x) for x in _rates(m, jnp.asarray(t)))
        np.testing.assert_allclose(A.T @ A, np.eye(3), atol=TOL)
        np.testing.assert_allclose(A.T @ A_dot, skew(w), atol=TOL * 10)
        np.testing.assert_allclose(dw, wd, atol=TOL * 10)
        B = np.asarray(m.directions)  # ω and ω̇ stay in the span of the directions
        for x in (w, wd):
            np.testing.assert_allclose(B @ (B.T @ x), x, atol=TOL * 10)


@eqx.filter_jit
def _rates(m, t):
    """A, Ȧ (forward mode), ω, ω̇ and dω/dt (forward mode) at t: one compiled kernel."""
    return (m.rotation(t), jax.jacfwd(m.rotation)(t), m.angular_velocity(t), m.angular_acceleration(t),
            jax.jacfwd(m.angular_velocity)(t))


def test_origin_rates_belong_to_the_origin():
    tr = HarmonicTranslation([0.01, -0.02, 0.03], 1.3)
    for t in (0.1, 0.6):
        t = jnp.asarray(t)
        r, v = tr.origin(t)
        np.testing.assert_allclose(jax.jacfwd(lambda s: tr.origin(s)[0])(t), v, atol=TOL)
        np.testing.assert_allclose(jax.jacfwd(lambda s: tr.origin(s)[1])(t), tr.origin_acceleration(t), atol=TOL)


def test_bad_motion_input():
    with pytest.raises(ValueError, match="3-vector"):
        SpinUp(1.0, 1.0, axis=(0.0, 1.0))
    with pytest.raises(ValueError, match="non-zero"):
        Stationary(axis=(0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="AbstractMotion"):
        RotatingFrameModel(paper_body(2), lambda t: (t, 1.0, 0.0))


@pytest.fixture(scope="module")
def beam():
    return paper_body(3)


@pytest.mark.parametrize("t", [0.3, pytest.param(1.7, marks=pytest.mark.slow)])
def test_rncf_equals_ancf_under_general_motion(beam, t):
    """The same deformed, moving state seen from the reference frame (RNCF: q, q̇, q̈) and from the
    inertial frame (ANCF: Aq + r₀, A(q̇ + ω×q) + ṙ₀, A(q̈ + 2ω×q̇ + ω̇×q + ω×(ω×q)) + r̈₀, the
    origin terms on position vectors): the ANCF residual rotated into the reference frame is the
    RNCF residual (Eq. 8). Both include gravity."""
    g = Loads(gravity=[0.0, -9.81, 0.0])
    rncf = RotatingFrameModel(beam, GENERAL, loads=g)
    ancf = InertialFrameModel(beam, GENERAL, loads=g)
    free = np.asarray(rncf.free_mask())
    rng = np.random.default_rng(1)
    q, v, a = (np.asarray(beam.q_hat).reshape(-1) + 0.0 * free, 0.0 * free, 0.0 * free)
    q = q + np.where(free, 1e-3 * rng.normal(size=free.size), 0.0)
    v = np.where(free, 1e-1 * rng.normal(size=free.size), 0.0)
    a = np.where(free, rng.normal(size=free.size), 0.0)
    Q, V, Acc = (x.reshape(-1, 3) for x in (q, v, a))
    A = np.asarray(GENERAL.rotation(t))
    w, wd = np.asarray(GENERAL.angular_velocity(t)), np.asarray(GENERAL.angular_acceleration(t))
    r0, rd0 = (np.asarray(x) for x in GENERAL.origin(t))
    rdd0 = np.asarray(GENERAL.origin_acceleration(t))
    pos = np.asarray(beam.is_position)[:, None]
    Q_in = Q @ A.T + pos * r0
    V_in = (V + np.cross(w, Q)) @ A.T + pos * rd0
    A_in = (Acc + 2 * np.cross(w, V) + np.cross(wd, Q) + np.cross(w, np.cross(w, Q))) @ A.T + pos * rdd0
    # The elastic forces agree by objectivity, F(Aq + r₀) = A F(q), up to round-off of the
    # stiffness's size (EA ε ~ 1e-8 N here; test_kappa checks them): compare the rest.
    r_rel = np.asarray(_inertia_and_loads(rncf, t, q, v, a))
    r_in = np.asarray(_inertia_and_loads(ancf, t, Q_in.reshape(-1), V_in.reshape(-1), A_in.reshape(-1)))
    scale = float(np.max(np.abs(r_in)))
    assert scale > 1.0  # the inertia terms are really exercised
    F3 = free.reshape(-1, 3)
    np.testing.assert_allclose(np.where(F3, r_in @ A, 0.0), np.where(F3, r_rel, 0.0), atol=TOL * scale)
    # The ANCF's prescribed (clamped) vectors move consistently: velocity = d(position)/dt.
    z = jnp.zeros_like(jnp.asarray(q))
    _, vc, _ = ancf.constrain(t, z, z, z)
    dq = jax.jacfwd(lambda s: ancf.constrain(s, z, z, z)[0])(jnp.asarray(t))
    np.testing.assert_allclose(dq, vc, atol=TOL * 10)
    # And its clamped rows are A q̂ + r₀ there.
    qc = np.asarray(ancf.constrain(t, z, z, z)[0]).reshape(-1, 3)[np.asarray(ancf.clamped)]
    np.testing.assert_allclose(qc, (np.asarray(beam.q_hat) @ A.T + pos * r0)[np.asarray(ancf.clamped)], atol=TOL)


@eqx.filter_jit
def _inertia_and_loads(model, t, q, v, a):
    """The model's residual less the elastic force at q (rows of nodal vectors)."""
    return model.residual(t, q, v, a).reshape(-1, 3) - model.body.elastic_force(q.reshape(-1, 3))


@pytest.mark.parametrize("force", [pytest.param("tensor", marks=pytest.mark.slow), "projected"])
def test_reduced_residual_is_the_projected_full_residual_under_general_motion(beam, force):
    """docs/theory.md, §4 Reduction: the reduced residual equals Ψᵀ r(q° + Ψp, Ψṗ, Ψp̈) of the full
    RNCF model, for a motion whose ω spans all three directions and whose origin accelerates."""
    full = RotatingFrameModel(beam, GENERAL, loads=Loads(gravity=[0.0, -9.81, 0.0]))
    Psi = vibration_modes(beam, full.free_mask(), 5).phi
    red = reduce_rotating_model(full, Psi, force=force)
    assert red.inertia.G.shape[0] == 3
    rng = np.random.default_rng(0)
    p, v, a = (jnp.asarray(rng.normal(size=5) * s) for s in (1e-2, 1e-1, 1.0))
    for t in (0.4, 1.9):
        r_full, r_red, S, x = (np.asarray(y) for y in _projection_check(full, red, Psi, jnp.asarray(t), p, v, a))
        expected = np.asarray(Psi).T @ r_full
        scale = float(np.max(np.abs(np.asarray(Psi).T @ np.abs(r_full)))) + float(np.max(np.abs(expected)))
        np.testing.assert_allclose(r_red, expected, atol=TOL * scale)
        # Its iteration matrix is the Jacobian of that residual (weights c_M, c_C, c_K = 1, 0.7,
        # 0.3): S⁻¹(J y) = y; the error is cond(S) ε ~ 1e-11 at most here.
        np.testing.assert_allclose(x, np.arange(1.0, 6.0), rtol=1e-9)


@eqx.filter_jit
def _projection_check(full, red, Psi, t, p, v, a):
    q_hat = full.body.q_hat.reshape(-1)
    r_full = full.residual(t, q_hat + Psi @ p, Psi @ v, Psi @ a)
    J = jax.jacfwd(lambda x: red.residual(t, p + 0.3 * x, v + 0.7 * x, a + x))(jnp.zeros(p.shape[0]))
    x = red.factor_iteration_matrix(t, p, v, 1.0, 0.7, 0.3).solve(J @ jnp.arange(1.0, p.shape[0] + 1.0))
    return r_full, red.residual(t, p, v, a), J, x


def test_fixed_axis_reduced_model_keeps_one_direction(beam):
    full = RotatingFrameModel(beam, SpinUp(3.0, 2.0))
    red = reduce_rotating_model(full, vibration_modes(beam, full.free_mask(), 3).phi)
    assert red.inertia.G.shape == (1, 3, 3)
    with pytest.raises(ValueError, match="directions"):
        red.with_motion(SpinUp(3.0, 2.0, axis=(1.0, 0.0, 0.0)))
    red.with_motion(SpinUp(5.0, 1.0))  # same axis: fine


@pytest.mark.slow
def test_axis_motion_frame_terms_equal_the_general_form():
    """A fixed-axis motion writes its frame terms with the rates factored out (θ̇ ẽ, θ̈ ẽ); they
    equal the general form (ω = θ̇ e) to round-off."""
    from nrrncf_jax.motion import AbstractMotion

    rng = np.random.default_rng(2)
    Q, V = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    for m in (SPIN, MOTIONS["fourier"]):
        for t in (0.4, 3.0):
            fast = _terms(m, t, Q, V, False)
            general = _terms(m, t, Q, V, True)
            for x, y in zip(fast, general):
                np.testing.assert_allclose(x, y, atol=TOL * 100)
    assert AbstractMotion.frame_terms is not type(SPIN).frame_terms


@eqx.filter_jit
def _terms(m, t, Q, V, general: bool):
    from nrrncf_jax.motion import AbstractMotion

    if general:
        return AbstractMotion.frame_terms(m, t, Q, V), AbstractMotion.frame_matrices(m, t)
    return m.frame_terms(t, Q, V), m.frame_matrices(t)


def test_half_cosine_turns_by_its_angle_with_its_own_rates():
    """``HalfCosine(angle, T)``: θ = (angle/2)(1 − cos πt/T) up to T, then held; its θ̇ and θ̈ are
    the derivatives of its θ (forward mode) inside (0, T), zero after T, and θ̇ is zero at both
    ends; a non-positive T is refused."""
    m = HalfCosine(np.pi, 0.4, axis=(0.0, -1.0, 0.0))
    for t in (0.05, 0.2, 0.33):
        th, dth, ddth = (float(x) for x in m(t))
        assert th == pytest.approx(np.pi / 2 * (1 - np.cos(np.pi * t / 0.4)), rel=1e-15)
        assert dth == pytest.approx(float(jax.jacfwd(lambda s: m(s)[0])(t)), rel=1e-13)
        assert ddth == pytest.approx(float(jax.jacfwd(lambda s: m(s)[1])(t)), rel=1e-13)
    assert [float(x) for x in m(0.0)[:2]] == [0.0, 0.0]
    assert [float(x) for x in m(0.6)] == [pytest.approx(np.pi, rel=1e-15), 0.0, 0.0]
    np.testing.assert_allclose(np.asarray(m.angular_velocity(0.2)), [0.0, -np.pi**2 / 0.8, 0.0], rtol=1e-14)
    with pytest.raises(ValueError, match="T must be > 0"):
        HalfCosine(1.0, 0.0)
