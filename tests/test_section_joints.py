"""Joints on section frames converge: a moment through a driver or a hinge is exact at every mesh.

Closed forms: a cantilever under a tip moment M rotates its tip by θ = M L/EI (constant curvature,
exact for any mesh of the C1 beam, whose Hermite field holds a constant-curvature state to the
order of θ²); a rigid body driven about a fixed hinge axis e through its centre of mass needs the
torque eᵀJe θ̈ (the gyroscopic torque ω × Jω has no component along e when ω ∥ e). A universal joint
blocks exactly the rotation about the normal of its two pins.

A joint that writes its moment on the beam's slope r_x instead (the formulation these replace)
loads one element's shear: its compliance grows like one over the element's length, and the
tip rotation under the same moment is 1.08, 1.14, 1.27, 1.53, 2.05 × L/EI on 2 … 32 elements, far
outside these tolerances.
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

from nrrncf_jax.bodies import Material, TubeSection, beam_body, straight_reference
from nrrncf_jax.bodies.rigid import RigidBody
from nrrncf_jax.integrate import constrained_equilibrium
from nrrncf_jax.motion import Stationary, SteadySpin
from nrrncf_jax.multibody import Marker, Mechanism, angle_driver, clamp, hinge, placed, universal
from nrrncf_jax.multibody.drivers import AngleDriver

E, RHO, RADIUS = 2.1e11, 7800.0, 0.02
EI = E * np.pi * RADIUS**4 / 4
THETA = 1e-3
"""A small rotation: the closed form θ = ML/EI is then exact to the geometric nonlinearity's
relative O(θ²) = 1e-6, which bounds the tolerance below; round-off is ~1e-12."""

RTOL_MOMENT = 1e-6


def _beam(length, n, start=0.0):
    body = beam_body(Material(E, RHO, 0.3), TubeSection(RADIUS), straight_reference(length, n))
    return placed(body, translation=(start, 0.0, 0.0))


def _effort(mech, eq, k):
    """The driver ``k`` (joint index)'s torque on its body: −λ."""
    j = mech.joints[k]
    assert isinstance(j, AngleDriver)
    return float(j.effort(eq.lam[mech.joint_slices()[k]]))


@pytest.mark.parametrize("n", [2, 8, 32])
def test_a_tip_moment_through_a_driver_is_exact_at_every_mesh(n):
    """A cantilever (clamped on its section frame) whose tip section is turned by θ about Z and
    about Y by a driver: the driver's torque is EIθ/L at every mesh, in and out of plane."""
    L = 1.0
    for axis in ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)):
        mech = Mechanism([_beam(L, n)], [clamp(None, Marker(0, (0.0, 0.0, 0.0))),
                                         angle_driver(None, Marker(0, (L, 0.0, 0.0)), axis, SteadySpin(THETA))])
        eq = constrained_equilibrium(mech, t=1.0)
        assert abs(_effort(mech, eq, 1) / (EI * THETA / L) - 1.0) < RTOL_MOMENT, (n, axis)


@pytest.mark.parametrize("tilt", [0.0, np.radians(5.0)])
@pytest.mark.parametrize("n", [2, 16])
def test_a_moment_through_a_hinge_is_exact_at_every_mesh(n, tilt):
    """Two beams in line, the first clamped at its root, joined by a hinge about an axis in the
    x-z plane (Z, or tilted 5° toward x as the four-bar benchmark's hinge at C); the far end of
    the second turned by θ about Y (and held about Z). The moment about Y is normal to the hinge's
    axis, so the hinge carries it whole: both beams bend at M = EIθ/(L₁ + L₂), and nothing turns
    about the axis (the torque about Z stays zero)."""
    L1, L2 = 0.6, 0.4
    axis = (np.sin(tilt), 0.0, np.cos(tilt))
    joint, tip = Marker(0, (L1, 0.0, 0.0)), Marker(1, (L1 + L2, 0.0, 0.0))
    mech = Mechanism([_beam(L1, n), _beam(L2, n, start=L1)],
                     [clamp(None, Marker(0, (0.0, 0.0, 0.0))), hinge(joint, Marker(1, joint.point), axis),
                      angle_driver(None, tip, (0.0, 1.0, 0.0), SteadySpin(THETA)),
                      angle_driver(None, tip, (0.0, 0.0, 1.0), Stationary())])
    eq = constrained_equilibrium(mech, t=1.0)
    M = EI * THETA / (L1 + L2)
    assert abs(_effort(mech, eq, 2) / M - 1.0) < RTOL_MOMENT
    assert abs(_effort(mech, eq, 3)) < RTOL_MOMENT * M


