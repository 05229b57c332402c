"""Multibody systems (``multibody``, ``integrate.GeneralizedAlphaIndex3``): ANCF beams joined by
joints, index-3 generalized-α.

- A stiff beam hinged at one end, released horizontally, swings with the compound pendulum's
  exact large-amplitude period (elliptic integral).
- The three-beam pendulum of the paper (coarse) conserves energy with ρ∞ = 1 and keeps its
  joints closed; its run's views (tips, transverse deflections) and the ``nrrncf pendulum``
  command.
- The multipliers are the joints' reactions: the momentum balance of the whole chain.
- Bad systems are refused before anything is traced.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import EPS, PENDULUM_RUN, RTOL_ROUNDOFF, pendulum_run_options
from scipy.special import ellipk

from nrrncf_jax.bodies.body import beam_body
from nrrncf_jax.bodies.mesh import straight_reference
from nrrncf_jax.elements.material import Material
from nrrncf_jax.elements.section import TubeSection
from nrrncf_jax.integrate import (
    AdaptiveStepSize,
    GeneralizedAlpha,
    GeneralizedAlphaIndex3,
    simulate,
)
from nrrncf_jax.multibody import Fixed, Marker, MultibodySystem, Spherical, hinge, placed
from nrrncf_jax.reduction import ErrorEstimator
from nrrncf_jax.scenarios.pendulum import PendulumBasis, PendulumSpec, build_pendulum

G = 9.81


def _beam(E=5e10, elements=2, length=1.0):
    return beam_body(Material(E, 1100.0, 0.3), TubeSection(0.005), straight_reference(length, elements))


def test_stiff_hinged_beam_has_the_compound_pendulums_exact_period():
    """Released from the horizontal, a rigid rod of length L hinged at one end swings with
    T = 4 √(2L/3g) K(sin²45°) (K the complete elliptic integral of the first kind, parameter m).
    A 5 mm steel-stiff rod deflects by micrometres, so what is left is the integrator's error:
    5.1e-4, 4.3e-5 and 3e-6 at rtol = atol = 1e-4, 1e-5 and 1e-6 (it follows the tolerance)."""
    beam = _beam()
    system = MultibodySystem([beam], [hinge(None, Marker(0, (0.0, 0.0, 0.0)), (0.0, 0.0, 1.0))],
                             gravity=(0.0, -G, 0.0))
    tip = beam.n_vectors - 6
    ts = jnp.linspace(0.0, 1.6, 1601)
    sol = simulate(system, GeneralizedAlphaIndex3(0.5), AdaptiveStepSize(1e-5, 1e-5), ts,
                   observe=lambda t, x, v: x.reshape(-1, 3)[tip])
    x = np.asarray(sol.ys)[:, 0]
    t = np.asarray(ts)
    i = np.flatnonzero(np.diff(np.sign(x)) != 0)  # the tip passes below the hinge: T/4 and 3T/4
    crossings = t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])
    T = 2.0 * (crossings[1] - crossings[0])
    T_exact = 4.0 * np.sqrt(2.0 * 1.0 / (3.0 * G)) * ellipk(0.5)
    assert len(crossings) == 2 and abs(T / T_exact - 1.0) < 2e-4, (T, T_exact)


def _as_flags(kw: dict) -> dict:
    """``run_pendulum``'s keywords as the command's flags gave them: the solver's ρ∞, the
    controller's tolerances and name (``integrate.step_control_name``) in place of the objects."""
    from nrrncf_jax.integrate import step_control_name

    out = {k: v for k, v in kw.items() if k not in ("solver", "controller")}
    if "solver" in kw:
        out["rho_inf"] = float(kw["solver"].rho_inf)
    if "controller" in kw:
        c = kw["controller"]
        out |= {"rtol": float(c.rtol), "atol": float(c.atol), "step_control": step_control_name(c)}
    return out


