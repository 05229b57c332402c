"""The dynamic lateral buckling of the validation set (Bauchau et al. 2016, problem (c);
``examples/lateral_buckling.py``): a crank and a link push a cantilever's tip up past Prandtl's
critical load, and the beam leaves its plane.

The model as the benchmark states it (fast): its joints, an initial state that satisfies them at
rest, the drive's half-cosine, and its direction: a crank turned rigidly by the prescribed angle
about −y satisfies the driven hinge at G, with B risen by 0.05 sin φ, and a crank turned the other
way does not. The buckling (slow, 2 beam elements, 0-0.2 s): while the link's compression stays
below Prandtl's load (4.013 √(EI_z GJ)/L² = 2.93 kN; ``tests/test_lateral_buckling.py`` finds it
statically) the beam stays in its plane to a fraction of the 0.1 mm imperfection; past it the
mid-span moves sideways by more than 100 times the imperfection and twists by more than 0.1 rad.
The perfect beam (no imperfection) takes the same load in its plane to round-off below the
critical load; past it the planar path is unstable and round-off grows (how much depends on the
machine's rounding, so the test asks only that it stays below the imperfect beam's motion).
"""

import numpy as np
import pytest

from nrrncf_jax.examples import lateral_buckling as lb
from nrrncf_jax.multibody import Marker
from nrrncf_jax.scenarios.mechanism_file import load_setup, run_setup


def _crank_turned(system, z, phi):
    """``z`` with the (full-order) crank turned rigidly about G by ``phi`` about −y."""
    c, s = np.cos(phi), np.sin(phi)
    A = np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])  # about −y: x onto (cos φ, 0, sin φ)
    G = np.asarray(lb.points()["G"])
    body = system.bodies[lb.CRANK]
    o, n = system.offsets[lb.CRANK], system.body_sizes()[lb.CRANK]
    x = np.asarray(z[o:o + n]).reshape(-1, 3)
    pos = np.asarray(body.body.is_position)
    x = np.where(pos[:, None], (x - G) @ A.T + G, x @ A.T)
    return np.concatenate([np.asarray(z[:o]), x.reshape(-1), np.asarray(z[o + n:])])


def test_the_model_is_the_benchmarks():
    setup = lb.mechanism(elements=2)
    system = setup.system
    assert [type(j).__name__ for j in system.joints] == ["Weld", "EccentricBall", "Revolute", "Revolute",
                                                        "AngleDriver"]
    z0 = np.asarray(system.reference())
    xs = system.nodal_vectors(z0)
    # the ball sits at C, 0.1 mm off the tip along y, in the tip's section frame
    ball = system.joints[1]
    np.testing.assert_allclose(np.asarray(xs[lb.BEAM][ball.position_a] + ball.offset(xs)[0]), lb.points()["C"],
                               atol=1e-15)
    # at rest in the reference the joints hold, and so do their velocity equations (the drive starts at rest)
    assert np.abs(np.asarray(system.constraints(z0, 0.0))).max() < 1e-14
    assert np.abs(np.asarray(system.constraint_rate(z0, 0.0))).max() < 1e-14
    # the drive: a half cosine from 0 to π over 0.4 s, then held
    drive = system.joints[-1].motion
    th = [float(drive(t)[0]) for t in (0.0, 0.1, 0.2, 0.4, 0.6)]
    np.testing.assert_allclose(th, [0.0, np.pi / 2 * (1 - np.cos(np.pi / 4)), np.pi / 2, np.pi, np.pi], atol=1e-15)
    assert float(drive(0.6)[1]) == 0.0 and float(drive(0.6)[2]) == 0.0
    # its direction: the crank turned by θ(t) about −y satisfies the driven hinge at t, B raised by 0.05 sin θ
    slices = system.joint_slices()
    B = lb.points()["B"]
    for t in (0.1, 0.2, 0.3):
        phi = float(drive(t)[0])
        turned = _crank_turned(system, z0, phi)
        C = np.asarray(system.constraints(turned, t))
        assert np.abs(C[slices[3]]).max() < 1e-14 and np.abs(C[slices[4]]).max() < 1e-14, (t, C[slices[4]])
        if t != 0.2:  # turned the other way (the driver's one equation holds at φ + π as well)
            wrong = np.asarray(system.constraints(_crank_turned(system, z0, -phi), t))
            assert np.abs(wrong[slices[4]]).max() > 0.5, (t, wrong[slices[4]])
        b = system.bodies[lb.CRANK].geometry().node(Marker(lb.CRANK, B))
        crank = np.asarray(system.nodal_vectors(turned)[lb.CRANK])
        np.testing.assert_allclose(crank[b, 2], B[2] + lb.L_CRANK * np.sin(phi), atol=1e-15)
    with pytest.raises(ValueError, match="even integers"):
        lb.mechanism(elements=3)
    with pytest.raises(ValueError, match="formulation"):
        lb.mechanism(formulation="rigid")
    with pytest.raises(ValueError, match="imperfection"):
        lb.mechanism(imperfection=0.1)


def test_the_reduced_model_starts_on_its_joints():
    """The reduced bars (``multibody.reduce``: a floating frame at each bar's first joint and the
    attachment modes of the other's force and moment) hold the joints in the reference."""
    system = lb.mechanism(formulation="nr-rncf", elements=2).system
    assert all(b.kind == "nr-rncf" for b in system.bodies)
    z0 = system.reference()
    assert np.abs(np.asarray(system.constraints(z0, 0.0))).max() < 1e-14
    assert system.n_dof < lb.mechanism(elements=2).system.n_dof + 60


@pytest.mark.slow
def test_the_beam_buckles_sideways_past_prandtls_load():
    P_cr = lb.prandtl_load()
    runs = {d: run_setup(load_setup("lateral_buckling", {"elements": 2, "imperfection": d, "t_end": 0.2}), n_out=41)
            for d in (lb.IMPERFECTION, 0.0)}
    run = runs[lb.IMPERFECTION]
    load = -run.series["link_N"]  # the link's compression, the tip load
    mid_y, twist = np.abs(run.series["mid_y"]), np.abs(run.series["tip_twist"])
    below = load < 0.9 * P_cr
    assert below[:10].all() and load.max() > 1.5 * P_cr, load
    # below the critical load: in the plane, to a fraction of the imperfection
    assert mid_y[below].max() < 0.5 * lb.IMPERFECTION and twist[below].max() < 1e-3, (mid_y[below], twist[below])
    # past it: sideways by centimetres, and twisted
    assert mid_y.max() > 100 * lb.IMPERFECTION and twist.max() > 0.1, (mid_y.max(), twist.max())
    # the tip rose as the crank imposes it (a quarter turn: 5 cm less the link's and crank's give)
    assert 0.035 < run.series["tip_z"].max() < 0.05
    # the perfect beam takes the same load in its plane below the critical load, to round-off (past it
    # the planar path is unstable and round-off grows, by how much depends on the machine's rounding)
    perfect = runs[0.0]
    assert np.abs(-perfect.series["link_N"] - load)[below].max() < 1e-3 * P_cr
    y0 = np.abs(perfect.series["mid_y"])
    assert y0[below].max() < 1e-12, y0[below]
    assert y0[-1] < mid_y.max(), (y0[below].max(), y0[-1])
