"""Joints on markers (a body and a point of its reference configuration) resolve to joints on the
nodes' section frames: the section vectors r_y, r_z of a C1 node, never its slope r_x
(``multibody.section_frame``), with every equation zero in the reference."""

import numpy as np
import pytest

from nrrncf_jax.multibody import (
    GROUND,
    EccentricBall,
    Marker,
    Mechanism,
    MultibodySystem,
    PointMass,
    Revolute,
    Spherical,
    Weld,
    ball,
    clamp,
    hinge,
    placed,
)
from nrrncf_jax.scenarios.pendulum import (
    PendulumBasis,
    PendulumSpec,
    _beam,
    build_pendulum,
    build_reduced_pendulum,
    build_rncf_pendulum,
)

R, RX, RY, RZ = 0, 1, 2, 4  # a C1 node's r, r_x, r_y, r_z


def _reference_equations(system):
    return np.asarray(system.joint_equations(tuple(np.asarray(x) for x in system.nodal_vectors(system.reference()))))


def test_pendulum_hinges_on_markers_read_the_section_vectors():
    """The three-beam pendulum's hinges about Z, written on markers (``scenarios.pendulum``), read
    the end nodes' positions and section vectors r_y, r_z only, in all three formulations
    (inertial-frame bodies, full-order and reduced floating frames, whose reference nodal vectors
    come from their frames), and hold in the reference to round-off."""
    spec = PendulumSpec(elements=2)
    end = 6 * spec.elements
    expected = [{(0, R), (0, RY), (0, RZ)}] + [{(k, end + R), (k, end + RY), (k, end + RZ), (k + 1, R), (k + 1, RY),
                                               (k + 1, RZ)} for k in range(2)]
    reduced = build_reduced_pendulum(spec, PendulumBasis(2, pairs=()))[0]
    for system in (build_pendulum(spec), build_rncf_pendulum(spec), reduced):
        assert all(isinstance(j, Revolute) for j in system.joints), type(system).__name__
        assert [set(j.references()) for j in system.joints] == expected, type(system).__name__
        assert np.abs(_reference_equations(system)).max() < 1e-14


def test_ball_and_clamp_on_markers():
    beam = _beam(PendulumSpec(elements=2))
    clamped = MultibodySystem([beam], [clamp(GROUND, Marker(0, (0.0, 0.0, 0.0)))])
    (weld,) = clamped.joints
    assert isinstance(weld, Weld) and set(weld.references()) == {(0, R), (0, RY), (0, RZ)}
    assert np.abs(_reference_equations(clamped)).max() < 1e-14
    # Two beams end to end, a ball joint at x = 1 and the first one hinged to the ground.
    bodies = [beam, placed(beam, translation=(1.0, 0.0, 0.0))]
    joints = [hinge(GROUND, Marker(0, (0.0, 0.0, 0.0)), axis=(0.0, 0.0, 1.0)),
              ball(Marker(0, (1.0, 0.0, 0.0)), Marker(1, (1.0, 0.0, 0.0)))]
    system = MultibodySystem(bodies, joints)
    assert system.joints[1] == Spherical(0, 12, 1, 0)
    # A hinge about any axis (here tilted out of every node vector) reads the same section vectors,
    # and its axis is fixed in b's section frame: the direction it had in the reference.
    axis = np.array([np.sin(0.3), 0.0, np.cos(0.3)])
    tilted = MultibodySystem(bodies, [joints[0], hinge(Marker(0, (1.0, 0.0, 0.0)), Marker(1, (1.0, 0.0, 0.0)), axis)])
    j = tilted.joints[1]
    assert set(j.references()) == {(0, 12 + R), (0, 12 + RY), (0, 12 + RZ), (1, R), (1, RY), (1, RZ)}
    xs = tuple(np.asarray(x) for x in tilted.nodal_vectors(tilted.reference()))
    np.testing.assert_allclose(j.axis(xs)[0], axis, atol=1e-15)
    np.testing.assert_allclose(j.normals(xs) @ axis, 0.0, atol=1e-15)


