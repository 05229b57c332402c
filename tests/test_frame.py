"""Frames: beams rigidly joined at an angle (joint links + joint cell), pinned bars.

Closed forms: the linear (Timoshenko, no shear correction factor: the C1 beam's transverse shear
carries G) solution of a right-angle frame clamped at one end and loaded at the other. Its
neglected effects are the section's own deformation (Poisson) and the joint's compliance:
O((r/L)²) = 1e-4 and, for the stiff cell used, (P L)/(G V) · L / δ ≈ 1e-5 relative; the links'
default stiffness 10 G A L adds O(0.1 · L/(G A)) / δ ≈ 1e-5.
"""

import functools

import jax.numpy as jnp
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from nrrncf_jax.bodies.frame import frame_body
from nrrncf_jax.elements import Bar, C1Beam, JointLink
from nrrncf_jax.elements.material import Material
from nrrncf_jax.elements.section import TubeSection

MAT = Material(70e9, 2700.0, 0.33)
SEC = TubeSection(0.01, 0.008)
E, G = 70e9, 70e9 / (2 * 1.33)
I, A = float(SEC.second_moment), float(SEC.area)
L = 1.0
SECTION_EFFECTS = 1e-4  # O((r/L)^2), the frame theory's neglected section deformation
L_FRAME = ([[0, 0, 0], [L, 0, 0], [L, L, 0]], [[0, 1], [1, 2]])


@functools.cache
def l_frame(n: int, joint_volume: float | None = None):
    """The right-angle frame with n elements a member, and its stiffness at the reference."""
    frame = frame_body(*L_FRAME, C1Beam(MAT, SEC), n, joint_volume=joint_volume)
    return frame, np.asarray(frame.body.stiffness_matrix(frame.body.q_hat))


def tip_deflection(frame_and_K, comp, P=1.0):
    """Linear static tip deflection (K u = f at the reference) of joint 2, joint 0 clamped."""
    frame, K = frame_and_K
    body = frame.body
    fixed = np.zeros((body.n_vectors, 3), bool)
    fixed[frame.clamp([0])] = True
    free = ~fixed.reshape(-1)
    f = np.zeros((body.n_vectors, 3))
    f[frame.joint_vectors[2, 0], comp] = P
    u = np.zeros(body.n_dof)
    u[free] = np.linalg.solve(K[np.ix_(free, free)], f.reshape(-1)[free])
    return u.reshape(-1, 3)[frame.joint_vectors[2, 0], comp]


@pytest.mark.xdist_group("l_frame")  # one worker builds the frame once (``l_frame`` is cached)
@pytest.mark.parametrize("comp, closed_form", [
    # in plane, along x: member 2 bends and shears, member 1 takes the moment P L and tension P
    (0, L**3 / (3 * E * I) + L**3 / (E * I) + L / (E * A) + L / (G * A)),
    # in plane, along y: member 2 in tension, member 1 bends and shears
    (1, L**3 / (3 * E * I) + L / (E * A) + L / (G * A)),
    # out of plane: both bend and shear, member 1 twists by P L (G J, J = 2I for a tube)
    (2, 2 * L**3 / (3 * E * I) + L**3 / (G * 2 * I) + 2 * L / (G * A)),
])
def test_right_angle_frame_against_frame_theory(comp, closed_form):
    frame = l_frame(2, 1e-3)  # a stiff joint cell
    assert tip_deflection(frame, comp) / closed_form - 1 == pytest.approx(0.0, abs=SECTION_EFFECTS)


@pytest.mark.slow
def test_joint_converges_under_refinement():
    """With the default joint cell (a cube of the tube's diameter) the tip deflection converges as
    the members are refined (without it the joint would turn into a hinge, see
    ``elements.joint_cell``): successive differences shrink, and the limit lies within the joint's
    own compliance, (P L)/(G D³) · L / δ ≈ 1.2e-3, of the rigid-joint closed form."""
    closed = L**3 / (3 * E * I) + L**3 / (E * I) + L / (E * A) + L / (G * A)
    d = [tip_deflection(l_frame(n), 0) for n in (2, 4, 8)]
    assert abs(d[2] - d[1]) < 0.8 * abs(d[1] - d[0])
    assert 0.0 < d[2] / closed - 1 < 2e-3


def _link_energy(G, F, k=2.0):
    """½ κ Q Q of one ``JointLink`` whose six vectors are the rows of G (member) and F (joint)."""
    link = JointLink(k)
    q_hat = np.concatenate([np.eye(3), np.eye(3)])
    q = np.concatenate([G, F])
    Q = 0.5 * (q @ q.T - q_hat @ q_hat.T)
    kappa = np.asarray(link.integrals(jnp.asarray(q_hat), jnp.ones(())).kappa)
    return 0.5 * np.einsum("abcd,ab,cd->", kappa, Q, Q)


