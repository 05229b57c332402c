"""``nrrncf run``: a model file of the user's own and a bundled example, end to end (in process)."""

import inspect
import json

import numpy as np
import pytest

from nrrncf_jax.cli import main
from nrrncf_jax.examples import slider_crank

MODEL = '''
import numpy as np
from nrrncf_jax.bodies import slender_rod
from nrrncf_jax.multibody import Marker, Mechanism, hinge
from nrrncf_jax.multibody.sensors import Energy, Position
from nrrncf_jax.scenarios.mechanism_file import MechanismSetup


def mechanism(length=1.0, angle=0.3):
    end = (length * np.sin(angle), -length * np.cos(angle), 0.0)
    rod = slender_rod(1.0, length, (0.0, 0.0, 0.0), end)
    system = Mechanism([rod], [hinge(None, Marker(0, (0.0, 0.0, 0.0)), (0.0, 0.0, 1.0))], gravity=(0.0, -9.81, 0.0))
    return MechanismSetup(system, {"tip": Position(Marker(0, end)), "E": Energy()}, t_end=0.5, rtol=1e-6)
'''


@pytest.mark.slow
def test_run_a_model_file(tmp_path, capsys):
    """A rigid pendulum from a user's file: the CSV has t, the tip's three components and the
    energy, which the run conserves to its tolerance; the JSON has the run's statistics."""
    path = tmp_path / "pendulum.py"
    path.write_text(MODEL)
    out = tmp_path / "run.csv"
    vtk, gif = tmp_path / "vtk", tmp_path / "run.gif"
    assert main(["run", str(path), "--param", "length=0.5", "--out", str(out), "--json", "--n-out", "11",
                 "--vtk", str(vtk), "--animate", str(gif)]) == 0
    record = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert record["dofs"] == 7 and record["steps"] > 0 and record["formulation"] == "rigid"
    assert {"compile_s", "run_s", "newton_iters"} <= set(record)
    header = out.read_text().splitlines()[0].split(",")
    assert header == ["t", "tip_0", "tip_1", "tip_2", "E"]
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    assert table.shape == (11, 5)
    np.testing.assert_allclose(np.linalg.norm(table[:, 1:4], axis=1), 0.5, rtol=1e-8)  # on its circle
    np.testing.assert_allclose(table[:, 4], table[0, 4], atol=1e-4 * abs(table[0, 4]))
    # the VTK series: the rod as a star from its centre of mass to its two points, at every output
    import meshio

    assert len(list(vtk.glob("*.vtu"))) == 11 and (vtk / "series.pvd").exists() and gif.stat().st_size > 0
    last = meshio.read(vtk / "t_00010.vtu")
    assert last.points.shape == (3, 3) and last.cells[0].data.shape == (2, 2)
    np.testing.assert_allclose(np.linalg.norm(last.points, axis=1)[1:], [0.0, 0.5], atol=1e-8)


def test_run_refuses_bad_arguments(tmp_path, capsys):
    assert main(["run", "slider_crank", "--param", "formulation"]) == 2
    assert "KEY=VALUE" in capsys.readouterr().err
    assert main(["run", "slider_crank", "--rtol", "5"]) == 2
    assert "--rtol" in capsys.readouterr().err
    assert main(["run", "slider_crank", "--dt", "0"]) == 2
    assert "--dt" in capsys.readouterr().err
    # a parameter the model refuses: its ValueError as one line, not a traceback
    assert main(["run", "slider_crank", "--param", "formulation=nr-rncf", "--param", "mds=0"]) == 2
    assert "mds must be" in capsys.readouterr().err
    # the estimate's settings without the estimate, and an estimate of a model without reduced bodies
    assert main(["run", "slider_crank", "--estimate-method", "static"]) == 2
    assert "add --estimate" in capsys.readouterr().err
    assert main(["run", "slider_crank", "--estimate", "--estimate-samples", "8"]) == 2  # the dynamic estimate's
    assert "static estimate's samples" in capsys.readouterr().err
    assert main(["run", "slider_crank", "--param", "formulation=rigid", "--estimate", "--no-progress"]) == 2
    assert "no NR-RNCF body" in capsys.readouterr().err
    # a target: error-controlled steps only, and the time-integration part it needs
    assert main(["run", "slider_crank", "--tol", "0"]) == 2
    assert "--tol must be > 0" in capsys.readouterr().err
    assert main(["run", "slider_crank", "--tol", "1", "--dt", "1e-4"]) == 2
    assert "fixed step" in capsys.readouterr().err
    assert main(["run", "slider_crank", "--tol", "1", "--no-estimate-integration"]) == 2
    assert "time-integration error" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.xdist_group("crank_cli")  # one worker: the --tol test below reuses this one's compiled runs
