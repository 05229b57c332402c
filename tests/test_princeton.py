"""The Princeton beam (``examples/princeton_beam.py``) and ``nrrncf static``: a static solve of a
mechanism with a force element, checked in the linear limit.

Closed form: a Timoshenko cantilever under a small tip load P at the load angle θ deflects by
P cos θ (L³/(3EI_flap) + L/(kGA)) in flap and P sin θ (L³/(3EI_lag) + L/(kGA)) in lag (the shear's
share is 4.6e-4 in lag: the test sees the section's shear correction), and does not twist (the
load passes through the section's centre). The load 1e-4 N keeps the geometric nonlinearity
(relative (u/L)² ~ 1e-13) far below the bound, 1e-6 of the larger deflection.
"""

import json

import numpy as np
import pytest

from nrrncf_jax.cli import main
from nrrncf_jax.examples.princeton_beam import linear_tip, mechanism
from nrrncf_jax.integrate import constrained_equilibrium
from nrrncf_jax.multibody.sensors import observe


@pytest.mark.parametrize("angle", [0.0, 30.0, 90.0])
def test_the_princeton_beam_bends_as_the_linear_cantilever_under_a_small_load(angle):
    setup = mechanism(load=1e-4, angle_deg=angle, elements=4)
    eq = constrained_equilibrium(setup.system, t=1.0, load_steps=1)
    out = observe(setup.system, setup.sensors)(1.0, eq.z, 0.0 * eq.z)
    flap, lag = linear_tip(1e-4, angle)
    scale = max(flap, lag)
    assert abs(-float(out["tip_z"]) - flap) < 1e-6 * scale, (float(out["tip_z"]), flap)
    assert abs(-float(out["tip_y"]) - lag) < 1e-6 * scale, (float(out["tip_y"]), lag)
    assert abs(float(out["twist"])) < 1e-8


@pytest.mark.slow
def test_static_command_on_the_princeton_beam(capsys):
    """``nrrncf static``: at 3 lbf and 45° the flap is below the linear limit (the bent beam
    stiffens) and the tip twists nose-down (the lag load on the flapped beam), as in Dowell's
    experiment; the record has the sensors and each increment's Newton corrections."""
    assert main(["static", "princeton_beam", "--param", "load=13.345", "--param", "angle_deg=45", "--load-steps", "5",
                 "--json", "--no-progress"]) == 0
    record = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    flap, lag = linear_tip(13.345, 45.0)
    assert 0.5 * flap < -record["tip_z"] < flap
    assert -0.2 < record["twist"] < -0.01
    assert len(record["newton_iters"]) == 5 and record["dofs"] == 162
    assert main(["static", "princeton_beam", "--load-steps", "0"]) == 2
    assert np.isfinite(record["solve_s"])