@pytest.mark.slow
@pytest.mark.xdist_group("pendulum")
def test_pendulum_conserves_energy_and_keeps_its_joints(pendulum_run):
    run = pendulum_run
    drift = np.abs(run.energy - run.energy[0]).max()
    # Generalized-α with ρ∞ = 1 conserves the energy of linear problems exactly; what is left
    # is of the order of the step's error tolerance (1e-5 relative) times the energy scale.
    assert drift < 1e-4 * run.kinetic.max(), (drift, run.kinetic.max())
    # The chain falls and bends in its plane.
    assert run.tips[-1, 2, 1] < -0.3 and np.abs(run.nodes[..., 2]).max() < 1e-9
    # The joints at the end of a step (the last output is one): closed to the size of the last
    # Newton correction, newton_tol (1e-3) times the error tolerance atol + rtol |x| (|x| <= 3 m).
    assert run.violation[-1] < 1e-3 * (1e-6 + 1e-5 * 3.0), run.violation[-1]
    # The first hinge stays at the origin, the right ends stay one beam length from their left
    # ends to within the beams' stretch (E = 5 MPa: a strain of a few 1e-4 under their weight).
    assert np.abs(run.nodes[:, 0, 0]).max() < 1e-6
    np.testing.assert_allclose(np.linalg.norm(run.tips - run.nodes[:, :, 0], axis=-1), 1.0, atol=0.05)
    np.testing.assert_allclose(run.nodes[:, 1:, 0], run.nodes[:, :-1, -1], atol=1e-6)


def test_pendulum_run_views():
    """``transverse_deflections``: zero for straight beams in any orientation, the tip's distance
    from the left end's tangent line otherwise, positive to the left; ``table``: t, x1, y1, ..."""
    from nrrncf_jax.scenarios.pendulum import PendulumRun

    s = np.linspace(0.0, 1.0, 3)
    phi = np.array([0.0, 0.7, -2.0])  # three straight chains at three angles
    e = np.stack([np.cos(phi), np.sin(phi), 0.0 * phi], -1)  # (nt, 3)
    nodes = np.stack([np.stack([(b + s)[:, None] * e[k] for b in range(2)]) for k in range(3)])  # (3, 2, 3, 3)
    slopes = np.repeat(e[:, None], 2, axis=1)
    z = np.zeros(3)
    run = PendulumRun(formulation="ancf", dofs=0, ts=np.arange(3.0), nodes=nodes, left_slopes=slopes, energy=z,
                      kinetic=z, violation=z, steps=0, rejected=0, newton_iters=0, compile_s=0.0, run_s=0.0)
    np.testing.assert_allclose(run.transverse_deflections, 0.0, atol=1e-15)
    bent = nodes.copy()
    bent[:, :, -1] += 0.1 * np.stack([-np.sin(phi), np.cos(phi), 0.0 * phi], -1)[:, None]  # 0.1 to the left
    run = PendulumRun(formulation="ancf", dofs=0, ts=np.arange(3.0), nodes=bent, left_slopes=slopes, energy=z,
                      kinetic=z, violation=z, steps=0, rejected=0, newton_iters=0, compile_s=0.0, run_s=0.0)
    np.testing.assert_allclose(run.transverse_deflections, 0.1, atol=1e-15)
    assert run.table_header() == "t,x1,y1,x2,y2"
    np.testing.assert_allclose(run.table()[1], [1.0, *bent[1, 0, -1, :2], *bent[1, 1, -1, :2]])


@pytest.mark.slow
@pytest.mark.xdist_group("pendulum")
def test_floating_frame_pendulum_runs_with_the_ancf_one(pendulum_run):
    """The full-order RNCF pendulum (``build_rncf_pendulum``: each beam in the frame of its left
    end, every other nodal coordinate kept) is the ANCF model in other coordinates, so the two
    runs differ by their time-integration errors alone: at rtol 1e-5 the tips agree to 9.6e-6 m
    over 0-0.4 s (1.0e-5 m in the section vectors' frame, ``LEFT_SECTION_FRAME``), and each
    model's own error there (against itself at rtol 1e-7) is 9.6e-6 m (ANCF) and 1.3e-5 m (RNCF);
    the bound 1e-4 m is 8× those, and a model that holds the section vectors entirely (the NR-RNCF
    cantilever clamp, ``REFERENCE_CONDITIONS``) misses it (3.4e-4 m). Energy (ρ∞ = 1) and the
    joints as the ANCF run's. A frame of other than six conditions is refused."""
    from nrrncf_jax.scenarios.pendulum import LEFT_END_FRAME, build_rncf_pendulum, run_pendulum

    with pytest.raises(ValueError, match="six distinct"):
        build_rncf_pendulum(PendulumSpec(elements=2), frame=LEFT_END_FRAME[:5] + LEFT_END_FRAME[:1])
    run = run_pendulum(PendulumSpec(elements=2), formulation="rncf", **pendulum_run_options(PENDULUM_RUN))
    assert run.formulation == "rncf" and run.dofs == 3 * (7 + 54 - 6)
    assert np.abs(run.tips - pendulum_run.tips).max() < 1e-4
    assert np.abs(run.energy - run.energy[0]).max() < 1e-4 * run.kinetic.max()
    assert run.constraint_max < 1e-8