def test_reference_full_reports_the_error_against_a_converged_reference_and_its_parts(capsys):
    """``--reference full``: the total error against the full model run at a hundredth of the
    tolerance, split into the run's time-integration error and the basis's. The parts bound the
    total by the triangle inequality (χ_rel normalised by the converged reduced run in the first
    part, by the reference in the others: hence the factor 1 + basis), and the reference's own
    error is a small part of what it measures.

    With ``--estimate-integration`` (by the dynamic estimate, the command's default) the same run
    also estimates its error from reduced runs alone: its total is the sum of its parts, and on
    each compared sensor the
    total estimate and its time-integration part (from a repetition at a tenth of the tolerance)
    are the ones measured against the converged references to within the factor 2 an error bar
    allows (the estimate is first order in the basis's error; the repetition's own error is a
    tenth of the run's, and the two repetitions measure their step errors on different norms:
    the model's sensors against every nodal vector)."""
    assert main(["run", "slider_crank", "--param", "formulation=nr-rncf", "--param", "elements=2", "--t-end", "0.02",
                 "--reference", "full", "--estimate-integration", "--json", "--no-progress"]) == 0
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    total, integration, basis = (out[k] for k in ("chi_rel_percent", "integration_error_percent",
                                                   "basis_error_percent"))
    default_rtol = inspect.signature(slider_crank.mechanism).parameters["rtol"].default
    assert out["reference_rtol"] == pytest.approx(default_rtol / 100)
    assert total <= (integration * (1 + basis / 100) + basis) * (1 + 1e-9)
    assert basis <= (total + integration * (1 + basis / 100)) * (1 + 1e-9)
    assert out["reference_error_percent"] < 0.1 * total
    assert set(out) >= {"chi_rel_percent_w_mid", "integration_error_percent_x_B", "basis_error_percent_w_mid"}
    assert out["chi_rel_estimate_percent"] == pytest.approx(out["basis_error_estimate_percent"]
                                                            + out["integration_error_estimate_percent"], rel=1e-12)
    # on the rod's deformation, which is far smaller than the mechanism's motion, the same error reads larger
    assert out["chi_rel_estimate_body_1_percent"] > out["basis_error_estimate_percent"]
    # which part dominates, on the sensor of the largest estimated total
    worst = max(("w_mid", "x_B"), key=lambda k: out[f"chi_rel_estimate_percent_{k}"])
    parts = {"basis": out[f"basis_error_estimate_percent_{worst}"],
             "time integration": out[f"integration_error_estimate_percent_{worst}"]}
    assert out["estimate_dominant_part"].startswith(max(parts, key=parts.get) + " (")
    assert out["estimate_dominant_part"].endswith(f"on {worst})")
    for name in ("w_mid", "x_B"):
        for part in ("chi_rel", "integration_error"):
            ratio = out[f"{part}_estimate_percent_{name}"] / out[f"{part}_percent_{name}"]
            assert 0.5 <= ratio <= 2.0, (name, part, ratio)


