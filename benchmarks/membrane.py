"""The rotating membrane (paper Sec. 4.3, Tables 7 and 8; issue 15): modes, and the in-plane and
bending-torsion cases with the full RNCF model and NR-RNCF.

    python benchmarks/membrane.py [--rings 15] [--modes 100] [--out benchmarks/results/membrane.md]

1. Modes: the membrane's first modes with their types (``scenarios.membrane.mode_types``): where
   the in-plane torsion and the axisymmetric bending modes fall (the paper: 3, 8 and 19), and
   how many in-plane modes there are among the first ``--modes``.
2. Case A (in-plane): the spin-up of Eq. 43 to ωs = 7 and 10 rad/s over Ts = 2 s, 0-3 s; the full
   RNCF model (sparse SuperLU), NR-RNCF with VM 19 alone and VM 19 + θ19,19. The orthogonality of
   VM 19 and θ19,19.
3. Case B (bending-torsion): ωs = 4 rad/s, Ts = 2 s, with the hub's w_z = 0.012 sin(0.5πt),
   0-4 s; full RNCF, NR-RNCF with VMs 3, 8, 19 alone and with their 6 MDs.
Per run: DOFs, steps, Newton iterations, compile and run time, offline time (modes, MMI, MDs,
tensors), χ_rel over the displacements of all position vectors, speed-up, rim deflections, and
the peak memory of the process.
"""

import argparse
import dataclasses
import json
import resource
import subprocess
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
from _machine import machine, report  # noqa: E402

from nrrncf_jax.reduction import modal_derivatives  # noqa: E402
from nrrncf_jax.scenarios.membrane import (  # noqa: E402
    DEFAULT_BASIS,
    MembraneSpec,
    build_membrane,
    membrane_model,
    membrane_modes,
    paper_basis,
    run_membrane,
)


def rss_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6


CASES = (("in-plane", 7.0, 3.0), ("in-plane", 10.0, 3.0), ("bending-torsion", 4.0, 4.0))


def case_rows(spec, n_modes, case, omega, t_end) -> list[str]:
    """The full RNCF run and NR-RNCF with the paper's basis, with and without its MDs: table rows."""
    membrane_modes(spec, n_modes)  # the modal analysis, outside the offline times (see the footnote)
    ref = run_membrane(case, omega, "rncf", spec, t_end=t_end, progress=True)
    rows = [ref]
    paper = dataclasses.replace(DEFAULT_BASIS, n_modes=n_modes)
    rows.append(run_membrane(case, omega, "nr-rncf", spec, paper, t_end=t_end, reference=ref))
    rows.append(run_membrane(case, omega, "nr-rncf", spec, dataclasses.replace(paper, mds=[]), t_end=t_end,
                             reference=ref))
    lines = []
    for r in rows:
        basis = "–" if r.vms is None else f"VMs {list(r.vms)} + {len(r.mds)} MDs"
        rim = ", ".join(f"{v:.3e}" for v in np.abs(r.rim).max(axis=0))
        # each rim component's largest error over the run, relative to its largest value
        # ('–' for a component the full run leaves at round-off: case A's Z)
        peak = np.abs(ref.rim).max(axis=0)
        diff = np.abs(r.rim - ref.rim).max(axis=0)
        err = "–" if r is ref else ", ".join("–" if p < 1e-9 * peak.max() else f"{e / p:.1e}"
                                               for e, p in zip(diff, peak))
        lines.append(
            f"| {case} | {omega:g} | {r.formulation} | {r.dofs} | {basis} | {r.steps} ({r.rejected}) | "
            f"{r.newton_iters} | {'–' if r.offline_s is None else f'{r.offline_s:.1f}'} | {r.compile_s:.1f} | "
            f"{r.run_s:.3f} | {'–' if r.chi_rel_percent is None else f'{r.chi_rel_percent:.3f}'} | "
            f"{'–' if r.speedup is None else f'{r.speedup:.0f}'} | {rim} | {err} |")
    return lines