def test_an_eccentric_ball_keeps_a_point_fixed_in_a_section_frame():
    """``ball(a, b, eccentric=True)``: b's node at a point off a's node, fixed in a's section frame:
    its equations vanish in the reference and after any rigid motion of the pair (the point turns
    with a's node), and not after a's node alone turns; without ``eccentric`` the differing points
    are refused, and on the ground it is refused."""
    beam = _beam(PendulumSpec(elements=2))
    offset = np.array([0.0, 0.02, -0.01])
    bodies = [beam, placed(beam, translation=(1.0, 0.0, 0.0) + offset)]
    a, b = Marker(0, (1.0, 0.0, 0.0)), Marker(1, tuple((1.0, 0.0, 0.0) + offset))
    system = MultibodySystem(bodies, [clamp(GROUND, Marker(0, (0.0, 0.0, 0.0))), ball(a, b, eccentric=True)])
    joint = system.joints[1]
    assert isinstance(joint, EccentricBall) and joint.n_equations == 3
    xs = [np.asarray(x) for x in system.nodal_vectors(system.reference())]
    np.testing.assert_allclose(joint(xs), 0.0, atol=1e-15)
    c, s_ = np.cos(0.7), np.sin(0.7)
    Q = np.array([[c, -s_, 0.0], [s_, c, 0.0], [0.0, 0.0, 1.0]]) @ np.array([[1.0, 0.0, 0.0], [0.0, c, -s_],
                                                                           [0.0, s_, c]])
    shift = np.array([0.3, -0.1, 0.2])
    moved = []
    for body, x in zip(system.bodies, xs):
        pos = np.asarray(body.geometry().is_position)[:, None]
        moved.append(np.where(pos, x @ Q.T + shift, x @ Q.T))
    np.testing.assert_allclose(joint(moved), 0.0, atol=1e-14)
    # a's directions turned, every position only shifted: b's node is not at a's turned point
    turned_a = [np.where(np.asarray(body.geometry().is_position)[:, None], x + shift, y)
                for body, x, y in zip(system.bodies, xs, (moved[0], xs[1]))]
    assert np.abs(np.asarray(joint(turned_a))).max() > 1e-3
    with pytest.raises(ValueError, match="the markers' points differ"):
        MultibodySystem(bodies, [ball(a, b)])
    with pytest.raises(ValueError, match="eccentric ball's point is fixed in a's node"):
        ball(None, b, eccentric=True)


def test_bad_markers_are_refused_naming_the_problem():
    beam = _beam(PendulumSpec(elements=2))
    bodies = [beam, placed(beam, translation=(1.0, 0.0, 0.0))]
    z = (0.0, 0.0, 1.0)
    with pytest.raises(ValueError, match=r"hinge between body 0 at \(0.4, 0, 0\) to the ground about \(0, 0, 1\): "
                                         r"marker point \(0.4, 0, 0\) is not a node of body 0 \(a joint sits on a "
                                         r"node\): the nearest node is \(0.5, 0, 0\)"):
        MultibodySystem([beam], [hinge(GROUND, Marker(0, (0.4, 0.0, 0.0)), axis=z)])
    with pytest.raises(ValueError, match=r"hinge between body 0 at \(1, 0, 0\) and body 1 at \(2, 0, 0\) about "
                                         r"\(0, 0, 1\): the markers' points differ"):
        MultibodySystem(bodies, [hinge(GROUND, Marker(0, (0.0, 0.0, 0.0)), axis=z),
                                 hinge(Marker(0, (1.0, 0.0, 0.0)), Marker(1, (2.0, 0.0, 0.0)), axis=z)])
    with pytest.raises(ValueError, match="the system has bodies 0..1"):
        MultibodySystem(bodies, [hinge(GROUND, Marker(2, (0.0, 0.0, 0.0)), axis=z)])
    with pytest.raises(ValueError, match=r"hinge between body 0 at \(1, 0, 0\) to the ground about \(0, 0, 1\): the "
                                         r"node of body 0 at \(1, 0, 0\) carries no section frame"):
        Mechanism([PointMass(1.0, (1.0, 0.0, 0.0))], [hinge(GROUND, Marker(0, (1.0, 0.0, 0.0)), axis=z)])
    with pytest.raises(ValueError, match="finite 3-vector"):
        Marker(0, (0.0, 1.0))
    with pytest.raises(ValueError, match="nonzero 3-vector"):
        hinge(GROUND, Marker(0, (0.0, 0.0, 0.0)), axis=(0.0, 0.0, 0.0))
