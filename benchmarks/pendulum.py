"""The three-beam pendulum (paper Sec. 4.4, issue 17): mesh and tolerance convergence of the
full-order ANCF multibody model, energy with ρ∞ = 1, the full-order RNCF model (floating frames,
the paper's reference) against it, and NR-RNCF against both, with timings.

    python benchmarks/pendulum.py [--elements 10 20 40] [--t-end 2] [--no-energy] [--full-only] [--tips F.npz]
                                  [--repeats 3] [--out benchmarks/results/pendulum.md]

Each beam's right-end position over 0-t_end is compared with the finest run (most elements,
tightest tolerance): the largest distance over the run and the three tips. ANCF bodies joined by
revolute joints, index-3 generalized-α (``multibody``, ``integrate.GeneralizedAlphaIndex3``).
NR-RNCF (``multibody.floating``, ``scenarios.pendulum.build_reduced_pendulum``) on the coarsest
mesh, with 5 VMs + their 15 MDs a beam, with these and the right-end joint's static modes, the
extended Craig-Bampton basis (the joint's position as boundary coordinates, fixed-interface modes
and their MDs), with 8 MDs a beam chosen by MMI per beam, and with the 5 VMs alone: χ_rel over every node's
displacement against the full run on the same mesh and tolerance, and the speed-up; the same basis at
3 and 10 times the tolerance, with its own time-integration error against its run at a tenth of it.

The process is pinned to one core (``--all-cores`` not to): these models are too small to gain
from a second core, and XLA's hand-offs of their small operations between two cores made the
reduced run's time vary twofold from one run to the next (4.4-8.8 s; pinned 5.0-5.3 s).
"""

import argparse
import os
import resource
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
from _machine import machine, pin_to_one_core, report  # noqa: E402

from nrrncf_jax.integrate import AdaptiveStepSize, GeneralizedAlphaIndex3  # noqa: E402
from nrrncf_jax.post.metrics import chi_rel  # noqa: E402
from nrrncf_jax.scenarios.pendulum import (  # noqa: E402
    PendulumBasis,
    PendulumSpec,
    build_reduced_pendulum,
    mmi_per_body,
    run_chain,
    run_pendulum,
)

TOLERANCES = {10: 1e-4, 20: 3e-5, 40: 1e-5}


def finest_error(d_quarter, d_half):
    """The mesh order p and the finest mesh's error from the largest distances to it of the runs
    with a quarter and a half of its elements: with e(n) = e_f (n_f/n)^p, d(n_f/4) = e_f (4^p − 1)
    and d(n_f/2) = e_f (2^p − 1), so d(n_f/4)/d(n_f/2) = 2^p + 1."""
    two_p = np.asarray(d_quarter) / np.asarray(d_half) - 1.0
    return np.log2(two_p), np.asarray(d_half) / (two_p - 1.0)


