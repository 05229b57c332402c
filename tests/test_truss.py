"""The beamlike truss (issue 16) on a few bays, its time-dependent tip load, and its command.

The full truss (23,616 DOFs) runs in ``benchmarks/truss.py``; here: the layout's counts at full
size (no integrals), the symmetry of a small truss's modes, the harmonic load in the residuals, a
forced run's record (``scenarios.forced_run``, on a small beam), and one short forced run through
the command line (NR-RNCF against the full RNCF)."""

import json

import jax.numpy as jnp
import numpy as np
import pytest
from conftest import EPS, paper_body

from nrrncf_jax.cli import main
from nrrncf_jax.integrate import AdaptiveStepSize
from nrrncf_jax.models import Harmonic, Loads, RotatingFrameModel
from nrrncf_jax.motion import Stationary
from nrrncf_jax.reduction import Basis, vibration_modes
from nrrncf_jax.scenarios.truss import TrussSpec, _layout, build_truss, equivalent_beam, mode_types

SMALL = TrussSpec(bays=2)


def test_layout_has_the_papers_counts():
    """36 bays: 1092 beam elements (6 a longeron bay, 4 a batten) and 216 bars."""
    spec = TrussSpec()
    joints, longerons, battens, diagonals = _layout(spec)
    assert len(joints) == 111 and len(diagonals) == 216
    assert len(longerons) * spec.longeron_elements + len(battens) * spec.batten_elements == 1092
    # every diagonal joins adjacent stations on one face, two per face and bay, crossed
    st = np.asarray(diagonals) // 3
    assert np.all(st[:, 1] - st[:, 0] == 1)
    yz = spec.vertices()
    assert np.allclose(np.linalg.norm(yz[0] - yz[1]), spec.side) and yz[0, 1] == 0.0 and yz[0, 0] > 0


# The tests of the 2-bay truss share an xdist group: one worker builds it once (``build_truss`` is cached).
@pytest.mark.slow
@pytest.mark.xdist_group("truss_small")
def test_small_truss_modes_symmetric_and_typed():
    """The truss has the three-fold symmetry of its equilateral section, so its bending modes come
    in degenerate pairs, equal to the eigensolver's round-off (1e-8 of ω is far above it: measured
    1e-13 for this 1,584-DOF sparse problem; a joint link that also penalised the section's
    in-plane shear, which depends on the section axes, split the pair by 6e-8), and mode types
    find them; on 2 bays the first torsion mode lies below the first bending pair (measured 28.09 Hz
    against 28.59 Hz), on 36 bays far above it (benchmarks/results/truss.md)."""
    truss = build_truss(SMALL)
    model = RotatingFrameModel(truss.body, Stationary(), clamped=truss.clamped)
    modes = vibration_modes(truss.body, model.free_mask(), 6)
    w = np.asarray(modes.omega)
    types = mode_types(truss, np.asarray(modes.phi))
    assert types[0] == "torsion"
    assert w[2] / w[1] - 1 == pytest.approx(0.0, abs=1e-8)
    assert {types[1], types[2]} <= {"bending-y", "bending-z"}
    eq = equivalent_beam(TrussSpec())
    assert eq.f_bending < eq.f_bending_eb


@pytest.mark.slow
def test_small_truss_frequencies_converge_under_refinement():
    """The first torsion mode and bending pair of the 2-bay truss change by under 2e-4 from the
    paper's mesh (6 elements a longeron bay, 4 a batten) to twice as fine (measured 5.3e-5 and
    5.7e-5: the joints link the members in rotation, not in stretch, ``elements.JointLink``;
    members that share the joint's gradient over-stiffen the bending pair by 8.8e-4 here, 6e-3 on
    36 bays). The tolerance is a discretisation error's, far above the eigensolver's round-off."""
    coarse, fine = build_truss(SMALL), build_truss(TrussSpec(bays=2, longeron_elements=12, batten_elements=8))
    f = []
    for truss in (coarse, fine):
        model = RotatingFrameModel(truss.body, Stationary(), clamped=truss.clamped)
        f.append(np.asarray(vibration_modes(truss.body, model.free_mask(), 3).omega))
    assert np.all(np.abs(f[1] / f[0] - 1) < 2e-4)


