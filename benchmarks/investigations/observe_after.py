"""Observing in the adaptive loop against observing after it (issue 35: fewer operations a step).

    python benchmarks/investigations/observe_after.py [--repeats 5] [--batch 16]
        [--out benchmarks/results/observe_after.md]

``integrate.simulate`` runs a forward-mode run with a small state by recording (q, v) at the
output times and calling ``observe`` once over all of them after the loop (``_Config.after``);
before, each step that covered output times observed its whole window of 8 slots in the loop,
and a batched run (``simulate_batch``) observed its window in every step of every lane. The two
modes here are the same program but for that (``STATE_OUTPUTS_MAX_BYTES`` set to 0 forces the
loop, for an observation smaller than the state). Cases: the paper's NR-RNCF pendulum (81 DOFs,
rtol 1e-4, 0-2 s) with ``run_chain``'s observation (every node, the left slopes, the energies,
the joints' violation) at 1 ms and at 10 ms outputs, and the release-angle batch
(``scenarios.pendulum.release_sweep``, its tips at 10 ms). Run times: the compiled program's,
the two modes alternating, median and range of ``--repeats`` runs each; one core.
"""

import argparse
import importlib
import os
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from nrrncf_jax.integrate import AdaptiveStepSize, GeneralizedAlphaIndex3, Newton  # noqa: E402
from nrrncf_jax.scenarios.pendulum import PendulumSpec, _chain, build_reduced_pendulum, release_sweep  # noqa: E402

sys.path[:0] = [os.path.dirname(__file__), os.path.dirname(os.path.dirname(os.path.abspath(__file__)))]
from _machine import machine, pin_to_one_core, report  # noqa: E402

simulate_module = importlib.import_module("nrrncf_jax.integrate.simulate")
MODES = {"after the loop": simulate_module.STATE_OUTPUTS_MAX_BYTES, "in the loop": 0}


def _chain_run(system, dt_out):
    """One compiled single run with ``run_chain``'s observation: ``(run, steps, first output)``."""
    _, vectors, nodes = _chain(system)

    def observe(t, x, v):
        xs, kinetic = vectors(x), system.kinetic_energy(x, v)
        return (jnp.stack([xb[nodes] for xb in xs]), jnp.stack([xb[1] for xb in xs]),
                kinetic + system.potential_energy(x), kinetic, jnp.max(jnp.abs(system.constraints(x))))

    ts = jnp.asarray(np.arange(0.0, 2.0 + dt_out / 2, dt_out))

    def run():
        t0 = time.perf_counter()
        sol, compile_s, run_s = simulate_module.simulate_timed(
            system, GeneralizedAlphaIndex3(0.9), AdaptiveStepSize(1e-4, 1e-5), ts, observe=observe, newton=Newton(1e-2))
        return run_s, time.perf_counter() - t0 - run_s, int(sol.num_steps), np.asarray(sol.ys[0])

    return run


def _batch_run(system, n):
    angles = np.linspace(-np.pi / 3, 0.0, n)

    def run():
        r = release_sweep(system, angles)
        return r.run_s, r.compile_s, int(r.steps.sum()), r.tips

    return run


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--out", default="benchmarks/results/observe_after.md")
    args = ap.parse_args()
    pin_to_one_core()
    system, _ = build_reduced_pendulum(PendulumSpec())
    cases = [("pendulum, outputs every 1 ms", _chain_run(system, 1e-3), args.repeats),
             ("pendulum, outputs every 10 ms", _chain_run(system, 1e-2), args.repeats),
             (f"{args.batch} pendulums released at angles in -60°…0° (tips, 10 ms)", _batch_run(system, args.batch),
              max(2, args.repeats // 2))]
    rows = []
    for name, run, repeats in cases:
        times, compiles, outs = {m: [] for m in MODES}, {}, {}
        for _ in range(repeats):
            for mode, limit in MODES.items():
                simulate_module.STATE_OUTPUTS_MAX_BYTES = limit
                run_s, compile_s, steps, y = run()
                times[mode].append(run_s)
                compiles.setdefault(mode, compile_s)
                outs[mode] = (steps, y)
        diff = float(np.abs(outs["after the loop"][1] - outs["in the loop"][1]).max())
        for mode in MODES:
            t = np.asarray(times[mode])
            rows.append(f"| {name} | {mode} | {outs[mode][0]} | {compiles[mode]:.1f} | {np.median(t):.3f} "
                        f"| {t.min():.3f}-{t.max():.3f} | {diff:.1e} |")
            print(rows[-1], flush=True)
    simulate_module.STATE_OUTPUTS_MAX_BYTES = MODES["after the loop"]
    lines = [
        "# Observing after the adaptive loop against in it (issue 35)",
        "",
        f"Produced by `benchmarks/investigations/observe_after.py`. Machine: {machine()}.",
        "",
        "The same compiled run but for where `observe` is called (module docstring). Steps: accepted steps (all "
        "members for the batch). Compile: the first compilation of each mode [s]. Run: median and range over the "
        "repeats, the modes alternating. Δ: the largest difference of the first output between the modes (the "
        "nodes [m], or the tips).",
        "",
        "| case | observed | steps | compile [s] | run [s] | range [s] | Δ |",
        "|---|---|---:|---:|---:|---|---:|",
        *rows,
    ]
    report("\n".join(lines) + "\n", args.out, keep_notes="## Notes")


if __name__ == "__main__":
    main()
