"""The a-posteriori error estimate of NR-RNCF runs against the χ_rel measured with the full run
(issue 34): effectivity and cost on the paper's spin-up beams.

    python benchmarks/error_estimate.py [--cases paper:4 paper:10 ... curved-upwind:4] [--samples 16]
                                        [--out benchmarks/results/error_estimate.md]

For each case, beam:ω_s (the paper's beam at 4, 10, 20, 40 rad/s and its three curved beams at 4,
as in the paper; the paper's mesh, 0-30 s): the full RNCF run at rtol 1e-4 (the issue's
reference) and at 1e-6 (converged), the reduced model with the default basis
(``run_nr_rncf_spinup``) and with vibration modes only (as many as the default basis has
coordinates, no MDs: a basis deliberately too small in kind), each run at rtol 1e-4 and 1e-6.
Estimates: the static correction on the rtol 1e-4 run's own (interpolated) outputs,
``reduction.run_error``'s default route (the run at rtol 1e-4 ending steps on the samples,
estimated at its own states; also with twice the samples), its repetition at rtol/10 (the
basis estimate there and the run's integration error against it), and the error equation
(``method="dynamic"``) on a run at rtol 1e-4 that ends a step on every output. Measured: χ_rel
against the same-tolerance full run, and against the converged full run of the run (total) and
of the rtol 1e-6 run (basis). Costs compiled first, timed apart. One core.

Large bodies: ``truss`` (the paper's 36-bay truss, 0-10 s, its 4 VMs + 6 MDs and 4 VMs alone,
``run_truss``'s defaults) and ``membrane:CASE:RINGS`` (the rotating membrane's case on a disk of
RINGS rings, 15 the paper's; its paper basis and the VMs alone, ``run_membrane``'s defaults), each
run's estimate made by ``run_forced`` at 16 samples over the position vectors, as their χ_rel, and
the error equation (``method="dynamic"``) over every output of the run repeated with a step ending
on each (a sparse factorisation an output).
"""

import argparse
import dataclasses
import os
import sys

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from nrrncf_jax.integrate import AdaptiveStepSize  # noqa: E402
from nrrncf_jax.reduction import Basis  # noqa: E402
from nrrncf_jax.reduction.error_estimate import estimate_error  # noqa: E402
from nrrncf_jax.reduction.run_error import estimate_run_error, estimate_times  # noqa: E402
from nrrncf_jax.scenarios.spinup import build_spinup_model, run_nr_rncf_spinup, run_spinup  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from _machine import machine, pin_to_one_core, report  # noqa: E402

RTOL, TIGHT = 1e-4, 1e-6  # the runs' tolerance, and the converged runs'


def _pv(res, rtol, step_ts=None, atol=None):
    """The reduced run's (p, ṗ) at its output times at ``rtol`` (atol rtol/100 unless given), ending
    steps on ``step_ts``: ``(P, V, run_s, steps)``, compiled first."""
    from nrrncf_jax.integrate import AdaptiveStepSize, GeneralizedAlpha, simulate_timed

    atol = rtol / 100 if atol is None else atol
    sol, _, run_s = simulate_timed(res.reduction.model, GeneralizedAlpha(0.9), AdaptiveStepSize(rtol, atol),
                                   res.ts, observe=lambda t, p, v: (p, v), max_steps=10**6, step_ts=step_ts)
    P, V = (np.asarray(y) for y in sol.ys)
    return P, V, run_s, int(sol.num_steps)


def _displacements(model, P):
    return np.asarray(jax.vmap(lambda p: model.displacements(0.0, p).reshape(-1))(P))