def test_harmonic_point_load_in_the_residuals(paper4):
    """The residual at rest is −Q(t): the point force times sin(2π f t) on its vector, in the RNCF
    and the reduced model alike (to round-off of the force)."""
    body = paper4
    tip = body.n_vectors - body.vectors_per_node
    P = np.array([[0.0, 3.0, -1.0]])
    loads = Loads(point_vectors=[tip], point_forces=P, point_history=Harmonic(0.7, 0.3))
    full = RotatingFrameModel(body, Stationary(), loads=loads)
    q0, v0 = full.initial_state(0.0)
    t = 0.4
    r = np.asarray(full.residual(t, q0, v0, v0)).reshape(-1, 3)
    expected = -P[0] * np.sin(2 * np.pi * 0.7 * t + 0.3)
    np.testing.assert_allclose(r[tip], expected, rtol=0, atol=1e-14)
    from nrrncf_jax.reduction import reduce_rotating_model

    Psi = np.asarray(vibration_modes(body, full.free_mask(), 3).phi)
    red = reduce_rotating_model(full, Psi)
    rr = np.asarray(red.residual(t, jnp.zeros(3), jnp.zeros(3), jnp.zeros(3)))
    np.testing.assert_allclose(rr, Psi.T @ np.asarray(full.residual(t, q0, v0, v0)), rtol=0, atol=1e-12)
    # The step error measured on chosen rows of the physical coordinates: the same rows of q and Ψe.
    rows = np.arange(3, 3 * body.n_vectors, 7)
    p, e = jnp.array([0.1, -0.2, 0.3]), jnp.array([1.0, 2.0, -1.0])
    x_all, e_all, m_all = red.error_space(p, e)
    x_r, e_r, m_r = red.with_error_rows(rows).error_space(p, e)
    # Ψ[rows] p against (Ψ p)[rows]: two matrix products, whose 3-term sums may be ordered (and
    # fused) differently, each within 3ε of Σ|Ψ_ij||p_j|; q° adds its own rounding, ε|x|.
    bound = 8 * EPS * (np.abs(np.asarray(red.q_eq).reshape(-1)) + np.abs(Psi) @ np.abs(np.asarray(p)))[rows]
    assert np.all(np.abs(np.asarray(x_r) - np.asarray(x_all)[rows]) <= bound)
    e_bound = 8 * EPS * (np.abs(Psi) @ np.abs(np.asarray(e)))[rows]
    assert np.all(np.abs(np.asarray(e_r) - np.asarray(e_all)[rows]) <= e_bound)
    np.testing.assert_array_equal(np.asarray(m_r), np.asarray(m_all)[rows])
    with pytest.raises(ValueError, match="error_rows"):
        red.with_error_rows([body.n_dof])
    with pytest.raises(ValueError, match="function of time"):
        Loads(point_vectors=[tip], point_forces=P, point_history=3.0)


def test_forced_run_records_the_point_and_every_position():
    """``scenarios.forced_run.run_forced`` (the truss's and the membrane's runs) on the paper's beam
    (2 elements, full RNCF) under a harmonic tip force along y, 0-0.5 s: it starts at rest at the
    reference, the observed point is the mean displacement of its position vectors (the tip's and
    the middle node's), the position vectors are all of the body's, the DOFs its free coordinates
    (2 × 18 + 9: the root keeps 9 of its 18), and the force moves the tip along y, not along z."""
    from nrrncf_jax.scenarios.forced_run import run_forced

    body = paper_body(2)
    tip = body.n_vectors - body.vectors_per_node
    mid = tip - body.vectors_per_node
    loads = Loads(point_vectors=[tip], point_forces=[[0.0, 5.0, 0.0]], point_history=Harmonic(0.5))
    run = run_forced(RotatingFrameModel(body, Stationary(), loads=loads), "rncf", np.linspace(0.0, 0.5, 11), [tip, mid])
    positions = list(np.flatnonzero(np.asarray(body.is_position)))
    assert run.dofs == 2 * 18 + 9 and run.positions.shape == (11, len(positions), 3) and run.steps > 0
    np.testing.assert_array_equal(run.positions[0], 0.0)
    w_tip, w_mid = run.positions[:, positions.index(tip)], run.positions[:, positions.index(mid)]
    np.testing.assert_allclose(run.point, 0.5 * (w_tip + w_mid), rtol=0, atol=4 * EPS * np.abs(w_tip).max())
    assert w_tip[:, 1].max() > 0 and np.abs(w_tip[:, 2]).max() < 1e-9 * w_tip[:, 1].max()
    with pytest.raises(ValueError, match="formulation"):
        run_forced(RotatingFrameModel(body, Stationary()), "ancf", np.linspace(0.0, 0.5, 11), [tip])


