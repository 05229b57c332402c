"""The ``nrrncf`` command, as a script would use it, and the library's import hygiene."""

import csv
import json
import math
import os
import subprocess
import sys
from types import SimpleNamespace

import jax.numpy as jnp
import pytest

import nrrncf_jax.cli as cli
from nrrncf_jax.cli import build_parser, main
from nrrncf_jax.cli._common import BEAM_NAMES, ESTIMATE_METHODS
from nrrncf_jax.reduction import Basis, SpinCheck
from nrrncf_jax.reduction.pipeline import Reduction, nr_rncf
from nrrncf_jax.scenarios import BEAMS
from nrrncf_jax.scenarios.spinup import build_spinup_model, output_times


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


def test_spinup_step_control_is_recorded_and_reaches_the_same_motion(capsys):
    """``--step-control pi``: the run's record names its controller and it follows the plain controller's
    motion, each run within its own error: at most the sum of the steps' error tolerances,
    atol + rtol·max|u| a step."""
    argv = ["spinup", "--formulation", "rncf", "--beam", "paper", "--omega", "4", "--t-end", "2", "--elements", "2",
            "--json", "--no-progress"]
    runs = {}
    for control in ("plain", "pi"):
        assert main(argv + ["--step-control", control]) == 0
        runs[control] = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert "step_control" not in runs["plain"] and runs["pi"]["step_control"] == "pi"  # named where not the default
    steps = sum(runs[c]["steps"] + runs[c]["rejected"] for c in runs)
    bound = steps * (1e-6 + 1e-4 * abs(runs["plain"]["tip_uy_min"]))  # the CLI's rtol 1e-4, atol 1e-6
    assert abs(runs["pi"]["tip_uy_min"] - runs["plain"]["tip_uy_min"]) <= bound
    assert abs(runs["pi"]["tip_ux_min"] - runs["plain"]["tip_ux_min"]) <= bound


@pytest.mark.slow
@pytest.mark.xdist_group("cli_paper2_nr_rncf")
def test_spinup_nr_rncf_to_a_tolerance_json(capsys):
    """``--tol``: the basis search's record in the JSON. The first basis tried (two columns: the
    first mode and its modal derivative) meets 50 %; the one-column basis tried next, the mode
    alone, misses the foreshortening (an estimate of about 90 %), so two columns are kept."""
    rc = main(["spinup", "--formulation", "nr-rncf", "--beam", "paper", "--elements", "2", "--omega", "4",
               "--t-end", "3", "--modes", "8", "--tol", "50", "--json", "--no-progress"])
    assert rc == 0
    d = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert d["tol_percent"] == 50 and d["tol_met"] is True
    assert [t["columns"] for t in d["basis_trials"]] == [2, 1]
    assert d["basis_trials"][1]["chi_rel_estimate_percent"] > 50
    assert d["dofs"] == d["basis_trials"][0]["dofs"] == 2 and (d["vms"], d["mds"]) == (1, 1)
    # the step tolerances chosen to the same target: the run's own integration error at most tol / 2,
    # the estimate reported the run's total (its basis part estimated again on the chosen run)
    assert d["integration_error_estimate_percent"] <= 25 and d["step_rtol"] <= 1e-4
    assert d["chi_rel_estimate_percent"] == pytest.approx(d["basis_error_estimate_percent"]
                                                          + d["integration_error_estimate_percent"])


@pytest.mark.xdist_group("cli_paper2_nr_rncf")
def test_spinup_estimate_samples(capsys):
    """``--estimate-samples N``: the static estimate at N sampled outputs, the record says N."""
    assert main(["spinup", "--formulation", "nr-rncf", "--beam", "paper", "--elements", "2", "--omega", "4",
                 "--t-end", "1", "--modes", "4", "--estimate-samples", "3", "--json", "--no-progress"]) == 0
    d = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert d["estimate_samples"] == 3 and d["chi_rel_estimate_percent"] > 0


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


@pytest.mark.slow
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


