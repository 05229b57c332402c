"""The beamlike truss (paper Sec. 4.5, issue 16): modes, mesh convergence, and the forced response
with the full RNCF model and NR-RNCF.

    python benchmarks/truss.py [--bays 36] [--t-end 10] [--no-convergence] [--out benchmarks/results/truss.md]

1. Modes: the first 10 frequencies and types of the cantilevered truss (6 beam elements a
   longeron bay, 4 a batten), against the equivalent beam's closed forms
   (``scenarios.truss.equivalent_beam``), and on a mesh refined twice (12 and 8) for convergence.
2. Dynamics: F0 sin(2π f1 t) along y at the free end's centroid, f1 the first bending frequency and
   F0 such that the linear resonant tip response reaches 5 % of the length at t_end; the full RNCF
   model (sparse SuperLU), and NR-RNCF with 4 VMs alone and 4 VMs + 6 MDs chosen by MMI: DOFs,
   steps, compile and run time, offline time, χ_rel over all position vectors, speed-up.
"""

import argparse
import dataclasses
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
from _machine import machine  # noqa: E402

from nrrncf_jax.models import RotatingFrameModel  # noqa: E402
from nrrncf_jax.motion import Stationary  # noqa: E402
from nrrncf_jax.reduction import vibration_modes  # noqa: E402
from nrrncf_jax.scenarios.truss import (  # noqa: E402
    DEFAULT_BASIS,
    TrussSpec,
    build_truss,
    equivalent_beam,
    mode_types,
    resonant_force,
    run_truss,
)


def modes_of(spec, count=10):
    t0 = time.perf_counter()
    truss = build_truss(spec)
    t1 = time.perf_counter()
    model = RotatingFrameModel(truss.body, Stationary(), clamped=truss.clamped)
    modes = vibration_modes(truss.body, model.free_mask(), count)
    f = np.asarray(modes.omega) / (2 * np.pi)
    t2 = time.perf_counter()
    return truss, f, mode_types(truss, np.asarray(modes.phi)), t1 - t0, t2 - t1


def main(argv=None):
    p = argparse.ArgumentParser()
    p.add_argument("--bays", type=int, default=36)
    p.add_argument("--t-end", type=float, default=10.0)
    p.add_argument("--no-convergence", action="store_true")
    p.add_argument("--out", default="benchmarks/results/truss.md")
    a = p.parse_args(argv)
    spec = TrussSpec(bays=a.bays)
    lines = ["# The beamlike truss (paper Sec. 4.5)", "",
             f"Produced by `benchmarks/truss.py --bays {a.bays} --t-end {a.t_end:g}`. Machine: {machine()}.", ""]

    truss, f, types, build_s, modes_s = modes_of(spec)
    body = truss.body
    n_free = body.n_dof - 3 * len(truss.clamped)
    lines += [f"Truss: {a.bays} bays, {truss.frame.n_beams} beam elements, {truss.frame.n_bars} bars, "
              f"{body.n_dof} DOFs ({n_free} free). "
              f"Build (element integrals) {build_s:.1f} s, first 10 modes (sparse shift-invert) {modes_s:.1f} s.", ""]
    fine = None
    if not a.no_convergence:
        fine_spec = TrussSpec(bays=a.bays, longeron_elements=12, batten_elements=8)
        tf, fine, _, b2, m2 = modes_of(fine_spec)
        lines += [f"Refined mesh (12 elements a longeron bay, 8 a batten): {tf.body.n_dof} DOFs, build {b2:.1f} s, "
                  f"modes {m2:.1f} s.", ""]
    eq = equivalent_beam(spec)
    lines += ["## Modes", "", "| mode | type | f [Hz] | f, refined mesh [Hz] | change |", "|---:|---|---:|---:|---:|"]
    for i, (fi, ti) in enumerate(zip(f, types)):
        row = f"| {i} | {ti} | {fi:.5f} |"
        row += f" {fine[i]:.5f} | {fine[i] / fi - 1:+.2e} |" if fine is not None else " – | – |"
        lines.append(row)
    first_torsion = f[types.index("torsion")] if "torsion" in types else float("nan")
    lines += ["", "Equivalent beam (`scenarios.truss.equivalent_beam`): "
              f"EI = {eq.EI:.4g} N m², GA = {eq.GA:.4g} N, GJ = {eq.GJ:.4g} N m², m = {eq.m:.4f} kg/m, "
              f"I_p = {eq.I_p:.4g} kg m.", "",
              "| quantity | closed form [Hz] | FE [Hz] | FE / closed − 1 |", "|---|---:|---:|---:|",
              f"| first bending, Euler-Bernoulli | {eq.f_bending_eb:.5f} | {f[0]:.5f} | "
              f"{f[0] / eq.f_bending_eb - 1:+.2%} |",
              f"| first bending, with shear (Southwell-Dunkerley) | {eq.f_bending:.5f} | {f[0]:.5f} | "
              f"{f[0] / eq.f_bending - 1:+.2%} |",
              f"| first torsion, quarter-wave shaft | {eq.f_torsion:.5f} | {first_torsion:.5f} | "
              f"{first_torsion / eq.f_torsion - 1:+.2%} |", ""]

    F0, f1 = resonant_force(truss, 0.05 * spec.length, a.t_end)
    lines += ["## Forced response", "",
              f"F(t) = F0 sin(2π f1 t) along y at the free end's centroid (shared by the three tip joints), "
              f"f1 = {f1:.5f} Hz, F0 = {F0:.4g} N; 0-{a.t_end:g} s, outputs every 0.02 s, generalized-α ρ∞ = 0.9, "
              "rtol 1e-4, atol 1e-6. χ_rel (docs/theory.md, §9 Accuracy measures and checks) over the "
              "displacements of all position vectors.", "",
              "| model | DOFs | basis | steps (rejected) | Newton it. | offline [s] | compile [s] | run [s] | "
              "χ_rel [%] | speed-up | tip y max [m] | tip z max [m] |",
              "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    sys.stdout.write("\n".join(lines) + "\n")
    sys.stdout.flush()
    ref = run_truss("rncf", spec, F0, f1, t_end=a.t_end, progress=True)
    rows = [ref]
    for vms, mds in ((4, 0), (4, 6)):
        basis = dataclasses.replace(DEFAULT_BASIS, vms=vms, mds=mds)
        rows.append(run_truss("nr-rncf", spec, F0, f1, t_end=a.t_end, basis=basis, reference=ref))
    for r in rows:
        s = r.summary()
        basis = "–" if r.vms is None else f"{len(r.vms)} VMs {list(r.vms)} + {len(r.mds)} MDs"
        lines.append(
            f"| {r.formulation} | {r.dofs} | {basis} | {r.steps} ({r.rejected}) | {r.newton_iters} | "
            f"{'–' if r.offline_s is None else f'{r.offline_s:.1f}'} | {r.compile_s:.1f} | {r.run_s:.3f} | "
            f"{'–' if r.chi_rel_percent is None else f'{r.chi_rel_percent:.3f}'} | "
            f"{'–' if r.speedup is None else f'{r.speedup:.0f}'} | {s['tip_y_max_m']:.4f} | {s['tip_z_max_m']:.2e} |")
    if rows[-1].mds:
        lines += ["", f"MDs chosen by MMI (0-based mode pairs): {[list(p) for p in rows[-1].mds]}."]
    from _machine import report

    report("\n".join(lines) + "\n", a.out)


if __name__ == "__main__":
    main()