@pytest.mark.slow
def test_the_reduced_chains_integration_error_estimate_meets_the_measured_one():
    """``run_pendulum(estimator=ErrorEstimator(integration=True))`` (issue 61), the coarse chain
    (``PENDULUM_RUN``: 2 elements a beam, 0-0.4 s, ρ∞ = 1, rtol 1e-5) with 3 VMs and their MDs a
    beam: the run repeated at rtol/10 (``TIGHTEN``) estimates its own time-integration error,
    and the summary's total estimate is the basis part plus it. Measured against the chain at
    rtol/100, over every node (the reduced bodies' position vectors, the norm of
    ``integration_error_percent``): the estimate is within a factor 2 of it (measured 2.9e-3 %,
    estimated 2.4e-3 %: the repetition's own error, a tenth of the run's, is left in it), and so
    is each beam's right end's (``integration_error_estimate_percent_tip<k>``)."""
    from nrrncf_jax.integrate import tightened
    from nrrncf_jax.post.metrics import chi_rel
    from nrrncf_jax.scenarios.pendulum import run_pendulum

    options = pendulum_run_options(PENDULUM_RUN)
    kw = dict(formulation="nr-rncf", basis=PendulumBasis(3))
    run = run_pendulum(PendulumSpec(elements=2), estimator=ErrorEstimator(integration=True), **kw, **options)
    s = run.summary()
    assert s["chi_rel_estimate_percent"] == pytest.approx(
        s["basis_error_estimate_percent"] + s["integration_error_estimate_percent"], rel=1e-12, abs=0)
    assert s["integration_error_estimate_percent"] > 0 and s["estimate_reliable"]
    converged = run_pendulum(PendulumSpec(elements=2), **kw,
                             **options | dict(controller=tightened(options["controller"], 100)))

    def measured(w, w_ref):  # χ_rel of the displacements from the first output (the same state in both)
        return float(chi_rel(w_ref - w_ref[:1], w - w[:1]))

    ratio = s["integration_error_estimate_percent"] / measured(run.nodes, converged.nodes)
    assert 0.5 < ratio < 2, ratio
    for k in range(3):
        ratio = s[f"integration_error_estimate_percent_tip{k + 1}"] / measured(run.tips[:, k], converged.tips[:, k])
        assert 0.5 < ratio < 2, (k, ratio)
        # each tip's total: its basis part (the estimate's sensors) and its integration part
        parts = s[f"basis_error_estimate_percent_tip{k + 1}"], s[f"integration_error_estimate_percent_tip{k + 1}"]
        assert parts[0] > 0 and s[f"chi_rel_estimate_percent_tip{k + 1}"] == pytest.approx(sum(parts), rel=1e-12)


def _swinging_run():
    """A made-up run of the pendulum's shape (3 straight beams of 2 elements, 0-0.4 s every
    0.01 s): the chain turning about the hinge, with made-up statistics."""
    from nrrncf_jax.scenarios.pendulum import PendulumRun

    ts = np.linspace(0.0, 0.4, 41)
    phi = -0.5 * (ts / 0.4) ** 2  # falling from the horizontal
    e = np.stack([np.cos(phi), np.sin(phi), 0.0 * phi], -1)  # (nt, 3)
    s = np.linspace(0.0, 1.0, 3)
    nodes = (np.arange(3)[:, None] + s)[None, :, :, None] * e[:, None, None, :]  # (nt, beams, nodes, 3)
    kinetic = 5.0 * (ts / 0.4) ** 2
    return PendulumRun(formulation="ancf", dofs=162, ts=ts, nodes=nodes, left_slopes=np.repeat(e[:, None], 3, 1),
                       energy=kinetic - kinetic, kinetic=kinetic, violation=np.full(41, 1e-9), steps=40, rejected=1,
                       newton_iters=93, compile_s=1.5, run_s=0.25)


