"""Compile time against run time under XLA's CPU code-generation options, for whole simulations.

    python benchmarks/investigations/xla_options.py [--cases nr_pendulum ancf_pendulum rncf_spinup nr_spinup]
                                     [--repeats 4] [--out benchmarks/results/xla_options.md]

On a CPU most of a short study's time is XLA's compilation of the integrator loop (the reduced
pendulum: about 10-17 s to compile, 2-3 s to run). Two of XLA's options change that balance:

- ``xla_cpu_use_fusion_emitters=False``: the older (LLVM IR) emitter for fused element-wise
  kernels instead of the MLIR-based one;
- ``xla_cpu_experimental_ynn_fusion_type=""``: no YNNPACK kernels for small dot products (XLA's
  own instead).

Each case's loop is lowered once and compiled under each variant (``Lowered.compile``'s
``compiler_options``: per executable, no global flag); the compiled programs then run in turn
(A B C D, then D C B A, ...) so that a drift of this VM's speed falls on all; run time is the
median of ``--repeats``. The variants round differently (another fusion, another summation
order), so their step counts may differ by a few percent; the time a step is given too.

The same options for every compilation of a process: ``XLA_FLAGS=--xla_cpu_use_fusion_emitters=false``
in the environment (the test suite under it: see the results file).

The process is pinned to one core (``--all-cores`` not to), as ``pendulum.py``.
"""

import argparse
import os
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

sys.path[:0] = [os.path.dirname(__file__), os.path.dirname(os.path.dirname(os.path.abspath(__file__)))]
from _machine import machine, pin_to_one_core, report  # noqa: E402

from nrrncf_jax.integrate import AdaptiveStepSize, GeneralizedAlpha, GeneralizedAlphaIndex3, Newton  # noqa: E402
from nrrncf_jax.integrate.simulate import _prepare, _simulate  # noqa: E402

VARIANTS = {
    "default": {},
    "fusion emitters off": {"xla_cpu_use_fusion_emitters": False},
    "YNNPACK dots off": {"xla_cpu_experimental_ynn_fusion_type": ""},
    "both off": {"xla_cpu_use_fusion_emitters": False, "xla_cpu_experimental_ynn_fusion_type": ""},
}


def _case(name: str):
    """``(description, model, t_end, (solver, controller, newton))``."""
    if name == "nr_pendulum":
        from nrrncf_jax.scenarios.pendulum import PendulumBasis, PendulumSpec, build_reduced_pendulum

        model, _ = build_reduced_pendulum(PendulumSpec(elements=10), PendulumBasis(5, "all"))
        return ("NR-RNCF pendulum, 5 VMs + 15 MDs a beam", model, 2.0,
                (GeneralizedAlphaIndex3(0.9), AdaptiveStepSize(1e-4, 1e-5), Newton(1e-2)))
    if name == "ancf_pendulum":
        from nrrncf_jax.scenarios.pendulum import PendulumSpec, build_pendulum

        return ("ANCF pendulum, 10 elements a beam", build_pendulum(PendulumSpec(elements=10)), 0.2,
                (GeneralizedAlphaIndex3(0.9), AdaptiveStepSize(1e-4, 1e-5), Newton(1e-2)))
    if name in ("rncf_spinup", "nr_spinup"):
        from nrrncf_jax.scenarios.spinup import build_spinup_model

        full = build_spinup_model("rncf", "paper", 4.0)
        if name == "rncf_spinup":
            return ("full RNCF spin-up, paper beam, ωs = 4 rad/s", full, 30.0,
                    (GeneralizedAlpha(0.9), AdaptiveStepSize(1e-4, 1e-6), Newton()))
        from nrrncf_jax import nr_rncf

        reduced = nr_rncf(full, jnp.linspace(0.0, 30.0, 3001))
        return ("NR-RNCF spin-up of that beam (24 candidates, automatic selection)", reduced.model, 30.0,
                (GeneralizedAlpha(0.9), AdaptiveStepSize(1e-4, 1e-6), Newton()))
    raise ValueError(f"unknown case {name!r}")


def run_case(name: str, repeats: int) -> list[str]:
    description, model, t_end, (solver, controller, newton) = _case(name)
    ts = jnp.linspace(0.0, t_end, int(round(t_end / 0.01)) + 1)
    args = _prepare(model, solver, controller, ts, None, newton, 0.0, None, "forward", 200_000, False)
    lowered = _simulate.lower(*args)
    compiled, compile_s = {}, {}
    for label, opts in VARIANTS.items():
        t0 = time.perf_counter()
        compiled[label] = lowered.compile(compiler_options=opts or None)
        compile_s[label] = time.perf_counter() - t0
    runs = {label: [] for label in VARIANTS}
    stats = {}
    order = list(VARIANTS)
    for i in range(repeats):
        for label in order if i % 2 == 0 else order[::-1]:
            t0 = time.perf_counter()
            sol = jax.block_until_ready(compiled[label](*args))
            runs[label].append(time.perf_counter() - t0)
            if not bool(sol.succeeded):
                raise RuntimeError(f"{name} under {label}: {sol.message}")
            stats[label] = (int(sol.num_steps), int(sol.num_newton))
    rows = []
    for label in VARIANTS:
        steps, newton = stats[label]
        run = float(np.median(runs[label]))
        rows.append(f"| {description} | {model.n_dof} | 0-{t_end:g} | {label} | {steps} | {newton} | "
                    f"{compile_s[label]:.2f} | {run:.3f} | {min(runs[label]):.3f}-{max(runs[label]):.3f} | "
                    f"{1e3 * run / steps:.3f} |")
        print(rows[-1], flush=True)
    return rows


def main(argv=None):
    p = argparse.ArgumentParser()
    p.add_argument("--cases", nargs="+", default=["nr_pendulum", "ancf_pendulum", "rncf_spinup", "nr_spinup"])
    p.add_argument("--repeats", type=int, default=4)
    p.add_argument("--all-cores", action="store_true")
    p.add_argument("--out", default="benchmarks/results/xla_options.md")
    a = p.parse_args(argv)
    if not a.all_cores:
        pin_to_one_core()
    lines = ["# Compile time against run time under XLA's CPU options", "",
             f"Produced by `benchmarks/investigations/xla_options.py --cases {' '.join(a.cases)} "
             f"--repeats {a.repeats}`. "
             f"Machine: {machine()}.", "",
             "Each loop lowered once, compiled under each variant (per-executable compiler options), run in turn; "
             f"run [s]: the median of {a.repeats} (their range beside it).", "",
             "| case | DOFs | t [s] | XLA options | steps | Newton it. | compile [s] | run [s] | runs' range [s] | "
             "ms a step |", "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|"]
    for name in a.cases:
        lines += run_case(name, a.repeats)
    report("\n".join(lines) + "\n", a.out)


if __name__ == "__main__":
    main()