class _Quadratic(eqx.Module):
    """θ(t) = β t + ½ α t²: a drive with a rate and an acceleration at t = 0."""

    alpha: float
    beta: float

    def __call__(self, t):
        return self.beta * t + 0.5 * self.alpha * t**2, self.beta + self.alpha * t, self.alpha + 0.0 * t


def test_a_tilted_hinge_drives_a_rigid_body_with_the_rigid_body_torque():
    """A rigid body with a full inertia tensor, hinged to the ground at its centre of mass about
    the tilted axis e = (sin 5°, 0, cos 5°) (along none of its axes), turning at β and driven at
    θ̈ = α: the driver's torque is eᵀJe α to round-off, whatever the spin."""
    rng = np.random.default_rng(3)
    Q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    J = Q @ np.diag([2.0, 3.0, 4.0]) @ Q.T
    e = np.array([np.sin(np.radians(5.0)), 0.0, np.cos(np.radians(5.0))])
    alpha, beta = 0.7, 1.3
    mech = Mechanism([RigidBody(2.0, J)], [hinge(None, Marker(0, (0.0, 0.0, 0.0)), e, drive=_Quadratic(alpha, beta))])
    z = mech.reference()
    v = mech.rigid_velocity(omega=beta * e)
    mech.check_velocity(z, v, 0.0)
    lam = mech.reactions(0.0, z, v)
    tau = float(mech.joints[1].effort(lam[mech.joint_slices()[1]]))
    assert abs(tau - e @ J @ e * alpha) < 1e-10 * (e @ J @ e * alpha)


def test_a_universal_joint_blocks_the_rotation_about_its_pins_normal():
    """A rigid body on a universal joint to the ground (pins X on the ground, Y on the body): a
    spin about X, about Y or both satisfies the joint's velocity equations; a spin about Z = the
    pins' normal does not (``Mechanism.check_velocity`` refuses it)."""
    mech = Mechanism([RigidBody(1.0, [1.0, 1.0, 1.0])],
                     [universal(None, Marker(0, (0.0, 0.0, 0.0)), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0))])
    z = mech.reference()
    for omega in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.6, -0.8, 0.0)):
        mech.check_velocity(z, mech.rigid_velocity(omega=omega), 0.0)
    with pytest.raises(ValueError):
        mech.check_velocity(z, mech.rigid_velocity(omega=(0.0, 0.0, 1.0)), 0.0)
    with pytest.raises(ValueError, match="universal between body 0 .* must be normal to each other"):
        Mechanism([RigidBody(1.0, [1.0, 1.0, 1.0])],
                  [universal(None, Marker(0, (0.0, 0.0, 0.0)), (1.0, 0.0, 0.0), (1.0, 1.0, 0.0))])


def test_the_static_solver_refuses_bad_input():
    mech = Mechanism([_beam(1.0, 2)], [clamp(None, Marker(0, (0.0, 0.0, 0.0)))])
    with pytest.raises(ValueError, match="z0 must have shape"):
        constrained_equilibrium(mech, z0=jnp.zeros(3))
    with pytest.raises(ValueError, match="takes a constrained model"):
        constrained_equilibrium(object())