def main(argv=None):
    p = argparse.ArgumentParser()
    p.add_argument("--elements", type=int, nargs="+", default=[10, 20, 40])
    p.add_argument("--t-end", type=float, default=2.0)
    p.add_argument("--no-energy", action="store_true", help="skip the ρ∞ = 1 energy run (the longest)")
    p.add_argument("--full-only", action="store_true", help="only the full runs and their convergence table")
    p.add_argument("--out", default="benchmarks/results/pendulum.md")
    p.add_argument("--all-cores", action="store_true", help="do not pin the process to one core (see the module "
                   "docstring)")
    p.add_argument("--repeats", type=int, default=3, help="runs of each reduced model; its time is their median")
    p.add_argument("--tips", help="also write each full run's tips (t, beam, xyz) to this .npz, and compare with the "
                                  "runs already in it (a finer mesh run separately)")
    a = p.parse_args(argv)
    if not a.all_cores:
        pin_to_one_core()
    lines = ["# The three-beam pendulum (paper Sec. 4.4)", "",
             f"Produced by `benchmarks/pendulum.py --elements {' '.join(map(str, a.elements))} --t-end {a.t_end:g}"
             f"{' --no-energy' if a.no_energy else ''}`. "
             f"Machine: {machine()}.", "",
             "Three beams of 1 m, solid section r = 5 mm, ρ = 1100 kg/m³, E = 5 MPa, ν = 0.3, C1 elements; a ground "
             "hinge and two hinges about Z; released from rest along +x under gravity −9.81 m/s² along Y. ANCF "
             "bodies (inertial frame) joined by revolute joints, index-3 generalized-α (ρ∞ = 0.9), the constrained "
             "iteration matrix factored body by body with the joints' Schur complement. Tolerances tighten with the "
             "mesh (rtol, atol = rtol/10).", "",
             "| elements a beam | DOFs | rtol | steps (rejected) | Newton it. | compile [s] | run [s] | "
             "max joint violation [m] | tip 1, 2, 3 at t_end [m] |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    runs = {}
    saved = dict(np.load(a.tips)) if a.tips and os.path.exists(a.tips) else {}
    for ne in a.elements:
        rtol = TOLERANCES.get(ne, 1e-5)
        r = run_pendulum(PendulumSpec(elements=ne), t_end=a.t_end, dt_out=0.01,
                         controller=AdaptiveStepSize(rtol, rtol / 10))
        runs[ne] = r
        at_end = "; ".join(f"({x:.4f}, {y:.4f})" for x, y in r.tips[-1, :, :2])
        lines.append(f"| {ne} | {r.dofs} | {rtol:g} | {r.steps} ({r.rejected}) | {r.newton_iters} | "
                     f"{r.compile_s:.1f} | {r.run_s:.1f} | {r.constraint_max:.1e} | {at_end} |")
        sys.stdout.write(lines[-1] + "\n")
        sys.stdout.flush()
    if a.tips:
        saved.update({str(ne): r.tips for ne, r in runs.items()})
        np.savez(a.tips, **saved)
    tips = {int(k): v for k, v in saved.items()} | {ne: r.tips for ne, r in runs.items()}
    finest = max(tips)
    lines += ["", f"Convergence: each run's tips against the finest ({finest} elements), the largest distance over "
              f"0-{a.t_end:g} s.", "", "| elements a beam | tip 1 [m] | tip 2 [m] | tip 3 [m] |",
              "|---:|---:|---:|---:|"]
    dist = {ne: np.linalg.norm(tips[ne] - tips[finest], axis=2).max(axis=0) for ne in sorted(tips) if ne != finest}
    for ne, d in dist.items():
        lines.append(f"| {ne} | " + " | ".join(f"{x:.2e}" for x in d) + " |")
    meshes = sorted(tips)
    if len(meshes) >= 3 and meshes[-3] * 4 == meshes[-2] * 2 == meshes[-1]:
        p_order, e_finest = finest_error(dist[meshes[-3]], dist[meshes[-2]])
        lines += ["", "The finest run's own mesh error, estimated (Richardson) from the two coarser meshes' distances "
                  "to it, with e(n) = e_finest (n_finest/n)^p: d(n/4)/d(n/2) = 2^p + 1, e_finest = d(n/2)/(2^p − 1). "
                  "Order p " + ", ".join(f"{x:.2f}" for x in p_order) + "; tips 1, 2, 3 of the "
                  f"{finest}-element run within " + ", ".join(f"{1e3 * x:.2f}" for x in e_finest) +
                  " mm of the mesh-converged motion (an estimate from the largest distances over the run, not a "
                  "measurement)."]
    if a.full_only:
        report("\n".join(lines) + "\n", a.out)
        return
    coarse = min(runs)
    rtol = TOLERANCES.get(coarse, 1e-5)
    rncf = run_pendulum(PendulumSpec(elements=coarse), t_end=a.t_end, dt_out=0.01,
                        controller=AdaptiveStepSize(rtol, rtol / 10), formulation="rncf")
    full = runs[coarse]
    lines += ["", f"The full-order RNCF model on the {coarse}-element mesh (`--formulation rncf`, "
              "`multibody.full_order_frame`): each beam in the floating frame of its left end (Euler parameters; "
              "the left node's position, its centre line's tangent and the plane of it and r_y held, "
              "six conditions: `scenarios.pendulum.LEFT_END_FRAME`), "
              "every other nodal coordinate kept, the elements' own elastic force; each body's iteration-matrix "
              "block dense (the frame couples with every coordinate through the mass matrix). The ANCF model in "
              "other coordinates: the two differ by their time-integration errors.", "",
              "| model | DOFs | rtol | steps (rejected) | Newton it. | compile [s] | run [s] | χ_rel vs ANCF [%] | "
              "largest tip distance to ANCF [m] |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
              f"| RNCF, {coarse} elements a beam | {rncf.dofs} | {rtol:g} | {rncf.steps} ({rncf.rejected}) | "
              f"{rncf.newton_iters} | {rncf.compile_s:.1f} | {rncf.run_s:.1f} | "
              f"{float(chi_rel(full.nodes - full.nodes[0], rncf.nodes - rncf.nodes[0])):.3f} | "
              f"{np.linalg.norm(rncf.tips - full.tips, axis=2).max():.2e} |"]
    sys.stdout.write(lines[-1] + "\n")
    sys.stdout.flush()
    lines += ["", f"NR-RNCF on the {coarse}-element mesh against its full ANCF run (χ_rel; the speed-up against "
              f"both full models; rtol {rtol:g}): "
              "each beam in its floating frame (Euler parameters), its deformation reduced to its cantilever "
              "modes (left node's r, r_y, r_z clamped), the lowest 5 in-plane ones (the mirror-odd coordinates held "
              "at zero, `elements.beam.mirror_even`), and their MDs, deflated by SVD; the mass matrix from the "
              "inertia invariants; the velocities projected onto the joints' and the Euler parameters' velocity "
              "constraints after each step (`integrate.GeneralizedAlphaIndex3`). Newton stops at 1 % of the step's "
              "error tolerance (both models).", "",
              f"run [s]: the median of {a.repeats} runs of the compiled program (their range beside it): "
              "this VM's speed varies by a third over minutes, and a run of a few seconds sees one state of "
              "it, where the full runs' tens of seconds average several.", "",
              "| basis a beam | DOFs | steps (rejected) | Newton it. | offline [s] | compile [s] | run [s] | "
              "runs' range [s] | χ_rel [%] | speed-up vs ANCF | speed-up vs RNCF | largest tip distance [m] |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    # The last rows: the same basis at looser tolerances. Its time-integration error (against its
    # own run at rtol/10, below) stays far below its basis error (χ_rel), so it need not run at the
    # full model's tolerance, which that model needs as the reference.
    reduced = {}
    t_mmi = time.perf_counter()
    selections = mmi_per_body(PendulumSpec(elements=coarse), n_vms=5, n_mds=8, t_end=a.t_end)
    t_mmi = time.perf_counter() - t_mmi
    for label, pairs, basis, tol in (("5 VMs + 15 MDs", "all", "cantilever", rtol),
                                     ("5 VMs + 15 MDs + 2 in-plane joint modes", "all", "joint modes", rtol),
                                     ("extended Craig-Bampton: 2 boundary coordinates + 5 fixed-interface VMs + 15 MDs",
                                      "all", "craig-bampton", rtol),
                                     ("5 VMs + 8 MDs a beam, chosen by MMI per beam", "all", "mmi", rtol),
                                     ("5 VMs", [], "cantilever", rtol),
                                     (f"5 VMs + 15 MDs, rtol {3 * rtol:g}", "all", "cantilever", 3 * rtol),
                                     (f"5 VMs + 15 MDs, rtol {10 * rtol:g}", "all", "cantilever", 10 * rtol)):
        try:  # a cap on the steps, in case the step size collapses
            system, info = build_reduced_pendulum(PendulumSpec(elements=coarse), PendulumBasis(
                5, pairs, joint_modes=basis == "joint modes", craig_bampton=basis == "craig-bampton",
                body_pairs=[sel.pairs for sel in selections] if basis == "mmi" else None))
            runs = [run_chain(system, a.t_end, 0.01, solver=GeneralizedAlphaIndex3(0.9),
                              controller=AdaptiveStepSize(tol, tol / 10), max_steps=40_000)
                    for _ in range(a.repeats)]
            r = runs[0]
            r.offline, r.run_s = info, float(np.median([x.run_s for x in runs]))
            r.compare(full)
            spread = f"{min(x.run_s for x in runs):.2f}-{max(x.run_s for x in runs):.2f}"
        except Exception as e:  # noqa: BLE001 - reported in the table
            lines.append(f"| {label} | – | failed: {str(e).splitlines()[0][:120]} | | | | | | | | | |")
            continue
        if pairs == "all" and basis == "cantilever":
            reduced[tol] = r
        d = np.linalg.norm(r.tips - full.tips, axis=2).max()
        lines.append(f"| {label} | {r.dofs} | {r.steps} ({r.rejected}) | {r.newton_iters} | "
                     f"{r.offline['offline_s']:.1f} | {r.compile_s:.1f} | {r.run_s:.2f} | {spread} | "
                     f"{r.chi_rel_percent:.2f} | "
                     f"{r.speedup:.2f} | {rncf.run_s / r.run_s:.2f} | {d:.3f} |")
        sys.stdout.write(lines[-1] + "\n")
        sys.stdout.flush()
    lines += ["", f"MMI per beam (`scenarios.pendulum.mmi_per_body`, the paper's Fig. 16): W from the 5-VM reduced "
              f"pendulum's run over 0-{a.t_end:g} s ({t_mmi:.1f} s with its compilation, not in the offline column); "
              "the 8 pairs kept, beam by beam: "
              + "; ".join(f"beam {b + 1}: " + " ".join(f"θ{i + 1}{j + 1}" for i, j in sel.pairs)
                          for b, sel in enumerate(selections)) + "."]
    if reduced:
        fine = run_pendulum(PendulumSpec(elements=coarse), t_end=a.t_end, dt_out=0.01,
                            controller=AdaptiveStepSize(rtol / 10, rtol / 100), formulation="nr-rncf",
                            max_steps=200_000)
        errs = ", ".join(f"{float(chi_rel(fine.nodes - fine.nodes[0], r.nodes - r.nodes[0])):.3f} % at rtol {tol:g}"
                         for tol, r in sorted(reduced.items()))
        lines += ["", f"The reduced model's own time-integration error: χ_rel of its runs against its run at rtol "
                  f"{rtol / 10:g} ({fine.steps} steps): {errs}. Its basis error (χ_rel against the full model) is "
                  f"{reduced[min(reduced)].chi_rel_percent:.2f} %."]
        sys.stdout.write(lines[-1] + "\n")
    if not a.no_energy:
        r1 = run_pendulum(PendulumSpec(elements=coarse), t_end=a.t_end, dt_out=0.01,
                          solver=GeneralizedAlphaIndex3(1.0), controller=AdaptiveStepSize(1e-5, 1e-6))
        drift = float(np.abs(r1.energy - r1.energy[0]).max())
        lines += ["", f"Energy with ρ∞ = 1 ({coarse} elements, rtol 1e-5, atol 1e-6): largest drift {drift:.2e} J over "
                  f"0-{a.t_end:g} s, {drift / r1.kinetic.max():.1e} of the peak kinetic energy "
                  f"({r1.kinetic.max():.3f} J); {r1.steps} steps ({r1.rejected} rejected), max joint violation "
                  f"{r1.constraint_max:.1e} m."]
        lines += ["", "The NR-RNCF model's energy (5 VMs + 15 MDs, rtol 1e-5, atol 1e-6):", ""]
        for rho in (1.0, 0.98):
            try:
                r2 = run_pendulum(PendulumSpec(elements=coarse), t_end=a.t_end, dt_out=0.01,
                                  solver=GeneralizedAlphaIndex3(rho), controller=AdaptiveStepSize(1e-5, 1e-6),
                                  formulation="nr-rncf", max_steps=200_000)
            except Exception as e:  # noqa: BLE001 - reported
                lines.append(f"- ρ∞ = {rho:g}: failed: {str(e).splitlines()[0][:120]}")
                continue
            drift = float(np.abs(r2.energy - r2.energy[0]).max())
            lines.append(f"- ρ∞ = {rho:g}: largest drift {drift:.2e} J, {drift / r2.kinetic.max():.1e} of the peak "
                         f"kinetic energy; {r2.steps} steps ({r2.rejected} rejected), run {r2.run_s:.1f} s.")
            sys.stdout.write(lines[-1] + "\n")
            sys.stdout.flush()
    lines += ["", f"Peak memory: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6:.1f} GB.", ""]
    report("\n".join(lines) + "\n", a.out)


if __name__ == "__main__":
    main()