def test_pendulum_command(tmp_path, monkeypatch, capsys):
    """``nrrncf pendulum``: its options reach ``run_pendulum`` and its outputs are written, here
    from a made-up run (the simulations are tested above and in test_floating). An NR-RNCF run
    compared with its reference reports χ_rel and the speed-up of the two: made up with 1.5 times
    the reference's displacements and half its run time, 50 % and 2."""
    import dataclasses
    import json

    from nrrncf_jax.cli import main
    from nrrncf_jax.scenarios import pendulum

    calls = []
    pendulum_run = _swinging_run()

    def fake_run(spec, **kw):
        calls.append((spec, kw))
        formulation = kw.get("formulation", "ancf")
        if formulation != "nr-rncf":
            return dataclasses.replace(pendulum_run, formulation=formulation)
        nodes = pendulum_run.nodes
        return dataclasses.replace(pendulum_run, formulation=formulation, nodes=nodes[0] + 1.5 * (nodes - nodes[0]),
                                   run_s=pendulum_run.run_s / 2)

    monkeypatch.setattr(pendulum, "run_pendulum", fake_run)
    out = tmp_path / "tips.csv"
    argv = ["pendulum", "--elements", "2", "--t-end", "0.4", "--dt-out", "0.01", "--rho-inf", "1", "--rtol", "1e-5",
            "--atol", "1e-6", "--out", str(out), "--plot", str(tmp_path / "p.png"), "--animate",
            str(tmp_path / "p.gif"), "--vtk", str(tmp_path / "vtk"), "--json"]
    assert main(argv) == 0
    (spec, kw), = calls
    assert spec == PendulumSpec(elements=2)
    assert _as_flags(kw) == dict(PENDULUM_RUN, progress=False, step_control="plain", error_on="nodes")
    d = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    for key in ("dofs", "steps", "newton_iters", "compile_s", "run_s"):
        assert d[key] == pendulum_run.summary()[key]
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    assert open(out).readline().strip() == "t,x1,y1,x2,y2,x3,y3"
    np.testing.assert_allclose(table[:, 1:], pendulum_run.tips[:, :, :2].reshape(len(table), -1), rtol=1e-8, atol=1e-9)
    assert (tmp_path / "p.png").stat().st_size > 0 and (tmp_path / "p.gif").stat().st_size > 0
    assert (tmp_path / "vtk" / "series.pvd").exists() and len(list((tmp_path / "vtk").glob("*.vtu"))) == len(table)
    # NR-RNCF against the full model: χ_rel of 1.5 times the reference's displacements is 50 % (of
    # the reference's: the other way round it would be 33 %), and half the run time a speed-up of 2
    calls.clear()
    assert main(argv[:-9] + ["--formulation", "nr-rncf", "--vms", "3", "--mds", "none", "--joint-modes",
                             "--reference", "ancf", "--json"]) == 0
    # the run, the full model converged (at a tenth and a hundredth of the tighter of its default
    # rtol and the run's), and the reduced chain again at a hundredth of its rtol
    assert [kw.get("formulation", "ancf") for _, kw in calls] == ["nr-rncf", "ancf", "ancf", "nr-rncf"]
    np.testing.assert_allclose([_as_flags(kw)["rtol"] for _, kw in calls], [1e-5, 1e-6, 1e-7, 1e-7], rtol=1e-12)
    assert calls[0][1]["basis"] == PendulumBasis(3, pairs=(), joint_modes=True)
    assert calls[0][1]["estimator"] == ErrorEstimator(method="static")  # by default
    assert calls[3][1]["estimator"] is None and calls[3][1]["basis"].n_vms == 3
    d = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert d["chi_rel_percent"] == pytest.approx(50.0, rel=RTOL_ROUNDOFF) and d["speedup"] == pytest.approx(2.0)
    assert d["reference_dofs"] == pendulum_run.dofs and d["reference_converged"]
    assert d["reference_error_percent"] == 0.0 and d["integration_error_percent"] == 0.0  # made-up runs
    assert d["basis_error_percent"] == pytest.approx(50.0, rel=RTOL_ROUNDOFF)
    # the converged reference at its own tolerance (and ten times it), its atol scaled alike
    calls.clear()
    assert main(argv[:-9] + ["--formulation", "nr-rncf", "--craig-bampton", "--reference", "ancf",
                             "--reference-rtol", "1e-6", "--json"]) == 0
    assert calls[0][1]["basis"].craig_bampton is True and calls[0][1]["basis"].joint_modes is False
    np.testing.assert_allclose([(_as_flags(kw)["rtol"], _as_flags(kw)["atol"]) for _, kw in calls[:3]],
                               [(1e-5, 1e-6), (1e-5, 1e-6), (1e-6, 1e-7)], rtol=1e-12)
    assert json.loads(capsys.readouterr().out.strip().splitlines()[-1])["reference_rtol"] == pytest.approx(1e-6)
    calls.clear()
    assert main(argv[:-9] + ["--formulation", "nr-rncf", "--estimate-method", "dynamic", "--json"]) == 0
    assert calls[0][1]["estimator"] == ErrorEstimator(method="dynamic")
    calls.clear()
    assert main(argv[:-9] + ["--formulation", "nr-rncf", "--no-estimate", "--json"]) == 0
    assert calls[0][1]["estimator"] is None
    # --estimate-integration: off by default (above), passed on; a reduced run's estimate's
    calls.clear()
    assert main(argv[:-9] + ["--formulation", "nr-rncf", "--estimate-integration", "--json"]) == 0
    assert calls[0][1]["estimator"] == ErrorEstimator(method="static", integration=True)
    capsys.readouterr()
    for bad, says in ((["--estimate-integration"], "use it with --formulation nr-rncf"),
                      (["--formulation", "nr-rncf", "--no-estimate", "--estimate-integration"],
                       "leave out --no-estimate")):
        assert main(["pendulum"] + bad) == 2
        assert says in capsys.readouterr().err
    capsys.readouterr()
    assert main(["pendulum", "--no-estimate"]) == 2
    assert "--no-estimate go with --formulation nr-rncf" in capsys.readouterr().err
    assert main(["pendulum", "--formulation", "nr-rncf", "--reference-rtol", "1e-6"]) == 2
    assert "--reference-rtol needs --reference ancf" in capsys.readouterr().err
    assert main(["pendulum", "--formulation", "nr-rncf", "--craig-bampton", "--joint-modes"]) == 2
    assert "pass one of --joint-modes, --craig-bampton" in capsys.readouterr().err
    # the reference conditions: passed on; mean axes with the dynamic estimate only, not with Craig-Bampton
    calls.clear()
    assert main(argv[:-9] + ["--formulation", "nr-rncf", "--conditions", "mean-axis", "--estimate-method", "dynamic",
                             "--json"]) == 0
    assert calls[0][1]["basis"].conditions == "mean-axis" and calls[0][1]["estimator"].method == "dynamic"
    capsys.readouterr()
    for extra, message in ((["--formulation", "nr-rncf"], "pass --estimate-method dynamic or --no-estimate"),
                           (["--formulation", "nr-rncf", "--no-estimate", "--craig-bampton"], "not mean-axis"),
                           ([], "--conditions, --joint-modes")):
        assert main(["pendulum", "--conditions", "mean-axis"] + extra) == 2
        assert message in capsys.readouterr().err
    # the full-order floating-frame model, alone and as the reference
    calls.clear()
    assert main(argv[:-9] + ["--formulation", "rncf", "--json"]) == 0
    assert [kw.get("formulation", "ancf") for _, kw in calls] == ["rncf"]
    calls.clear()
    assert main(argv[:-9] + ["--formulation", "nr-rncf", "--reference", "rncf", "--json"]) == 0
    assert [kw.get("formulation", "ancf") for _, kw in calls] == ["nr-rncf", "rncf", "rncf", "nr-rncf"]
    capsys.readouterr()
    assert main(["pendulum", "--formulation", "rncf", "--vms", "3"]) == 2
    assert "go with --formulation nr-rncf" in capsys.readouterr().err
    assert main(["pendulum", "--vms", "3"]) == 2
    assert "go with --formulation nr-rncf" in capsys.readouterr().err
    # --tol: the basis search's choice is what runs, and its record reaches the JSON
    from nrrncf_jax.multibody.basis_to_tolerance import MechanismSearch, MechanismTrial

    trial = MechanismTrial(columns=2, items=(0, pendulum.JOINT_MODES), dofs=30, chi_rel_estimate_percent=0.2,
                           valid_until=None, reliable=True, steps=100, seconds=1.0)
    searches, chains = [], []

    def fake_search(spec, tol, **kw):
        searches.append((spec, tol, kw))
        return MechanismSearch(tol=tol, safety=2.0, met=True, trials=[trial], chosen=trial, order=[0, "joint modes"],
                               system="the chosen system", estimate=None)

    def fake_chain(system, *args, **kw):
        chains.append((system, args, kw))
        return dataclasses.replace(pendulum_run, formulation="nr-rncf")

    def fake_to_tolerance(system, tol, estimator, **kw):  # the step settings chosen: tolerances halved
        run = fake_chain(system, tol, estimator, **kw)
        run.step_tolerances = (float(kw["controller"].rtol) / 2, float(kw["controller"].atol) / 2)
        return run

    monkeypatch.setattr(pendulum, "pendulum_to_tolerance", fake_search)
    monkeypatch.setattr(pendulum, "run_chain", fake_chain)
    monkeypatch.setattr(pendulum, "chain_to_tolerance", fake_to_tolerance)
    calls.clear()
    assert main(argv[:-9] + ["--formulation", "nr-rncf", "--tol", "0.5", "--train-t", "0.3", "--vms", "4",
                             "--reference", "ancf", "--json"]) == 0
    (spec, tol, kw), = searches
    assert tol == 0.5 and kw["n_vms"] == 4 and kw["t_train"] == 0.3 and kw["t_end"] == 0.4
    assert _as_flags(kw) == dict(n_vms=4, t_train=0.3, t_end=0.4, rho_inf=1.0, rtol=1e-5, atol=1e-6,
                                 step_control="pi")  # the training runs' integrator: the run's own
    assert chains[0][0] == "the chosen system" and [c[1].get("formulation", "ancf") for c in calls] == ["ancf"] * 2
    assert len(chains) == 2 and chains[1][0] == "the chosen system" and "estimator" not in chains[1][2]
    assert chains[0][1] == (0.5, chains[0][1][1])  # chain_to_tolerance's target: the basis's
    # the converged comparison repeats the chain at a hundredth of the chosen tolerances
    assert float(chains[1][2]["controller"].rtol) == pytest.approx(1e-5 / 2 / 100)
    d = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert d["step_rtol"] == pytest.approx(5e-6) and d["step_atol"] == pytest.approx(5e-7)
    assert d["tol_met"] and d["basis_chosen"] == ["φ0", "joint modes"] and d["basis_trials"][0]["dofs"] == 30
    assert "chi_rel_percent" in d
    for bad, says in ((["--tol", "0.5"], "use it with --formulation nr-rncf"),
                      (["--formulation", "nr-rncf", "--tol", "0.5", "--joint-modes"], "leave out --mds"),
                      (["--formulation", "nr-rncf", "--tol", "-1"], "--tol"),
                      (["--formulation", "nr-rncf", "--train-t", "0.3"], "give --tol too")):
        assert main(["pendulum"] + bad) == 2
        assert says in capsys.readouterr().err


