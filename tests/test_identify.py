"""Parameter identification: measurement checks, both gradient paths against finite
differences, the degenerate-eigenvalue fallback, and the demonstration through the CLI."""

import json
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import FD_STEP, RTOL_ROUNDOFF, paper_body

from nrrncf_jax import Basis, RotatingFrameModel, SpinUp, nr_rncf
from nrrncf_jax.cli import main
from nrrncf_jax.integrate import ConstantStepSize, GeneralizedAlpha, Newton
from nrrncf_jax.integrate.simulate import simulate
from nrrncf_jax.reduction.modes import eigh
from nrrncf_jax.scenarios import beam_preset
from nrrncf_jax.studies.families import DegenerateModesWarning, OfflineSpinupFamily, SpinupFamily, offline_family
from nrrncf_jax.studies.identification import AdamLbfgs, Measurement, Observation, identify, misfit, tip_deflection

TS = np.linspace(0.0, 2.0, 21)
# Fixed steps (finite differences then see no step-size changes) and tightly converged Newton
# (the gradient differentiates the converged step equations).
FIXED = dict(controller=ConstantStepSize(0.02, rtol=1e-6, atol=1e-9), newton=Newton(1e-5))


def _reduction(beam: str, n_el: int, omega_s=6.0, T_s=1.47):
    full = RotatingFrameModel(paper_body(n_el, beam), SpinUp(omega_s, T_s))
    return full, nr_rncf(full, jnp.asarray(TS), Basis(n_modes=6, vms=2, mds=2, max_dofs=None, spin_state=False))


# The tests of ``straight`` share an xdist group, so that one worker builds it (and compiles its runs) once.
@pytest.fixture(scope="module")
def straight():
    return _reduction("classic", 3)


@pytest.fixture(scope="module")
def curved():
    return _reduction("curved-upwind", 2, omega_s=2.0)


def _measurement(family, params):
    """A synthetic record of ``family(params)`` plus a small deterministic disturbance."""
    m = family(params)
    ys = simulate(m, GeneralizedAlpha(0.9), ConstantStepSize(0.02), jnp.asarray(TS),
                  observe=Observation(m, tip_deflection(m))).ys
    return Measurement(TS, np.asarray(ys) + 1e-3 * np.sin(7 * TS))


@pytest.mark.parametrize("bad, match", [
    (dict(ts=[0.0, 1.0, 1.0], values=[1.0, 2.0, 3.0]), "strictly increasing"),
    (dict(ts=[0.0, 1.0, 2.0], values=[1.0, 2.0]), "3 samples"),
    (dict(ts=[0.0, 1.0, 2.0], values=[1.0, np.nan, 3.0]), "NaN"),
    (dict(ts=[], values=[]), "at least 2"),
    (dict(ts=[0.0, np.inf], values=[1.0, 2.0]), "NaN or Inf"),
])
def test_measurement_rejects_bad_arrays(bad, match):
    with pytest.raises(ValueError, match=match):
        Measurement(**bad)


@pytest.mark.xdist_group("identify_straight")
def test_misfit_is_the_relative_mean_square_misfit(straight):
    """``misfit`` of ``family(params)`` against twice its own response y (the in-plane tip
    deflection): Σ(y − 2y)² / Σ(2y)² = 1/4. Both runs are the same fixed-step simulation; where
    round-off flipped a Newton count in a step, y would move by less than newton_tol (atol + rtol|y|),
    ~1e-11 relative here (|y| up to 1.3 m), and the ratio by about twice that."""
    full, red = straight
    E0 = float(beam_preset("classic").E)
    fam = SpinupFamily.from_reduction(red, E0)
    params = {"E": 1.1 * E0, "zeta": 0.03, "omega_s": 6.3, "T_s": 1.4}
    m = fam(params)
    y = np.asarray(simulate(m, GeneralizedAlpha(0.9), ConstantStepSize(0.02, rtol=1e-6, atol=1e-9), jnp.asarray(TS),
                            adjoint="forward", observe=Observation(m, tip_deflection(m)), newton=Newton(1e-5),
                            max_steps=100_000).ys)
    assert np.abs(y).max() > 1e-2  # the beam deflects
    value = float(misfit(fam, params, Measurement(TS, 2 * y), solver=GeneralizedAlpha(0.9), adjoint="forward",
                         max_steps=100_000, **FIXED))
    assert value == pytest.approx(0.25, rel=1e-9)


