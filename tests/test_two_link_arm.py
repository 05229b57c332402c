"""Gradients through a jointed simulation: the flexible two-link arm (``examples.two_link_arm``)
with driven hinges, a payload on a ball joint, full ANCF and NR-RNCF links.

The residual-vibration objective J(c) of the hinges' trajectory coefficients is differentiated
in forward mode through the index-3 integrator (constant steps: J is then a smooth function of
c) and checked against central differences. The run's Newton stops at 1e-8 of the positions
(≈ 2 m), which moves J by at most 2|x − x*| · 2e-8 ≈ 1e-9; over 2ε = 2e-4 that is 1e-5 of
these directional derivatives (≥ 1e-4), and the difference's truncation error ε² J'''/6 is
below it: 1e-4 of the derivative is allowed."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from nrrncf_jax.examples.two_link_arm import mechanism, optimise_trajectory, trajectory_objective

EPS = 1e-4


def _directional_check(setup):
    objective, _ = trajectory_objective(setup, dt=4e-3, n_out=41)
    f = jax.jit(lambda c: objective(c)[0])
    c0 = jnp.asarray([[0.01, -0.02, 0.0], [0.03, 0.0, -0.01]])
    d = jnp.asarray(np.random.default_rng(1).normal(size=(2, 3)))
    _, slope = jax.jit(lambda c, dc: jax.jvp(f, (c,), (dc,)))(c0, d)
    fd = (f(c0 + EPS * d) - f(c0 - EPS * d)) / (2 * EPS)
    assert abs(float(slope)) > 1e-4
    np.testing.assert_allclose(float(slope), float(fd), rtol=1e-4)


@pytest.mark.slow
@pytest.mark.parametrize("formulation", ["nr-rncf", "ancf"])
def test_the_arm_s_vibration_gradient_matches_finite_differences(formulation):
    """dJ/dc along a random direction, forward mode against central differences, for reduced
    (3 modes and their derivatives a link) and full ANCF links (2 elements a link)."""
    _directional_check(mechanism(formulation, elements=2, t_end=1.4))


@pytest.mark.slow
def test_the_arm_s_gradient_reaches_a_material_parameter():
    """d/dE of a sensor's history through the jointed ANCF simulation (the links' Young's modulus
    traced through the elements' construction), against central differences."""
    base = mechanism("ancf", elements=2, t_end=1.2)
    ts = np.linspace(0.0, 1.2, 25)

    def tip_y_mean(E):
        s = mechanism("ancf", elements=2, t_end=1.2, E=E)
        from nrrncf_jax.integrate import ConstantStepSize, GeneralizedAlphaIndex3, simulate
        from nrrncf_jax.multibody.sensors import observe

        sol = simulate(s.system, GeneralizedAlphaIndex3(0.5), ConstantStepSize(4e-3, rtol=1e-8, atol=1e-10), ts,
                       observe=observe(s.system, {"tip": base.sensors["tip"]}))
        return jnp.mean(sol.ys["tip"][:, 1])

    # not under jit: the mesh and the markers' resolution need concrete geometry; only E is traced
    E0, rel = 70e9, 1e-4
    slope = jax.jacfwd(tip_y_mean)(E0)
    fd = (tip_y_mean(E0 * (1 + rel)) - tip_y_mean(E0 * (1 - rel))) / (2 * rel * E0)
    np.testing.assert_allclose(float(slope) * E0, float(fd) * E0, rtol=1e-3)


@pytest.mark.slow
def test_a_few_adam_steps_cut_the_arm_s_residual_vibration():
    """Four Adam steps on the reduced arm lower the objective tenfold (the benchmark's forty cut
    the residual amplitude more than tenfold: ``benchmarks/results/mechanisms.md``)."""
    run = optimise_trajectory(mechanism("nr-rncf", elements=2), steps=4, learning_rate=0.01, dt=4e-3, n_out=41)
    assert min(run.history) < 0.1 * run.history[0]
    assert run.amplitude_final < run.amplitude_initial
