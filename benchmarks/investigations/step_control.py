"""The PI step-size controller (``AdaptiveStepSize(pcoeff=, icoeff=)``) against the plain one
(issue 35): attempted steps, Newton iterations, time and accuracy.

    python benchmarks/investigations/step_control.py [--repeats 5] [--out benchmarks/results/step_control.md]

The four models of ``jacobian_reuse.py`` (full-order RNCF spin-up, NR-RNCF spin-up, the NR-RNCF
pendulum, the NR-RNCF slider-crank), each run adaptive with one factorisation a step: the plain
controller (``icoeff = 1``) at the model's tolerance, and the PI controller (``pcoeff = 0.4,
icoeff = 0.3``, Gustafsson's) at the same tolerance and at twice it. Error: the largest difference
of the recorded output from a run at 1/1000 of the tolerance (plain controller), relative to that
run's largest value. Run time: the median of ``--repeats`` runs of the compiled program
(``block_until_ready``). Steps, rejections and Newton iterations are the same on every machine up to
round-off; the times are this machine's. One core.
"""

import argparse
import os
import sys

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from nrrncf_jax.integrate import STEP_CONTROLS, AdaptiveStepSize, Newton  # noqa: E402

sys.path[:0] = [os.path.dirname(__file__), os.path.dirname(os.path.dirname(os.path.abspath(__file__)))]
from _machine import machine, pin_to_one_core, report  # noqa: E402
from jacobian_reuse import _cases, _run  # noqa: E402

PI = STEP_CONTROLS["pi"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default="benchmarks/results/step_control.md")
    args = ap.parse_args()
    pin_to_one_core()
    rows = []
    for name, dofs, model, solver, ts, observe, y0, rtol, atol, _, ntol in _cases():
        ts = jnp.asarray(ts)
        ref, _, _ = _run(model, solver, ts, observe, y0, AdaptiveStepSize(rtol / 1000, atol / 1000), Newton(ntol), 1)
        y_ref = np.asarray(ref.ys)
        scale = np.abs(y_ref).max()
        for label, factor, coeffs in (("plain", 1.0, {}), ("PI", 1.0, PI), ("PI", 2.0, PI)):
            controller = AdaptiveStepSize(factor * rtol, factor * atol, **coeffs)
            sol, c_s, r_s = _run(model, solver, ts, observe, y0, controller, Newton(ntol), args.repeats)
            err = np.abs(np.asarray(sol.ys) - y_ref).max() / scale
            rows.append((name, dofs, label, factor * rtol, int(sol.num_steps), int(sol.num_rejected),
                         int(sol.num_newton), c_s, r_s, err))
            print(rows[-1], flush=True)
    lines = [
        "# The PI step-size controller against the plain one (issue 35)",
        "",
        f"Produced by `benchmarks/investigations/step_control.py`. Machine: {machine()}.",
        "",
        "plain: `AdaptiveStepSize(rtol, atol)`, the step grown by 0.9 err^(-1/3); PI: "
        f"`AdaptiveStepSize(rtol, atol, pcoeff={PI['pcoeff']}, icoeff={PI['icoeff']})`, an accepted step's growth "
        "also weighted by the last accepted step's error. One factorisation a step. attempted: accepted + "
        "rejected steps. error: the largest difference of the output from a run at 1/1000 of the "
        "tolerance, relative to its largest value. run: the median of the compiled program's runs.",
        "",
        "| model | DOFs | controller | rtol | steps (rejected) | attempted | Newton it. | compile [s] | run [s] "
        "| error |",
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]:g} | {r[4]} ({r[5]}) | {r[4] + r[5]} | {r[6]} "
                     f"| {r[7]:.1f} | {r[8]:.3f} | {r[9]:.1e} |")
    report("\n".join(lines) + "\n", args.out, keep_notes="## Notes")


if __name__ == "__main__":
    main()
