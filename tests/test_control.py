"""Spin-up profile optimisation: the FourierSpinUp profile (exact integrals, end-speed constraint,
Eq. 43 at zero coefficients), the gradient of the residual objective against finite differences,
and a short optimisation that beats Eq. 43."""

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import RTOL_FD, RTOL_ROUNDOFF, paper_body

from nrrncf_jax import RotatingFrameModel, SpinUp, reduce_rotating_model, vibration_modes
from nrrncf_jax.integrate import ConstantStepSize, Newton
from nrrncf_jax.models.observe import tip_index, tip_observer
from nrrncf_jax.motion.profiles import FourierSpinUp
from nrrncf_jax.studies.control import OPTIMIZER, optimal_spinup, residual_amplitude, residual_mean_square, tip_response

OMEGA_S, T_S, T_END = 1.0, 3.0, 5.0  # a short manoeuvre; still tip deflections of ~0.8 m
# fixed steps: finite differences must not see step choices
FIXED = dict(controller=ConstantStepSize(0.02, rtol=1e-5, atol=1e-8))
# ... and Newton converged far below the finite-difference step (rtol/atol only scale its test)
TIGHT = dict(controller=ConstantStepSize(0.02, rtol=1e-10, atol=1e-12), newton=Newton(kind="full"))


def _random_profile(seed, n=3, omega_s=OMEGA_S, T_s=T_S, scale=1.0):
    c = np.random.default_rng(seed).normal(size=(2, n)) * scale * omega_s / T_s
    return FourierSpinUp(omega_s, T_s, c)


@pytest.mark.parametrize("seed", [0, 1])
def test_profile_end_speed_continuity_and_exact_integrals(seed):
    p = _random_profile(seed, n=4)
    T, w = float(p.T_s), float(p.omega_s)
    th, dth, ddth = p(T)
    assert float(dth) == pytest.approx(w, rel=RTOL_ROUNDOFF)  # θ̇(Ts) = ωs for any coefficients
    eps = 1e-9
    for t in (0.0, T):  # θ̈ continuous: 0 at both ends, from both sides
        for s in (t - eps, t, t + eps):
            assert abs(float(p(s)[2])) < 1e-6
    assert float(p(0.0)[0]) == 0.0 and float(p(0.0)[1]) == 0.0
    after = p(jnp.array([T + 0.5, T + 3.0]))
    np.testing.assert_allclose(after[1], w, rtol=0)
    np.testing.assert_allclose(after[2], 0.0, atol=0)
    np.testing.assert_allclose(after[0], float(th) + w * np.array([0.5, 3.0]), rtol=1e-13)
    # θ̇ = dθ/dt, θ̈ = dθ̇/dt (automatic derivatives of the closed forms)
    ts = jnp.linspace(0.01, T + 1.0, 157)
    d_th = jax.jit(jax.vmap(jax.grad(lambda t: p(t)[0])))(ts)
    d_dth = jax.jit(jax.vmap(jax.grad(lambda t: p(t)[1])))(ts)
    th_, dth_, ddth_ = p(ts)
    np.testing.assert_allclose(d_th, dth_, atol=1e-12 * w)
    np.testing.assert_allclose(d_dth, ddth_, atol=1e-12 * w)
    # and θ̇, θ are the integrals of θ̈, θ̇ from 0 (composite Simpson on a fine grid)
    x = np.linspace(0.0, T + 1.0, 20001)
    h = x[1] - x[0]
    d1, dd = (np.asarray(a) for a in p(jnp.asarray(x))[1:])

    def simpson(f):
        return h / 3 * (f[0] + f[-1] + 4 * f[1:-1:2].sum() + 2 * f[2:-1:2].sum())

    assert simpson(dd) == pytest.approx(float(p(x[-1])[1]), rel=1e-9)
    assert simpson(d1) == pytest.approx(float(p(x[-1])[0]), rel=1e-9)
    # closed-form RMS of the correction against quadrature
    base = np.asarray(SpinUp(w, T)(jnp.asarray(x))[2])
    xi = x <= T
    assert np.sqrt(simpson(np.where(xi, (dd - base) ** 2, 0.0)) / T) == pytest.approx(
        float(jnp.sqrt(p.correction_mean_square())), rel=1e-6)


def test_zero_coefficients_equal_eq43():
    ts = jnp.linspace(0.0, 2 * T_S, 301)
    a = FourierSpinUp(OMEGA_S, T_S, n_terms=5)(ts)
    b = SpinUp(OMEGA_S, T_S)(ts)
    for x, y in zip(a, b):
        np.testing.assert_allclose(x, y, rtol=RTOL_ROUNDOFF, atol=1e-14)


def test_residual_measures_in_closed_form():
    """``residual_mean_square`` and ``residual_amplitude`` of uy = A sin(2π t) + c sampled every
    0.05 s over the four whole periods after Ts (80 samples; those before Ts, set far larger, must
    not count): the mean of the squares is A²/2 + c² (the samples' mean of sin² is 1/2 and of sin
    0, exactly but for round-off), the largest |uy| A + c, at a sample (t = Ts + 1/4 s)."""
    T_s, A, c = 3.0, 0.7, 0.1
    k = np.arange(-60, 80)
    ts = T_s + 0.05 * k
    uy = np.where(k >= 0, A * np.sin(2 * np.pi * 0.05 * k) + c, 100.0)
    assert float(residual_mean_square(jnp.asarray(ts), jnp.asarray(uy), T_s)) == pytest.approx(
        A**2 / 2 + c**2, rel=RTOL_ROUNDOFF)
    assert residual_amplitude(ts, uy, T_s) == pytest.approx(A + c, rel=RTOL_ROUNDOFF)
    assert residual_amplitude(ts, uy, ts[-1] + 1.0) == 0.0  # no sample after Ts


