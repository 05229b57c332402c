"""Sweeps beyond one process (``studies.distributed``): two local processes of one
``jax.distributed`` runtime (CPU collectives over gloo, loopback only) against the single-process
sweep case by case; shards merged against it; the launcher's failure and timeout paths; the CLI.

Fixed steps (``dt``) in the comparisons: each case is its own run, and with fixed steps the only
difference between the splits is the round-off of other batch shapes. Each step passes it
through a Newton solve whose iteration matrix's condition number is ~1e5 here (the reduced
stiffness against the mass over h²), and 200 steps accumulate it: 1e-16 · 1e5 · 200 ≈ 2e-9 of
the deflections at most, so 2e-9 of the largest one is allowed (the step counts must be equal)."""

import json
import pickle
import textwrap

import jax
import numpy as np
import pytest
from conftest import FAST_COMPILE_FLAGS

from nrrncf_jax.cli import main
from nrrncf_jax.integrate import ConstantStepSize
from nrrncf_jax.scenarios.spinup import sweep_reduction
from nrrncf_jax.studies.distributed import LaunchError, launch_local, merge_parts, shard_indices
from nrrncf_jax.studies.sweep import spinup_sweep, sweep_grid

OMEGA, TS, E_SCALE = [float(w) for w in np.linspace(2.0, 9.0, 8)], 1.5, [1.0, 2.0]
KW = dict(t_end=2.0, dt_out=0.02)
DT = 0.01  # fixed steps: the cases' results are then independent of the batch to round-off
TOL = 2e-9  # see the module docstring


def test_shards_partition_the_cases_with_the_same_mix():
    cost = np.array([5.0, 1.0, 4.0, 2.0, 3.0, 6.0, 0.5])
    parts = [shard_indices(cost, k, 3) for k in range(3)]
    assert sorted(np.concatenate(parts).tolist()) == list(range(7))
    # sorted costliest first: 5, 0, 2, 4, 3, 1, 6; dealt round-robin, shard 0 gets the 1st, 4th, 7th
    assert parts[0].tolist() == [4, 5, 6] and parts[1].tolist() == [0, 3] and parts[2].tolist() == [1, 2]
    with pytest.raises(ValueError, match="K/N"):
        shard_indices(cost, 3, 3)


def test_merge_refuses_missing_repeated_and_foreign_parts(tmp_path):
    head = "case,cases,x\n"
    (tmp_path / "a.csv").write_text(head + "0,3,1.0\n2,3,3.0\n")
    (tmp_path / "b.csv").write_text(head + "1,3,2.0\n")
    out = tmp_path / "all.csv"
    assert merge_parts([tmp_path / "a.csv", tmp_path / "b.csv"], out) == 3
    assert out.read_text().splitlines() == ["case,cases,x", "0,3,1.0", "1,3,2.0", "2,3,3.0"]
    with pytest.raises(ValueError, match=r"cases \[1\] of 3 are in no part"):
        merge_parts([tmp_path / "a.csv"], out)
    with pytest.raises(ValueError, match="more than one part"):
        merge_parts([tmp_path / "a.csv", tmp_path / "a.csv"], out)
    (tmp_path / "c.csv").write_text("omega_s,x\n1,2\n")
    with pytest.raises(ValueError, match="not a part"):
        merge_parts([tmp_path / "c.csv"], out)
    assert main(["sweep-merge", str(tmp_path / "nope.csv"), "--out", str(out)]) == 2
    assert main(["sweep", "--omega", "2:4:3", "--shard", "2/2"]) == 2
    assert main(["sweep", "--omega", "2:4:3", "--shard", "0/2", "--processes", "2"]) == 2


def test_a_failing_worker_ends_the_launch_in_bounded_time():
    """Worker 1 dies while worker 0 would wait a minute (as in a collective whose peer is gone):
    the launch ends within seconds, naming process 1 and showing its error; a launch that outlasts
    its timeout is stopped."""
    code = textwrap.dedent("""
        import os, sys, time
        if os.environ["NRRNCF_PROCESS_ID"] == "1":
            print("case 7 broke", file=sys.stderr)
            sys.exit(3)
        time.sleep(60)
    """)
    import time

    t0 = time.monotonic()
    with pytest.raises(LaunchError, match=r"worker process 1 \(exit status 3\) of 2 failed[\s\S]*case 7 broke"):
        launch_local([], 2, timeout_s=50, code=code)
    assert time.monotonic() - t0 < 30
    with pytest.raises(LaunchError, match="did not finish within 1 s"):
        launch_local([], 2, timeout_s=1, code="import time; time.sleep(60)")