def test_pendulum_command_defaults_follow_the_formulation():
    """``nrrncf pendulum``: the reduced chain runs at rtol 1e-3 with the PI controller, the full
    models at 1e-4 with the plain one, atol a tenth of rtol; what a user gives is kept."""
    from nrrncf_jax.cli import parse

    for argv, want in ((["--formulation", "nr-rncf"], (1e-3, 1e-4, "pi")), ([], (1e-4, 1e-5, "plain")),
                       (["--formulation", "rncf"], (1e-4, 1e-5, "plain")),
                       (["--formulation", "nr-rncf", "--rtol", "1e-5", "--step-control", "plain"],
                        (1e-5, 1e-6, "plain")),
                       (["--rtol", "1e-3", "--atol", "1e-2"], (1e-3, 1e-2, "plain"))):
        a = parse(["pendulum"] + argv)
        assert (a.rtol, a.step_control) == (want[0], want[2]) and a.atol == pytest.approx(want[1], rel=1e-15), argv


def test_multipliers_are_the_reactions():
    """The chain's momentum balance: Σ_bodies Σ_α ϱ_α a_α = m g + R, where R = −λ[:3] is the ground
    hinge's force on the chain (the hinges between beams cancel in pairs). At a moving state. And
    ``constraint_force`` is C_xᵀλ."""
    spec = PendulumSpec(elements=2)
    system = build_pendulum(spec)
    x0 = system.reference()
    key = jax.random.PRNGKey(0)
    v = 0.3 * jax.random.normal(key, x0.shape)
    # a velocity field that respects the joints: project onto the null space of C_x
    B = np.asarray(system.constraint_jacobian(x0))
    v = np.asarray(v) - B.T @ np.linalg.solve(B @ B.T, B @ np.asarray(v))
    a, lam = system.consistent_accelerations(0.0, x0, jnp.asarray(v))
    C_ddot = system.constraint_jacobian(x0) @ a + system.constraint_acceleration(x0, jnp.asarray(v))
    scale = float(np.abs(np.asarray(a)).max())
    assert np.abs(np.asarray(C_ddot)).max() < 1e-9 * scale
    # C_xᵀλ by the reverse-mode product Newton uses, against the formed Jacobian (round-off)
    np.testing.assert_allclose(system.constraint_force(x0, lam), B.T @ np.asarray(lam), rtol=0,
                               atol=1e-13 * float(np.abs(B).max() * np.abs(np.asarray(lam)).sum()))
    momentum_rate = sum(np.asarray(b.body.varrho()) @ np.asarray(q) for b, q in zip(system.bodies,
                                                                                     system.nodal_vectors(a)))
    m = sum(float(b.body.mass) for b in system.bodies)
    R = -np.asarray(lam)[:3]
    np.testing.assert_allclose(momentum_rate, m * np.array([0.0, -G, 0.0]) + R, rtol=0, atol=1e-9 * m * G)


