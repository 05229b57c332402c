"""Work against precision for the README's main job, the paper's beam spun up to 40 rad/s (0-30 s,
24 elements): run time against the total error of each run against a converged full solution, for
the full RNCF model and the NR-RNCF model at several tolerances each
(``results/work_precision_spinup.md``).

The reference is the full RNCF run at rtol 1e-8, atol 1e-10, and its own error is shown: its
distance to the run at rtol 1e-7, atol 1e-9. Each run's error is χ_rel (Eq. 40) over all nodal
displacements and output times. The speed-up at equal accuracy reads the full model's time at a
reduced run's error off the full model's curve (``work_precision.full_time_at``), rather than
comparing runs at equal tolerances. Each model also runs at the command's defaults (rtol 1e-4,
atol 1e-6).

    python benchmarks/work_precision_spinup.py
"""

import os
import sys

import jax

jax.config.update("jax_enable_x64", True)

from nrrncf_jax.integrate import AdaptiveStepSize  # noqa: E402
from nrrncf_jax.post.metrics import chi_rel  # noqa: E402
from nrrncf_jax.scenarios.spinup import run_nr_rncf_spinup, run_spinup  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from _machine import machine, pin_to_one_core, report  # noqa: E402
from work_precision import full_time_at  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
CASE = dict(beam="paper", omega_s=40.0, T_s=15.0, t_end=30.0, elements=24, dt_out=0.01)
TOLERANCES = [(1e-4, 1e-6), (1e-5, 1e-7), (1e-6, 1e-8), (1e-7, 1e-9)]  # (rtol, atol); the first: the defaults
FULL_TOLERANCES = [(1e-3, 1e-5)] + TOLERANCES[:3]


def main():
    pin_to_one_core()
    ref = run_spinup("rncf", **CASE, controller=AdaptiveStepSize(1e-8, 1e-10), save_displacements=True)
    check = run_spinup("rncf", **CASE, controller=AdaptiveStepSize(1e-7, 1e-9), save_displacements=True)
    w_ref = ref.displacement_series()
    own = float(chi_rel(w_ref, check.displacement_series()))
    print(f"reference: {ref.steps} steps, {ref.run_s:.1f} s; its distance to rtol 1e-7: {own:.4f} %", flush=True)
    rows, full_curve = [], []
    for rtol, atol in FULL_TOLERANCES:
        run = run_spinup("rncf", **CASE, controller=AdaptiveStepSize(rtol, atol), save_displacements=True)
        err = float(chi_rel(w_ref, run.displacement_series()))
        full_curve.append((err, run.run_s))
        rows.append(("full RNCF", run.dofs, rtol, atol, run.steps, run.rejected, run.run_s, err))
        print(rows[-1], flush=True)
    for rtol, atol in TOLERANCES:
        run = run_nr_rncf_spinup(**CASE, controller=AdaptiveStepSize(rtol, atol), estimator=None)
        err = float(chi_rel(w_ref, run.displacement_series()))
        rows.append(("NR-RNCF (the command's basis)", run.dofs, rtol, atol, run.steps, run.rejected, run.run_s, err))
        print(rows[-1], flush=True)
    lines = ["# Work against precision: the paper's beam spun up to 40 rad/s", "",
             f"Produced by `benchmarks/work_precision_spinup.py`. Machine: {machine()}.", "",
             f"The README's main job (`nrrncf spinup --formulation nr-rncf --beam paper --omega 40`: 24 elements, "
             f"0-30 s, ρ∞ = 0.9, the plain controller). Total error: χ_rel (Eq. 40) over all nodal displacements "
             f"and output times against the full RNCF run at rtol 1e-8, atol 1e-10 ({ref.steps} steps, "
             f"{ref.run_s:.0f} s), whose own error is below its distance to the run at rtol 1e-7, atol 1e-9: "
             f"{own:.4f} %. Full time at this error: the full model's run time interpolated (log-log) on its "
             "curve at the row's error; the speed-up at equal accuracy is its ratio to the row's run time "
             "(– outside the full curve's range). The first row of each model is at the command's defaults.", "",
             "| model | DOFs | rtol | atol | steps (rejected) | run [s] | total error χ_rel [%] | "
             "full time at this error [s] | speed-up at equal accuracy |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for label, dofs, rtol, atol, steps, rejected, run_s, err in rows:
        t_full = full_time_at(err, [full_curve]) if label != "full RNCF" else None
        lines.append(f"| {label} | {dofs} | {rtol:g} | {atol:g} | {steps} ({rejected}) | {run_s:.3f} | {err:.3f} | "
                     f"{'–' if t_full is None else f'{t_full:.2f}'} | "
                     f"{'–' if t_full is None else f'{t_full / run_s:.0f}×'} |")
    report("\n".join(lines) + "\n", os.path.join(HERE, "results", "work_precision_spinup.md"), keep_notes="## Notes")


if __name__ == "__main__":
    main()