def test_a_converged_reference_splits_the_error_into_its_parts():
    """``run_forced(..., reference=True)`` (the truss's and the membrane's ``--reference``) on the
    paper's beam (2 elements) under a harmonic tip force, NR-RNCF with 2 VMs and 3 MDs at the loose
    rtol 1e-2 (both parts of the error are then a few per cent or more): the reference is the full
    model at a tenth and a hundredth of the tolerances, and the run's total error against it splits
    into its time-integration part (the run against its repetition at the reference's tolerance)
    and its basis part (the repetition against the reference). The parts bound the total by the
    triangle inequality (up to the relative norms' different denominators, which differ by the
    parts themselves); the reference's own error is below a tenth of the total it measures; a
    reference given as a run is compared as it is."""
    from nrrncf_jax.scenarios.forced_run import run_forced

    body = paper_body(2)
    tip = body.n_vectors - body.vectors_per_node
    loads = Loads(point_vectors=[tip], point_forces=[[0.0, 5.0, 0.5]], point_history=Harmonic(2.0))
    full = RotatingFrameModel(body, Stationary(), loads=loads)
    ts = np.linspace(0.0, 0.5, 26)
    kw = dict(basis=Basis(n_modes=6, vms=2, mds=3, max_dofs=None), controller=AdaptiveStepSize(1e-2, 1e-5),
              estimator=None)
    run = run_forced(full, "nr-rncf", ts, [tip], reference=True, **kw)
    e = run.comparison()
    assert e["reference_converged"] and run.reference is not None and run.reference.formulation == "rncf"
    assert e["reference_rtol"] == pytest.approx(1e-4)
    total, part_i, part_b = e["chi_rel_percent"], e["integration_error_percent"], e["basis_error_percent"]
    slack = 1.0 + 1e-2 * max(part_i, part_b)  # the relative norms' denominators differ by the parts (in %)
    assert total <= (part_i + part_b) * slack and total >= abs(part_i - part_b) / slack, e
    assert part_i > 1.0 and part_b > 1.0 and e["reference_error_percent"] < 0.1 * total, e
    again = run_forced(full, "nr-rncf", ts, [tip], reference=run.reference, **kw).comparison()
    assert not again["reference_converged"] and "basis_error_percent" not in again
    assert again["chi_rel_percent"] == pytest.approx(total, rel=1e-12)
    with pytest.raises(ValueError, match="full model"):
        run_forced(full, "rncf", ts, [tip], reference=True)


TINY_TRUSS = TrussSpec(bays=1, longeron_elements=1, batten_elements=1)


@pytest.mark.xdist_group("truss_small")
def test_truss_run_estimates_its_integration_error_on_request():
    """``run_truss(estimator=ErrorEstimator(integration=True))`` (issue 61) on the smallest truss
    (1 bay, one beam element a member), NR-RNCF (its default basis) over 0-0.01 s: the estimate
    has the run's own time-integration part (against its repetition at rtol/10) beside the basis's,
    at the samples asked for, and the record's total is their sum, as ``nrrncf spinup``'s is. The
    runner checks its objects before anything runs."""
    from nrrncf_jax.integrate import ConstantStepSize
    from nrrncf_jax.reduction import ErrorEstimator
    from nrrncf_jax.scenarios.truss import run_truss

    kw = dict(t_end=0.01, dt_out=0.001)
    run = run_truss("nr-rncf", TINY_TRUSS, **kw, estimator=ErrorEstimator(integration=True, samples=4))
    s = run.summary()
    assert s["estimate_samples"] == 4 and s["integration_error_estimate_percent"] >= 0.0
    assert s["chi_rel_estimate_percent"] == pytest.approx(s["basis_error_estimate_percent"]
                                                          + s["integration_error_estimate_percent"], rel=1e-12)
    assert run.estimate.integration_percent == s["integration_error_estimate_percent"]
    for bad, says in ((dict(controller=ConstantStepSize(0.001)), "controller must be an integrate.AdaptiveStepSize"),
                      (dict(solver=0.9), "solver must be an integrate.GeneralizedAlpha"),
                      (dict(basis=10), "basis must be a reduction.Basis"),
                      (dict(estimator="static"), "estimator must be a reduction.ErrorEstimator"),
                      (dict(controller=AdaptiveStepSize(1.5, 1e-6)), "rtol must be < 1")):
        with pytest.raises(ValueError, match=says):
            run_truss("nr-rncf", TINY_TRUSS, **kw, **bad)


