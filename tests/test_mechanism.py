"""Mechanisms of the user's own (``multibody.Mechanism``): rigid bodies, ANCF and floating-frame
bodies in one system, prismatic joints and drivers, sensors, one-call reduction and model files.

Closed forms: the rigid body's kinetic energy ½ m v² + ½ ωᵀJω from its nodal mass matrix; the
compound pendulum's period 2π √(J_O / m g d) (1 + θ₀²/16); the rigid slider-crank's x_B(θ) and its
driving torque τ = dT/dθ from the kinematics alone; a free rigid body's angular momentum."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import RTOL_RESIDUAL, RTOL_ROUNDOFF

from nrrncf_jax.bodies import Material, TubeSection, beam_body, straight_reference
from nrrncf_jax.bodies.rigid import RigidBody, slender_rod
from nrrncf_jax.integrate import AdaptiveStepSize, GeneralizedAlphaIndex3, simulate
from nrrncf_jax.multibody import Marker, Mechanism, MultibodySystem, PointMass, ball, hinge, slider
from nrrncf_jax.multibody.rigid import rigid_floating_body
from nrrncf_jax.multibody.sensors import AngularMomentum, Energy, Position, Velocity
from nrrncf_jax.scenarios.mechanism_file import load_setup, run_setup

Z = (0.0, 0.0, 1.0)


def test_a_rigid_body_has_its_mass_and_inertia():
    """T(ż) for the rigid motion (V, ω) is ½ m |V_c|² + ½ ωᵀJω, V_c the centre of mass's velocity,
    to round-off: the nodal mass matrix (m on the centre, Θ' = ½ tr J − J on the axes) is the
    body's, for any axes the nodes carry."""
    rng = np.random.default_rng(0)
    Q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    J = Q @ np.diag([2.0, 3.0, 4.0]) @ Q.T
    axes = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    axes[:, 2] *= np.sign(np.linalg.det(axes))
    body = rigid_floating_body(RigidBody(1.7, J, com=(0.3, -0.2, 0.5), points=[(1.0, 0.0, 0.0)], axes=axes))
    z = body.initial()
    V, w = rng.normal(size=3), rng.normal(size=3)
    v = body.rigid_velocity(z, V, w)
    Vc = V + np.cross(w, [0.3, -0.2, 0.5])
    expected = 0.5 * 1.7 * Vc @ Vc + 0.5 * w @ J @ w
    assert abs(float(body.kinetic_energy(z, v)) - expected) < RTOL_ROUNDOFF * expected
    # and the nodal velocities are the rigid field's, at every node
    x, xv = body.nodal_vectors(z), body.tangent(z, v)
    pos = np.asarray(body.body.is_position)
    field = np.where(pos[:, None], V[None] + np.cross(w[None], x), np.cross(w[None], x))
    np.testing.assert_allclose(xv, field, atol=RTOL_ROUNDOFF * np.abs(field).max())


@pytest.mark.slow
def test_the_compound_pendulum_has_its_period():
    """A uniform rigid rod hinged at one end, released from θ₀ = 0.05 rad: the period
    2π √(J_O / (m g L/2)) (1 + θ₀²/16) (the next term, 11θ₀⁴/3072, is 2e-8). The zero crossings
    are interpolated from 400 outputs a period, where the swing is nearly linear in t (error
    ~ (ωΔt)³/… ≪ 1e-6); the run's own phase error at rtol 1e-8 is far below the 2e-5 allowed."""
    m, L, g, th0 = 1.0, 1.0, 9.81, 0.05
    rod = slender_rod(m, L, (0.0, 0.0, 0.0), (L * np.sin(th0), -L * np.cos(th0), 0.0))
    mech = Mechanism([rod], [hinge(None, Marker(0, (0.0, 0.0, 0.0)), Z)], gravity=(0.0, -g, 0.0))
    T = 2 * np.pi * np.sqrt((m * L**2 / 3) / (m * g * L / 2)) * (1 + th0**2 / 16)
    ts = np.linspace(0.0, 1.5 * T, 601)
    end = Position(Marker(0, (L * np.sin(th0), -L * np.cos(th0), 0.0)), 0).resolve(mech)
    sol = simulate(mech, GeneralizedAlphaIndex3(0.9), AdaptiveStepSize(1e-8, 1e-10), ts,
                   observe=lambda t, z, v: end(mech, t, z, v))
    x = np.asarray(sol.ys)
    i = np.flatnonzero(np.diff(np.sign(x)) != 0)
    crossings = ts[i] - x[i] * (ts[i + 1] - ts[i]) / (x[i + 1] - x[i])
    assert len(crossings) >= 3
    np.testing.assert_allclose(2 * np.diff(crossings), T, rtol=2e-5)


@pytest.fixture(scope="module")
def rigid_crank():
    setup = load_setup("slider_crank", {"formulation": "rigid"})
    return setup, run_setup(setup, n_out=201, controller=setup.controller(1e-6))


def _rigid_kinetic_energy(theta, omega=150.0, r=0.152, L=0.304, rho=2770.0, radius=0.005, m_s=0.033):
    """T(θ) of the rigid slider-crank at crank speed ω, from its kinematics alone: the crank about
    O, the rod's centre and spin, the slider; the rates d/dθ by forward-mode differentiation."""
    area = np.pi * radius**2
    m_c, m_r = rho * area * r, rho * area * L

    def positions(th):
        A = jnp.stack([r * jnp.cos(th), r * jnp.sin(th)])
        B = jnp.stack([r * jnp.cos(th) + jnp.sqrt(L**2 - (r * jnp.sin(th)) ** 2), 0.0 * th])
        return 0.5 * (A + B), jnp.arctan2(B[1] - A[1], B[0] - A[0]), B[0]

    _, (dG, dphi, dB) = jax.jvp(positions, (theta,), (jnp.ones_like(theta),))
    return 0.5 * omega**2 * (m_c * r**2 / 3 + m_r * dG @ dG + (m_r * L**2 / 12) * dphi**2 + m_s * dB**2)


@pytest.mark.slow
def test_the_rigid_slider_crank_follows_its_kinematics_and_driving_torque(rigid_crank):
    """All rigid, crank driven at ω = 150 rad/s: x_B = r cos θ + √(L² − r² sin² θ) to the Newton
    tolerance (the index-3 constraints hold at every step), and the driving torque (the driver's
    multiplier) τ = dT/dθ, T(θ) the mechanism's kinetic energy from its kinematics (no gravity,
    constant ω: τ ω = dT/dt), differentiated by JAX: both to round-off of the consistent solve.
    (Nested central differences of T are not accurate enough here: ε T / δ is 1e-5 of τ.)"""
    from nrrncf_jax.examples.slider_crank import rigid_slider_position

    setup, run = rigid_crank
    np.testing.assert_allclose(run.series["x_B"], rigid_slider_position(run.ts), atol=1e-8)
    tau = np.asarray(jax.vmap(jax.grad(_rigid_kinetic_energy))(jnp.asarray(150.0 * run.ts)))
    scale = np.abs(tau).max()
    np.testing.assert_allclose(run.series["torque"], tau, atol=1e-6 * scale)
    assert np.abs(run.series["w_mid"]).max() < 1e-12  # a rigid rod does not bend


@pytest.mark.slow
def test_a_motor_with_state_feedback_is_a_damped_oscillator():
    """A rigid rod hinged at one end (J_O = m L²/3, no gravity), driven by a motor whose law reads
    the rod's end through sensors (``motor(..., inputs=...)``): τ = τ₀ − k θ̂ − c ω̂, with θ̂ =
    atan2(y, x) from the end's position and ω̂ = (x v_y − y v_x)/L² from its velocity. The
    closed loop is J_O θ̈ + c θ̇ + k θ = τ₀, whose step response from rest is
    θ = τ₀/k [1 − e^(−ζΩt)(cos Ω_d t + ζ/√(1−ζ²) sin Ω_d t)]; the run at rtol 1e-8 follows it to
    1e-5 of τ₀/k (its own error is ~1e-7 of it). d θ(t_end)/dk by forward mode through the run
    (``params`` traced) against the closed form's derivative, to 1e-4."""
    from nrrncf_jax.multibody import motor

    m, L, tau0 = 1.0, 1.0, 0.4
    J = m * L**2 / 3
    end = Marker(0, (L, 0.0, 0.0))
    rod = slender_rod(m, L, (0.0, 0.0, 0.0), (L, 0.0, 0.0))

    def law(t, angle, rate, p, inputs):
        (x, y, _), (vx, vy, _) = inputs["end"], inputs["end_velocity"]
        return tau0 - p[0] * jnp.arctan2(y, x) - p[1] * (x * vy - y * vx) / L**2

    def mechanism(p):
        return Mechanism([rod], [hinge(None, Marker(0, (0.0, 0.0, 0.0)), Z)],
                         forces=[motor(None, Marker(0, (0.0, 0.0, 0.0)), Z, law, p,
                                       inputs={"end": Position(end), "end_velocity": Velocity(end)})])

    def exact(t, k, c):
        Om = jnp.sqrt(k / J)
        zeta = c / (2 * jnp.sqrt(k * J))
        Od = Om * jnp.sqrt(1 - zeta**2)
        return tau0 / k * (1 - jnp.exp(-zeta * Om * t) * (jnp.cos(Od * t) + zeta / jnp.sqrt(1 - zeta**2)
                                                          * jnp.sin(Od * t)))

    ts = np.linspace(0.0, 2.0, 201)

    def angles(p):
        mech = mechanism(p)
        tip = Position(end).resolve(mech)
        sol = simulate(mech, GeneralizedAlphaIndex3(0.9), AdaptiveStepSize(1e-8, 1e-10), ts,
                       observe=lambda t, z, v: (lambda x: jnp.arctan2(x[1], x[0]))(tip(mech, t, z, v)))
        return sol.ys

    k, c = 3.0, 0.4  # Ω = 3 rad/s, ζ = 0.2
    theta, dtheta_dk = jax.jvp(lambda k: angles(jnp.stack([k, c])), (k,), (1.0,))  # one run, both
    np.testing.assert_allclose(theta, exact(ts, k, c), atol=1e-5 * tau0 / k)
    np.testing.assert_allclose(dtheta_dk[-1], jax.grad(exact, argnums=1)(ts[-1], k, c), rtol=1e-4)
    p0 = (k, c)
    with pytest.raises(ValueError, match="kinematic sensors"):
        motor(None, Marker(0, (0.0, 0.0, 0.0)), Z, law, p0, inputs={"energy": Energy()})


def test_a_free_rigid_body_keeps_its_angular_momentum():
    """A torque-free asymmetric body spinning about a tilted axis (it tumbles): its angular
    momentum about the origin and its energy stay constant to the integration error (rtol 1e-8
    over three turns: 1e-5 allowed)."""
    J = np.diag([1.0, 2.0, 2.5])
    body = RigidBody(2.0, J, com=(0.1, 0.2, 0.0))
    mech = Mechanism([body])
    z0 = mech.reference()
    v0 = mech.rigid_velocity(velocity=(0.3, 0.0, 0.0), omega=(0.2, 3.0, 0.4))
    sensors = {"L": AngularMomentum(), "E": Energy("kinetic")}
    sol = simulate(mech, GeneralizedAlphaIndex3(0.9), AdaptiveStepSize(1e-8, 1e-10), np.linspace(0, 6.0, 61),
                   observe=lambda t, z, v: {k: s(mech, t, z, v) for k, s in sensors.items()}, y0=(z0, v0))
    Lh, E = np.asarray(sol.ys["L"]), np.asarray(sol.ys["E"])
    np.testing.assert_allclose(Lh, np.broadcast_to(Lh[0], Lh.shape), atol=1e-5 * np.linalg.norm(Lh[0]))
    np.testing.assert_allclose(E, E[0], rtol=1e-5)


@pytest.mark.slow
def test_an_ancf_body_in_a_mechanism_is_the_multibody_systems():
    """The same hinged beam as an ``InertialBody`` of a ``Mechanism`` and in a ``MultibodySystem``:
    equal residual, constraints, their Jacobian and mass matrix at a perturbed state, to round-off."""
    beam = beam_body(Material(2e11, 7800.0, 0.3), TubeSection(0.01), straight_reference(1.0, 2))
    joints = [hinge(None, Marker(0, (0.0, 0.0, 0.0)), Z)]
    a, b = Mechanism([beam], joints, gravity=(0, -9.81, 0)), MultibodySystem([beam], joints, gravity=(0, -9.81, 0))
    rng = np.random.default_rng(1)
    x = b.reference() + 1e-3 * rng.normal(size=b.n_dof)
    v, acc = rng.normal(size=b.n_dof), rng.normal(size=b.n_dof)
    for f in (lambda s: s.residual(0.0, x, v, acc), lambda s: s.constraints(x), lambda s: s.constraint_jacobian(x),
              lambda s: s.mass_matrix(x)):
        ya, yb = np.asarray(f(a)), np.asarray(f(b))
        np.testing.assert_allclose(ya, yb, atol=RTOL_ROUNDOFF * max(1.0, np.abs(yb).max()))
    assert not a.small_kernels and not b.small_kernels  # element forces over a mesh: XLA's defaults


@pytest.mark.slow
def test_point_mass_and_mechanism_bookkeeping():
    """A point mass hung by a ball joint on a rigid rod's end: one system of a floating and a
    point body; formulation 'rigid', a consistent initial acceleration of the pendulum under
    gravity (the bob's acceleration at rest is g's component across the rod... here along it:
    the rod hangs, so a = 0)."""
    rod = slender_rod(1.0, 1.0, (0.0, 0.0, 0.0), (0.0, -1.0, 0.0))
    mech = Mechanism([rod, PointMass(0.5, (0.0, -1.0, 0.0))],
                     [hinge(None, Marker(0, (0.0, 0.0, 0.0)), Z), ball(Marker(0, (0.0, -1.0, 0.0)),
                                                                     Marker(1, (0.0, -1.0, 0.0)))],
                     gravity=(0.0, -9.81, 0.0))
    assert mech.formulation == "rigid" and mech.n_dof == 7 + 3 and mech.small_kernels
    z0 = mech.reference()
    a, lam = mech.consistent_accelerations(0.0, z0, jnp.zeros_like(z0))
    assert np.abs(np.asarray(a)).max() < 1e-10
    # the hinge carries the whole weight: its first three multipliers are (0, −(1 + 0.5) g, 0) up to sign
    np.testing.assert_allclose(np.abs(np.asarray(lam[:3])), [0.0, 1.5 * 9.81, 0.0], atol=1e-9)


# --- errors -------------------------------------------------------------------------------------
def test_bad_rigid_bodies_and_joints_are_refused():
    with pytest.raises(ValueError, match="positive definite"):
        RigidBody(1.0, np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match="triangle inequality"):
        RigidBody(1.0, np.diag([1.0, 1.0, 3.0]))
    with pytest.raises(ValueError, match="mass"):
        RigidBody(0.0, np.eye(3))
    crank = slender_rod(1.0, 1.0, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    # a prismatic joint on a point with no direction
    with pytest.raises(ValueError, match="carries no section frame"):
        Mechanism([PointMass(1.0, (1.0, 0.0, 0.0))], [slider(None, Marker(0, (1.0, 0.0, 0.0)), (1.0, 0.0, 0.0))])
    # a mechanism that locks: a rigid link hinged to the ground at both ends
    with pytest.raises(ValueError, match="redundant"):
        Mechanism([crank], [hinge(None, Marker(0, (0.0, 0.0, 0.0)), Z), hinge(None, Marker(0, (1.0, 0.0, 0.0)), Z)])
    # a driver incompatible with the joints: a driven hinge on a clamped body
    from nrrncf_jax.motion import SteadySpin
    from nrrncf_jax.multibody import clamp
    with pytest.raises(ValueError, match="redundant"):
        Mechanism([crank], [clamp(None, Marker(0, (1.0, 0.0, 0.0))),
                            hinge(None, Marker(0, (0.0, 0.0, 0.0)), Z, drive=SteadySpin(1.0))])
    # an initial velocity the joints do not allow
    mech = Mechanism([crank], [hinge(None, Marker(0, (0.0, 0.0, 0.0)), Z)])
    with pytest.raises(ValueError, match="velocit"):
        mech.check_velocity(mech.reference(), mech.rigid_velocity(velocity=(1.0, 0.0, 0.0)))
    with pytest.raises(ValueError, match="drive must be a motion"):
        hinge(None, Marker(0, (0.0, 0.0, 0.0)), Z, drive=3.0)


def test_model_files_are_checked(tmp_path):
    with pytest.raises(ValueError, match="no model file or bundled example"):
        load_setup("no_such_example")
    bad = tmp_path / "bad.py"
    bad.write_text("x = 1\n")
    with pytest.raises(ValueError, match="does not define mechanism"):
        load_setup(str(bad))
    wrong = tmp_path / "wrong.py"
    wrong.write_text("def mechanism(a=1):\n    return 3\n")
    with pytest.raises(ValueError, match="not a MechanismSetup"):
        load_setup(str(wrong))
    with pytest.raises(ValueError, match="unknown parameter"):
        load_setup(str(wrong), {"b": 2})
    with pytest.raises(ValueError, match="missing.py"):
        load_setup(str(tmp_path / "missing.py"))
    # a body reduced with mds="mmi" whose pairs were never chosen would run on its VMs alone
    pending = tmp_path / "pending.py"
    pending.write_text(
        "from nrrncf_jax.bodies import Material, TubeSection, beam_body, straight_reference\n"
        "from nrrncf_jax.multibody import Marker, Mechanism, hinge\n"
        "from nrrncf_jax.multibody.reduce import reduce\n"
        "from nrrncf_jax.multibody.sensors import Position\n"
        "from nrrncf_jax.scenarios.mechanism_file import MechanismSetup\n"
        "def mechanism():\n"
        "    beam = beam_body(Material(2e6, 1100.0, 0.3), TubeSection(0.01), straight_reference(1.0, 2))\n"
        "    body = reduce(beam, [(0.0, 0.0, 0.0)], vms=2, mds='mmi', plane_normal=(0.0, 0.0, 1.0))\n"
        "    mech = Mechanism([body], [hinge(None, Marker(0, (0.0, 0.0, 0.0)), (0.0, 0.0, 1.0))])\n"
        "    return MechanismSetup(mech, {'tip': Position(Marker(0, (1.0, 0.0, 0.0)))})\n")
    setup = load_setup(str(pending))
    assert setup.system.bodies[0].awaiting_mds
    with pytest.raises(ValueError, match="never chosen"):
        run_setup(setup, t_end=0.01)


@pytest.fixture(scope="module")
def rotor_runs():
    """The torque-driven rotor (``examples.rotor``), 4 elements a beam, to t = 2.5 s (the motor's
    pulse and half a second after), full ANCF and NR-RNCF."""
    runs = {}
    for formulation in ("nr-rncf", "ancf"):
        setup = load_setup("rotor", {"formulation": formulation, "elements": 4, "t_end": 2.5})
        runs[formulation] = (setup, run_setup(setup, n_out=251))
    return runs


@pytest.mark.slow
@pytest.mark.xdist_group("rotor")  # one worker runs the fixture, not one per test
@pytest.mark.parametrize("formulation", ["nr-rncf", "ancf"])
def test_the_rotor_keeps_its_momentum_and_energy_balances(rotor_runs, formulation):
    """The rotor's angular momentum about its axis is the motor's impulse, and its energy the
    motor's work ∫ τ ω dt (Simpson's rule on the outputs, 1e-7 of it for this smooth power),
    both to the integration error: the step tolerance is 1e-5 and a few hundred steps
    accumulate ~1e-4, so 1e-3 of the final values is allowed. The hub's clamps are welds on the
    section frames (six equations) for the reduced and the ANCF beams alike."""
    from scipy.integrate import cumulative_simpson

    from nrrncf_jax.examples.rotor import impulse

    setup, run = rotor_runs[formulation]
    kinds = {type(j).__name__ for j in setup.system.joints[1:]}
    assert kinds == {"Weld"}
    assert setup.system.small_kernels == (formulation == "nr-rncf")
    H = impulse(run.ts, 2000.0, 2.0)
    np.testing.assert_allclose(run.series["H_z"], H, atol=1e-3 * H[-1])
    W = cumulative_simpson(run.series["power"], x=run.ts, initial=0.0)
    np.testing.assert_allclose(run.series["energy"] - run.series["energy"][0], W, atol=1e-3 * W[-1])
    assert run.series["omega"][-1] > 0.5 and np.abs(run.series["tip"]).max() > 0.1  # it spun up and bent
    # The root's bending moment at the largest tip deflection w, where the beam's deflection rate
    # is zero: a cantilever under a load of one sign has |M| ≥ 3 EI |w| / L² (all of it at the
    # tip), and the spin-up's inertial load ρA α r, growing outward, lies between a tip load's 3
    # and a uniform load's 4 EI |w| / L²; M3's sign is w's (beam_preset("paper"): EI, L).
    from nrrncf_jax.scenarios import beam_preset

    preset = beam_preset("paper")
    EI = preset.E * np.pi / 4 * (preset.r_outer**4 - preset.r_inner**4)
    i = int(np.argmax(np.abs(run.series["tip"])))
    w, M = run.series["tip"][i], run.series["M_root"][i]
    assert M * w > 0 and 3.0 <= abs(M) * preset.length**2 / (EI * abs(w)) <= 4.0


@pytest.mark.slow
@pytest.mark.xdist_group("rotor")
def test_the_reduced_rotor_follows_the_full_one(rotor_runs):
    """NR-RNCF (4 in-plane modes and their derivatives a beam) against full ANCF on the same
    mesh: the hub's speed and beam 0's tip deflection within χ_rel 1 %."""
    from nrrncf_jax.post.metrics import chi_rel

    full, reduced = rotor_runs["ancf"][1], rotor_runs["nr-rncf"][1]
    for name in ("omega", "tip"):
        assert float(chi_rel(full.series[name], reduced.series[name])) < 1.0, name


def test_welded_rigid_bodies_hang_still_and_carry_their_weight():
    """A rigid body welded to the ground, and a second one welded to it at a point whose axes are
    turned 30° about Z (clamps between rigid directions resolve to six-equation welds, with the
    reference relation of the two triads): under gravity nothing moves, to the Newton tolerance,
    and the ground weld's reaction force is the two bodies' weight (consistent multipliers, to
    round-off of that solve)."""
    from nrrncf_jax.multibody import clamp
    from nrrncf_jax.multibody.sensors import JointReaction
    from nrrncf_jax.multibody.weld import Weld

    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    turned = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    a = RigidBody(2.0, [0.1, 0.2, 0.25], com=(0.5, 0.0, 0.0), points=[(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)])
    b = RigidBody(1.5, [0.05, 0.1, 0.12], com=(1.0 + 0.4 * c, 0.4 * s, 0.0), points=[(1.0, 0.0, 0.0)], axes=turned)
    g = np.array([0.0, -9.81, 0.0])
    mech = Mechanism([a, b], [clamp(None, Marker(0, (0.0, 0.0, 0.0))),
                              clamp(Marker(0, (1.0, 0.0, 0.0)), Marker(1, (1.0, 0.0, 0.0)))], gravity=g)
    assert all(isinstance(j, Weld) for j in mech.joints) and mech.n_joint_equations == 12
    ts = np.linspace(0.0, 0.5, 6)
    tip = Position(Marker(1, (1.0, 0.0, 0.0))).resolve(mech)
    sensors = {"tip": lambda t, z, v: tip(mech, t, z, v), "lam": lambda t, z, v: JointReaction(0)(mech, t, z, v)}
    sol = simulate(mech, GeneralizedAlphaIndex3(0.9), AdaptiveStepSize(1e-6, 1e-8), ts,
                   observe=lambda t, z, v: {k: f(t, z, v) for k, f in sensors.items()})
    np.testing.assert_allclose(sol.ys["tip"], np.broadcast_to([1.0, 0.0, 0.0], (6, 3)), atol=1e-9)
    weight = (2.0 + 1.5) * g
    np.testing.assert_allclose(np.asarray(sol.ys["lam"])[:, :3], np.broadcast_to(-weight, (6, 3)),
                               atol=1e-9 * np.linalg.norm(weight))


def test_section_resultants_of_a_stretched_turned_beam():
    """``post.stress.SectionResultant`` at the root, an interior node and the tip of a beam stretched
    uniformly by ε along its axis and turned (rotated and moved) as a whole: the section vectors
    keep their length, so E11 = ε + ε²/2 is the only strain, S11 = E E11 (``Material.beam_D``),
    the force the section carries N = (1 + ε) E A (ε + ε²/2) (the first Piola-Kirchhoff traction
    F S e₁ on the stretched axis; ``kind="conjugate"``: ∫ S11 = E A (ε + ε²/2)), exactly; the
    shear forces, torque and moments are zero (to the round-off of F's products, relative to N).
    Read the same through an ANCF body and a floating-frame body (``reduce(basis="full")``) whose
    frame carries the rotation."""
    from scipy.spatial.transform import Rotation

    from nrrncf_jax.multibody.floating import euler_parameters
    from nrrncf_jax.multibody.reduce import reduce
    from nrrncf_jax.multibody.sensors import observe
    from nrrncf_jax.post.stress import SectionResultant

    E, r, eps = 1e9, 0.01, 2e-3
    beam = beam_body(Material(E, 2700.0, 0.3), TubeSection(r), straight_reference(1.0, 4))
    A = Rotation.from_rotvec([0.3, -0.2, 0.9]).as_matrix()
    R = np.array([0.4, -1.0, 2.0])
    stretched = np.asarray(beam.q_hat) * np.array([1.0 + eps, 1.0, 1.0])  # x components: positions and r_x
    x = stretched @ A.T + np.asarray(beam.is_position)[:, None] * R
    N_conjugate = E * np.pi * r**2 * (eps + eps**2 / 2)
    N = (1.0 + eps) * N_conjugate
    sensors = {f"at_{s}": SectionResultant(Marker(0, (s, 0.0, 0.0))) for s in (0.0, 0.5, 1.0)}
    sensors["N_tip"] = SectionResultant(Marker(0, (1.0, 0.0, 0.0)), "N")
    sensors["S_tip"] = SectionResultant(Marker(0, (1.0, 0.0, 0.0)), "N", kind="conjugate")
    full = reduce(beam, [(0.0, 0.0, 0.0)], basis="full")
    p = (stretched - np.asarray(full.body.q_hat)).reshape(-1)[np.asarray(full.free)]
    for mech, z in ((Mechanism([beam]), x.reshape(-1)),
                    (Mechanism([full]), np.concatenate([R, euler_parameters(A), p]))):
        out = observe(mech, sensors)(0.0, jnp.asarray(z), jnp.zeros(mech.n_dof))
        for s in (0.0, 0.5, 1.0):
            expected = np.array([N, 0.0, 0.0, 0.0, 0.0, 0.0])
            np.testing.assert_allclose(out[f"at_{s}"], expected, rtol=1e-10, atol=1e-9 * N)
        np.testing.assert_allclose(out["N_tip"], N, rtol=1e-10)
        np.testing.assert_allclose(out["S_tip"], N_conjugate, rtol=1e-10)
    with pytest.raises(ValueError, match="kind must be"):
        SectionResultant(Marker(0, (0.0, 0.0, 0.0)), "N", kind="cauchy")
    with pytest.raises(ValueError, match="quantity must be"):
        SectionResultant(Marker(0, (0.0, 0.0, 0.0)), "moment")
    with pytest.raises(ValueError, match="no C1 beam elements"):
        observe(Mechanism([RigidBody(1.0, [0.1, 0.1, 0.1])]), {"m": SectionResultant(Marker(0, (0.0, 0.0, 0.0)))})


def test_stiffened_bodies_scale_their_elastic_force():
    """``Mechanism.stiffened(s)``: at rest, without gravity, a body's residual is its elastic force
    alone, and it scales by s, for an ANCF body (κ scaled) and a reduced one (its tensors scaled),
    to round-off; a rigid body is unchanged."""
    from nrrncf_jax.multibody.reduce import reduce

    beam = beam_body(Material(1e9, 2700.0, 0.3), TubeSection(0.01), straight_reference(1.0, 2))
    reduced = reduce(beam, [(0.0, 0.0, 0.0)], vms=2, mds=[(0, 0)], plane_normal=Z)
    mech = Mechanism([beam, reduced, RigidBody(1.0, [0.1, 0.1, 0.1], com=(3.0, 0.0, 0.0))])
    z = mech.reference() + 1e-3 * jnp.asarray(np.random.default_rng(2).normal(size=mech.n_dof))
    zero = jnp.zeros_like(z)
    r1 = mech.residual(0.0, z, zero, zero)
    r2 = mech.stiffened(2.5).residual(0.0, z, zero, zero)
    scale = float(jnp.abs(r1).max())
    for part1, part2, kind in zip(mech.split(r1), mech.split(r2), ("ancf", "nr-rncf", "rigid")):
        np.testing.assert_allclose(part2, 2.5 * part1, atol=1e-12 * scale, err_msg=kind)


def test_reduce_keeps_the_interfaces_static_modes_and_refuses_what_it_cannot_build():
    """``reduce(..., interface_modes=True)``: a cantilever's in-plane basis of 2 VMs gains the two
    in-plane static modes of its other end, and a static axial tip load's deflection (the body's
    own stiffness solve) then lies in the basis to the SVD's round-off; without them it does not
    (the two lowest in-plane modes bend: the stretch is nearly orthogonal to them). Bad
    combinations are refused before anything is computed."""
    from nrrncf_jax.multibody.reduce import reduce

    beam = beam_body(Material(1e9, 2700.0, 0.3), TubeSection(0.01), straight_reference(1.0, 2))
    ends = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)]
    plain = reduce(beam, ends, vms=2, mds=[], plane_normal=Z)
    joint = reduce(beam, ends, vms=2, mds=[], plane_normal=Z, interface_modes=True)
    assert (plain.k, joint.k) == (2, 4)
    free = np.asarray(joint.free)
    K = np.asarray(beam.stiffness_matrix(beam.q_hat))[np.ix_(free, free)]
    tip = 3 * 12  # the right end's position vector (node 2, vector 0), its axial component
    load = np.zeros(beam.n_dof)
    load[tip] = 1.0
    u = np.zeros(beam.n_dof)
    u[free] = np.linalg.solve(K, load[free])

    def off_span(Psi):
        Psi = np.asarray(Psi)
        return np.linalg.norm(u - Psi @ np.linalg.lstsq(Psi, u, rcond=None)[0]) / np.linalg.norm(u)

    assert off_span(joint.basis) < 1e-10 and off_span(plain.basis) > 1e-3
    for kwargs, match in [({"mds": "mmi", "interface_modes": True}, "explicit list of pairs"),
                          ({"basis": "craig-bampton", "interface_modes": True}, "goes with basis='free'"),
                          ({"basis": "modal"}, "basis must be"),
                          ({"mds": "some"}, "mds must be"),
                          ({"mds": 0}, "mds must be")]:
        with pytest.raises(ValueError, match=match):
            reduce(beam, ends, **kwargs)
    with pytest.raises(ValueError, match="needs a second interface"):
        reduce(beam, ends[:1], interface_modes=True)
    with pytest.raises(ValueError, match="at least one interface"):
        reduce(beam, [])


