"""``scenarios.run_record.RunRecord``, the run record that ``PendulumRun``, ``ForcedRun`` (the truss
and the membrane) and ``SpinupResult`` share: ``compare`` gives χ_rel (Eq. 40) of each record's own
displacement series and the speed-up, and every record's ``--json`` fields keep their names,
values and order."""

import numpy as np
import pytest

from nrrncf_jax.post.metrics import chi_rel
from nrrncf_jax.scenarios.forced_run import ForcedRun
from nrrncf_jax.scenarios.pendulum import PendulumRun
from nrrncf_jax.scenarios.run_record import RunRecord
from nrrncf_jax.scenarios.spinup import SpinupResult
from nrrncf_jax.scenarios.truss import TrussRun

TS = np.linspace(0.0, 0.2, 3)
STATS = dict(ts=TS, steps=7, rejected=2, newton_iters=19, compile_s=1.23456, run_s=0.123456)


def _series(seed, shape):
    return np.random.default_rng(seed).standard_normal((len(TS), *shape))


def _pendulum(seed, **kw):
    nodes = _series(seed, (2, 3, 3))
    return PendulumRun(**{**STATS, "formulation": "ancf", "dofs": 40, "nodes": nodes,
                          "left_slopes": _series(seed + 1, (2, 3)), "energy": np.array([1.0, 1.5, 0.5]),
                          "kinetic": np.array([0.0, 2.0, 1.0]), "violation": np.array([0.0, 1e-9, 3e-9]), **kw})


def _truss(seed, **kw):
    return TrussRun(**{**STATS, "formulation": "rncf", "dofs": 300, "point": _series(seed, (3,)),
                       "positions": _series(seed + 1, (4, 3)), **kw})


def _spinup(seed, **kw):
    w = _series(seed, (5, 3))
    return SpinupResult(**{**STATS, "formulation": "rncf", "beam": "paper", "omega_s": 4.0, "T_s": 15.0,
                           "elements": 2, "dofs": 30, "theta": np.zeros(len(TS)), "tip": w[:, -2],
                           "displacements": w, **kw})


def test_records_share_the_run_record():
    for run in (_pendulum(0), _truss(0), _spinup(0)):
        assert isinstance(run, RunRecord)
        assert run.chi_rel_percent is None and run.comparison() == {}
    with pytest.raises(TypeError):  # keyword-only: every record adds fields of its own
        PendulumRun("ancf", 0, TS)


@pytest.mark.parametrize("make, series", [
    (_pendulum, lambda r: r.nodes - r.nodes[0]),  # every node's displacement from its initial position
    (_truss, lambda r: r.positions),
    (_spinup, lambda r: r.displacements),
])
def test_compare_gives_chi_rel_of_the_displacements_and_the_speedup(make, series):
    ref = make(1, run_s=2.5, dofs=99)
    run = make(2)
    assert run.compare(ref) is run
    assert run.chi_rel_percent == pytest.approx(float(chi_rel(series(ref), series(run))), rel=1e-15)
    assert run.speedup == 2.5 / run.run_s and (run.reference_dofs, run.reference_run_s) == (99, 2.5)
    assert make(3).compare(make(3)).chi_rel_percent == 0.0
    with pytest.raises(ValueError, match="the reference must be"):
        run.compare(make(1, ts=TS + 0.1))
    short = make(4, ts=TS[:2])
    for name in ("nodes", "positions", "displacements"):
        if hasattr(short, name):
            setattr(short, name, getattr(short, name)[:2])
    with pytest.raises(ValueError, match="the reference must be"):
        run.compare(short)


def test_spinup_compare_keeps_the_reference_and_needs_its_displacements():
    ref, run = _spinup(1), _spinup(2, formulation="nr-rncf", vms=(0, 1), mds=((0, 0),), offline_s={"total": 1.0})
    run.compare(ref)
    assert run.reference is ref
    with pytest.raises(ValueError, match="save_displacements=True"):
        _spinup(3).compare(_spinup(4, displacements=None))