def test_a_reduced_body_carries_a_joint_moment_with_its_rotation_attachment_modes():
    """A cantilever reduced to 3 vibration modes (``multibody.reduce``), its tip turned by a driver
    about each axis: with the attachment modes of the tip's force and moment
    (``interface_rotations``) the torque is the closed form to round-off (θ = 1e-6: the geometric
    nonlinearity, which modal derivatives would carry, is 1e-8 of it); with the force's alone the
    tip's twist is not in the basis (the driver is refused as redundant) and its bending is 5-9 %
    too stiff. Craig-Bampton with the tip's section vectors as boundary coordinates is as exact."""
    from nrrncf_jax.multibody.reduce import reduce

    L, theta = 1.0, 1e-6
    beam = _beam(L, 8)
    G = E / (2 * 1.3)
    closed = {0: G * np.pi * RADIUS**4 / 2, 1: EI, 2: EI}
    ends = [(0.0, 0.0, 0.0), (L, 0.0, 0.0)]
    for rotations in (True, False):
        body = reduce(beam, ends, vms=3, mds=[], interface_modes=True, interface_rotations=rotations)
        for k, axis in enumerate(np.eye(3)):
            joints = [clamp(None, Marker(0, ends[0])), angle_driver(None, Marker(0, ends[1]), axis, SteadySpin(theta))]
            if not rotations and k == 0:
                with pytest.raises(ValueError, match="redundant"):
                    Mechanism([body], joints)
                continue
            mech = Mechanism([body], joints)
            ratio = _effort(mech, constrained_equilibrium(mech, t=1.0), 1) / (closed[k] * theta / L)
            if rotations:
                assert abs(ratio - 1.0) < RTOL_MOMENT, (k, ratio)
            else:
                assert ratio > 1.03, (k, ratio)
    with pytest.raises(ValueError, match="interface_mds needs interface_modes"):
        reduce(beam, ends, vms=3, interface_mds=True)
    # Craig-Bampton with the tip's section vectors among its boundary coordinates: the same
    cb = reduce(beam, ends, vms=3, mds=[], basis="craig-bampton", interface_rotations=True)
    for k, axis in enumerate(np.eye(3)):
        mech = Mechanism([cb], [clamp(None, Marker(0, ends[0])),
                                angle_driver(None, Marker(0, ends[1]), axis, SteadySpin(theta))])
        ratio = _effort(mech, constrained_equilibrium(mech, t=1.0), 1) / (closed[k] * theta / L)
        assert abs(ratio - 1.0) < RTOL_MOMENT, (k, ratio)


def test_a_bent_beam_carries_no_axial_force():
    """A cantilever bent by a pure tip moment (its tip section turned by θ = 0.3 rad about Z by a
    driver, nothing else): a cut anywhere carries the moment and no force. The section force
    (``SectionResultant``, first Piola-Kirchhoff traction in the deformed frame) reads N ≈ 0 to
    the mesh's error (decaying like h⁴: 18.7, 1.4, 0.11 N on 4, 8, 16 elements, against κM =
    2375 N) and M the driver's torque; the work-conjugate ∫ S11 (``kind="conjugate"``) reads
    −κM instead, the Green-Lagrange strain's ½(yκ)² term, which is why it is not the force a peer
    code reports."""
    from nrrncf_jax.multibody.sensors import observe
    from nrrncf_jax.post.stress import SectionResultant

    theta, L = 0.3, 1.0
    mech = Mechanism([_beam(L, 8)], [clamp(None, Marker(0, (0.0, 0.0, 0.0))),
                                     angle_driver(None, Marker(0, (L, 0.0, 0.0)), (0.0, 0.0, 1.0), SteadySpin(theta))])
    eq = constrained_equilibrium(mech, t=1.0)
    M = _effort(mech, eq, 1)
    mid = Marker(0, (L / 2, 0.0, 0.0))
    out = observe(mech, {"force": SectionResultant(mid), "conjugate": SectionResultant(mid, kind="conjugate")})(
        1.0, eq.z, jnp.zeros(mech.n_dof))
    kM = theta / L * M
    N, V2, V3, T, M2, M3 = (float(x) for x in out["force"])
    assert abs(N) < 1e-3 * kM and max(abs(V2), abs(V3), abs(T), abs(M2)) < 1e-9 * M
    assert M3 == pytest.approx(M, rel=1e-4)
    assert float(out["conjugate"][0]) == pytest.approx(-kM, rel=1e-3)