@pytest.mark.slow
@pytest.mark.xdist_group("cli_paper2_nr_rncf")
def test_spinup_nr_rncf_with_reference_json(tmp_path, capsys):
    png = tmp_path / "tip.png"
    rc = main(["spinup", "--formulation", "nr-rncf", "--beam", "paper", "--elements", "2", "--omega", "4",
               "--t-end", "3", "--modes", "8", "--reference", "rncf", "--plot", str(png), "--json", "--no-progress",
               "--estimate-method", "dynamic", "--estimate-integration"])
    assert rc == 0
    d = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    for key in ("vms", "mds", "dofs", "offline_s", "chi_rel_percent", "speedup", "steps", "run_s",
                "chi_rel_estimate_percent", "effectivity", "estimate_run_s", "integration_error_estimate_percent"):
        assert key in d
    assert d["effectivity"] == pytest.approx(d["chi_rel_estimate_percent"] / d["chi_rel_percent"])
    assert d["estimate_samples"] == 301  # the error equation runs over every output (0-3 s by 0.01 s)
    assert d["integration_error_estimate_percent"] >= 0
    assert d["formulation"] == "nr-rncf"
    assert 0 < d["dofs"] <= d["vms"] + d["mds"] and d["vms"] >= 1
    assert len(d["selected_vms"]) == d["vms"] and len(d["selected_mds"]) == d["mds"]
    assert d["basis"].startswith(f"{d['dofs']} DOFs ({d['vms']} VMs + {d['mds']} MDs")
    assert isinstance(d["chi_rel_percent"], float) and math.isfinite(d["chi_rel_percent"])
    assert 0 <= d["chi_rel_percent"] < 5
    assert d["speedup"] > 0 and d["reference"]["dofs"] == 2 * 18 + 9
    # the reference is converged (rtol/100) and the total splits into its parts: they bound it by
    # the triangle inequality (χ_rel of the integration part normalised by the tight reduced run,
    # of the others by the reference: the factor 1 + basis), and the reference's own error is small
    total, integration, basis = (d[k] for k in ("chi_rel_percent", "integration_error_percent",
                                               "basis_error_percent"))
    assert d["reference_rtol"] == pytest.approx(1e-6)
    assert total <= (integration * (1 + basis / 100) + basis) * (1 + 1e-9)
    assert d["reference_error_percent"] < 0.5 * total
    assert d["chi_rel_estimate_percent"] == pytest.approx(d["basis_error_estimate_percent"]
                                                          + d["integration_error_estimate_percent"])
    assert png.stat().st_size > 10_000


@pytest.mark.slow
@pytest.mark.xdist_group("cli_paper2_nr_rncf")
def test_modes_mmi_json(tmp_path, capsys):
    png = tmp_path / "mmi.png"
    # The same beam, mesh, candidate count and time span as the nr-rncf test above, on the same xdist
    # worker (their group): compiled code is reused.
    assert main(["modes", "--beam", "paper", "--elements", "2", "--count", "8", "--mmi", "--omega", "4",
                 "--t-end", "3", "--plot", str(png), "--json"]) == 0
    d = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    mmi = d["mmi"]
    W = mmi["W_quarter"]
    assert len(W) == 8 and all(len(row) == 8 for row in W)
    assert max(max(row) for row in W) == 1.0
    assert mmi["selected_vms"] and all(0 <= i < 8 for i in mmi["selected_vms"])  # 0-based, as in Python
    assert all(i <= j and i in mmi["selected_vms"] and j in mmi["selected_vms"] for i, j in mmi["selected_mds"])
    assert png.stat().st_size > 5_000
    # The same selection as the Python API's, index for index (one convention: 0-based).
    full = build_spinup_model("rncf", "paper", 4.0, 15.0, 2)
    sel = nr_rncf(full, jnp.asarray(output_times(3.0, 0.01)), Basis(n_modes=8)).selection
    assert mmi["selected_vms"] == list(sel.vms)
    assert mmi["selected_mds"] == [list(p) for p in sel.pairs]
    assert mmi["basis"].startswith(f"{mmi['dofs']} DOFs ({len(sel.vms)} VMs + {len(sel.pairs)} MDs")