def test_reduce_gives_modal_derivatives_to_the_named_loads_and_the_sections_their_own_modes():
    """``interface_mds`` as load names: the derivatives of those loads' attachment modes alone,
    a subspace of ``interface_mds=True``'s (all six names give its very basis), one column a
    pair; ``interface_sections``: the attachment modes of the far section's stretch and shear,
    loads that do no work on its rotation (δr = e × r), whose static deflection then lies in the
    basis to round-off and otherwise does not. Bad values are refused."""
    from nrrncf_jax.multibody.markers import BodyGeometry
    from nrrncf_jax.multibody.reduce import INTERFACE_LOADS, moment_loads, reduce, section_loads

    beam = beam_body(Material(1e9, 2700.0, 0.3), TubeSection(0.01), straight_reference(1.0, 2))
    ends = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)]
    kw = {"vms": 0, "mds": [], "interface_modes": True, "interface_rotations": True}
    linear, every, named = (reduce(beam, ends, **kw, interface_mds=m) for m in (False, True, INTERFACE_LOADS))
    out_of_plane = reduce(beam, ends, **kw, interface_mds=("fz", "mx", "my"))
    assert linear.k == 6 and out_of_plane.k == 6 + 6 and every.k > out_of_plane.k
    np.testing.assert_allclose(np.asarray(named.basis), np.asarray(every.basis), atol=1e-12)

    def off_span(u, Psi):
        Psi = np.asarray(Psi)
        return np.linalg.norm(u - Psi @ np.linalg.lstsq(Psi, u, rcond=None)[0]) / np.linalg.norm(u)

    assert max(off_span(c, every.basis) for c in np.asarray(out_of_plane.basis).T) < 1e-10
    # the far section's own deformation: its loads are orthogonal to every rotation of the section
    sections = reduce(beam, ends, **kw, interface_sections=True)
    assert sections.k == 6 + 3
    local = sections.body
    geometry = BodyGeometry(np.asarray(local.q_hat), np.asarray(local.is_position), local.vectors_per_node,
                            local.section_slots)
    section = geometry.section(0, geometry.node(Marker(0, ends[1])))  # the far end's r_y, r_z
    F = section_loads(local, section)
    np.testing.assert_allclose(F.T @ moment_loads(local, section), 0.0, atol=1e-15)
    q = np.asarray(local.q_hat)
    turned = np.zeros((local.n_dof, 3))
    for k, e in enumerate(np.eye(3)):
        for v in section:
            turned[3 * v:3 * v + 3, k] = np.cross(e, q[v])
    np.testing.assert_allclose(F.T @ turned, 0.0, atol=1e-15)
    free = np.asarray(sections.free)
    K = np.asarray(local.stiffness_matrix(local.q_hat))[np.ix_(free, free)]
    u = np.zeros((local.n_dof, 3))
    u[free] = np.linalg.solve(K, F[free])
    assert max(off_span(c, sections.basis) for c in u.T) < 1e-10
    assert min(off_span(c, linear.basis) for c in u.T) > 1e-3
    # "all": every free section's own modes, the mid node's three beside the far end's
    everywhere = reduce(beam, ends, **kw, interface_sections="all")
    assert everywhere.k == 6 + 3 + 3
    assert max(off_span(c, everywhere.basis) for c in np.asarray(sections.basis).T) < 1e-10
    for kwargs, match in [({"interface_sections": "some"}, "interface_sections must be"),
                          ({"interface_mds": ("fq",)}, "interface_mds must be"),
                          ({"interface_mds": "fz"}, "interface_mds must be"),
                          ({"interface_mds": ()}, "interface_mds must be"),
                          ({"interface_mds": ("my",), "interface_rotations": False}, "no interface mode here"),
                          ({"interface_sections": True, "interface_modes": False}, "needs interface_modes"),
                          ({"vms": 0, "interface_modes": False}, "vms=0"),
                          ({"vms": -1}, "non-negative")]:
        with pytest.raises(ValueError, match=match):
            reduce(beam, ends, **(kw | kwargs))


