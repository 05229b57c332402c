"""Batched spin-up sweeps: the vmapped sweep against single runs, the sharded sweep against the
unsharded one (4 forced host devices, in a subprocess), input errors before tracing, the CLI.

One tiny basis (2 elements, 4 candidate modes) and one grid serve every sweep, and the CLI test
asks for the same settings, so it reuses the code compiled for the library tests. The sweeps are in
the slow tier (the basis and the compiled sweep take ~15 s); the input checks are not.
"""

import json
import os
import pickle
import subprocess
import sys
import textwrap

import equinox as eqx
import jax
import numpy as np
import pytest
from conftest import FAST_COMPILE_FLAGS, paper_body

from nrrncf_jax.cli import main
from nrrncf_jax.integrate import GeneralizedAlphaIndex3
from nrrncf_jax.scenarios.spinup import sweep_reduction
from nrrncf_jax.studies.sweep import (
    SweepGrid,
    case_model,
    parse_range,
    schedule,
    single_run,
    spinup_sweep,
    sweep_grid,
)

E0 = 70e9  # the paper beam's Young's modulus
OMEGA, TS, E_SCALE = [2.0, 4.0, 6.0], 3.0, [1.0, 2.0]
T_END, DT_OUT, ELEMENTS, MODES = 4.0, 0.02, 2, 4
CLI_ARGS = ["sweep", "--beam", "paper", "--omega", "2:6:3", "--ts", "3", "--E", f"{E0:g},{2 * E0:g}",
            "--t-end", str(T_END), "--elements", str(ELEMENTS), "--modes", str(MODES), "--dt-out", str(DT_OUT)]


# The tests of the basis share an xdist group, so that one worker builds it (and compiles its runs) once.
@pytest.fixture(scope="module")
def grid():
    return sweep_grid(OMEGA, TS, E_SCALE)


@pytest.fixture(scope="module")
def red(grid):
    return sweep_reduction("paper", grid, t_end=T_END, elements=ELEMENTS, dt_out=DT_OUT, n_modes=MODES)


@pytest.fixture(scope="module")
def res(red, grid):
    return spinup_sweep(red, grid, t_end=T_END, dt_out=DT_OUT)


@pytest.mark.slow
@pytest.mark.xdist_group("sweep_basis")
def test_vmapped_sweep_equals_single_runs(red, grid, res):
    assert grid.shape == (3, 1, 2) and res.cases == 6 and res.tip.shape == (6, res.ts.size, 3)
    assert res.devices == jax.device_count() and res.collectives == 0
    scale = float(np.abs(res.tip).max())
    for i in range(grid.cases):
        sol = single_run(red, grid.omega_s[i], grid.T_s[i], grid.E_scale[i], t_end=T_END, dt_out=DT_OUT)
        # Equal to the integration tolerance: batched and single LU and contractions round
        # differently, which the adaptive step control carries into the solution.
        np.testing.assert_allclose(res.tip[i], np.asarray(sol.ys), rtol=0, atol=1e-5 * scale)
        assert abs(int(sol.num_steps) - res.steps[i]) <= 0.05 * res.steps[i]
    # E scaling by the sweep's rescaled inertia and loads = the elastic tensors scaled by E/E0.
    i = int(np.flatnonzero(grid.E_scale == 2.0)[-1])
    m = eqx.tree_at(lambda r: r.elastic, red.model, red.model.elastic.scaled(2.0))
    sol = single_run(m, grid.omega_s[i], grid.T_s[i], t_end=T_END, dt_out=DT_OUT)
    np.testing.assert_allclose(res.tip[i], np.asarray(sol.ys), rtol=0, atol=1e-5 * scale)
    # The summaries come from the series; physics: faster spin-up → more lag, stiffer → less.
    np.testing.assert_array_equal(res.peak_uy, np.abs(res.tip[:, :, 1]).max(axis=1))
    after = res.ts >= TS
    np.testing.assert_allclose(res.residual_uy, 0.5 * np.ptp(res.tip[:, after, 1], axis=1))
    uy = res.peak_uy.reshape(grid.shape)[:, 0, :]
    assert np.all(np.diff(uy, axis=0) > 0) and np.all(uy[:, 1] < uy[:, 0])
    assert np.all(res.peak_ux.reshape(grid.shape)[-1] > res.peak_ux.reshape(grid.shape)[0])


