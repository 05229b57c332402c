"""The reduced pendulum's arithmetic a step against its time a step: a roofline row (issue 35).

    python benchmarks/roofline.py [--rtols 1e-4 1e-3] [--repeats 3] [--out benchmarks/results/roofline.md]

The arithmetic comes from the optimized HLO of the compiled run (the same program ``hlo_ops.py``
counts): every dot's 2·(output size)·(contracted size) and every LAPACK call's own count (an LU of
m × n, m ≥ n, 2(m n² − n³/3); a triangular solve n² a right-hand side; both per system of a
batch), in the adaptive loop's body outside the Newton loop (once per attempted step) and in the
Newton loop's body (once per iteration). Element-wise fusions are left out of the arithmetic (their multiply-adds are of
the order of their output sizes, listed beside it, and on this model far fewer than the dots'); so
the GFLOP/s below is the dots' and the factorisations' rate, an upper bound of what the step
could reach if nothing else cost time.

The time is the whole compiled run's (``simulate``, compiled first; median of ``--repeats``)
divided among its attempted steps. The machine's reach, for the roofline: a large float64 matrix
product (1024 × 1024) and a product of the size of the step's largest (the 3 × 198 × 20 batched
mode-matrix product) on the same pinned core.

The process is pinned to one core, as ``pendulum.py``.
"""

import argparse
import math
import os
import re
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from _machine import machine, pin_to_one_core, report  # noqa: E402
from hlo_ops import computations, counts, loop_bodies  # noqa: E402

from nrrncf_jax.integrate import AdaptiveStepSize, GeneralizedAlphaIndex3, Newton, simulate  # noqa: E402
from nrrncf_jax.scenarios.pendulum import PendulumSpec, build_reduced_pendulum  # noqa: E402

_SHAPE = re.compile(r"^\s*(?:ROOT )?%?([\w.\-]+) = (\w+)\[([\d,]*)\]")


def _shapes(hlo: str) -> dict[str, tuple[int, ...]]:
    """Every array-valued instruction's name → shape (tuples and scalars' names map to ())."""
    out = {}
    for line in hlo.splitlines():
        m = _SHAPE.match(line)
        if m:
            out[m.group(1)] = tuple(int(d) for d in m.group(3).split(",") if d)
    return out


def _operands(line: str) -> list[str]:
    body = line.split("=", 1)[1]
    inner = body[body.index("(") + 1:]
    return re.findall(r"%([\w.\-]+)", inner.split(")", 1)[0])


def line_flops(line: str, shapes) -> tuple[str, float]:
    """``(kind, flops)`` of one instruction: ``"dot"``, ``"lu"``, ``"trsm"`` or ``"other"`` (0)."""
    out = _SHAPE.match(line)
    if " dot(" in line and out is not None:
        out_shape = tuple(int(d) for d in out.group(3).split(",") if d)
        lhs = shapes[_operands(line)[0]]
        dims = re.search(r"lhs_contracting_dims=\{([\d,]*)\}", line).group(1)
        contracted = math.prod(lhs[int(d)] for d in dims.split(",") if d)
        return "dot", 2.0 * math.prod(out_shape) * contracted
    if " custom-call(" in line:
        target = re.search(r'custom_call_target="([^"]+)"', line).group(1)
        declared = re.search(r"operand_layout_constraints=\{((?:\w+\[[\d,]*\]\{[\d,]*\}(?:, )?)+)\}", line)
        ops = ([tuple(int(d) for d in m.split(",") if d) for m in re.findall(r"\w+\[([\d,]*)\]", declared.group(1))]
               if declared else [shapes.get(o, ()) for o in _operands(line)])
        if "getrf" in target:
            big, small = max(ops[0][-2:]), min(ops[0][-2:])  # m × n: max·min² − min³/3 multiply-adds
            return "lu", 2.0 * (big * small ** 2 - small ** 3 / 3.0) * math.prod(ops[0][:-2])
        if "trsm" in target:
            a, b = ops[0], ops[1]
            return "trsm", float(a[-1]) ** 2 * b[-1] * math.prod(b[:-2]) if len(b) >= 2 else 0.0
    return "other", 0.0


def arithmetic(hlo: str) -> dict:
    """Flops of the step outside Newton and of a Newton iteration, by kind, with their operation
    counts (``hlo_ops.step_operations``' computations)."""
    comps, entry = computations(hlo)
    shapes = _shapes(hlo)
    step, newton = loop_bodies(comps, entry)
    out = {}
    for part, name in (("step", step), ("newton", newton)):
        kinds = {"dot": 0.0, "lu": 0.0, "trsm": 0.0}
        for line in comps[name]:
            kind, f = line_flops(line, shapes)
            if kind in kinds:
                kinds[kind] += f
        out[part] = {"ops": sum(counts(comps, name).values()), **kinds, "flops": sum(kinds.values())}
    return out