def test_profile_input_errors():
    with pytest.raises(ValueError, match="omega_s"):
        FourierSpinUp(0.0, 1.0, n_terms=2)
    with pytest.raises(ValueError, match="T_s"):
        FourierSpinUp(1.0, -1.0, n_terms=2)
    with pytest.raises(ValueError, match="shape"):
        FourierSpinUp(1.0, 1.0, jnp.zeros(3))
    with pytest.raises(ValueError, match="shape"):
        FourierSpinUp(1.0, 1.0, jnp.zeros((3, 2)))
    with pytest.raises(ValueError, match="finite"):
        FourierSpinUp(1.0, 1.0, jnp.array([[0.0, jnp.nan], [0.0, 0.0]]))
    with pytest.raises(ValueError, match="n_terms"):
        FourierSpinUp(1.0, 1.0)


# The tests of ``tiny`` share an xdist group, so that one worker builds it (and compiles its runs) once.
@pytest.fixture(scope="module")
def tiny():
    """2-element paper beam reduced on its first two bending pairs (no MDs: plumbing, not accuracy)."""
    body = paper_body(2)
    full = RotatingFrameModel(body, SpinUp(OMEGA_S, T_S))
    modes = vibration_modes(body, full.free_mask(), 4)
    model = reduce_rotating_model(full, modes.phi, force="tensor")
    return full, model, tip_index(body)


@pytest.mark.slow
@pytest.mark.xdist_group("control_tiny")
def test_objective_gradient_matches_finite_differences(tiny):
    full, model, tip = tiny
    obs = tip_observer(model, tip)
    # the reduced model's tip displacement is the full model's at q = q° + Ψ p
    p = jnp.linspace(-0.1, 0.1, model.n_dof)
    np.testing.assert_allclose(obs(0.0, p, p), full.displacements(0.0, model.coordinates(p).reshape(-1))[tip],
                               atol=1e-12)
    ts = jnp.arange(0.0, T_END + 1e-9, 0.05)
    p0 = _random_profile(3, n=2, scale=0.3)

    @jax.jit
    @jax.value_and_grad
    def loss(c):
        prof = eqx.tree_at(lambda q: q.coeffs, p0, c)
        uy = tip_response(model, prof, ts, observer=obs, adjoint="reverse", **TIGHT)[:, 1]
        return residual_mean_square(ts, uy, T_S)

    c0 = p0.coeffs
    val, g = loss(c0)
    assert float(val) > 0
    eps = 2e-5  # truncation error ~1e-6 relative here; 1e-4 gives 2e-5
    for idx in [(0, 0), (0, 1), (1, 0), (1, 1)]:
        e = jnp.zeros_like(c0).at[idx].set(eps)
        fd = (float(loss(c0 + e)[0]) - float(loss(c0 - e)[0])) / (2 * eps)
        assert float(g[idx]) == pytest.approx(fd, rel=RTOL_FD, abs=1e-9 * float(jnp.abs(g).max())), idx


@pytest.mark.slow
@pytest.mark.xdist_group("control_tiny")
def test_short_optimisation_beats_eq43(tiny):
    full, model, tip = tiny
    r = optimal_spinup(model, OMEGA_S, T_S, T_END, n_terms=2, tip=tip, **FIXED,
                       optimizer=dataclasses.replace(OPTIMIZER, adam_steps=2, lbfgs_steps=4))
    assert r.amplitude_baseline > 1e-4  # Eq. 43 leaves a measurable residual on this short manoeuvre
    assert r.rms_optimal < 0.3 * r.rms_baseline
    assert r.amplitude_optimal < 0.5 * r.amplitude_baseline
    assert r.loss_history[r.best_iteration] == min(r.loss_history)
    # the profile still meets the end speed and starts/ends with zero acceleration
    th, dth, ddth = r.profile(T_S)
    assert float(dth) == pytest.approx(OMEGA_S, rel=RTOL_ROUNDOFF)
    # the reported figures are those of the best iterate (no smoothness penalty: loss = ms / ms_Eq.43)
    assert (r.rms_optimal / r.rms_baseline) ** 2 == pytest.approx(r.loss_history[r.best_iteration], rel=1e-10)
    after = r.ts >= T_S
    assert r.amplitude_optimal == pytest.approx(np.abs(r.tip_optimal[after, 1]).max())


@pytest.mark.xdist_group("control_tiny")
def test_optimal_spinup_input_errors(tiny):
    full, model, tip = tiny
    with pytest.raises(ValueError, match="t_end"):
        optimal_spinup(model, OMEGA_S, T_S, T_S, tip=tip)
    with pytest.raises(ValueError, match="grad"):
        optimal_spinup(model, OMEGA_S, T_S, T_END, tip=tip, grad="sideways")
    with pytest.raises(ValueError, match="adam_steps"):
        optimal_spinup(model, OMEGA_S, T_S, T_END, tip=tip, optimizer=dataclasses.replace(OPTIMIZER, adam_steps=-1))
    with pytest.raises(ValueError, match="optimizer must be"):
        optimal_spinup(model, OMEGA_S, T_S, T_END, tip=tip, optimizer={"adam_steps": 2})
    with pytest.raises(ValueError, match="omega_s"):
        optimal_spinup(model, -1.0, T_S, T_END, tip=tip)
    with pytest.raises(ValueError, match="tip"):
        optimal_spinup(model, OMEGA_S, T_S, T_END)  # a tensor-force reduced model keeps no body