def test_bad_systems_are_refused():
    beam = _beam()
    pin = hinge(None, Marker(0, (0.0, 0.0, 0.0)), (0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="refers to body 1"):
        MultibodySystem([beam], [pin, Spherical(1, 0)])
    with pytest.raises(ValueError, match="refers to nodal vector 99"):
        MultibodySystem([beam], [Spherical(0, 99)])
    with pytest.raises(ValueError, match=r"bodies \[1\] are held by no joint"):
        MultibodySystem([beam, placed(beam, translation=(2.0, 0.0, 0.0))], [pin])
    with pytest.raises(ValueError, match="redundant"):
        MultibodySystem([beam], [Spherical(0, 0), Spherical(0, 0)])
    with pytest.raises(ValueError, match="violates joint equations"):
        MultibodySystem([beam], [Spherical(0, 0, point=(0.0, 1.0, 0.0))])
    with pytest.raises(ValueError, match="proper 3 × 3 rotation"):
        placed(beam, rotation=np.diag([1.0, 1.0, -1.0]))
    system = MultibodySystem([beam], [Fixed(0, [0, 1, 2, 4], values=np.asarray(beam.q_hat)[[0, 1, 2, 4]])])
    with pytest.raises(ValueError, match="needs a constrained solver"):
        simulate(system, GeneralizedAlpha(0.9), AdaptiveStepSize(), jnp.array([0.0, 0.1]))


def test_body_by_body_solver_matches_the_dense_one():
    """``factor_augmented``: each body's S factored apart (block-tridiagonal) and the joints by
    their Schur complement solve the same system as one dense LU of ``[[S, C_xᵀ], [C_x, 0]]``
    (the Schur form leaves the joints' Hessian out, so the dense matrix here does too), to
    round-off: ε times the condition number of the augmented matrix."""
    system = build_pendulum(PendulumSpec(elements=2))
    assert all(b.structured for b in system.bodies)  # each beam factored by its block-tridiagonal solver
    x = system.reference() + 1e-3 * jax.random.normal(jax.random.PRNGKey(1), (system.n_dof,))
    m = system.n_constraints
    F = jax.random.normal(jax.random.PRNGKey(2), (system.n_dof + m,))
    c_C, c_K = 0.01, 2.5e-5  # a step of about 0.01 s
    @jax.jit
    def both(x, F):
        v = jnp.zeros_like(x)
        z = system.factor_augmented(0.0, x, v, jnp.zeros(m), c_C, c_K).solve(F)
        B = system.constraint_jacobian(x)
        S = system.iteration_matrix(0.0, x, v, 1.0, c_C, c_K)
        return z, jnp.block([[S, B.T], [B, jnp.zeros((m, m))]])

    z, A = both(x, F)
    A = np.asarray(A)
    z_dense = np.linalg.solve(A, np.asarray(F))
    bound = 10 * EPS * np.linalg.cond(A) * np.abs(z_dense).max()
    assert np.abs(np.asarray(z) - z_dense).max() < bound
