"""Joints on markers (a body and a point of its reference configuration) resolve to the
nodal-vector joints they name: the same joints as written by index, so the same equations."""

import equinox as eqx
import numpy as np
import pytest

from nrrncf_jax.multibody import GROUND, Fixed, Marker, MultibodySystem, Revolute, Spherical, ball, clamp, hinge, placed
from nrrncf_jax.scenarios.pendulum import (
    PendulumSpec,
    _beam,
    build_pendulum,
    build_reduced_pendulum,
    build_rncf_pendulum,
)

R, RX, RY, RZ = 0, 1, 2, 4  # a C1 node's r, r_x, r_y, r_z


def _equal(js, ks):
    return len(js) == len(ks) and all(bool(eqx.tree_equal(j, k)) for j, k in zip(js, ks))


def test_pendulum_hinges_on_markers_are_the_indexed_ones():
    """The three-beam pendulum's hinges about Z, written on markers (``scenarios.pendulum``), are
    the index-written ``Revolute``s in all three formulations (inertial-frame bodies, full-order
    and reduced floating frames, whose reference nodal vectors come from their frames)."""
    spec = PendulumSpec(elements=2)
    end = 6 * spec.elements
    indexed = [Revolute(None, None, None, 0, R, RZ)]
    indexed += [Revolute(k, end + R, (end + RX, end + RY), k + 1, R, RZ) for k in range(2)]
    for system in (build_pendulum(spec), build_rncf_pendulum(spec), build_reduced_pendulum(spec, 2, pairs=[])[0]):
        assert _equal(system.joints, indexed), type(system).__name__


def test_ball_and_clamp_on_markers():
    beam = _beam(PendulumSpec(elements=2))
    q = np.asarray(beam.q_hat)
    clamped = MultibodySystem([beam], [clamp(GROUND, Marker(0, (0.0, 0.0, 0.0)))])
    assert _equal(clamped.joints, [Fixed(0, [R, RX, RY, RZ], values=q[[R, RX, RY, RZ]])])
    # Two beams end to end, a ball joint at x = 1 and the first one hinged to the ground.
    bodies = [beam, placed(beam, translation=(1.0, 0.0, 0.0))]
    joints = [hinge(GROUND, Marker(0, (0.0, 0.0, 0.0)), axis=(0.0, 0.0, 1.0)),
              ball(Marker(0, (1.0, 0.0, 0.0)), Marker(1, (1.0, 0.0, 0.0)))]
    system = MultibodySystem(bodies, joints)
    assert _equal(system.joints, [Revolute(None, None, None, 0, R, RZ), Spherical(0, 12, 1, 0)])
    # A hinge about Y picks the other section vector, and the slope and r_z as the normals.
    about_y = MultibodySystem(bodies, [joints[0], hinge(Marker(0, (1.0, 0.0, 0.0)), Marker(1, (1.0, 0.0, 0.0)),
                                                        axis=(0.0, -2.0, 0.0))])
    assert _equal(about_y.joints[1:], [Revolute(0, 12, (12 + RX, 12 + RZ), 1, R, RY)])


def test_bad_markers_are_refused_naming_the_problem():
    beam = _beam(PendulumSpec(elements=2))
    bodies = [beam, placed(beam, translation=(1.0, 0.0, 0.0))]
    z = (0.0, 0.0, 1.0)
    with pytest.raises(ValueError, match=r"not a node of body 0: the nearest node is \(0.5, 0.0, 0.0\)"):
        MultibodySystem([beam], [hinge(GROUND, Marker(0, (0.4, 0.0, 0.0)), axis=z)])
    with pytest.raises(ValueError, match="along none of the node's gradient vectors"):
        MultibodySystem([beam], [hinge(GROUND, Marker(0, (0.0, 0.0, 0.0)), axis=(1.0, 1.0, 0.0))])
    with pytest.raises(ValueError, match="the markers' points differ"):
        MultibodySystem(bodies, [hinge(GROUND, Marker(0, (0.0, 0.0, 0.0)), axis=z),
                                 hinge(Marker(0, (1.0, 0.0, 0.0)), Marker(1, (2.0, 0.0, 0.0)), axis=z)])
    with pytest.raises(ValueError, match="the system has bodies 0..1"):
        MultibodySystem(bodies, [hinge(GROUND, Marker(2, (0.0, 0.0, 0.0)), axis=z)])
    with pytest.raises(ValueError, match="finite 3-vector"):
        Marker(0, (0.0, 1.0))
    with pytest.raises(ValueError, match="nonzero 3-vector"):
        hinge(GROUND, Marker(0, (0.0, 0.0, 0.0)), axis=(0.0, 0.0, 0.0))
