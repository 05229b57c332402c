"""The paper's spin-up examples (Tables 2-5) against converged references: the error a user gets at
the defaults, split into its parts (``results/table3_converged.md``).

    python benchmarks/table3_converged.py [--speeds 4 10 20 40] [--no-curved] [--t-end 30]

``table3.md`` compares each NR-RNCF run with the full RNCF run at the same tolerance (rtol 1e-4), so
its χ_rel is the difference of two runs' time-integration errors and the basis's. Here each case's
NR-RNCF run, with the same basis as there (``run_nr_rncf_spinup``'s automatic MMI selection, the
same candidates and size cap), is measured against the full RNCF run at a hundredth of its
tolerances (``run_nr_rncf_spinup(reference=True)``): the total error (χ_rel, Eq. 40, over all nodal
displacements and outputs), its time-integration part (the run against its repetition at the
reference's tolerance), its basis part (that repetition against the reference), and the
reference's own error (its distance to the full run at a tenth of the tolerance, which bounds it).
Beside them the run's estimate of its total error from reduced runs alone (basis and
time-integration parts, ``reduction.run_error``) and its effectivity. The README's table reads the
total and the basis part from here.
"""

import argparse
import os
import sys

import jax

jax.config.update("jax_enable_x64", True)

from nrrncf_jax.integrate import AdaptiveStepSize  # noqa: E402
from nrrncf_jax.reduction import Basis, ErrorEstimator  # noqa: E402
from nrrncf_jax.scenarios.spinup import default_elements, run_nr_rncf_spinup  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from _machine import machine, pin_to_one_core, report  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
CURVED = ("curved-upwind", "curved-downwind", "curved-out-of-plane")
HEAD = ("case", "DOFs", "rtol", "steps (rejected)", "run [s]", "total χ_rel [%]", "time integration [%]",
        "basis [%]", "reference's own [%]", "estimate, total [%]", "effectivity", "speed-up vs RNCF at rtol/10")


def _row(case, rtol, x):
    s = x.summary()
    e = x.error_split
    return (case, x.dofs, f"{rtol:g}",
            f"{x.steps} ({x.rejected})", f"{x.run_s:.3f}", f"{x.chi_rel_percent:.3f}",
            f"{e['integration_error_percent']:.3f}", f"{e['basis_error_percent']:.3f}",
            f"{e['reference_error_percent']:.4f}", f"{s['chi_rel_estimate_percent']:.3f}",
            f"{s['effectivity']:.2f}", f"{x.speedup:.1f}x")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--speeds", type=float, nargs="+", default=[4.0, 10.0, 20.0, 40.0])
    p.add_argument("--no-curved", action="store_true")
    p.add_argument("--t-end", type=float, default=30.0)
    p.add_argument("--rtol", type=float, default=1e-4)
    p.add_argument("--modes", type=int, default=24, help="candidate vibration modes (table3.py's)")
    p.add_argument("--out", default=os.path.join(HERE, "results", "table3_converged.md"))
    a = p.parse_args()
    pin_to_one_core()
    # table3.py's cases: the straight beam on the paper's meshes (basis up to 25 DOFs), the curved
    # beams on 8 elements (up to 16)
    cases = [("paper", w, default_elements(w), 25) for w in a.speeds]
    cases += [] if a.no_curved else [(b, 4.0, 8, 16) for b in CURVED]
    rows = []
    for beam, w, n_el, max_dofs in cases:
        case = f"{beam}, ωs = {w:g}"
        print(f"{case} ...", file=sys.stderr, flush=True)
        x = run_nr_rncf_spinup(beam, w, T_s=15.0, t_end=a.t_end, elements=n_el,
                               basis=Basis(n_modes=a.modes, max_dofs=max_dofs),
                               controller=AdaptiveStepSize(a.rtol, a.rtol / 100),
                               estimator=ErrorEstimator(integration=True), reference=True)
        rows.append(_row(case, a.rtol, x))
        print("| " + " | ".join(str(c) for c in rows[-1]) + " |", file=sys.stderr, flush=True)
    lines = ["| " + " | ".join(HEAD) + " |", "|---|" + "---:|" * (len(HEAD) - 1)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    text = (f"# NR-RNCF spin-up against converged references (paper Tables 2-5; T_s = 15 s, 0-{a.t_end:g} s, "
            f"ρ∞ = 0.9)\n\nProduced by `benchmarks/table3_converged.py`. Machine: {machine()}.\n\n"
            f"Each NR-RNCF run at rtol {a.rtol:g} (atol rtol/100), its basis chosen as in `table3.md`, against "
            f"the full RNCF run at a hundredth of its tolerances. Parts: the run against its repetition at the "
            f"reference's tolerances (time integration), that repetition against the reference (basis), the "
            f"reference against the full run at a tenth of the run's tolerances (its own error, an upper bound). "
            f"Estimate: the run's own (basis + time-integration parts) from reduced runs alone; effectivity = "
            f"estimate / total. Speed-up: the full run at a tenth of the tolerance over the reduced run, "
            f"compilation apart.\n\n" + "\n".join(lines) + "\n")
    report(text, a.out, keep_notes="## Notes")


if __name__ == "__main__":
    main()