def test_a_planar_basis_keeps_the_in_plane_moments_attachment_modes():
    """``plane_normal`` with ``interface_rotations``: of the far end's three moments only the one
    about the normal has an in-plane part (the others act on the coordinates the plane holds),
    so the basis gains one moment mode, whose static deflection it spans to round-off, under
    every reference condition that loads the far end; a named derivative of an out-of-plane
    moment is refused, naming the loads there are."""
    from nrrncf_jax.multibody.markers import BodyGeometry
    from nrrncf_jax.multibody.reduce import moment_loads, reduce

    beam = beam_body(Material(1e9, 2700.0, 0.3), TubeSection(0.01), straight_reference(1.0, 2))
    ends = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)]
    kw = {"vms": 1, "mds": [], "interface_modes": True, "plane_normal": (0.0, 0.0, 1.0)}
    for conditions in ("clamped", "pinned", "mean-axis"):
        forces = reduce(beam, ends, **kw, conditions=conditions)
        moments = reduce(beam, ends, **kw, conditions=conditions, interface_rotations=True)
        assert moments.k == forces.k + (2 if conditions == "mean-axis" else 1), conditions  # mz at each loaded end
    clamped = reduce(beam, ends, **kw, interface_rotations=True)
    local, free = clamped.body, np.asarray(clamped.free)
    geometry = BodyGeometry(np.asarray(local.q_hat), np.asarray(local.is_position), local.vectors_per_node,
                            local.section_slots)
    F = moment_loads(local, geometry.section(0, geometry.node(Marker(0, ends[1]))))[:, 2]  # about z
    assert not F[~free].any()
    K = np.asarray(local.stiffness_matrix(local.q_hat))[np.ix_(free, free)]
    u = np.zeros(local.n_dof)
    u[free] = np.linalg.solve(K, F[free])
    Psi = np.asarray(clamped.basis)
    assert np.linalg.norm(u - Psi @ np.linalg.lstsq(Psi, u, rcond=None)[0]) < 1e-10 * np.linalg.norm(u)
    with pytest.raises(ValueError, match="no interface mode here"):
        reduce(beam, ends, **kw, interface_rotations=True, interface_mds=("mx",))