def test_joint_link_ties_direction_not_length():
    """The link (``elements.JointLink``) costs k sin²θ for a relative rotation θ about each of the
    member's axes (a spring of 2k, isotropic), nothing for a stretch or a distortion of the member's
    own section, nothing for a common rotation, and is the same in any section axes (a circular
    tube's truss keeps its three-fold symmetry: the pairs of ``test_truss`` are degenerate). Exact
    identities: to round-off of products of O(1) vectors, 1e-15."""
    k, th = 2.0, 0.3
    for axis in range(3):
        assert _link_energy(np.eye(3), Rotation.from_rotvec(th * np.eye(3)[axis]).as_matrix().T, k) == \
            pytest.approx(k * np.sin(th) ** 2, rel=1e-13)
    stretch = np.diag([1.01, 0.97, 1.05])
    stretch[1, 2] = stretch[2, 1] = 0.02  # the section's own in-plane shear
    assert abs(_link_energy(stretch, np.eye(3))) < 1e-15
    rng = np.random.default_rng(3)
    G, F = np.eye(3) + 0.05 * rng.normal(size=(3, 3)), np.eye(3) + 0.05 * rng.normal(size=(3, 3))
    U = _link_energy(G, F)
    assert U > 1e-4
    R = Rotation.from_rotvec([0.4, -1.0, 0.6]).as_matrix()
    assert _link_energy(G @ R.T, F @ R.T) == pytest.approx(U, rel=1e-13)  # a common rotation
    P = np.eye(3)
    P[1:, 1:] = Rotation.from_rotvec([0.7, 0.0, 0.0]).as_matrix()[1:, 1:]  # other section axes
    assert _link_energy(P @ G, P @ F) == pytest.approx(U, rel=1e-13)


def test_rigid_motion_gives_zero_force():
    """A large rigid rotation and translation of a frame with an oblique member and a bar: zero
    elastic force and energy, to round-off of the force of a unit strain (eps 2.2e-16)."""
    joints = [[0, 0, 0], [1, 0, 0], [1, 0.7, 0.2], [0, 0.5, 0.9]]
    frame = frame_body(joints, [[0, 1], [1, 2], [2, 3]], C1Beam(MAT, SEC), 2, bars=[[0, 2], [1, 3]],
                       bar=Bar(E, 2700.0, 3e-6))
    body = frame.body
    R = Rotation.from_rotvec([0.3, -1.1, 0.7]).as_matrix()
    q = body.q_hat @ R.T + np.where(np.asarray(body.is_position)[:, None], [1.0, 2.0, 3.0], 0.0)
    F = np.asarray(body.elastic_force(jnp.asarray(q)))
    # The elements' own forces (before assembly) under a unit strain, from a uniform 1 % stretch,
    # times |q|²: Q = ½(q·q − q̂·q̂) cancels products of size |q|² (here |q| ≤ 4.6), so its
    # round-off is eps |q|², and the force's that times the unit-strain force.
    unit = max(float(np.abs(np.asarray(g.forces(1.01 * body.q_hat, body.q_hat))).max()) for g in body.groups) / 0.01
    scale = unit * float(np.abs(q).max()) ** 2
    assert np.abs(F).max() < 100 * 2.2e-16 * scale
    assert abs(float(body.strain_energy(jnp.asarray(q)))) < 100 * 2.2e-16 * scale


def test_frame_counts_and_bad_input():
    frame = frame_body(*L_FRAME, C1Beam(MAT, SEC), [3, 2], bars=[[0, 2]], bar=Bar(E, 2700.0, 3e-6))
    assert (frame.n_beams, frame.n_bars) == (5, 1)
    # joints: 4 vectors each; interior nodes: 6; member ends: 5 own vectors each
    assert frame.body.n_vectors == 3 * 4 + (2 + 1) * 6 + 2 * 2 * 5
    assert [len(p) for p in frame.member_positions] == [4, 3]
    with pytest.raises(ValueError, match="refer to joint"):
        frame_body(*L_FRAME[:1], [[0, 3]], C1Beam(MAT, SEC), 2)
    with pytest.raises(ValueError, match="to itself"):
        frame_body(*L_FRAME[:1], [[0, 1], [2, 2]], C1Beam(MAT, SEC), 2)
    with pytest.raises(ValueError, match="belong to no member"):
        frame_body(*L_FRAME[:1], [[0, 1]], C1Beam(MAT, SEC), 2)
    with pytest.raises(ValueError, match="zero length"):
        frame_body([[0, 0, 0], [0, 0, 0]], [[0, 1]], C1Beam(MAT, SEC), 2)
    with pytest.raises(ValueError, match="bar=elements.Bar"):
        frame_body(*L_FRAME, C1Beam(MAT, SEC), 2, bars=[[0, 2]])
    with pytest.raises(ValueError, match="joint_volume must be > 0"):
        frame_body(*L_FRAME, C1Beam(MAT, SEC), 2, joint_volume=0.0)
    with pytest.raises(ValueError, match="link_stiffness must be > 0"):
        frame_body(*L_FRAME, C1Beam(MAT, SEC), 2, link_stiffness=-1.0)
