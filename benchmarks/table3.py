"""The paper's Tables 2-3 (straight beam) and 4-5 (curved beams) in one run on one machine.

    python benchmarks/table3.py [--no-ancf] [--speeds 4 10 20 40] [--t-end 30] [--no-curved]
                                [--out benchmarks/results/table3.md] [--figures benchmarks/results/figures]

Straight paper beam, spin-up of Eq. 43 with T_s = 15 s, ωs = 4, 10, 20, 40 rad/s on the paper's
meshes (6, 10, 16, 24 elements): ANCF, RNCF, NR-RNCF (automatic MMI selection from 24 candidate
modes) and a vibration-modes-only basis of the same size (the Km most active VMs, no MDs).
Then the three curved beams (8 elements, ωs = 4): RNCF against NR-RNCF. χ_rel is Eq. 40
against RNCF on all nodal displacements q − q̂ (rotating frame) at every output time.
Compile and run times are measured apart (ahead-of-time compilation, then a blocked run);
offline = the NR-RNCF basis construction (modes, MMI simulation, MDs, deflation, tensors),
compilation included. Figures (tip full vs reduced, MMI bar plots) go to ``--figures``.
"""

import argparse
import os
import sys

import jax

jax.config.update("jax_enable_x64", True)

from _machine import machine, report  # noqa: E402

from nrrncf_jax import chi_rel  # noqa: E402
from nrrncf_jax.integrate import AdaptiveStepSize  # noqa: E402
from nrrncf_jax.post.plotting import plot_mmi, plot_tip  # noqa: E402
from nrrncf_jax.reduction import Basis  # noqa: E402
from nrrncf_jax.scenarios import run_spinup  # noqa: E402
from nrrncf_jax.scenarios.spinup import default_elements, run_nr_rncf_spinup  # noqa: E402

PAPER_BASIS = {  # paper Tables 2 and 4: (VMs, MDs, DOFs)
    ("paper", 4.0): (3, 6, 9), ("paper", 10.0): (4, 10, 14), ("paper", 20.0): (5, 12, 17),
    ("paper", 40.0): (6, 16, 22), ("curved-upwind", 4.0): (3, 6, 9), ("curved-downwind", 4.0): (3, 6, 9),
    ("curved-out-of-plane", 4.0): (6, 10, 16),
}
CURVED = ("curved-upwind", "curved-downwind", "curved-out-of-plane")
HEAD = ("case", "model", "elements", "DOFs", "VMs", "MDs", "steps", "rejected", "compile [s]", "run [s]",
        "offline [s]", "tip uy min [m]", "χ_rel [%]", "speed-up vs RNCF", "speed-up vs ANCF")


def _log(msg):
    print(msg, file=sys.stderr, flush=True)


def _row(case, label, x, rncf, ancf, chi):
    reduced = x.vms is not None
    spin = x.spin if reduced and x.spin is not None and x.spin.enriched else None
    vms = "" if not reduced else f"{len(x.vms)}" + (f" + {len(spin.vms)}*" if spin else "")
    mds = "" if not reduced else f"{len(x.mds)}" + (f" + {len(spin.pairs)}*" if spin else "")
    return (case, label, x.elements, x.dofs, vms, mds,
            x.steps, x.rejected, f"{x.compile_s:.1f}", f"{x.run_s:.2f}",
            f"{x.offline_s['total']:.1f}" if reduced else "", f"{x.tip[:, 1].min():.4f}",
            "(ref)" if x is rncf else f"{chi:.3f}", f"{rncf.run_s / x.run_s:.1f}x",
            f"{ancf.run_s / x.run_s:.1f}x" if ancf is not None else "—")


def _table(rows):
    lines = ["| " + " | ".join(HEAD) + " |", "|---|---|" + "---:|" * (len(HEAD) - 2)]
    return "\n".join(lines + ["| " + " | ".join(str(c) for c in row) + " |" for row in rows])


def _basis_line(case, beam, omega, x, vm_only=None):
    pv, pm, pd = PAPER_BASIS.get((beam, omega), ("?", "?", "?"))
    mds = " ".join(f"θ{i},{j}" for i, j in x.mds) or "none"  # 0-based mode indices, as everywhere
    s = f"- {case}: NR-RNCF VMs {list(x.vms)}, MDs {mds}"
    c = x.spin
    if c is not None and c.enriched:
        s += (f", spinning modes* {list(c.vms)} and MDs* "
              + " ".join(f"θ*{i},{j}" for i, j in c.pairs))
    s += f" → {x.dofs} DOFs after deflation (paper: {pv} VMs + {pm} MDs = {pd})"
    if c is not None:
        s += (f"; spinning-state check: mode {c.mode} of the beam spinning at {c.omega:g} rad/s, "
              f"{c.omega_spin:.4f} rad/s, rest-basis estimate {100 * c.rel_err:+.3f} %")
    if vm_only is not None:
        s += f"; VM-only basis: VMs {list(vm_only.vms)}"
    return s