def test_json_fields_keep_their_names_values_and_order():
    """The ``--json`` records, field by field as before the records shared a base."""
    ref = _pendulum(1, run_s=2.46913)
    run = _pendulum(2, formulation="nr-rncf", dofs=12, offline={"offline_s": 0.98765}).compare(ref)
    s = run.summary()
    assert list(s) == ["formulation", "dofs", "steps", "rejected", "newton_iters", "compile_s", "run_s",
                       "constraint_max", "energy_drift", "kinetic_max", "tips_final_m", "offline_s",
                       "reference_dofs", "reference_run_s", "chi_rel_percent", "speedup", "reference_converged"]
    assert (s["steps"], s["rejected"], s["newton_iters"], s["compile_s"], s["run_s"]) == (7, 2, 19, 1.235, 0.1235)
    assert (s["offline_s"], s["reference_dofs"], s["reference_run_s"]) == (0.988, 40, 2.469)
    assert s["energy_drift"] == 0.5 and s["kinetic_max"] == 2.0 and s["constraint_max"] == 3e-9
    assert list(ref.summary()) == ["formulation", "dofs", "steps", "rejected", "newton_iters", "compile_s", "run_s",
                                   "constraint_max", "energy_drift", "kinetic_max", "tips_final_m"]

    ref = _truss(1, run_s=30.0)
    run = _truss(2, formulation="nr-rncf", dofs=10, vms=(0, 2), mds=((0, 0), (0, 2)), offline_s=1.234)
    s = run.summary()
    assert list(s) == ["formulation", "dofs", "vms", "mds", "steps", "rejected", "newton_iterations", "compile_s",
                       "run_s", "offline_s", "tip_y_max_m", "tip_z_max_m"]
    assert s["vms"] == [0, 2] and s["mds"] == [[0, 0], [0, 2]] and s["offline_s"] == 1.23
    assert (s["newton_iterations"], s["compile_s"], s["run_s"]) == (19, 1.235, 0.1235)
    run.compare(ref)
    assert list(run.summary()) == ["formulation", "dofs", "vms", "mds", "steps", "rejected", "newton_iterations",
                                   "compile_s", "run_s", "offline_s", "reference_dofs", "reference_run_s",
                                   "chi_rel_percent", "speedup", "reference_converged", "tip_y_max_m",
                                   "tip_z_max_m"]
    c = run.command_record(extra_field=1)
    assert list(c) == ["dofs", "vms", "mds", "steps", "compile_s", "run_s", "offline_s", "reference_dofs",
                       "reference_run_s", "chi_rel_percent", "speedup", "reference_converged", "formulation",
                       "extra_field"]
    assert c["reference_run_s"] == 30.0 and c["speedup"] == 30.0 / 0.123456
    assert list(ref.command_record()) == ["dofs", "vms", "mds", "steps", "compile_s", "run_s", "offline_s",
                                          "formulation"]
    with pytest.raises(ValueError, match=ForcedRun.REFERENCE):
        run.compare(_truss(1, ts=TS + 1.0))

    ref = _spinup(1, run_s=4.0, compile_s=2.0004)
    run = _spinup(2, formulation="nr-rncf", dofs=9, vms=(0, 1), mds=((0, 0),), offline_s={"total": 1.23456})
    run.compare(ref)
    s = run.summary()
    assert list(s) == ["formulation", "beam", "omega_s", "T_s", "t_end", "elements", "dofs", "steps", "rejected",
                       "newton_iters", "compile_s", "run_s", "tip_ux_min", "tip_uy_min", "tip_uy_max",
                       "tip_uz_absmax", "vms", "mds", "selected_vms", "selected_mds", "offline_s", "basis",
                       "spin_enriched", "spin_check", "chi_rel_percent", "speedup", "reference"]
    assert s["reference"] == {"formulation": "rncf", "dofs": 30, "steps": 7, "rejected": 2, "newton_iters": 19,
                              "compile_s": 2.0, "run_s": 4.0}
    assert list(s["reference"]) == ["formulation", "dofs", "steps", "rejected", "newton_iters", "compile_s", "run_s"]
    assert s["offline_s"] == 1.235 and s["speedup"] == 4.0 / 0.123456
    assert "reference_dofs" not in s and "reference_dofs" not in ref.summary()
    assert "chi_rel (Eq. 40, all q - q^) [%]" in run.table()
