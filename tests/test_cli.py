"""The ``nrrncf`` command, as a script would use it, and the library's import hygiene."""

import csv
import json
import math
import os
import subprocess
import sys

from nrrncf_jax.cli import main


def test_spinup_json_csv_plot(tmp_path, capsys):
    out, png = tmp_path / "tip.csv", tmp_path / "tip.png"
    rc = main(["spinup", "--formulation", "rncf", "--beam", "paper", "--omega", "4", "--t-end", "2",
               "--elements", "2", "--out", str(out), "--plot", str(png), "--json", "--no-progress"])
    assert rc == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    d = json.loads(last)
    for key in ("formulation", "dofs", "steps", "rejected", "newton_iters", "compile_s", "run_s", "tip_uy_min",
                "tip_uy_max"):
        assert key in d
    assert d["formulation"] == "rncf" and d["dofs"] == 2 * 18 + 9 and d["steps"] > 0
    assert d["tip_uy_min"] < 0
    rows = list(csv.reader(open(out)))
    assert rows[0] == ["t", "theta", "ux", "uy", "uz"]
    assert len(rows) == 1 + 201 and float(rows[-1][0]) == 2.0
    assert png.stat().st_size > 10_000


def test_modes_json(capsys):
    assert main(["modes", "--beam", "paper", "--elements", "4", "--count", "4", "--json"]) == 0
    d = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert abs(d["omega_rad_s"][0] - 2.9096) < 1e-3


def test_bad_cli_value_is_an_error_not_a_traceback(capsys):
    assert main(["spinup", "--omega", "-3", "--t-end", "1", "--no-progress"]) == 2
    assert "omega" in capsys.readouterr().err


def test_library_import_leaves_jax_config_alone():
    code = "import jax, nrrncf_jax; print(jax.config.jax_enable_x64, jax.config.jax_compilation_cache_dir)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False None"


def test_compilation_cache_keeps_small_kernels(tmp_path):
    """compilation_cache stores even a tiny kernel, a new process finds it, and the block leaves
    JAX's cache setting as it found it."""
    code = ("import os, jax, nrrncf_jax\nwith nrrncf_jax.compilation_cache(os.environ['D']) as p:\n"
            "    jax.jit(lambda x: 2.0 * x + 1.0)(1.0).block_until_ready()\n"
            "assert jax.config.jax_compilation_cache_dir is None\nprint(len(os.listdir(p)))")
    env = dict(os.environ, D=str(tmp_path / "xla"))
    first = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env)
    second = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env)
    assert int(first.stdout) >= 1
    assert int(second.stdout) == int(first.stdout)  # a hit: nothing new written


def test_spinup_nr_rncf_with_reference_json(tmp_path, capsys):
    png = tmp_path / "tip.png"
    rc = main(["spinup", "--formulation", "nr-rncf", "--beam", "paper", "--elements", "2", "--omega", "4",
               "--t-end", "3", "--modes", "8", "--reference", "rncf", "--plot", str(png), "--json", "--no-progress"])
    assert rc == 0
    d = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    for key in ("vms", "mds", "dofs", "offline_s", "chi_rel_percent", "speedup", "steps", "run_s"):
        assert key in d
    assert d["formulation"] == "nr-rncf"
    assert 0 < d["dofs"] <= d["vms"] + d["mds"] and d["vms"] >= 1
    assert len(d["selected_vms"]) == d["vms"] and len(d["selected_mds"]) == d["mds"]
    assert isinstance(d["chi_rel_percent"], float) and math.isfinite(d["chi_rel_percent"])
    assert 0 <= d["chi_rel_percent"] < 5
    assert d["speedup"] > 0 and d["reference"]["dofs"] == 2 * 18 + 9
    assert png.stat().st_size > 10_000


def test_modes_mmi_json(tmp_path, capsys):
    png = tmp_path / "mmi.png"
    # The same beam, mesh, candidate count and time span as the nr-rncf test above: compiled code is reused.
    assert main(["modes", "--beam", "paper", "--elements", "2", "--count", "8", "--mmi", "--omega", "4",
                 "--t-end", "3", "--plot", str(png), "--json"]) == 0
    d = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    mmi = d["mmi"]
    W = mmi["W_quarter"]
    assert len(W) == 8 and all(len(row) == 8 for row in W)
    assert max(max(row) for row in W) == 1.0
    assert mmi["selected_vms"] and all(1 <= i <= 8 for i in mmi["selected_vms"])
    assert all(i <= j and i in mmi["selected_vms"] and j in mmi["selected_vms"] for i, j in mmi["selected_mds"])
    assert png.stat().st_size > 5_000


def test_modes_mmi_needs_omega(capsys):
    assert main(["modes", "--elements", "2", "--mmi"]) == 2
    assert "--omega" in capsys.readouterr().err