@pytest.mark.slow
def test_a_worker_killed_mid_run_does_not_leave_the_others_hanging():
    """Two processes of one runtime; process 1 is killed (SIGKILL) while process 0 waits for it
    in a gather: the launch ends within seconds with the error, instead of process 0 waiting for
    ever."""
    code = textwrap.dedent("""
        import os, signal
        import numpy as np
        from nrrncf_jax.studies import distributed
        distributed.initialize(timeout_s=60)
        import jax
        from jax.experimental import multihost_utils
        if jax.process_index() == 1:
            os.kill(os.getpid(), signal.SIGKILL)
        multihost_utils.process_allgather(np.ones(1))
    """)
    import time

    t0 = time.monotonic()
    with pytest.raises(LaunchError, match="worker process"):
        launch_local([], 2, timeout_s=120, code=code, env={"JAX_PLATFORMS": "cpu"})
    assert time.monotonic() - t0 < 60


_WORKER = textwrap.dedent("""
    import json, pickle, sys
    from nrrncf_jax.studies import distributed
    distributed.initialize(timeout_s=60)
    import jax
    jax.config.update("jax_enable_x64", True)
    from nrrncf_jax.studies.sweep import spinup_sweep, sweep_grid
    model = pickle.load(open(sys.argv[1], "rb"))
    from nrrncf_jax.integrate import ConstantStepSize
    res = spinup_sweep(model, sweep_grid({omega}, {ts}, {e}), controller=ConstantStepSize({dt}), **{kw})
    if jax.process_index() == 0:
        json.dump(dict(processes=jax.process_count(), devices=res.devices, peak_uy=res.peak_uy.tolist(),
                       residual_uy=res.residual_uy.tolist(), tip=res.tip.tolist(), steps=res.steps.tolist()),
                  open(sys.argv[2], "w"))
""")


@pytest.fixture(scope="module")
def single():
    grid = sweep_grid(OMEGA, TS, E_SCALE)
    red = sweep_reduction("paper", grid, t_end=KW["t_end"], elements=2, dt_out=KW["dt_out"], n_modes=4)
    return grid, red, spinup_sweep(red, grid, devices=1, controller=ConstantStepSize(DT), **KW)


@pytest.mark.slow
def test_two_processes_gather_the_single_process_results_case_by_case(single, tmp_path):
    grid, red, one = single
    model = tmp_path / "model.pkl"
    with open(model, "wb") as f:
        pickle.dump(jax.tree_util.tree_map(np.asarray, red.model), f)
    out = tmp_path / "two.json"
    code = _WORKER.format(omega=OMEGA, ts=TS, e=E_SCALE, kw=KW, dt=DT)
    launch_local([str(model), str(out)], 2, timeout_s=600, code=code,
                 env={"JAX_PLATFORMS": "cpu", "XLA_FLAGS": " ".join(FAST_COMPILE_FLAGS)})
    two = json.loads(out.read_text())
    assert two["processes"] == 2 and two["devices"] == 2 and grid.cases == 16
    scale = float(np.abs(one.tip).max())
    np.testing.assert_allclose(np.asarray(two["tip"]), one.tip, rtol=0, atol=TOL * scale)
    np.testing.assert_allclose(two["peak_uy"], one.peak_uy, rtol=0, atol=TOL * scale)
    assert two["steps"] == one.steps.tolist()


@pytest.mark.slow
def test_shards_merged_equal_the_whole_sweep(single, tmp_path):
    grid, red, one = single
    whole = tmp_path / "whole.csv"
    one.to_csv(whole)
    parts = []
    for k in range(2):
        idx = shard_indices(grid.expected_cost(), k, 2)
        res = spinup_sweep(red, grid.subset(idx), devices=1, controller=ConstantStepSize(DT), **KW)
        res.case_index, res.cases_total = idx, grid.cases
        parts.append(tmp_path / f"part{k}.csv")
        res.to_csv(parts[-1])
    merged = tmp_path / "merged.csv"
    assert merge_parts(parts, merged) == 16
    a = np.loadtxt(merged, delimiter=",", skiprows=1)
    b = np.loadtxt(whole, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(a[:, :5], b[:, :5])  # case, cases, ωs, Ts, E
    assert np.all(np.isfinite(b[:, 5:8]))
    np.testing.assert_allclose(a[:, 5:8], b[:, 5:8], rtol=0, atol=TOL * np.abs(b[:, 5:8]).max())


@pytest.mark.slow
def test_cli_sweep_on_two_processes(capfd, tmp_path):
    """``nrrncf sweep --processes 2``: process 0 prints one JSON line with both processes' cases
    and writes the CSV (the results against one process: the tests above, at fixed steps)."""
    args = ["sweep", "--omega", "2:6:3", "--ts", "1", "--t-end", "2", "--elements", "2", "--modes", "4",
            "--dt-out", "0.02", "--json", "--no-progress"]
    csv_path = tmp_path / "sweep.csv"
    assert main(args + ["--processes", "2", "--timeout", "600", "--out", str(csv_path)]) == 0
    two = json.loads(capfd.readouterr().out.strip().splitlines()[-1])
    assert two["processes"] == 2 and two["devices"] == 2 and two["cases"] == 3
    table = np.loadtxt(csv_path, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(table[:, :2], [[0, 3], [1, 3], [2, 3]])
    np.testing.assert_allclose(table[:, 5], two["peak_uy"], rtol=1e-9)
    assert np.all(np.diff(table[:, 5]) > 0)  # faster spin-up, more lag