def test_modes_mmi_needs_omega(capsys):
    assert main(["modes", "--elements", "2", "--mmi"]) == 2
    assert "--omega" in capsys.readouterr().err


# --- bad input: one line on stderr and exit status 2, before any work ----------------------------------------------

MISSING = "/nonexistent/dir/"
BAD_INPUT = {
    "step-control-unknown": (["spinup", "--omega", "10", "--step-control", "fast"],
                             "argument --step-control: invalid choice: 'fast'"),
    "vms-zero": (["spinup", "--formulation", "nr-rncf", "--omega", "10", "--vms", "0"],
                 "argument --vms: must be 'auto' or an integer >= 1, got '0'"),
    "mds-nonsense": (["spinup", "--formulation", "nr-rncf", "--omega", "10", "--mds", "many"],
                     "argument --mds: must be 'auto' or an integer >= 0, got 'many'"),
    "mds-negative": (["spinup", "--formulation", "nr-rncf", "--omega", "10", "--mds", "-2"],
                     "argument --mds: must be 'auto' or an integer >= 0, got '-2'"),
    "vms-beyond-modes": (["spinup", "--formulation", "nr-rncf", "--omega", "10", "--vms", "9", "--modes", "8"],
                         "--vms 9 asks for more vibration modes than the --modes 8 candidates"),
    "tol-negative": (["spinup", "--formulation", "nr-rncf", "--omega", "4", "--tol=-1"],
                     "--tol (target chi_rel in per cent) must be > 0, got -1"),
    "tol-full-order": (["spinup", "--omega", "4", "--tol", "1"], "--tol chooses a reduced basis; use it with"),
    "estimate-method-full-order": (["spinup", "--omega", "4", "--estimate-method", "dynamic"],
                                   "--estimate-method and --estimate-integration estimate a reduced run's error"),
    "estimate-integration-full-order": (["spinup", "--omega", "4", "--estimate-integration"],
                                        "--estimate-method and --estimate-integration estimate a reduced run's"),
    "membrane-estimate-integration-full-order": (["membrane", "--formulation", "rncf", "--estimate-integration"],
                                                 "--estimate-integration estimates a reduced run's error; use it with"),
    "truss-estimate-integration-full-order": (["truss", "dynamics", "--formulation", "rncf", "--estimate-integration"],
                                              "--estimate-integration estimates a reduced run's error; use it with"),
    "estimate-samples-one": (["spinup", "--formulation", "nr-rncf", "--omega", "4", "--estimate-samples", "1"],
                             "--estimate-samples must be >= 2, got 1"),
    "estimate-samples-full-order": (["membrane", "--formulation", "rncf", "--estimate-samples", "8"],
                                    "--estimate-samples goes with --formulation nr-rncf"),
    "estimate-samples-dynamic": (["truss", "dynamics", "--estimate-method", "dynamic", "--estimate-samples", "8"],
                                 "--estimate-samples sets the static estimate's samples"),
    "estimate-samples-no-estimate": (["pendulum", "--formulation", "nr-rncf", "--no-estimate", "--estimate-samples",
                                      "8"], "--estimate-samples sets the error estimate's samples; leave out"),
    "truss-tol-full-order": (["truss", "dynamics", "--formulation", "rncf", "--tol", "1"],
                             "--reference, --tol and --estimate-method go with --formulation nr-rncf"),
    "membrane-tol-zero": (["membrane", "--tol", "0"], "--tol (target chi_rel in per cent) must be > 0, got 0"),
    "spinup-out-dir": (["spinup", "--omega", "10", "--out", MISSING + "tip.csv"],
                       f"--out {MISSING}tip.csv: the directory /nonexistent/dir does not exist"),
    "spinup-plot-dir": (["spinup", "--omega", "10", "--plot", MISSING + "tip.png"], "/nonexistent/dir does not exist"),
    "spinup-out-is-a-directory": (["spinup", "--omega", "10", "--out", "."], "--out . is a directory"),
    "modes-plot-dir": (["modes", "--mmi", "--omega", "4", "--plot", MISSING + "mmi.png"], "does not exist"),
    "identify-plot-dir": (["identify", "--demo", "--plot", MISSING + "fit.png"], "does not exist"),
    "sweep-out-dir": (["sweep", "--omega", "2:40:4", "--out", MISSING + "sweep.csv"], "does not exist"),
    "sweep-plot-dir": (["sweep", "--omega", "2:40:4", "--plot", MISSING + "sweep.png"], "does not exist"),
    "rtol-too-large": (["spinup", "--omega", "10", "--rtol", "5"], "--rtol (relative tolerance) must be < 1"),
    "rtol-one": (["sweep", "--omega", "2:40:4", "--rtol", "1"], "--rtol (relative tolerance) must be < 1"),
    "rtol-zero": (["spinup", "--omega", "10", "--rtol", "0"], "--rtol (relative tolerance) must be > 0, got 0"),
    "rtol-negative": (["sweep", "--omega", "2:40:4", "--rtol=-1e-4"],
                      "--rtol (relative tolerance) must be > 0, got -0.0001"),
    "omega-negative": (["spinup", "--omega", "-5"], "--omega (steady spin rate) must be > 0, got -5"),
    "omega-nan": (["spinup", "--omega", "nan"], "--omega (steady spin rate) must be finite and > 0, got nan"),
    "modes-omega-negative": (["modes", "--mmi", "--omega", "-5"], "--omega (steady spin rate) must be > 0, got -5"),
    "range-reversed": (["sweep", "--omega", "40:2:4"], "--omega: the start of '40:2:4' must be smaller than its stop"),
    "range-count-zero": (["sweep", "--omega", "2:40:0"], "--omega: the count in '2:40:0' must be an integer >= 1"),
    "range-count-fraction": (["sweep", "--omega", "2:40:2.5"], "the count in '2:40:2.5' must be an integer >= 1"),
    "range-negative-values": (["sweep", "--omega=-4:2:3"], "--omega (steady spin rates omega_s) must be finite and"),
    "ts-range-reversed": (["sweep", "--omega", "4", "--ts", "20:10:3"], "--ts: the start of '20:10:3'"),
    "flag-typo": (["spinup", "--omgea", "10"], "unrecognized arguments: --omgea 10; did you mean --omega?"),
    "flag-typo-sweep": (["sweep", "--omega", "2:4:2", "--devcies", "2"], "unrecognized arguments: --devcies 2"),
    "t-end-negative": (["spinup", "--omega", "10", "--t-end", "-1"], "--t-end (end time) must be > 0, got -1"),
    "dt-out-beyond-t-end": (["spinup", "--omega", "10", "--t-end", "1", "--dt-out", "2"], "must not exceed --t-end"),
    "elements-zero": (["modes", "--elements", "0"], "--elements must be >= 1, got 0"),
    "reference-without-reduction": (["spinup", "--omega", "10", "--reference", "rncf"], "--formulation nr-rncf"),
    "identify-without-demo": (["identify"], "only the demonstration"),
    "identify-seed-negative": (["identify", "--demo", "--seed", "-1"], "--seed must be >= 0, got -1"),
    "sweep-devices-zero": (["sweep", "--omega", "4", "--devices", "0"], "--devices must be >= 1, got 0"),
    "missing-omega": (["spinup"], "the following arguments are required: --omega"),
}