@pytest.mark.slow
@pytest.mark.xdist_group("truss_small")
def test_truss_dynamics_command_estimates_the_integration_error(capsys):
    """``nrrncf truss dynamics --estimate-integration`` on the smallest truss: the JSON reports the
    run's own time-integration part beside the basis's, their sum the total estimate, as ``nrrncf
    spinup --formulation nr-rncf`` does; without the flag (the default) neither is there, the
    total being the basis part; with the full model the flag is refused."""
    args = ["truss", "dynamics", "--bays", "1", "--longeron-elements", "1", "--batten-elements", "1", "--t-end",
            "0.01", "--dt-out", "0.001", "--estimate-samples", "4", "--json", "--no-progress"]
    assert main([*args, "--estimate-integration"]) == 0
    d = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert d["estimate_samples"] == 4 and d["integration_error_estimate_percent"] >= 0.0
    assert d["chi_rel_estimate_percent"] == pytest.approx(d["basis_error_estimate_percent"]
                                                          + d["integration_error_estimate_percent"], rel=1e-12)
    assert main(args) == 0
    d = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert "integration_error_estimate_percent" not in d
    assert d["chi_rel_estimate_percent"] == d["basis_error_estimate_percent"]
    assert main([*args, "--formulation", "rncf", "--estimate-integration"]) == 2


@pytest.mark.slow
@pytest.mark.xdist_group("truss_small")
def test_truss_dynamics_command(capsys, tmp_path):
    """``nrrncf truss dynamics`` on 2 bays, 0-0.02 s (half a period of this short truss's first
    bending mode, 28.6 Hz), NR-RNCF 4 VMs + 6 MDs: the JSON keys, a 10-DOF basis, a finite
    response, the plot and the VTK files. (The full-RNCF reference on the 36-bay truss and its
    χ_rel are ``benchmarks/truss.py``'s: on a 2-bay truss over a fraction of a period the VMs'
    truncation dominates χ_rel, 9 %, which says nothing about the method; and the full run costs
    a minute here.)"""
    plot = tmp_path / "tip.png"
    code = main(["truss", "dynamics", "--bays", "2", "--t-end", "0.02", "--dt-out", "0.0005", "--json",
                 "--plot", str(plot), "--vtk", str(tmp_path / "vtk")])
    assert code == 0
    d = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    for key in ("dofs", "vms", "mds", "steps", "compile_s", "run_s", "offline_s", "chi_rel_estimate_percent"):
        assert key in d
    assert d["dofs"] == 10 and len(d["vms"]) == 4 and len(d["mds"]) == 6
    assert d["chi_rel_estimate_percent"] > 0
    assert np.isfinite(d["tip_y_max_m"]) and d["tip_y_max_m"] > 0
    assert plot.stat().st_size > 0 and len(list((tmp_path / "vtk").glob("*.vtu"))) > 1
    assert main(["truss", "dynamics", "--formulation", "rncf", "--reference", "rncf"]) == 2
    assert main(["truss", "dynamics", "--formulation", "rncf", "--estimate-method", "dynamic"]) == 2


@pytest.mark.xdist_group("truss_small")
def test_truss_modes_command(capsys):
    code = main(["truss", "modes", "--bays", "2", "--count", "4", "--json"])
    assert code == 0
    d = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    f = d["frequencies_hz"]
    assert len(f) == 4 and f == sorted(f) and len(d["mode_types"]) == 4
    assert main(["truss", "modes", "--bays", "0"]) == 2