@pytest.mark.slow
def test_modal_derivatives_chosen_by_the_mechanisms_own_motion():
    """``reduce(..., mds="mmi")`` then ``select_modal_derivatives``: two soft beams hinged end to
    end, 3 VMs each, their motion over 0-0.3 s. Each beam's W is symmetric and non-negative, its
    two pairs are its largest W_ij (i ≤ j), the two beams' W differ (they move differently), and
    each rebuilt basis spans its vibration modes and the modal derivatives of its pairs (the
    projection leaves round-off of the SVD-deflated columns)."""
    from nrrncf_jax.multibody.modal_interaction import select_modal_derivatives
    from nrrncf_jax.multibody.reduce import reduce
    from nrrncf_jax.multibody.system import placed
    from nrrncf_jax.reduction import modal_derivatives

    material, section = Material(2e6, 1100.0, 0.3), TubeSection(0.01)
    beams = [placed(beam_body(material, section, straight_reference(1.0, 2)), None, (x, 0.0, 0.0)) for x in (0.0, 1.0)]
    bodies = [reduce(b, [(x, 0.0, 0.0)], vms=3, mds="mmi", plane_normal=Z) for b, x in zip(beams, (0.0, 1.0))]
    assert [b.k for b in bodies] == [3, 3] and all(b.awaiting_mds for b in bodies)
    joints = [hinge(None, Marker(0, (0.0, 0.0, 0.0)), Z),
              hinge(Marker(0, (1.0, 0.0, 0.0)), Marker(1, (1.0, 0.0, 0.0)), Z)]
    mech = Mechanism(bodies, joints, gravity=(0.0, -9.81, 0.0))
    enriched, sels = select_modal_derivatives(mech, np.linspace(0.0, 0.3, 31), n_mds=2)
    cand = [(i, j) for i in range(3) for j in range(i, 3)]
    for body, sel in zip(enriched.bodies, sels):
        W = np.asarray(sel.W)
        assert W.shape == (3, 3) and np.allclose(W, W.T) and W.min() >= 0.0
        assert list(sel.pairs) == sorted(cand, key=lambda p: -W[p])[:2]
        Psi, phi = np.asarray(body.basis), np.asarray(body.modes)
        theta = np.asarray(modal_derivatives(body.body, np.asarray(body.free), phi, sel.pairs).theta)
        X = np.concatenate([phi, theta], axis=1)
        X = X / np.linalg.norm(X, axis=0)
        assert np.abs(X - Psi @ np.linalg.lstsq(Psi, X, rcond=None)[0]).max() < 1e-6
    assert not np.allclose(sels[0].W, sels[1].W, rtol=1e-2)
    # a model file's reduced body: the slider-crank's rod, its pairs chosen by a first run
    setup = load_setup("slider_crank", {"formulation": "nr-rncf", "elements": 2, "vms": 2, "mds": "mmi", "n_mds": 1,
                                        "t_end": 0.005})
    rod = setup.system.bodies[1]
    assert rod.kind == "nr-rncf" and rod.k == 3 and np.asarray(rod.modes).shape[1] == 2 and not rod.awaiting_mds
    with pytest.raises(ValueError, match="records its vibration modes"):
        select_modal_derivatives(Mechanism([RigidBody(1.0, [0.1, 0.1, 0.1])]), [0.0, 0.1])
    with pytest.raises(ValueError, match="basis='free'"):
        reduce(beams[0], [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)], mds="mmi", basis="craig-bampton")


