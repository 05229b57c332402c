"""The reduced pendulum's arithmetic a step against its time a step: a roofline row (issue 35).

    python benchmarks/investigations/roofline.py [--cases 1e-4:plain 1e-3:plain 2e-3:pi] [--repeats 5] [--no-accuracy]
                                  [--out benchmarks/results/roofline.md]

Each case is an error tolerance (rtol; atol = rtol/10) and a step-size controller by name
(``integrate.STEP_CONTROLS``: ``plain``, ``pi``).

The arithmetic comes from the optimized HLO of the compiled run (the same program ``hlo_ops.py``
counts): every dot's 2·(output size)·(contracted size) and every LAPACK call's own count (an LU of
m × n, m ≥ n, 2(m n² − n³/3); a triangular solve n² a right-hand side; both per system of a
batch), in the adaptive loop's body outside the Newton loop (once per attempted step) and in the
Newton loop's body (once per iteration); a product that XLA fused into a library-call fusion is
counted inside it. Element-wise fusions are left out of the arithmetic (their multiply-adds are of
the order of their output sizes, and on this model far fewer than the dots'); so the GFLOP/s
below is the dots' and the factorisations' rate.

The accuracy of each case (issue 35's conditions): χ_rel (every node's displacement, outputs every
10 ms) against the full-order ANCF run on the same mesh (rtol 1e-4, ``pendulum.md``'s reference),
and its own time-integration error, χ_rel against the same reduced model at rtol 1e-6
(``scenarios.pendulum.run_pendulum``, the same integrator options).

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

sys.path[:0] = [os.path.dirname(__file__), os.path.dirname(os.path.dirname(os.path.abspath(__file__)))]
from _machine import machine, pin_to_one_core, report  # noqa: E402
from hlo_ops import computations, counts, loop_bodies  # noqa: E402

from nrrncf_jax.integrate import (  # noqa: E402
    AdaptiveStepSize,
    GeneralizedAlphaIndex3,
    Newton,
    adaptive_step_size,
    simulate,
)
from nrrncf_jax.post.metrics import chi_rel  # noqa: E402
from nrrncf_jax.scenarios.pendulum import PendulumSpec, build_reduced_pendulum, run_pendulum  # noqa: E402

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


def _with_fused(line: str, comps, shapes):
    """``(kind, flops)`` of an instruction and, for a fusion, of the instructions it calls (XLA's
    CPU backend fuses most products of the reduced step into library-call fusions, whose dots
    are inside)."""
    yield line_flops(line, shapes)
    m = re.search(r"calls=%?([\w.\-]+)", line) if " fusion(" in line else None
    if m and m.group(1) in comps:
        for inner in comps[m.group(1)]:
            yield from _with_fused(inner, comps, shapes)


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
            for kind, f in _with_fused(line, comps, shapes):
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


def _case(text: str) -> tuple[float, str]:
    rtol, _, control = text.partition(":")
    return float(rtol), control or "plain"


def accuracy(spec, cases) -> dict:
    """``{(rtol, control): (χ_rel against the full ANCF run, against the reduced run at rtol 1e-6)}``
    in per cent (module docstring)."""
    def displacements(r):
        return r.nodes - r.nodes[0]

    full = displacements(run_pendulum(spec, dt_out=0.01, controller=AdaptiveStepSize(1e-4, 1e-5)))
    fine = displacements(run_pendulum(spec, dt_out=0.01, controller=AdaptiveStepSize(1e-6, 1e-7),
                                      formulation="nr-rncf"))
    out = {}
    for rtol, control in cases:
        w = displacements(run_pendulum(spec, dt_out=0.01, controller=adaptive_step_size(rtol, rtol / 10, control),
                                       formulation="nr-rncf"))
        out[rtol, control] = (float(chi_rel(full, w)), float(chi_rel(fine, w)))
        print(rtol, control, out[rtol, control], flush=True)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", type=_case, nargs="+", default=[(1e-4, "plain"), (1e-3, "plain"), (2e-3, "pi")],
                    help="RTOL:CONTROLLER each (controller: plain or pi)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--no-accuracy", action="store_true",
                    help="skip the χ_rel table (its full-order run is the longest)")
    ap.add_argument("--out", default="benchmarks/results/roofline.md")
    args = ap.parse_args()
    pin_to_one_core()
    spec = PendulumSpec(elements=10)
    model = build_reduced_pendulum(spec)[0]
    ts = jnp.linspace(0.0, 2.0, 201)

    def observe(t, z, v):
        return jnp.stack([x[-6] for x in model.nodal_vectors(z)])

    rows = []
    for rtol, control in args.cases:
        def run(y0, rtol=rtol, control=control):
            return simulate(model, GeneralizedAlphaIndex3(0.9), adaptive_step_size(rtol, rtol / 10, control), ts,
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
        rows.append(dict(rtol=rtol, control=control, steps=int(sol.num_steps), attempted=attempted, iters=iters,
                         compile_s=compile_s, run_s=run_s, times=times, arith=arith, flops=flops, ops=ops))
        print({k: v for k, v in rows[-1].items() if k != "arith"}, flush=True)
    acc = None if args.no_accuracy else accuracy(spec, args.cases)
    peak = matmul_rate(1, 1024, 1024, 1024, reps=3)
    small = matmul_rate(3, 198, 20, 1, reps=20000)
    a = rows[0]["arith"]
    lines = [
        "# The reduced pendulum's arithmetic against its time: a roofline row (issue 35)",
        "",
        f"Produced by `benchmarks/investigations/roofline.py`. Machine: {machine()}.",
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
        "| rtol | controller | steps (attempted) | Newton it. | compile [s] | run [s] | runs' range [s] | µs a step | "
        "operations a step | kflop a step | µs an operation | achieved GFLOP/s |"
        + ("" if acc is None else " χ_rel vs full ANCF [%] | time-integration χ_rel [%] |"),
        "|---:|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|" + ("" if acc is None else "---:|---:|"),
    ]
    for r in rows:
        us_step = 1e6 * r["run_s"] / r["attempted"]
        line = (f"| {r['rtol']:g} | {r['control']} | {r['steps']} ({r['attempted']}) | {r['iters']} | "
                f"{r['compile_s']:.1f} | {r['run_s']:.3f} | {min(r['times']):.3f}-{max(r['times']):.3f} | "
                f"{us_step:.0f} | {r['ops'] / r['attempted']:.0f} | "
                f"{r['flops'] / r['attempted'] / 1e3:.0f} | {1e6 * r['run_s'] / r['ops']:.2f} | "
                f"{r['flops'] / r['run_s'] / 1e9:.3f} |")
        if acc is not None:
            line += " {:.3f} | {:.3f} |".format(*acc[r["rtol"], r["control"]])
        lines.append(line)
    lines += [
        "",
        f"The core's reach: a 1024 × 1024 float64 product {peak:.1f} GFLOP/s; the step's largest product's "
        f"shape (3 × 198 × 20 by 20, batched) {small:.2f} GFLOP/s.",
    ]
    report("\n".join(lines) + "\n", args.out, keep_notes="## Notes")


if __name__ == "__main__":
    main()