_SUBPROCESS = textwrap.dedent("""
    import json, pickle, sys
    import jax
    import numpy as np
    from nrrncf_jax.studies.sweep import spinup_sweep, sweep_grid
    model = pickle.load(open(sys.argv[1], "rb"))
    grid = sweep_grid({omega}, {ts}, {e})
    from nrrncf_jax.integrate import ConstantStepSize
    kw = dict(t_end={t_end}, dt_out={dt_out}, controller=ConstantStepSize(0.01))
    one = spinup_sweep(model, grid, devices=1, lanes=2, **kw)  # 6 cases queue for 2 lanes
    four = spinup_sweep(model, grid, devices=4, **kw)
    print(json.dumps(dict(device_count=jax.device_count(), x64=jax.config.jax_enable_x64, devices=four.devices,
                          lanes=[one.lanes, four.lanes], padded=four.padded, collectives=four.collectives,
                          steps=four.steps.tolist(),
                          diff=float(np.abs(one.tip - four.tip).max()), scale=float(np.abs(one.tip).max()),
                          peak_diff=float(np.abs(one.peak_uy - four.peak_uy).max()))))
""")


@pytest.mark.slow
@pytest.mark.xdist_group("sweep_basis")
def test_sharded_sweep_equals_unsharded_on_4_host_devices(red, tmp_path):
    path = tmp_path / "model.pkl"
    with open(path, "wb") as f:
        pickle.dump(jax.tree_util.tree_map(np.asarray, red.model), f)
    code = _SUBPROCESS.format(omega=OMEGA, ts=TS, e=E_SCALE, t_end=T_END, dt_out=DT_OUT)
    # The device count is fixed when JAX starts, hence a subprocess. Fixed steps: the sharded
    # and unsharded programs are fused differently by XLA, and adaptive steps would carry that
    # round-off further (to well below the tolerance, but beyond 1e-12).
    env = dict(os.environ, JAX_ENABLE_X64="1", JAX_PLATFORMS="cpu",
               XLA_FLAGS=" ".join(("--xla_force_host_platform_device_count=4",) + FAST_COMPILE_FLAGS))
    out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, env=env,
                         timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    d = json.loads(out.stdout.strip().splitlines()[-1])
    assert d["x64"] and d["device_count"] == 4 and d["devices"] == 4
    assert d["lanes"] == [2, 2] and d["padded"] == 2  # 6 cases padded to 8: 2 per device, no queue
    assert d["collectives"] == 0  # no cross-device operation in the compiled program
    assert d["steps"] == [int(T_END / 0.01)] * 6
    assert d["diff"] <= 1e-11 * d["scale"], d
    assert d["peak_diff"] <= 1e-11 * d["scale"], d


def test_grid_and_ranges_refuse_bad_input():
    """``sweep_grid``, ``SweepGrid`` and ``parse_range`` (the ``--omega`` syntax ``start:stop:count``
    or a list) refuse bad values naming them; good ones give the grid's values."""
    for kwargs, match in [
        (dict(omega_s=[]), "empty"),
        (dict(omega_s=[2.0, -1.0]), "omega_s"),
        (dict(omega_s=[2.0, np.nan]), "omega_s"),
        (dict(omega_s=4.0, T_s=0.0), "T_s"),
        (dict(omega_s=4.0, E_scale=[1.0, -2.0]), "E_scale"),
    ]:
        with pytest.raises(ValueError, match=match):
            sweep_grid(**kwargs)
    with pytest.raises(ValueError, match="one value per case"):
        SweepGrid([1.0, 2.0], [1.0, 2.0, 3.0], 1.0)
    for spec in ["2:40", "2:40:", "a:b:3", "2:40:1.5", "", "2,x"]:
        with pytest.raises(ValueError, match="--omega"):
            parse_range(spec, "--omega")
    with pytest.raises(ValueError, match="count"):
        parse_range("2:40:0", "--omega")
    np.testing.assert_allclose(parse_range("2:40:64"), np.linspace(2, 40, 64))
    np.testing.assert_allclose(parse_range("4, 10,20"), [4, 10, 20])
    grid = sweep_grid(OMEGA, TS, E_SCALE)
    assert grid.shape == (3, 1, 2) and grid.cases == 6
    np.testing.assert_array_equal(grid.omega_s, np.repeat(OMEGA, 2))
    np.testing.assert_array_equal(grid.E_scale, np.tile(E_SCALE, 3))