@pytest.mark.parametrize("example", ["slider_crank", "rotor"])
def test_the_fused_dae_residual_is_the_residual_with_the_joints_forces(example):
    """``Mechanism.dae_residual`` (the index-3 step's Newton evaluation: the joints' forces added to
    each body's nodal forces before its J ᵀ) equals ``residual + constraint_force`` (C_zᵀλ by
    reverse mode through every body's map) and ``constraints``, at a state off the motion: rigid and
    reduced bodies, a driver (the slider-crank), a motor and welds (the rotor)."""
    from nrrncf_jax.examples import rotor, slider_crank

    module = {"slider_crank": slider_crank, "rotor": rotor}[example]
    system = module.mechanism(formulation="nr-rncf", elements=4, vms=2).system
    rng = np.random.default_rng(7)
    # turned out of its reference (a strain-free state: the elastic forces, large for these stiff
    # bodies, would hide the joints' share of r)
    z = system.turned((0.3, -0.2, 1.0), 0.4).reference()
    v, a = (jnp.asarray(rng.standard_normal(system.n_dof)) for _ in range(2))
    lam = jnp.asarray(rng.standard_normal(system.n_constraints))
    t = 0.3
    r, C = jax.jit(lambda *s: system.dae_residual(t, *s))(z, v, a, lam)
    r_ref = system.residual(t, z, v, a) + system.constraint_force(z, lam, t)
    np.testing.assert_allclose(r, r_ref, rtol=0, atol=RTOL_RESIDUAL * np.abs(r_ref).max())
    C_ref = system.constraints(z, t)
    np.testing.assert_allclose(C, C_ref, rtol=0, atol=RTOL_RESIDUAL * max(np.abs(C_ref).max(), 1.0))