@pytest.mark.parametrize("argv, message", BAD_INPUT.values(), ids=BAD_INPUT.keys())
def test_bad_input_gets_one_line_before_any_work(argv, message, capsys, monkeypatch):
    """Exit status 2 and one line ``nrrncf: error: ...`` naming the problem, before anything runs or
    is printed about the run (the run itself is replaced by a trap)."""

    def trap(args):
        raise AssertionError(f"the run started for bad input {argv}")

    monkeypatch.setattr(cli, "_run", trap)
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == ""  # no header describing the run
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("nrrncf: error: "), err
    assert message in lines[0]


def test_typo_of_a_required_flag_is_reported_as_the_typo(capsys):
    assert main(["spinup", "--omgea", "10"]) == 2
    err = capsys.readouterr().err
    assert "--omgea" in err and "required" not in err


def test_error_message_names_its_value_once(capsys):
    assert main(["spinup", "--omega", "-5"]) == 2
    err = capsys.readouterr().err
    assert err == "nrrncf: error: --omega (steady spin rate) must be > 0, got -5\n"
    # the library's own message, at its source
    with pytest.raises(ValueError, match=r"^omega \(steady spin rate\) must be > 0, got -5$"):
        build_spinup_model("rncf", "paper", -5.0)


def test_help_and_argument_errors_do_not_start_jax():
    """``--help`` of every subcommand and an argument error, in a fresh process: JAX never imported."""
    code = """if True:
        import contextlib, io, sys
        from nrrncf_jax.cli import SUBCOMMANDS, build_parser, main
        build_parser()
        for argv in [["--help"]] + [[name, "--help"] for name in SUBCOMMANDS]:
            with contextlib.redirect_stdout(io.StringIO()) as out:
                assert main(argv) == 0
            assert "usage: nrrncf" in out.getvalue()
        with contextlib.redirect_stderr(io.StringIO()) as err:
            assert main(["spinup", "--omega", "-5"]) == 2
            assert main(["sweep", "--omega", "40:2:4"]) == 2
            assert main(["spinup", "--omgea", "10"]) == 2
        assert len(err.getvalue().splitlines()) == 3
        import nrrncf_jax
        print(sorted(m for m in sys.modules if m == "jax" or m.startswith(("jax.", "jaxlib"))))
    """
    env = {k: v for k, v in os.environ.items() if k != "JAX_ENABLE_X64"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"  # so help and argument errors cost no JAX start-up (seconds)


def test_every_option_has_help_and_shows_its_default():
    parser = build_parser()
    subs = next(a.choices for a in parser._actions if a.dest == "command")
    for name, sub in subs.items():
        for action in sub._actions:
            assert action.help and action.help.strip(), f"nrrncf {name} {action.option_strings} has no help"
    assert "relative tolerance of the step control, in (0, 1) (default: 0.0001)" in " ".join(
        subs["spinup"].format_help().split())
    assert "seed of the noise" in subs["identify"].format_help()
    assert "0-based" in subs["modes"].format_help() and "0-based" in subs["spinup"].format_help()


def test_progress_lines_go_to_stderr_only_when_asked(capsys):
    """``_progress.note``: one line on standard error when enabled (standard output keeps a
    command's results, e.g. its ``--json`` object), nothing otherwise."""
    from nrrncf_jax._progress import note

    note(True, "compiling")
    note(False, "quiet")
    out, err = capsys.readouterr()
    assert out == "" and len(err.splitlines()) == 1 and "compiling" in err


def test_beam_names_are_the_presets():
    assert BEAM_NAMES == tuple(sorted(BEAMS))


def test_estimate_methods_are_the_library_s():
    from nrrncf_jax.reduction.error_estimate import METHODS

    assert ESTIMATE_METHODS == METHODS


def test_basis_summary_accounts_for_every_coordinate():
    spin = SpinCheck(40.0, 0, 8.51, 8.69, True, (0,), ((0, 0), (0, 1), (0, 2), (1, 1)))
    red = Reduction(model=SimpleNamespace(n_dof=14), omega=None, selection=None, n_vms=3, n_mds=6, offline_s={},
                    spin=spin)
    assert red.describe() == ("14 DOFs (3 VMs + 6 MDs + 5 spinning-state vectors: "
                              "1 spinning mode + 4 MDs of spinning modes)")
    red = Reduction(model=SimpleNamespace(n_dof=8), omega=None, selection=None, n_vms=3, n_mds=6, offline_s={})
    assert red.describe() == "8 DOFs (3 VMs + 6 MDs; 1 removed by the SVD deflation)"