@pytest.mark.slow
@pytest.mark.xdist_group("identify_straight")
def test_fixed_basis_gradient_matches_finite_differences(straight):
    full, red = straight
    E0 = float(beam_preset("classic").E)
    fam = SpinupFamily.from_reduction(red, E0)
    meas = _measurement(fam, {"E": 1.1 * E0, "zeta": 0.03, "omega_s": 6.3, "T_s": 1.4})
    x = {"E": E0, "zeta": 0.02, "omega_s": 6.0, "T_s": 1.47}  # Ts off the step grid (θ⃛ jumps there)

    def f(logx):
        return misfit(fam, {k: jnp.exp(v) for k, v in logx.items()}, meas, **FIXED)

    logx = {k: jnp.log(v) for k, v in x.items()}
    g = jax.grad(f)(logx)
    eps = FD_STEP
    for k in x:
        up = dict(logx, **{k: logx[k] + eps})
        dn = dict(logx, **{k: logx[k] - eps})
        fd = (float(f(up)) - float(f(dn))) / (2 * eps)
        assert float(g[k]) == pytest.approx(fd, rel=2e-5, abs=1e-9 * abs(float(f(logx)))), k
        assert abs(float(g[k])) > 1e-6  # every parameter moves the response


@pytest.mark.xdist_group("identify_straight")
def test_offline_path_degenerate_tube_falls_back_with_a_warning(straight):
    full, red = straight
    with pytest.warns(DegenerateModesWarning, match="repeated eigenvalue"):
        fam = offline_family(full, red, beam_preset("classic"))
    assert isinstance(fam, SpinupFamily)
    # jnp.linalg.eigh's own derivative is NaN at a repeated eigenvalue; the library's is finite.
    D = jnp.diag(jnp.array([1.0, 1.0, 2.0]))
    assert not bool(jnp.all(jnp.isfinite(jax.grad(lambda A: jnp.linalg.eigh(A)[1][0, 2])(D))))
    assert bool(jnp.all(jnp.isfinite(jax.grad(lambda A: eigh(A)[1][0, 2])(D))))


@pytest.mark.slow
def test_offline_path_gradient(curved):
    """Path (b) through modes, MDs, deflation and tensors: E gives the fixed-basis gradient
    (the basis does not depend on E), ν changes the basis and matches finite differences."""
    full, red = curved
    preset = beam_preset("curved-upwind")
    with warnings.catch_warnings():
        warnings.simplefilter("error", DegenerateModesWarning)
        fam = offline_family(full, red, preset)
    assert isinstance(fam, OfflineSpinupFamily)
    fixed = SpinupFamily.from_reduction(red, preset.E)
    meas = _measurement(fam, {"E": 1.05 * preset.E, "nu": 0.2})
    nominal = fam({})
    np.testing.assert_allclose(nominal.elastic.K, red.model.elastic.K, rtol=1e-9, atol=1e-9 * float(
        jnp.abs(red.model.elastic.K).max()))

    def f_off(s, nu):
        return misfit(fam, {"E": s * preset.E, "nu": nu}, meas, **FIXED)

    g_E, g_nu = jax.grad(f_off, argnums=(0, 1))(1.0, preset.nu)
    g_fixed = jax.grad(lambda s: misfit(fixed, {"E": s * preset.E}, meas, **FIXED))(1.0)
    # Equal up to the round-off that the eigenvector derivatives (1/gap factors) amplify.
    assert float(g_E) == pytest.approx(float(g_fixed), rel=1e-4)
    # A wide step and a loose tolerance: the low eigenvalues (~10) of a matrix whose norm is
    # ~1e11 (the stiff cross-section modes) carry round-off ~1e-5, which finite differences
    # amplify by 1/eps (the autodiff eigenvalue derivative equals the Rayleigh quotient
    # φᵀ(∂K/∂ν)φ to 1e-7; finite differences reach it only for eps ≳ 1e-2).
    eps = 1e-3
    fd = (float(f_off(1.0, preset.nu + eps)) - float(f_off(1.0, preset.nu - eps))) / (2 * eps)
    assert np.isfinite(float(g_nu)) and abs(fd) > 0
    assert float(g_nu) == pytest.approx(fd, rel=1e-2)