@pytest.fixture(scope="module")
def reduced_crank():
    """The reduced slider-crank on 2 elements and its first 2 ms: a setup and run two tests share
    (building and compiling it is most of their time)."""
    from nrrncf_jax.examples.slider_crank import mechanism

    setup = mechanism("nr-rncf", elements=2, E=1.0e10)
    return setup, run_setup(setup, t_end=2e-3, n_out=5)


@pytest.mark.xdist_group("reduced_crank")
def test_a_rerun_with_new_parameter_values_does_not_compile(reduced_crank):
    """``run_setup`` compiles the system as an argument of its program, not as constants in it:
    a second run with another Young's modulus (the same shapes) compiles nothing, and its answer
    moves (the rod's stiffness reaches the run)."""
    import jax

    from nrrncf_jax.examples.slider_crank import mechanism

    _, first = reduced_crank
    stiffer = mechanism("nr-rncf", elements=2, E=1.3e10)
    compiles = []
    listener = lambda event, *args, **kwargs: compiles.append(event) if "backend_compile" in event else None  # noqa: E731
    jax.monitoring.register_event_duration_secs_listener(listener)
    try:
        second = run_setup(stiffer, t_end=2e-3, n_out=5)
    finally:
        jax.monitoring.unregister_event_duration_listener(listener)
    assert compiles == []
    assert not np.allclose(first.series["w_mid"], second.series["w_mid"], rtol=1e-6, atol=0)