def _case(beam, omega, n_el, args, fig_dir, with_ancf, with_vm_only, max_dofs=25):
    common = dict(T_s=15.0, t_end=args.t_end, elements=n_el, progress=not args.no_progress,
                  controller=AdaptiveStepSize(args.rtol, 1e-6))
    case = f"{beam}, ωs = {omega:g}"
    _log(f"{case}: RNCF ({n_el} elements) ...")
    rncf = run_spinup("rncf", beam, omega, save_displacements=True, **common)
    ancf = None
    if with_ancf:
        _log(f"{case}: ANCF ...")
        ancf = run_spinup("ancf", beam, omega, save_displacements=True, **common)
    _log(f"{case}: NR-RNCF (automatic selection from {args.modes} modes) ...")
    nr = run_nr_rncf_spinup(beam, omega, basis=Basis(n_modes=args.modes, max_dofs=max_dofs), reference=rncf,
                            **common)
    paper = None
    if nr.spin is not None and nr.spin.enriched:
        _log(f"{case}: NR-RNCF with the paper's basis alone (no spinning-state enrichment) ...")
        paper = run_nr_rncf_spinup(beam, omega, basis=Basis(n_modes=args.modes, max_dofs=max_dofs, spin_state=False),
                                   reference=rncf, **common)
    vm = None
    if with_vm_only:
        _log(f"{case}: VM-only basis of {nr.dofs} modes ...")
        vm = run_nr_rncf_spinup(beam, omega, basis=Basis(n_modes=args.modes, vms=nr.dofs, mds=0), reference=rncf,
                                **common)

    rows = [_row(case, "RNCF", rncf, rncf, ancf, None)]
    if ancf is not None:
        rows.insert(0, _row(case, "ANCF", ancf, rncf, ancf, float(chi_rel(rncf.displacements, ancf.displacements))))
    rows.append(_row(case, "NR-RNCF", nr, rncf, ancf, nr.chi_rel_percent))
    if paper is not None:
        rows.append(_row(case, "NR-RNCF, paper basis", paper, rncf, ancf, paper.chi_rel_percent))
    if vm is not None:
        rows.append(_row(case, "VM only", vm, rncf, ancf, vm.chi_rel_percent))

    tag = f"{beam}_w{omega:g}"
    runs = [rncf, nr]
    labels = [f"RNCF ({rncf.dofs} DOF)", f"NR-RNCF ({nr.dofs} DOF), χ_rel = {nr.chi_rel_percent:.2f} %"]
    if vm is not None:
        runs.append(vm)
        labels.append(f"VMs only ({vm.dofs} DOF), χ_rel = {vm.chi_rel_percent:.2f} %")
    if ancf is not None:
        runs.append(ancf)
        labels.append(f"ANCF ({ancf.dofs} DOF)")
    plot_tip(os.path.join(fig_dir, f"tip_{tag}.png"), *runs, labels=labels, dpi=90)
    sel = nr.reduction.selection
    plot_mmi(os.path.join(fig_dir, f"mmi_{tag}.png"), sel.W, sel, nr.reduction.omega, dpi=90,
             title=f"MMI, {beam} beam, {n_el} elements, $\\omega_s$ = {omega:g} rad/s")
    return rows, _basis_line(case, beam, omega, nr, vm)


def main(argv=None):
    p = argparse.ArgumentParser()
    p.add_argument("--speeds", type=float, nargs="+", default=[4.0, 10.0, 20.0, 40.0])
    p.add_argument("--t-end", type=float, default=30.0)
    p.add_argument("--rtol", type=float, default=1e-4)
    p.add_argument("--modes", type=int, default=24, help="candidate vibration modes for the MMI selection")
    p.add_argument("--no-ancf", action="store_true", help="skip the ANCF rows (slow: minutes at ωs = 40)")
    p.add_argument("--no-curved", action="store_true", help="skip the curved beams (Tables 4-5)")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--out", default="benchmarks/results/table3.md")
    p.add_argument("--figures", default="benchmarks/results/figures")
    a = p.parse_args(argv)
    os.makedirs(a.figures, exist_ok=True)

    straight, basis = [], []
    for w in a.speeds:
        rows, b = _case("paper", w, default_elements(w), a, a.figures, not a.no_ancf, True)
        straight += rows
        basis.append(b)
    curved = []
    if not a.no_curved:
        for beam in CURVED:
            # The paper's budget for the curved beams is 16 reduced DOFs (Table 4).
            rows, b = _case(beam, 4.0, 8, a, a.figures, False, False, max_dofs=16)
            curved += rows
            basis.append(b)

    text = (f"# NR-RNCF spin-up: paper Tables 2-5 (T_s = 15 s, 0-{a.t_end:g} s, rtol = {a.rtol:g}, ρ∞ = 0.9)\n\n"
            f"Produced by `benchmarks/table3.py{' --no-ancf' if a.no_ancf else ''}`. Machine: {machine()}\n\n"
            "## Straight beam (Tables 2-3)\n\n" + _table(straight) + "\n\n")
    if curved:
        text += "## Curved beams, ωs = 4 rad/s (Tables 4-5)\n\n" + _table(curved) + "\n\n"
    text += ("## Bases (mode indices 0-based, ascending frequency)\n\n" + "\n".join(basis) + "\n\n"
             "χ_rel: Eq. 40 against the full RNCF run, on all nodal displacements q − q̂ in the rotating frame "
             "(positions and gradients), every 0.01 s. Speed-up: run time of RNCF (ANCF) over the row's run time; "
             "compile and offline times are not in it. NR-RNCF: automatic MMI selection (Eq. 39) from "
             f"{a.modes} candidate modes, deflated by SVD, with the spinning-state check of `nr_rncf` (beyond the "
             "paper: where the rest basis misses the spinning beam's dominant frequency by more than 0.2 %, the first "
             "spinning mode and four modal derivatives of spinning-mode pairs, marked *, join the basis within the "
             "same DOF budget; 'paper basis' is the same run without them); VM only: the same number of the most "
             "active vibration modes, no modal derivatives. A compile time near 0 means JAX reused code compiled for "
             "an earlier row of the same shapes (the VM-only run after the NR-RNCF run of the same size). The CPU is "
             "shared with other jobs, so timings are indicative.\n")
    report(text, a.out, keep_notes="## Notes")  # the notes read from an earlier run's figures stay


if __name__ == "__main__":
    main()
