"""Rayleigh damping D = αM + βK̂ in the full RNCF and the reduced model."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import RTOL_ROUNDOFF, paper_body

from nrrncf_jax import RayleighDamping, RotatingFrameModel, SpinUp, Stationary, simulate
from nrrncf_jax.integrate import ConstantStepSize, GeneralizedAlpha
from nrrncf_jax.models import InertialFrameModel
from nrrncf_jax.reduction import reduce_rotating_model, vibration_modes


def test_rayleigh_ratio_at_the_two_frequencies():
    d = RayleighDamping.from_ratio(0.02, 3.0, 18.0)
    np.testing.assert_allclose(d.ratio(jnp.array([3.0, 18.0])), 0.02, rtol=1e-14)
    assert float(d.ratio(8.0)) < 0.02  # between the two frequencies ζ dips below the target
    stiff = RayleighDamping.from_ratio(0.05, 4.0)
    assert float(stiff.alpha) == 0.0 and float(stiff.ratio(4.0)) == pytest.approx(0.05, rel=1e-14)


@pytest.mark.parametrize("bad", [dict(alpha=-1.0), dict(beta=float("nan"))])
def test_rayleigh_rejects_negative_or_nan(bad):
    with pytest.raises(ValueError, match="damping"):
        RayleighDamping(**bad)


def test_ancf_refuses_damping():
    with pytest.raises(ValueError, match="RotatingFrameModel"):
        InertialFrameModel(paper_body(2), Stationary(), damping=RayleighDamping(0.1, 0.0))


@pytest.mark.slow
def test_free_decay_of_the_first_mode_matches_closed_form():
    """A small first-mode deflection decays as e^{−ζωt}(cos ω_d t + ζ/√(1−ζ²) sin ω_d t)."""
    zeta = 0.03
    body = paper_body(4, "classic")
    probe = RotatingFrameModel(body, Stationary())
    modes = vibration_modes(body, probe.free_mask(), 2)
    w1, w2 = (float(w) for w in modes.omega)  # the tube's two bending planes: w1 == w2 here
    model = RotatingFrameModel(body, Stationary(), damping=RayleighDamping.from_ratio(zeta, w1))
    phi = modes.phi[:, 0]
    eta0 = 1e-3 / float(jnp.abs(phi).max())  # 1 mm: linear regime
    q0 = body.q_hat.reshape(-1) + eta0 * phi
    M = jnp.kron(model.M, jnp.eye(3))
    T = 2 * np.pi / w1
    ts = jnp.linspace(0.0, 3 * T, 61)
    sol = simulate(model, GeneralizedAlpha(1.0), ConstantStepSize(T / 400), ts, y0=(q0, jnp.zeros_like(q0)),
                   observe=lambda t, q, v: phi @ (M @ (q - body.q_hat.reshape(-1))))
    wd = w1 * np.sqrt(1 - zeta**2)
    t = np.asarray(ts)
    exact = eta0 * np.exp(-zeta * w1 * t) * (np.cos(wd * t) + zeta / np.sqrt(1 - zeta**2) * np.sin(wd * t))
    np.testing.assert_allclose(np.asarray(sol.ys), exact, atol=2e-3 * eta0)
    undamped = eta0 * np.cos(w1 * t)
    assert np.abs(np.asarray(sol.ys) - undamped).max() > 0.2 * eta0  # the damping is really there


def test_reduced_damped_residual_is_projected_full():
    body = paper_body(3)
    full = RotatingFrameModel(body, SpinUp(5.0, 4.0), damping=RayleighDamping(0.3, 2e-3))
    modes = vibration_modes(body, full.free_mask(), 6)
    red = reduce_rotating_model(full, modes.phi)
    assert red.damping is full.damping
    key = jax.random.split(jax.random.PRNGKey(3), 3)
    p, v, a = (0.01 * jax.random.normal(k, (6,)) for k in key)
    Psi = red.Psi
    for t in (0.7, 2.5):
        r_full = full.residual(t, body.q_hat.reshape(-1) + Psi @ p, Psi @ v, Psi @ a)
        np.testing.assert_allclose(red.residual(t, p, v, a), Psi.T @ r_full, rtol=0,
                                   atol=RTOL_ROUNDOFF * float(jnp.abs(Psi.T @ r_full).max()) * 10)
    # The iteration matrix's velocity part includes D̄: compare a solve with the autodiff Jacobian.
    c_M, c_C, c_K = 2.0, 0.7, 1.3
    S = (c_M * jax.jacfwd(red.residual, 3)(1.0, p, v, a) + c_C * jax.jacfwd(red.residual, 2)(1.0, p, v, a)
         + c_K * jax.jacfwd(red.residual, 1)(1.0, p, v, a))
    b = jnp.arange(1.0, 7.0)
    np.testing.assert_allclose(red.factor_iteration_matrix(1.0, p, v, c_M, c_C, c_K).solve(b),
                               jnp.linalg.solve(S, b), rtol=1e-9)