def matmul_rate(n_batch: int, m: int, k: int, n: int, reps: int = 200) -> float:
    """GFLOP/s of a compiled float64 (batched) product of the given shape, best of 5."""
    a = jnp.asarray(np.random.default_rng(0).standard_normal((n_batch, m, k)))
    b = jnp.asarray(np.random.default_rng(1).standard_normal((n_batch, k, n)))

    @jax.jit
    def loop(a, b):
        # the carry enters the product, so that XLA cannot hoist it out of the loop
        return jax.lax.fori_loop(0, reps, lambda i, c: c + jnp.einsum("bmk,bkn->bmn", a, b + c)[0, 0, 0] * 1e-30,
                                 0.0)

    loop(a, b).block_until_ready()
    best = math.inf
    for _ in range(5):
        t0 = time.perf_counter()
        loop(a, b).block_until_ready()
        best = min(best, time.perf_counter() - t0)
    return 2.0 * n_batch * m * k * n * reps / best / 1e9


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rtols", type=float, nargs="+", default=[1e-4, 1e-3])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default="benchmarks/results/roofline.md")
    args = ap.parse_args()
    pin_to_one_core()
    spec = PendulumSpec(elements=10)
    model = build_reduced_pendulum(spec)[0]
    ts = jnp.linspace(0.0, 2.0, 201)

    def observe(t, z, v):
        return jnp.stack([x[-6] for x in model.nodal_vectors(z)])

    rows = []
    for rtol in args.rtols:
        def run(y0, rtol=rtol):
            return simulate(model, GeneralizedAlphaIndex3(0.9), AdaptiveStepSize(rtol, rtol / 10), ts,
                            observe=observe, y0=y0, newton=Newton(1e-2), throw=False)

        t0 = time.perf_counter()
        compiled = jax.jit(run).lower(None).compile()
        compile_s = time.perf_counter() - t0
        arith = arithmetic(compiled.as_text())
        times = []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            sol = jax.block_until_ready(compiled(None))
            times.append(time.perf_counter() - t0)
        run_s = float(np.median(times))
        attempted = int(sol.num_steps) + int(sol.num_rejected)
        iters = int(sol.num_newton)
        flops = attempted * arith["step"]["flops"] + iters * arith["newton"]["flops"]
        ops = attempted * arith["step"]["ops"] + iters * arith["newton"]["ops"]
        rows.append(dict(rtol=rtol, steps=int(sol.num_steps), attempted=attempted, iters=iters, compile_s=compile_s,
                         run_s=run_s, arith=arith, flops=flops, ops=ops))
        print(rows[-1], flush=True)
    peak = matmul_rate(1, 1024, 1024, 1024, reps=3)
    small = matmul_rate(3, 198, 20, 1, reps=20000)
    a = rows[0]["arith"]
    lines = [
        "# The reduced pendulum's arithmetic against its time: a roofline row (issue 35)",
        "",
        f"Produced by `benchmarks/roofline.py`. Machine: {machine()}.",
        "",
        "The NR-RNCF pendulum (10 C1 elements a beam, 5 VMs + 15 MDs a beam, 81 DOFs), 0-2 s, ρ∞ = 0.9, "
        "Newton to 1 % of the step's tolerance, outputs every 10 ms. Arithmetic from the optimized HLO "
        "(module docstring): the dots' and LAPACK calls' flops; element-wise fusions left out.",
        "",
        "Arithmetic of one piece of the program:",
        "",
        "| piece | operations | dots [flop] | LU [flop] | triangular solves [flop] | all [flop] |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for part, label in (("step", "a step, outside Newton"), ("newton", "a Newton iteration")):
        p = a[part]
        lines.append(f"| {label} | {p['ops']} | {p['dot']:.0f} | {p['lu']:.0f} | {p['trsm']:.0f} | {p['flops']:.0f} |")
    lines += [
        "",
        "The runs (time: median of the compiled run's repeats; a step: an attempted step):",
        "",
        "| rtol | steps (attempted) | Newton it. | compile [s] | run [s] | µs a step | operations a step | "
        "kflop a step | µs an operation | achieved GFLOP/s |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        us_step = 1e6 * r["run_s"] / r["attempted"]
        lines.append(f"| {r['rtol']:g} | {r['steps']} ({r['attempted']}) | {r['iters']} | {r['compile_s']:.1f} | "
                     f"{r['run_s']:.3f} | {us_step:.0f} | {r['ops'] / r['attempted']:.0f} | "
                     f"{r['flops'] / r['attempted'] / 1e3:.0f} | {1e6 * r['run_s'] / r['ops']:.2f} | "
                     f"{r['flops'] / r['run_s'] / 1e9:.3f} |")
    lines += [
        "",
        f"The core's reach: a 1024 × 1024 float64 product {peak:.1f} GFLOP/s; the step's largest product's "
        f"shape (3 × 198 × 20 by 20, batched) {small:.2f} GFLOP/s.",
    ]
    report("\n".join(lines) + "\n", args.out, keep_notes="## Notes")


if __name__ == "__main__":
    main()
