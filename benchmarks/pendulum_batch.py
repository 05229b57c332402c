"""A batch of NR-RNCF pendulums released at different angles, in one compiled, vmapped run.

    python benchmarks/pendulum_batch.py [--sizes 1 4 16] [--lanes L ...] [--range -60 0] [--elements 10]
                                        [--t-end 2] [--out benchmarks/results/pendulum_batch.md]

The paper's pendulum reduced as in ``benchmarks/pendulum.py`` (5 VMs + 15 MDs a beam, 81 DOFs),
released from rest at n angles spread over ``--range`` (degrees, −60° … 0° by default: below the
horizontal) about the ground hinge
(``scenarios.pendulum.release_sweep``: ``integrate.simulate_batch``, every member with its own
adaptive steps; ``--lanes`` of them advance together and the rest queue for a lane, by default
``integrate.batch_lanes``: all n on a GPU, a few on a CPU). For each n (and lane count): compile
and run time apart (ahead-of-time compilation, then a blocked run), the run time per pendulum;
the members' steps (mean, largest, and all together), the run time per member-step (against the
one-member run's time a step: what batching saves), and failed members. The angles cost
different numbers of steps, and a lane whose member is done runs on, masked, while others do.
Above the horizontal the chain falls onto its hinge and its soft beams (E = 5 MPa: a beam's Euler
load, ~6 mN, is under 1 % of its weight) buckle: released at +60°, 42,183 steps over 0-2 s against
3,011 at 0°, which is why the default range stays below the horizontal (a lowered chain stretches
its beams instead). On a machine with a GPU, ``benchmarks/gpu_sweep.sh`` runs it with n = 256 (the
issue's GPU row). On a CPU the process is pinned to one core (``--all-cores`` not to), as
``pendulum.py``.
"""

import argparse
import os
import sys

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from nrrncf_jax.integrate import AdaptiveStepSize  # noqa: E402
from nrrncf_jax.scenarios.pendulum import PendulumBasis, PendulumSpec, build_reduced_pendulum, release_sweep  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from _machine import machine, pin_to_one_core, report  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[1, 4, 16])
    ap.add_argument("--lanes", type=int, nargs="+", default=[None],
                    help="lane counts to run each size with (default: integrate.batch_lanes)")
    ap.add_argument("--range", type=float, nargs=2, default=[-60.0, 0.0], metavar=("LO", "HI"),
                    help="release angles [degrees] from the +x axis, counter-clockwise about Z")
    ap.add_argument("--elements", type=int, default=10)
    ap.add_argument("--t-end", type=float, default=2.0)
    ap.add_argument("--rtol", type=float, default=1e-4)
    ap.add_argument("--out", default="benchmarks/results/pendulum_batch.md")
    ap.add_argument("--all-cores", action="store_true", help="do not pin the process to one core (on a CPU)")
    ap.add_argument("--small-kernels", action="store_true",
                    help="compile the batch with integrate.SMALL_KERNEL_OPTIONS (release_sweep's small_kernels)")
    a = ap.parse_args(argv)
    if not a.all_cores:
        pin_to_one_core()
    system, info = build_reduced_pendulum(PendulumSpec(elements=a.elements), PendulumBasis(5))
    lines = ["# NR-RNCF pendulums released at different angles, one batched run", "",
             f"Produced by `benchmarks/pendulum_batch.py --sizes {' '.join(map(str, a.sizes))} --range "
             f"{a.range[0]:g} {a.range[1]:g} --elements {a.elements} --t-end {a.t_end:g}"
             f"{' --small-kernels' if a.small_kernels else ''}`. Machine: {machine()}.", "",
             f"The paper's pendulum ({a.elements} C1 elements a beam), NR-RNCF with 5 VMs + 15 MDs a beam "
             f"({system.n_dof} DOFs; offline {info['offline_s']:.1f} s), released from rest at n angles evenly "
             f"spread over {a.range[0]:g}° … {a.range[1]:g}° about the ground hinge, 0-{a.t_end:g} s, "
             f"rtol {a.rtol:g}, ρ∞ = 0.9, "
             "outputs every 10 ms; each member with its own steps, 'lanes' of them advancing together, the rest "
             "queued (n = 1: released along +x). Per member-step: steps tried, rejected ones included.", "",
             "| device | n | lanes | compile [s] | run [s] | run a pendulum [s] | steps mean | steps max | "
             "steps, all members | run a member-step [ms] | failed |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    device = f"{jax.devices()[0].platform.upper()} ({jax.devices()[0].device_kind})"
    for n in a.sizes:
        angles = np.deg2rad(np.linspace(*a.range, n)) if n > 1 else np.zeros(1)
        for lanes in a.lanes:
            sweep = release_sweep(system, angles, t_end=a.t_end, dt_out=0.01,
                                  controller=AdaptiveStepSize(a.rtol, a.rtol / 10), lanes=lanes,
                                  small_kernels=a.small_kernels)
            tried = sweep.steps + sweep.rejected  # what the loop computes, accepted or not
            lines.append(f"| {device} | {n} | {sweep.lanes} | {sweep.compile_s:.1f} | {sweep.run_s:.2f} | "
                         f"{sweep.run_s / n:.3f} | {sweep.steps.mean():.0f} | {sweep.steps.max()} | "
                         f"{sweep.steps.sum()} | {1e3 * sweep.run_s / tried.sum():.3f} | {int((~sweep.ok).sum())} |")
            print(lines[-1], flush=True)
    report("\n".join(lines) + "\n", a.out)


if __name__ == "__main__":
    main()