@pytest.mark.xdist_group("reduced_crank")
def test_a_setup_runs_with_the_users_solver_controller_and_newton(reduced_crank):
    """``run_setup(solver=, controller=, newton=)``, the integrator's objects as ``simulate`` takes
    them: the model's own objects (``MechanismSetup.solver()``, ``.controller()``), built by hand,
    give the default run exactly (the same program, not compiled again) and the same settings,
    which say what ran; a tighter Newton iterates more; an object
    of the wrong kind, a fixed step longer than the run, a non-physical rtol, ρ∞ or step, and a
    step control for fixed steps are refused before anything runs."""
    from nrrncf_jax.examples.slider_crank import mechanism
    from nrrncf_jax.integrate import ConstantStepSize, Newton, adaptive_step_size

    setup = mechanism("nr-rncf", elements=2)
    base = run_setup(setup, t_end=2e-3, n_out=5)
    same = run_setup(setup, t_end=2e-3, n_out=5, solver=GeneralizedAlphaIndex3(setup.rho_inf),
                     controller=adaptive_step_size(setup.rtol, setup.rtol / 10, setup.step_control))
    for k in base.series:
        np.testing.assert_array_equal(same.series[k], base.series[k])
    assert (same.steps, same.rejected) == (base.steps, base.rejected)
    assert same.settings == base.settings
    assert base.settings["solver"] == "GeneralizedAlphaIndex3" and base.settings["step_control"] == setup.step_control
    assert base.settings["rtol"] == setup.rtol and base.settings["rho_inf"] == setup.rho_inf
    assert setup.controller(dt=5e-4) == ConstantStepSize(5e-4, rtol=setup.rtol, atol=setup.rtol / 10)
    with pytest.raises(ValueError, match="fixed step must lie in"):
        run_setup(setup, t_end=2e-3, controller=ConstantStepSize(1e-2))
    with pytest.raises(ValueError, match="rtol must lie in"):
        setup.controller(rtol=2.0)
    with pytest.raises(ValueError, match="dt must be > 0"):
        setup.controller(dt=0.0)
    with pytest.raises(ValueError, match="not both"):
        setup.controller(dt=1e-4, step_control="pi")
    with pytest.raises(ValueError, match="rho_inf must lie in"):
        setup.solver(1.5)
    with pytest.raises(ValueError, match="newton must be a Newton, got float"):
        run_setup(setup, newton=1e-3)
    assert run_setup(setup, t_end=2e-3, n_out=5, newton=Newton(1e-6)).newton_iters >= base.newton_iters


