"""Force elements (``multibody.forces``): spring-dampers and actuators on markers, against closed
forms of one-degree-of-freedom mechanisms.

The runs are at rtol 1e-8; generalized-α's phase error, (ωh)² ωt / 12 for the step h the
controller takes there (ωh ≈ 7e-3), is about 1e-4 of the amplitude over these runs, so
2e-4 of the peak is allowed; the balances (momentum, energy against the motor's work) hold to the
same integration error."""

import numpy as np
import pytest

from nrrncf_jax.bodies.rigid import RigidBody
from nrrncf_jax.integrate import AdaptiveStepSize, GeneralizedAlphaIndex3, simulate
from nrrncf_jax.multibody import Marker, Mechanism, actuator, hinge, motor, slider, spring, torsion_spring
from nrrncf_jax.multibody.sensors import AngularMomentum, ElementForce, Energy, Position, observe

Z = (0.0, 0.0, 1.0)
O = Marker(0, (0.0, 0.0, 0.0))
TS = np.linspace(0.0, 3.0, 301)


def _run(mech, sensors, v0=None, rho_inf=0.9):
    z0 = mech.reference()
    v0 = 0.0 * z0 if v0 is None else v0
    sol = simulate(mech, GeneralizedAlphaIndex3(rho_inf), AdaptiveStepSize(1e-8, 1e-10), TS,
                   observe=observe(mech, sensors), y0=(z0, v0))
    return {k: np.asarray(y) for k, y in sol.ys.items()}


def test_a_slider_on_a_spring_damper_oscillates_as_the_damped_oscillator():
    """A 2 kg slider on a spring (k = 50 N/m, c = 0.4 N s/m) to a fixed point 1 m behind it, from
    rest position with velocity 0.3 m/s: x = v₀/ω_d e^{−ζωt} sin ω_d t; the spring's force is
    −k x − c ẋ."""
    m, k, c, v = 2.0, 50.0, 0.4, 0.3
    mech = Mechanism([RigidBody(m, [0.1, 0.1, 0.1])], [slider(None, O, (1.0, 0.0, 0.0))],
                     forces=[spring((-1.0, 0.0, 0.0), O, k, c)])
    y = _run(mech, {"x": Position(O, 0), "f": ElementForce(0), "s": ElementForce(0, "rate")},
             mech.rigid_velocity(velocity=(v, 0.0, 0.0)))
    w = np.sqrt(k / m)
    zeta = c / (2 * np.sqrt(k * m))
    wd = w * np.sqrt(1 - zeta**2)
    x = v / wd * np.exp(-zeta * w * TS) * np.sin(wd * TS)
    np.testing.assert_allclose(y["x"], x, atol=2e-4 * np.abs(x).max())
    np.testing.assert_allclose(y["f"], -k * y["x"] - c * y["s"], atol=1e-9 * k * np.abs(x).max())


def test_a_torsion_spring_at_a_hinge_has_its_frequency_and_keeps_energy():
    """A rigid disk (J = 0.5 kg m² about the hinge axis) on a torsion spring k = 8 N m/rad, from
    rest angle with 0.5 rad/s: θ = ω₀/Ω sin Ωt, Ω = √(k/J); with ρ∞ = 1 the energy (kinetic plus
    the spring's potential) is kept to the integration error."""
    J, k, w0 = 0.5, 8.0, 0.5
    mech = Mechanism([RigidBody(1.0, [0.3, 0.3, J])], [hinge(None, O, Z)], forces=[torsion_spring(None, O, Z, k)])
    y = _run(mech, {"theta": ElementForce(0, "measure"), "E": Energy()}, mech.rigid_velocity(omega=(0.0, 0.0, w0)),
             rho_inf=1.0)
    W = np.sqrt(k / J)
    theta = w0 / W * np.sin(W * TS)
    np.testing.assert_allclose(y["theta"], theta, atol=2e-4 * np.abs(theta).max())
    np.testing.assert_allclose(y["E"], 0.5 * J * w0**2, rtol=2e-4)


def test_a_motor_spins_a_disk_up_with_its_torque_s_impulse_and_work():
    """A constant motor torque τ on a free disk about its hinge: the angular momentum about the
    axis is τ t, the kinetic energy the motor's work ½ (τ t)²/J, and the motor's power τ ω (the
    law reads its parameter: ``params`` is traced)."""
    J, tau = 0.5, 3.0
    mech = Mechanism([RigidBody(1.0, [0.3, 0.3, J])], [hinge(None, O, Z)],
                     forces=[motor(None, O, Z, lambda t, angle, rate, p: p, tau)])
    y = _run(mech, {"L": AngularMomentum(), "E": Energy(), "P": ElementForce(0, "power")})
    np.testing.assert_allclose(y["L"][:, 2], tau * TS, atol=2e-4 * tau * TS[-1])
    np.testing.assert_allclose(y["E"], 0.5 * (tau * TS) ** 2 / J, atol=2e-4 * 0.5 * (tau * TS[-1]) ** 2 / J)
    np.testing.assert_allclose(y["P"], tau**2 * TS / J, atol=2e-4 * tau**2 * TS[-1] / J)


def test_a_force_actuator_along_a_slider_accelerates_it():
    """A constant force F along the slider's axis: x = F t² / (2m)."""
    m, F = 2.0, 0.8
    mech = Mechanism([RigidBody(m, [0.1, 0.1, 0.1])], [slider(None, O, (1.0, 0.0, 0.0))],
                     forces=[actuator(None, O, lambda t, s, s_dot, p: F, axis=(1.0, 0.0, 0.0))])
    y = _run(mech, {"x": Position(O, 0)})
    np.testing.assert_allclose(y["x"], F * TS**2 / (2 * m), atol=2e-4 * F * TS[-1] ** 2 / (2 * m))


def test_an_actuator_s_float_parameter_is_an_argument_not_a_constant():
    """A float in an actuator's ``params`` reaches a compiled function as an array: a new value
    reuses the compiled program (one trace for two values) and gives its own force; an integer
    leaf stays an integer."""
    import equinox as eqx

    traces = []

    @eqx.filter_jit
    def force(mech):
        traces.append(1)
        return mech.forces[0].force(0.0, 0.0, 0.0)

    def law(t, s, s_dot, p):
        return p[0] * p[1]

    def built(F):
        return Mechanism([RigidBody(2.0, [0.1, 0.1, 0.1])], [slider(None, O, (1.0, 0.0, 0.0))],
                         forces=[actuator(None, O, law, params=(F, 2), axis=(1.0, 0.0, 0.0))])

    assert [float(force(built(F))) for F in (0.8, 1.3)] == [1.6, 2.6] and len(traces) == 1
    assert isinstance(built(0.8).forces[0].params[1], int)


def test_force_elements_refuse_bad_input():
    body = RigidBody(1.0, [0.1, 0.1, 0.1])
    with pytest.raises(ValueError, match="k must be finite and >= 0"):
        spring((1.0, 0.0, 0.0), O, -1.0)
    with pytest.raises(ValueError, match="not a node"):
        Mechanism([body], [hinge(None, O, Z)], forces=[torsion_spring(None, Marker(0, (1.0, 0.0, 0.0)), Z, 1.0)])
    with pytest.raises(ValueError, match="law must be callable"):
        Mechanism([body], [hinge(None, O, Z)], forces=[motor(None, O, Z, 3.0)])
    with pytest.raises(ValueError, match="the system has bodies"):
        Mechanism([body], [hinge(None, O, Z)], forces=[spring((1.0, 0.0, 0.0), Marker(2, (0.0, 0.0, 0.0)), 1.0)])
