"""The iteration matrix kept across steps (``Newton(reuse=True)``) and the fixed-step mode, against
one factorisation a step (issue 35).

    python benchmarks/investigations/jacobian_reuse.py [--repeats 3] [--out benchmarks/results/jacobian_reuse.md]

Four models: the paper's beam spun up to 4 rad/s in full-order RNCF (C1 elements, modified
Newton); its NR-RNCF model at 10 rad/s (full Newton by default); the NR-RNCF three-beam pendulum
(81 DOFs, index 3, 0-2 s); the NR-RNCF slider-crank (35 DOFs, index 3, 0-0.1 s). Each is run
adaptive and at a constant step, with one factorisation a step (the default) and with the matrix
kept. Columns: steps (rejected), Newton iterations, factorisations, compile and run time (the
median of ``--repeats`` runs of the compiled program, ``block_until_ready``), and the largest
difference of the recorded output from the default adaptive run, relative to its largest value,
next to the same for a run at 1/100 of the tolerance (the adaptive run's own error). One core.
"""

import argparse
import os
import statistics
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from nrrncf_jax.examples.slider_crank import mechanism  # noqa: E402
from nrrncf_jax.integrate import (  # noqa: E402
    AdaptiveStepSize,
    ConstantStepSize,
    GeneralizedAlpha,
    GeneralizedAlphaIndex3,
    Newton,
    simulate,
)
from nrrncf_jax.multibody.sensors import observe as observe_sensors  # noqa: E402
from nrrncf_jax.reduction import Basis, nr_rncf  # noqa: E402
from nrrncf_jax.scenarios.pendulum import PendulumSpec, build_reduced_pendulum  # noqa: E402
from nrrncf_jax.scenarios.spinup import build_spinup_model  # noqa: E402

sys.path[:0] = [os.path.dirname(__file__), os.path.dirname(os.path.dirname(os.path.abspath(__file__)))]
from _machine import machine, pin_to_one_core, report  # noqa: E402


def _cases():
    """(name, DOFs, model, solver, ts, observe, y0, rtol, atol, dt, newton_tol) per model."""
    out = []
    ts = np.linspace(0.0, 30.0, 301)
    full = build_spinup_model("rncf", "paper", 4.0, 15.0, None)
    tip = full.body.n_vectors - full.body.vectors_per_node
    out.append(("spin-up ω=4, full RNCF", int(np.sum(np.asarray(full.free_mask()))), full, GeneralizedAlpha(0.9), ts,
                lambda t, q, v: full.displacements(t, q)[tip], None, 1e-4, 1e-6, 0.02, 1e-3))
    ts = np.linspace(0.0, 30.0, 3001)
    red = nr_rncf(build_spinup_model("rncf", "paper", 10.0, 15.0, None), jnp.asarray(ts),
                  Basis(n_modes=24, max_dofs=25)).model
    out.append(("spin-up ω=10, NR-RNCF", red.n_dof, red, GeneralizedAlpha(0.9), ts, lambda t, p, v: p, None,
                1e-4, 1e-6, 0.01, 1e-3))
    pend = build_reduced_pendulum(PendulumSpec(elements=10))[0]
    out.append(("pendulum, NR-RNCF", pend.n_dof, pend, GeneralizedAlphaIndex3(0.9), np.linspace(0.0, 2.0, 201),
                lambda t, z, v: jnp.stack([x[-6] for x in pend.nodal_vectors(z)]), None, 1e-4, 1e-5, 5e-4, 1e-2))
    crank = mechanism(formulation="nr-rncf")
    fn = observe_sensors(crank.system, crank.sensors)
    out.append(("slider-crank, NR-RNCF", crank.system.n_dof, crank.system, GeneralizedAlphaIndex3(crank.rho_inf),
                np.linspace(0.0, 0.1, 201), lambda t, z, v: fn(t, z, v)["w_mid"], crank.y0, 1e-4, 1e-5, 1e-4, 1e-3))
    return out


def _run(model, solver, ts, observe, y0, controller, newton, repeats):
    def go(y0):
        return simulate(model, solver, controller, ts, observe=observe, y0=y0, newton=newton, throw=False)

    t0 = time.perf_counter()
    compiled = jax.jit(go).lower(y0).compile()
    compile_s = time.perf_counter() - t0
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        sol = jax.block_until_ready(compiled(y0))
        times.append(time.perf_counter() - t0)
    if not bool(sol.succeeded):
        raise RuntimeError(f"run failed: {sol.message}")
    return sol, compile_s, statistics.median(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default="benchmarks/results/jacobian_reuse.md")
    args = ap.parse_args()
    pin_to_one_core()
    rows = []
    for name, dofs, model, solver, ts, observe, y0, rtol, atol, dt, ntol in _cases():
        ts = jnp.asarray(ts)
        base = None
        ref, _, _ = _run(model, solver, ts, observe, y0, AdaptiveStepSize(rtol / 100, atol / 100), Newton(ntol), 1)
        for label, controller in ((f"adaptive rtol {rtol:g}", AdaptiveStepSize(rtol, atol)),
                                  (f"constant dt {dt:g}", ConstantStepSize(dt, rtol=rtol, atol=atol))):
            for reuse in (False, True):
                sol, c_s, r_s = _run(model, solver, ts, observe, y0, controller, Newton(ntol, reuse=reuse),
                                     args.repeats)
                y = np.asarray(sol.ys)
                if base is None:
                    base = y
                    scale = np.abs(base).max()
                    own = np.abs(np.asarray(ref.ys) - base).max() / scale
                rows.append((name, dofs, label, "kept" if reuse else "fresh a step", int(sol.num_steps),
                             int(sol.num_rejected), int(sol.num_newton), int(sol.num_factorizations), c_s, r_s,
                             np.abs(y - base).max() / scale, np.abs(y - np.asarray(ref.ys)).max() / scale, own))
                print(rows[-1], flush=True)
    lines = [
        "# The iteration matrix kept across steps, and the fixed-step mode (issue 35)",
        "",
        f"Produced by `benchmarks/investigations/jacobian_reuse.py`. Machine: {machine()}.",
        "",
        "`Newton(reuse=True)`: modified Newton on a matrix kept from step to step while the step size stays "
        "within 20 % of the one it was factored for and its last solve contracted by 0.1 or better; a solve "
        "that contracts worse than 0.5 gives up and the step is solved again on a fresh matrix. Adaptive "
        "steps keep their size where the controller would grow it by less than 20 %. `constant dt` with "
        "`kept` is the fixed-step mode. run: the median of the compiled program's runs. Δ base: the largest "
        "difference of the output from the first row of the model (adaptive, fresh), relative to its "
        "largest value; Δ ref: the same from a run at 1/100 of the tolerance (each run's own error).",
        "",
        "| model | DOFs | steps by | matrix | steps (rejected) | Newton it. | factorisations | compile [s] "
        "| run [s] | Δ base | Δ ref |",
        "|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]} | {r[4]} ({r[5]}) | {r[6]} | {r[7]} | {r[8]:.1f} "
                     f"| {r[9]:.3f} | {r[10]:.1e} | {r[11]:.1e} |")
    report("\n".join(lines) + "\n", args.out, keep_notes="## Notes")


if __name__ == "__main__":
    main()