def test_an_observation_evaluates_what_its_sensors_share_once(monkeypatch):
    """``observe`` hands its sensors one evaluation of the nodal vectors per state (however many
    sensors read them), and each sensor's value is the one it gives on the system itself."""
    from nrrncf_jax.multibody.sensors import ChordDeflection, observe

    beam = beam_body(Material(1e9, 2700.0, 0.3), TubeSection(0.01), straight_reference(1.0, 2))
    mech = Mechanism([beam])
    a, b, m = (Marker(0, (s, 0.0, 0.0)) for s in (0.0, 1.0, 0.5))
    sensors = {"a": Position(a), "b_y": Position(b, 1), "m": ChordDeflection(a, b, m)}
    z = jnp.asarray(np.asarray(beam.q_hat).reshape(-1) + 1e-3 * np.sin(np.arange(beam.n_dof)))
    expected = {name: s.resolve(mech)(mech, 0.0, z, 0.0 * z) for name, s in sensors.items()}
    calls = []
    original = Mechanism.nodal_vectors
    monkeypatch.setattr(Mechanism, "nodal_vectors", lambda self, z: calls.append(1) or original(self, z))
    out = observe(mech, sensors)(0.0, z, 0.0 * z)
    assert len(calls) == 1
    for name in sensors:
        np.testing.assert_array_equal(out[name], expected[name])
