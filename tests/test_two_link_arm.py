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
from nrrncf_jax.motion import RestToRest

EPS = 1e-4


def test_a_rest_to_rest_move_ends_at_rest_and_is_c2():
    """``RestToRest``: θ(0) = 0, θ(T) = Δ, and θ̇, θ̈ zero at both ends for any coefficients; its
    closed-form rates are the derivatives of θ (forward mode, to round-off)."""
    m = RestToRest(1.2, 0.5, jnp.asarray([0.1, -0.2, 0.05]))
    ts = jnp.linspace(0.0, 0.7, 29)
    th, dth, ddth = m(ts)
    np.testing.assert_allclose(jax.vmap(jax.grad(lambda t: m(t)[0]))(ts), dth, atol=1e-13)
    np.testing.assert_allclose(jax.vmap(jax.grad(lambda t: m(t)[1]))(ts), ddth, atol=1e-11)
    for t in (0.0, 0.5 - 1e-9, 0.5, 0.6):
        _, d, dd = m(t)
        assert abs(float(d)) < 1e-7 and abs(float(dd)) < 1e-5
    assert float(m(0.0)[0]) == 0.0 and abs(float(m(0.6)[0]) - 1.2) < 1e-15
    with pytest.raises(ValueError, match="coeffs"):
        RestToRest(1.0, 1.0, [[0.1]])
    with pytest.raises(ValueError, match="coeffs must be"):
        mechanism(coeffs=np.zeros(3))


@pytest.mark.slow
def test_the_reduced_arm_s_gradient_matches_finite_differences_and_adam_cuts_its_vibration():
    """NR-RNCF links (3 in-plane modes and their derivatives each): the gradient at the initial
    coefficients along a random direction, and the derivative with respect to the links' Young's
    modulus, against central differences of J; and three Adam steps on it lower J fivefold (the
    second step reaches 0.10 of the initial J, the third overshoots at this learning rate; the
    benchmark's forty cut the residual amplitude more than tenfold:
    ``benchmarks/results/mechanisms_arm.md``)."""
    setup = mechanism("nr-rncf", elements=2)
    c0 = jnp.asarray([[0.01, -0.02, 0.0], [0.03, 0.0, -0.01]])
    run = optimise_trajectory(setup, steps=3, learning_rate=0.01, dt=4e-3, n_out=41, coeffs=c0)
    assert min(run.history) < 0.2 * run.history[0]
    assert run.amplitude_final < run.amplitude_initial
    objective, _ = trajectory_objective(setup, dt=4e-3, n_out=41)

    @jax.jit  # J and dJ/ds in one compiled program, used for every evaluation below
    def value_and_ds(c, s):
        return jax.jvp(lambda s: objective(c, s)[0], (s,), (1.0,))

    def f(c, s):
        return value_and_ds(c, s)[0]

    d = jnp.asarray(np.random.default_rng(1).normal(size=(2, 3)))
    slope = float(np.sum(run.gradients[0] * np.asarray(d)))
    fd = float((f(c0 + EPS * d, 1.0) - f(c0 - EPS * d, 1.0)) / (2 * EPS))
    assert abs(slope) > 1e-4
    np.testing.assert_allclose(slope, fd, rtol=1e-4)
    np.testing.assert_allclose(float(f(c0, 1.0)), run.history[0], rtol=1e-12)  # the same objective
    # a material parameter: the links' Young's modulus times s (the reduced tensors scaled, exact
    # for a basis of modes and modal derivatives, which a uniform E leaves unchanged)
    dJ_ds = value_and_ds(c0, 1.0)[1]
    fd_s = float((f(c0, 1.0 + EPS) - f(c0, 1.0 - EPS)) / (2 * EPS))
    assert abs(float(dJ_ds)) > 1e-6
    np.testing.assert_allclose(float(dJ_ds), fd_s, rtol=1e-4)


@pytest.mark.slow
def test_the_full_arm_s_gradient_reaches_a_material_parameter():
    """d/dE of a sensor's history through the jointed ANCF simulation (the links' Young's modulus
    traced through the elements' construction), against central differences."""
    from nrrncf_jax.integrate import ConstantStepSize, GeneralizedAlphaIndex3, simulate
    from nrrncf_jax.multibody.sensors import observe

    base = mechanism("ancf", elements=2, t_end=1.2)
    ts = np.linspace(0.0, 1.2, 25)

    def tip_y_mean(E):
        s = mechanism("ancf", elements=2, t_end=1.2, E=E)
        sol = simulate(s.system, GeneralizedAlphaIndex3(0.5), ConstantStepSize(4e-3, rtol=1e-8, atol=1e-10), ts,
                       observe=observe(s.system, {"tip": base.sensors["tip"]}))
        return jnp.mean(sol.ys["tip"][:, 1])

    # not under jit: the mesh and the markers' resolution need concrete geometry; only E is traced
    E0, rel = 70e9, 1e-4
    slope = jax.jacfwd(tip_y_mean)(E0)
    fd = (tip_y_mean(E0 * (1 + rel)) - tip_y_mean(E0 * (1 - rel))) / (2 * rel * E0)
    np.testing.assert_allclose(float(slope) * E0, float(fd) * E0, rtol=1e-3)