def main(argv=None):
    p = argparse.ArgumentParser()
    p.add_argument("--rings", type=int, default=15)
    p.add_argument("--modes", type=int, default=100, help="candidate modes (the paper's 100 VMs)")
    p.add_argument("--thickness", type=float, default=MembraneSpec().thickness, help="[m]")
    p.add_argument("--out", default="benchmarks/results/membrane.md")
    p.add_argument("--only", help=argparse.SUPPRESS)  # CASE:OMEGA:T_END, one case's rows as JSON (internal)
    a = p.parse_args(argv)
    spec = MembraneSpec(rings=a.rings, thickness=a.thickness)
    if a.only:
        case, omega, t_end = a.only.split(":")
        rows = case_rows(spec, a.modes, case, float(omega), float(t_end))
        print(json.dumps({"rows": rows, "rss_gb": rss_gb()}))
        return
    lines = ["# The rotating membrane (paper Sec. 4.3)", "",
             f"Produced by `benchmarks/membrane.py --rings {a.rings} --modes {a.modes} --thickness {a.thickness:g}`. "
             f"Machine: {machine()}.", ""]

    t0 = time.perf_counter()
    m = build_membrane(spec)
    build_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    modes, types = membrane_modes(spec, a.modes)
    modes_s = time.perf_counter() - t0
    f = np.asarray(modes.omega) / (2 * np.pi)
    body = m.body
    lines += [f"Membrane: b = {spec.radius} m, h = {spec.thickness * 1e3:.2f} mm, E = {spec.E / 1e9:g} GPa, "
              f"ν = {spec.nu}, ρ = {spec.rho:g} kg/m³; hub: the centre node clamped. {len(m.plate.triangles)} "
              f"triangles, {len(m.plate.vertices)} vertices, {len(m.plate.layout.edges)} edges: {body.n_dof} DOFs "
              f"({body.n_dof - 3 * len(m.clamped)} free). Build (element integrals) {build_s:.1f} s; the first "
              f"{a.modes} modes (sparse shift-invert) and their types {modes_s:.1f} s. Peak memory so far "
              f"{rss_gb():.1f} GB.", ""]
    in_plane = [i for i, t in enumerate(types) if t.startswith("in-plane")]
    lines += [f"In-plane modes among the first {a.modes} (0-based): {in_plane} "
              f"({', '.join(types[i] for i in in_plane)}).", "",
              "| mode (1-based, as the paper) | f [Hz] | type |", "|---:|---:|---|"]
    lines += [f"| {i + 1} | {f[i]:.4f} | {types[i]} |" for i in range(min(24, len(f)))]
    vms_b, _ = paper_basis("bending-torsion", spec, a.modes)
    lines += ["", f"The paper's modes found by type: axisymmetric bending {[i + 1 for i in vms_b[:2]]}, in-plane "
              f"torsion {vms_b[2] + 1} (1-based; the paper: 3, 8 and 19).", ""]
    sys.stdout.write("\n".join(lines) + "\n")
    sys.stdout.flush()

    # VM 19 and θ19,19 (the paper: inner product below 1e-8)
    k = vms_b[2]
    full = membrane_model(m, "in-plane", 7.0)
    free = np.asarray(full.free_mask())
    theta = np.asarray(modal_derivatives(body, free, modes.phi, [(k, k)]).theta)[:, 0]
    phi = np.asarray(modes.phi)[:, k]
    cos = abs(phi @ theta) / (np.linalg.norm(phi) * np.linalg.norm(theta))
    in_plane_share = np.sum(theta[m.plate.in_plane()] ** 2) / np.sum(theta**2)
    lines += [f"VM {k + 1} and its modal derivative θ{k + 1},{k + 1}: |φᵀθ| / (|φ||θ|) = {cos:.1e}; the MD's "
              f"in-plane share (sum of squares) {in_plane_share:.6f}.", ""]

    header = ["| case | ωs [rad/s] | model | DOFs | basis (0-based) | steps (rejected) | Newton it. | offline* [s] | "
              "compile [s] | run [s] | χ_rel [%] | speed-up | rim max X, Y, Z [m] | rim error X, Y, Z |",
              "|---|---:|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---|---|"]
    lines += ["## Dynamics", "",
              "Case A (in-plane): Eq. 43 with Ts = 2 s, 0-3 s. Case B (bending-torsion): ωs = 4 rad/s, Ts = 2 s, "
              "hub w_z = 0.012 sin(0.5πt) m, 0-4 s. Outputs every 0.01 s, generalized-α ρ∞ = 0.9, rtol 1e-5, "
              "atol 1e-7 (run_membrane's defaults). NR-RNCF: the paper's bases, no spinning-state enrichment. "
              "χ_rel (docs/theory.md, §9 Accuracy measures and checks) over the "
              "displacements of all position vectors; rim: the rim point on +X in the reference frame "
              "(radial X, tangential Y, axial Z); its error: the largest difference from the full run over the "
              "run, relative to the full run's largest value, per component.", ""] + header
    # Each case runs in a process of its own, so that each reports its own peak memory. (Before
    # linalg.sparse made and freed all SuperLU factors on one thread, scipy#15921 leaked one
    # factorisation a step, and three full runs in one process outgrew the machine's 24 GB.)
    peak = rss_gb()
    for case, omega, t_end in CASES:
        out = subprocess.run([sys.executable, __file__, "--rings", str(a.rings), "--modes", str(a.modes), "--thickness",
                              str(a.thickness), "--only", f"{case}:{omega}:{t_end}"], capture_output=True, text=True)
        if out.returncode != 0:
            raise RuntimeError(f"case {case} at {omega} rad/s failed:\n{out.stderr[-3000:]}")
        d = json.loads(out.stdout.strip().splitlines()[-1])
        lines += d["rows"]
        peak = max(peak, d["rss_gb"])
        sys.stdout.write("\n".join(d["rows"]) + "\n")
        sys.stdout.flush()
    lines += ["", f"\\* Offline: MMI simulation, modal derivatives and reduced tensors; the modal analysis of the "
              f"{a.modes} candidate modes ({modes_s:.1f} s, above) is made once per process and shared by its runs: "
              "add it for the whole offline stage.", "",
              f"Peak memory: {peak:.1f} GB (the largest of the processes: one for the modes, one per case).", ""]
    report("\n".join(lines) + "\n", a.out)


if __name__ == "__main__":
    main()