def _large(case):
    """Rows of a large body's case (module docstring): its runs carry their estimates."""
    if case == "truss":
        from nrrncf_jax.scenarios.truss import DEFAULT_BASIS, build_truss, resonant_force, run_truss, truss_model

        truss = build_truss()
        full = truss_model(truss, *resonant_force(truss, 0.05 * truss.spec.length, 10.0))  # run_truss's own
        ref = run_truss("rncf")
        runs = [("4 VMs + 6 MDs", run_truss("nr-rncf", reference=ref)),
                ("VMs only", run_truss("nr-rncf", basis=dataclasses.replace(DEFAULT_BASIS, mds=0), reference=ref))]
        name, om, rtol, atol = "truss (36 bays)", 0.0, 1e-4, 1e-6
    else:
        from nrrncf_jax.scenarios.membrane import (
            DEFAULT_BASIS,
            DEFAULT_OMEGA,
            MembraneSpec,
            build_membrane,
            membrane_model,
            run_membrane,
        )

        _, which, rings = case.split(":")
        spec = MembraneSpec(rings=int(rings))
        full = membrane_model(build_membrane(spec), which, DEFAULT_OMEGA[which])
        n_modes = 24 if int(rings) >= 15 else 60  # the in-plane torsion mode lies higher on coarse disks
        ref = run_membrane(which, formulation="rncf", spec=spec)
        paper = dataclasses.replace(DEFAULT_BASIS, n_modes=n_modes)
        runs = [("paper basis", run_membrane(which, formulation="nr-rncf", spec=spec, basis=paper, reference=ref)),
                ("VMs only", run_membrane(which, formulation="nr-rncf", spec=spec,
                                          basis=dataclasses.replace(paper, mds=[]), reference=ref))]
        name, om, rtol, atol = f"membrane {which} ({rings} rings, {ref.dofs} DOFs)", DEFAULT_OMEGA[which], 1e-5, 1e-7
    pos = np.flatnonzero(np.asarray(full.body.is_position))
    rows = (3 * pos[:, None] + np.arange(3)).reshape(-1)  # the position vectors, as run_forced's χ_rel
    out = []
    for label, r in runs:
        e = r.estimate
        # The error equation over every output, on the run repeated with a step ending on each.
        P, V, _, _ = _pv(r, rtol, estimate_times(r.ts, method="dynamic"), atol=atol)
        dyn = estimate_run_error(full, r.reduction.model, r.ts, P, V, method="dynamic", norm_rows=rows)
        out.append((name, om, label, r.dofs, r.chi_rel_percent, len(e.ts), e.chi_rel_percent,
                    e.chi_rel_percent / r.chi_rel_percent, e.run_s, r.run_s, e.reliable, dyn.chi_rel_percent,
                    dyn.valid_until, dyn.run_s))
        print(out[-1], flush=True)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", nargs="+", default=["paper:4", "paper:10", "paper:20", "paper:40", "curved-upwind:4",
                                                   "curved-downwind:4", "curved-out-of-plane:4"])
    ap.add_argument("--samples", type=int, default=16)
    ap.add_argument("--out", default="benchmarks/results/error_estimate.md")
    args = ap.parse_args()
    pin_to_one_core()
    rows, large = [], []
    for case in args.cases:
        if case == "truss" or case.startswith("membrane:"):
            large += _large(case)
            continue
        beam, om = case.split(":")[0], float(case.split(":")[1])
        ref = run_spinup("rncf", beam, om, t_end=30.0, save_displacements=True)
        converged = run_spinup("rncf", beam, om, t_end=30.0, save_displacements=True,
                               controller=AdaptiveStepSize(TIGHT, TIGHT / 100), max_steps=10**6)
        full = build_spinup_model("rncf", beam, om, 15.0, ref.elements)
        default = run_nr_rncf_spinup(beam, om, t_end=30.0, elements=ref.elements, reference=ref, estimator=None)
        vm_only = run_nr_rncf_spinup(beam, om, t_end=30.0, elements=ref.elements,
                                     basis=Basis(vms=default.dofs, mds=0, spin_state=False), reference=ref,
                                     estimator=None)
        for label, res in (("default", default), ("VMs only", vm_only)):
            model = res.reduction.model
            P, V, run_s, steps = _pv(res, RTOL)  # no stops: its outputs are interpolated between steps
            P_t, _, _, _ = _pv(res, TIGHT)
            w, w_t = _displacements(model, P), _displacements(model, P_t)
            w_c = converged.displacements.reshape(len(res.ts), -1)
            true_total = 100 * np.linalg.norm(w - w_c) / np.linalg.norm(w_c)
            true_basis = 100 * np.linalg.norm(w_t - w_c) / np.linalg.norm(w_c)
            on_run = estimate_error(full, model, res.ts, P, V, samples=args.samples)
            # The default route: the run ends steps on the samples and is estimated at its own states.
            P_s, V_s, run_stops_s, steps_stops = _pv(res, RTOL, estimate_times(res.ts, args.samples))
            est = estimate_run_error(full, model, res.ts, P_s, V_s, samples=args.samples)
            n2 = 2 * args.samples - 1
            P_2, V_2, _, _ = _pv(res, RTOL, estimate_times(res.ts, n2))
            more = estimate_run_error(full, model, res.ts, P_2, V_2, samples=n2)
            rep = estimate_run_error(full, model, res.ts, P_s, controller=AdaptiveStepSize(RTOL, RTOL / 100),
                                     samples=args.samples)
            P_d, V_d, _, _ = _pv(res, RTOL, estimate_times(res.ts, method="dynamic"))
            dyn = estimate_run_error(full, model, res.ts, P_d, V_d, method="dynamic")
            rows.append(dict(beam=beam, om=om, basis=label, dofs=res.dofs, same=res.chi_rel_percent,
                             basis_true=true_basis, total_true=true_total, on_run=on_run.chi_rel_percent,
                             est=est.chi_rel_percent, more=more.chi_rel_percent, rep=rep.chi_rel_percent,
                             integ=rep.integration_percent, rep_s=rep.run_s, reliable=est.reliable,
                             dyn=dyn.chi_rel_percent, dyn_valid=dyn.valid_until, dyn_s=dyn.run_s,
                             est_s=est.run_s, run_s=run_s, run_stops_s=run_stops_s, steps=steps,
                             steps_stops=steps_stops))
            print(rows[-1], flush=True)
    lines = [
        "# The a-posteriori error estimate of NR-RNCF runs (issue 34)",
        "",
        f"Produced by `benchmarks/error_estimate.py`. Machine: {machine()}.",
        "",
        f"Spin-up of Eq. 43 (T_s = 15 s, 0-30 s, the paper's meshes), each reduced run at rtol {RTOL:g} "
        f"(atol rtol/100) as a user runs it. `VMs only`: as many vibration modes as the default basis has "
        f"coordinates and no MDs. Three measured errors (χ_rel, %): against the full RNCF run at the same "
        f"tolerances (*same rtol*, the issue's measure), and against the full run at rtol {TIGHT:g} (converged) "
        f"of the run itself (*total*) and of the reduced model run at rtol {TIGHT:g} (*basis*, the reduction's "
        f"own error).",
        "",
        f"Estimates ({args.samples} samples): the static correction at the outputs of a run without stops, "
        f"interpolated between its steps (*on the run*, `reduction.error_estimate`); `reduction.run_error`'s "
        f"default route: the run ends steps on the samples (`estimate_times` as its `step_ts`) and the static "
        f"correction is made at its own states there (*basis est.*; with {2 * args.samples - 1} samples, "
        f"*× 2 samples*); the repetition at rtol/10 ending on the samples (`estimate_integration`: *repetition*, "
        f"and the run against it, *integration est.*). Effectivity of the basis estimate against the measured "
        f"basis error, and of the sum with the integration estimate against the measured total. *Dynamic*: the "
        f"linearised error equation over every output of a run at rtol {RTOL:g} that ends a step on each "
        f"(`method=\"dynamic\"`), with the time where it stopped being valid. Costs, each compiled first: the "
        f"estimate at the run's states (*estimate [s]*) against the run with its stops, the repetition with its "
        f"estimate, and the run with and without the stops (steps and seconds).",
        "",
        "| beam | ω_s | basis | DOFs | same rtol | total | basis | on the run | basis est. | × 2 samples "
        "| repetition | eff. basis | integration est. | eff. total | dynamic (valid until) | dynamic [s] "
        "| estimate [s] | run with stops [s] | cost ratio | repetition [s] | steps (no stops) | run, no stops [s] "
        "| reliable |",
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        dyn = f"{r['dyn']:.4f}" + ("" if r["dyn_valid"] is None else f" ({r['dyn_valid']:g} s)")
        lines.append(f"| {r['beam']} | {r['om']:g} | {r['basis']} | {r['dofs']} | {r['same']:.4f} "
                     f"| {r['total_true']:.4f} | {r['basis_true']:.4f} | {r['on_run']:.4f} | {r['est']:.4f} "
                     f"| {r['more']:.4f} | {r['rep']:.4f} "
                     f"| {r['est'] / r['basis_true']:.2f} | {r['integ']:.4f} "
                     f"| {(r['est'] + r['integ']) / r['total_true']:.2f} | {dyn} | {r['dyn_s']:.3f} "
                     f"| {r['est_s']:.4f} | {r['run_stops_s']:.4f} | {r['est_s'] / r['run_stops_s']:.2f} "
                     f"| {r['rep_s']:.3f} | {r['steps_stops']} ({r['steps']}) | {r['run_s']:.4f} "
                     f"| {'yes' if r['reliable'] else 'no'} |")
    if large:
        lines += ["", "Large bodies (`run_forced`'s estimate, now `reduction.run_error`; measured against the "
                  "full run at the same tolerances):", "",
                  "| case | ω | basis | DOFs | χ_rel measured [%] | samples | estimate [%] | effectivity "
                  "| estimate run [s] | reduced run [s] | cost ratio | reliable | dynamic [%] (valid until) "
                  "| dynamic eff. | dynamic [s] |",
                  "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---|---:|---:|"]
        for r in large:
            dyn = f"{r[11]:.4f}" + ("" if r[12] is None else f" ({r[12]:g} s)")
            lines.append(f"| {r[0]} | {r[1]:g} | {r[2]} | {r[3]} | {r[4]:.4f} | {r[5]} | {r[6]:.4f} | {r[7]:.2f} "
                         f"| {r[8]:.4f} | {r[9]:.4f} | {r[8] / r[9]:.2f} | {'yes' if r[10] else 'no'} | {dyn} "
                         f"| {r[11] / r[4]:.2f} | {r[13]:.1f} |")
    report("\n".join(lines) + "\n", args.out, keep_notes="## Notes")


if __name__ == "__main__":
    main()