def test_bad_input_raises_before_tracing(monkeypatch):
    """``spinup_sweep`` checks its input before it traces anything, on a reduced model of the
    paper's beam (2 elements, its first 2 modes: nothing runs)."""
    import nrrncf_jax.studies.sweep as sweep_mod
    from nrrncf_jax import RotatingFrameModel, SpinUp, reduce_rotating_model, vibration_modes

    full = RotatingFrameModel(paper_body(ELEMENTS), SpinUp(4.0, TS))
    red = reduce_rotating_model(full, vibration_modes(full.body, full.free_mask(), 2).phi)
    grid = sweep_grid(OMEGA, TS, E_SCALE)

    class NoTrace:
        def lower(self, *a, **k):
            raise AssertionError("traced before the input was checked")

    monkeypatch.setattr(sweep_mod, "_sweep_kernel", NoTrace())
    monkeypatch.setattr(sweep_mod, "_sweep_kernel_small", NoTrace())
    for kwargs, match in [
        (dict(t_end=0.0), "t_end"),
        (dict(t_end=-1.0), "t_end"),
        (dict(t_end=T_END, dt_out=0.0), "dt_out"),
        (dict(t_end=T_END, devices=jax.device_count() + 1), "devices"),
        (dict(t_end=T_END, devices=0), "devices"),
        (dict(t_end=T_END, lanes=0), "lanes"),
        (dict(t_end=T_END, balance="random"), "balance"),
        (dict(t_end=T_END, controller="adaptive"), "controller must be"),
        (dict(t_end=T_END, solver=GeneralizedAlphaIndex3(0.9)), "solver must be"),
        (dict(t_end=T_END, tip=10_000), "tip"),
        (dict(t_end=T_END, small_kernels="yes"), "small_kernels"),
    ]:
        with pytest.raises(ValueError, match=match):
            spinup_sweep(red, grid, **kwargs)
    with pytest.raises(ValueError, match="SweepGrid"):
        spinup_sweep(red, [2.0, 4.0], t_end=T_END)
    with pytest.raises(ValueError, match="ReducedRotatingModel"):
        spinup_sweep(case_model, grid, t_end=T_END)


def test_schedule_sorts_pads_and_balances():
    cost = np.array([5.0, 1.0, 4.0, 2.0, 3.0])
    blocks = schedule(cost, 2)
    assert blocks.tolist() == [0, 2, 4, 3, 1, 1]  # costliest first; padded with the cheapest to 2·3
    inter = schedule(cost, 2, "interleave")
    assert inter.tolist() == [0, 4, 1, 2, 3, 1]  # each device the same mix, costliest first
    assert schedule(cost, 1).tolist() == [0, 2, 4, 3, 1]


@pytest.mark.slow
@pytest.mark.xdist_group("sweep_basis")
def test_cli_sweep_json_and_errors(res, tmp_path, capsys):
    png = tmp_path / "sweep.png"
    assert main(CLI_ARGS + ["--plot", str(png), "--json"]) == 0
    out, err = capsys.readouterr()
    d = json.loads(out.strip().splitlines()[-1])
    # progress by default, on stderr: each stage of the long command
    for stage in ("reduced basis at omega_s = 6", "sweep: compiling", "running the 6 cases", "sweep: the slowest case"):
        assert stage in err, err
    for key in ("cases", "devices", "compile_s", "run_s", "single_run_s", "sweep_over_single", "throughput_per_s",
                "peak_uy", "peak_ux", "residual_uy", "dofs", "vms", "mds"):
        assert key in d, key
    assert d["cases"] == 6 and d["devices"] == jax.device_count() and d["dofs"] == res.dofs
    assert d["run_s"] > 0 and d["single_run_s"] > 0 and d["compile_s"] >= 0
    assert d["single_case"]["index"] == int(np.argmax(res.steps + res.rejected))
    assert d["E"] == [E0, 2 * E0, E0, 2 * E0, E0, 2 * E0]
    np.testing.assert_allclose(d["peak_uy"], res.peak_uy, rtol=1e-12)  # the same compiled program
    assert png.stat().st_size > 10_000
    assert d["vms"] + d["mds"] + d["spin_vectors"] >= d["dofs"]
    assert main(CLI_ARGS + ["--json", "--no-progress"]) == 0
    out, err = capsys.readouterr()
    assert err == "" and json.loads(out.strip().splitlines()[-1])["peak_uy"] == d["peak_uy"]
    assert main(CLI_ARGS + ["--no-progress"]) == 0
    out = capsys.readouterr().out
    assert f"{d['dofs']} DOFs ({d['vms']} VMs + {d['mds']} MDs" in out  # every coordinate accounted for
    assert main(["sweep", "--omega", "2:40", "--json"]) == 2
    assert "--omega" in capsys.readouterr().err
    assert main(["sweep", "--omega", "2:40:8", "--ts", "0", "--json"]) == 2
    assert "T_s" in capsys.readouterr().err
