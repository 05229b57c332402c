"""Work against precision for the flexible slider-crank: run time against the total error of each
run against a converged full solution, for the full ANCF rod and the reduced rods, at several
tolerances each (``results/work_precision.md``, ``results/figures/work_precision.png``).

The reference is the full ANCF rod (8 elements) at rtol 1e-7, and its own error is shown: its
distance to the run at 1e-6. Each run's error is χ_rel (Eq. 40) of w_mid, the rod midpoint's
distance from its chord, which is what deforms (x_B, the slider, follows the rigid kinematics
to 0.05 % in every run). The speed-up at equal accuracy reads the full model's time at a
reduced run's error off the full model's curve (log-log interpolation between its runs), rather
than comparing runs at equal rtol.

    python benchmarks/work_precision.py
"""

import os
import sys

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from nrrncf_jax.post.metrics import chi_rel  # noqa: E402
from nrrncf_jax.scenarios.mechanism_file import load_setup, run_setup  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from _machine import machine, pin_to_one_core, report  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
NODES = {"error_on": "nodes"}  # the step error on every nodal vector, with plain step control (``_controller``)
MODELS = [  # (label, load_setup parameters, run_setup options, tolerances); the first two are the full rod
    ("full ANCF, 8 elements, error on nodal vectors", {"formulation": "ancf"}, NODES,
     (1e-3, 3e-4, 1e-4, 3e-5, 1e-5)),
    ("full ANCF, 8 elements, error on sensors (PI)", {"formulation": "ancf"}, {}, (1e-4, 3e-5, 1e-5, 3e-6)),
    ("NR-RNCF pinned, 1 VM + 1 MD, error on sensors (PI; default)", {"formulation": "nr-rncf"}, {},
     (1e-4, 5e-5, 2e-5, 1e-5, 3e-6)),
    ("NR-RNCF pinned, 1 VM + 1 MD, error on nodal vectors", {"formulation": "nr-rncf"}, NODES,
     (1e-3, 3e-4, 1e-4, 3e-5, 1e-5)),
    ("NR-RNCF pinned, 2 VMs + 3 MDs, error on sensors (PI)", {"formulation": "nr-rncf", "vms": 2}, {},
     (1e-4, 2e-5, 5e-6)),
]
FULL = 2  # the full rod's curves: the first two models


def full_time_at(error, curves):
    """The full model's run time at ``error``: on each of its (error, time) curves interpolated
    log-log, the fastest; None outside every curve's range."""
    times = []
    for curve in curves:
        e, t = (np.log(np.asarray(x)) for x in zip(*sorted(curve)))
        x = np.log(error)
        if e[0] <= x <= e[-1]:
            times.append(float(np.exp(np.interp(x, e, t))))
    return min(times) if times else None


def _controller(setup, rtol, options):
    """The step control of a run with ``options``: plain on every nodal vector (``NODES``), else the
    model's own (PI on its sensors)."""
    return setup.controller(rtol, step_control="plain" if options else None)


def main():
    pin_to_one_core()
    full = load_setup("slider_crank", {"formulation": "ancf"})
    ref = run_setup(full, n_out=401, controller=_controller(full, 1e-7, NODES), **NODES)
    check = run_setup(full, n_out=401, controller=_controller(full, 1e-6, NODES), **NODES)
    own = float(chi_rel(ref.series["w_mid"], check.series["w_mid"]))
    print(f"reference: {ref.steps} steps, {ref.run_s:.1f} s; its distance to rtol 1e-6: {own:.4f} %", flush=True)
    rows, curves = [], {}
    for label, params, options, tols in MODELS:
        setup = load_setup("slider_crank", params)
        for rtol in tols:
            run = run_setup(setup, n_out=401, controller=_controller(setup, rtol, options), **options)
            err = float(chi_rel(ref.series["w_mid"], run.series["w_mid"]))
            curves.setdefault(label, []).append((err, run.run_s))
            rows.append((label, run.dofs, rtol, run.steps, run.rejected, run.run_s, err))
            print(rows[-1], flush=True)
    full_curves = [curves[m[0]] for m in MODELS[:FULL]]
    lines = ["# Work against precision: the flexible slider-crank", "",
             f"Produced by `benchmarks/work_precision.py`. Machine: {machine()}.", "",
             f"Total error: χ_rel (Eq. 40) of w_mid against the full ANCF rod at rtol 1e-7 ({ref.steps} steps), whose "
             f"own error is below its distance to the run at rtol 1e-6: {own:.4f} %. Generalized-α, ρ∞ = 0.5, "
             "atol = rtol/10 (m), 0-0.1 s. The step error on every nodal vector with the plain controller, or on "
             "the sensors w_mid and x_B (`error_on`, `Mechanism.observed_error`) with Gustafsson's PI controller. "
             "Full time at this error: the full model's run time interpolated (log-log) on its two curves at the "
             "row's error, the faster; the speed-up at equal accuracy is its ratio to the row's run time (– outside "
             "the full curves' range).", "",
             "| model | DOFs | rtol | steps (rejected) | run [s] | total error χ_rel w_mid [%] | "
             "full time at this error [s] | speed-up at equal accuracy |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for label, dofs, rtol, steps, rejected, run_s, err in rows:
        t_full = full_time_at(err, full_curves) if label not in [m[0] for m in MODELS[:FULL]] else None
        lines.append(f"| {label} | {dofs} | {rtol:g} | {steps} ({rejected}) | {run_s:.3f} | {err:.3f} | "
                     f"{'–' if t_full is None else f'{t_full:.2f}'} | "
                     f"{'–' if t_full is None else f'{t_full / run_s:.1f}×'} |")
    report("\n".join(lines) + "\n", os.path.join(HERE, "results", "work_precision.md"), keep_notes="## Notes")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.2))
    for label, curve in curves.items():
        e, t = zip(*sorted(curve))
        ax.loglog(e, t, "o-", label=label)
    ax.set_xlabel("total error χ_rel(w_mid) against the converged full run [%]")
    ax.set_ylabel("run time [s] (one core)")
    ax.set_title("Slider-crank: work against precision")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    os.makedirs(os.path.join(HERE, "results", "figures"), exist_ok=True)
    fig.savefig(os.path.join(HERE, "results", "figures", "work_precision.png"), dpi=120)


if __name__ == "__main__":
    main()