@pytest.mark.xdist_group("identify_straight")
def test_identify_rejects_bad_input_before_tracing(straight):
    full, red = straight
    E0 = float(beam_preset("classic").E)
    fam = SpinupFamily.from_reduction(red, E0)
    meas = Measurement(TS, np.sin(TS))
    with pytest.raises(ValueError, match="at least one"):
        identify(fam, meas, {})
    with pytest.raises(ValueError, match="adam_steps"):
        identify(fam, meas, {"E": E0}, optimizer=AdamLbfgs(adam_steps=-1))
    with pytest.raises(ValueError, match="optimizer must be an AdamLbfgs"):
        identify(fam, meas, {"E": E0}, optimizer={"adam_steps": 3})
    with pytest.raises(ValueError, match="unknown parameter"):
        identify(fam, meas, {"youngs": 1.0})
    with pytest.raises(ValueError, match="E must be > 0, got -1"):
        identify(fam, meas, {"E": -1.0})
    with pytest.raises(ValueError, match="shape"):
        identify(fam, Measurement(TS, np.ones((TS.size, 2))), {"E": E0})


def test_demonstration_refuses_bad_input_and_summarises_its_result():
    """``scenarios.identification``: bad settings stop ``identification_demo`` before any work,
    and its summary gives the identified parameters' errors relative to the true ones (here of a
    made-up result: E 72 against 70 GPa, ζ 0.021 against 0.02)."""
    from nrrncf_jax.scenarios.identification import IdentificationDemo, identification_demo
    from nrrncf_jax.studies.identification import IdentificationResult

    for bad, match in ((dict(zeta=0.0), "zeta"), (dict(noise=-0.1), "noise"), (dict(elements=0), "elements"),
                       (dict(omega_s=np.nan), "omega_s")):
        with pytest.raises(ValueError, match=match):
            identification_demo(**bad)
    result = IdentificationResult(params={"E": 72e9, "zeta": 0.021}, initial={"E": 91e9, "zeta": 0.026},
                                  loss_history=np.array([1.0, 0.1, 0.01]), adam_iterations=1, lbfgs_iterations=1,
                                  loss_evaluations=4, wall_s=2.0, compile_s=1.0, gradient="fixed_basis")
    ts = np.linspace(0.0, 1.0, 5)
    demo = IdentificationDemo(ts=ts, clean=ts, measured=ts, initial_fit=ts, final_fit=ts, E_true=70e9,
                              zeta_true=0.02, result=result, reduced_dofs=7, measurement_s=0.5, offline_s=0.25)
    d = json.loads(demo.json())
    assert d["E_rel_err"] == pytest.approx(72 / 70 - 1, rel=RTOL_ROUNDOFF)
    assert d["zeta_rel_err"] == pytest.approx(0.05, rel=RTOL_ROUNDOFF)
    assert (d["E_initial"], d["E_identified"], d["zeta_true"]) == (91e9, 72e9, 0.02)
    assert d["iterations"] == 2 and d["final_loss"] == 0.01 and d["samples"] == 5 and d["reduced_dofs"] == 7


@pytest.mark.slow
def test_identification_demo_cli(capsys):
    """The issue's demonstration, coarser (3 elements, 0-20 s every 0.1 s): E within 2 %, ζ within
    15 % from 30 % off, with 1 % noise. 6 Adam and 8 L-BFGS steps reach the minimiser (measured:
    E -0.145 %, ζ +1.92 %, the same to 1e-5 as after 10 + 15 steps, in 16 loss evaluations, not 60)."""
    rc = main(["identify", "--demo", "--json", "--elements", "3", "--t-end", "20", "--dt-out", "0.1",
               "--adam-steps", "6", "--lbfgs-steps", "8"])
    assert rc == 0
    out, err = capsys.readouterr()
    d = json.loads(out.strip().splitlines()[-1])
    assert "the measurement" in err and "adam    1" in err and "lbfgs" in err  # progress by default, on stderr
    for key in ("E_true", "E_identified", "E_rel_err", "zeta_true", "zeta_identified", "zeta_rel_err",
                "iterations", "wall_s"):
        assert key in d
    assert d["E_initial"] == pytest.approx(1.3 * d["E_true"])
    assert abs(d["E_rel_err"]) < 0.02
    assert abs(d["zeta_rel_err"]) < 0.15