@pytest.mark.slow
@pytest.mark.xdist_group("crank_cli")  # the same reduced crank's programs as the --reference full test
def test_tol_chooses_the_step_settings_and_says_what_stands_in_the_way(tmp_path, capsys):
    """``--tol P`` (``run_to_tolerance``) from a loose rtol (1e-3): the tolerances shrink until the
    estimated time-integration part on every compared sensor is at most P / 2, and the run's true
    integration error on each (against the same model at a thousandth of the chosen tolerances)
    is then at most P, which the estimate's effectivity band [0.5, 2] allows. The two-element rod's
    own basis leaves more than P / 2 on its mid-span deflection, so the target is reported not met,
    and the verdict names the basis and the sensor."""
    from nrrncf_jax.scenarios.mechanism_file import compare_sensors, load_setup, run_setup

    tol, kw, csv = 0.5, ["--t-end", "0.02"], tmp_path / "run.csv"
    assert main(["run", "slider_crank", "--param", "formulation=nr-rncf", "--param", "elements=2", *kw,
                 "--rtol", "1e-3", "--tol", str(tol), "--out", str(csv), "--json", "--no-progress"]) == 0
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert out["step_rtol"] < 1e-3 and out["step_atol"] == pytest.approx(out["step_rtol"] / 10)
    assert out["tol_percent"] == tol and out["estimate_samples"] == 201  # the dynamic estimate, every output
    for name in ("x_B", "w_mid"):
        assert out[f"integration_error_estimate_percent_{name}"] <= tol / 2
    assert out["basis_error_estimate_percent_w_mid"] > tol / 2 and not out["tol_met"]
    assert "NOT MET" in out["tol_verdict"] and "basis" in out["tol_verdict"] and "w_mid" in out["tol_verdict"]
    setup = load_setup("slider_crank", {"formulation": "nr-rncf", "elements": 2})
    table = np.genfromtxt(csv, delimiter=",", names=True)  # the run at the chosen settings, as the user gets it
    tight = run_setup(setup, t_end=0.02, controller=setup.controller(out["step_rtol"] / 1000))
    assert max(compare_sensors(setup, {k: table[k] for k in ("x_B", "w_mid")}, tight.series).values()) <= tol


def test_the_integration_repetition_is_ten_times_as_accurate():
    """The repetition that measures a run's time-integration error: tolerances a tenth, and a fixed
    step divided by √10 (generalized-α's error is second order in the step)."""
    from nrrncf_jax.integrate import AdaptiveStepSize, ConstantStepSize, tightened

    adaptive = tightened(AdaptiveStepSize(1e-4, 1e-5), 10.0)
    assert (float(adaptive.rtol), float(adaptive.atol)) == pytest.approx((1e-5, 1e-6), rel=1e-15)
    fixed = tightened(ConstantStepSize(1e-3, rtol=1e-4, atol=1e-5), 10.0)
    assert float(fixed.dt) == pytest.approx(1e-3 / np.sqrt(10.0), rel=1e-15)
    assert float(fixed.rtol) == pytest.approx(1e-5, rel=1e-15)


def test_params_are_python_literals():
    from nrrncf_jax.cli.run import _parse_params

    assert _parse_params(["a=1", "b=2.5", "c=[(0, 0), (0, 1)]", "d=nr-rncf", "e=True", "f= 3"]) == {
        "a": 1, "b": 2.5, "c": [(0, 0), (0, 1)], "d": "nr-rncf", "e": True, "f": 3}
    with pytest.raises(ValueError, match="KEY=VALUE"):
        _parse_params(["novalue"])


FAILING = '''
import jax.numpy as jnp
from nrrncf_jax.bodies import slender_rod
from nrrncf_jax.multibody import Marker, Mechanism, hinge, motor
from nrrncf_jax.multibody.sensors import Position
from nrrncf_jax.scenarios.mechanism_file import MechanismSetup


def mechanism():
    rod = slender_rod(1.0, 1.0, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    z = (0.0, 0.0, 1.0)
    torque = motor(None, Marker(0, (0.0, 0.0, 0.0)), z, lambda t, angle, rate, p: jnp.where(t > 0.05, jnp.nan, 1.0))
    system = Mechanism([rod], [hinge(None, Marker(0, (0.0, 0.0, 0.0)), z)], forces=[torque])
    return MechanismSetup(system, {"tip": Position(Marker(0, (1.0, 0.0, 0.0)))}, t_end=0.1)
'''


def test_a_run_that_stops_early_ends_in_one_line(tmp_path, capsys):
    """A motor whose torque turns NaN at t = 0.05 s: the run stops there, and the command says so
    in one line with the time and the reason (exit status 1), not in a traceback."""
    path = tmp_path / "failing.py"
    path.write_text(FAILING)
    assert main(["run", str(path), "--no-progress"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    import re

    assert len(err) == 1 and err[0].startswith("nrrncf: the simulation stopped early: simulation stopped at t = ")
    assert 0.04 < float(re.search(r"at t = ([0-9.e+-]+) s", err[0]).group(1)) <= 0.05 and "non-finite" in err[0]
