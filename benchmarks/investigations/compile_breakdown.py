"""Where a reduced mechanism's compile time goes: its run's StableHLO operations, counted by the
part of the integrator step that traced them, and the kernels XLA compiles from them (issues 35
and 60's cold-compile targets).

The program is the one a user's run compiles: for a bundled example, what
``scenarios.mechanism_file.run_setup`` hands to ``simulate`` for the example's NR-RNCF setup at
its defaults (its sensors, its step error on sensors, its controller, 201 outputs), as
``benchmarks/mechanisms.py`` runs it; for ``pendulum``, the paper's NR-RNCF pendulum with the
bare output z[:3]. Each operation of the lowered program carries its Python call stack in its
debug location; the operations are grouped by the library function that traced them, seen from
the integrator (the first frame below ``integrate/simulate.py``, and the frame below that), and
by the innermost library line. Times: lowering (tracing) and XLA's compilation apart, each the
best of ``--repeats`` cold compilations (JAX's caches cleared in between).

The kernels: XLA's compilation is mostly the code generation of the optimised program's
kernels, each fusion and each ``dot`` compiled on its own (a product of a few 3-vectors as a
``dot`` costs about as much to compile as a fused kernel of hundreds of element-wise
operations), so the table also counts them in the compiled program.

    python benchmarks/investigations/compile_breakdown.py [--model pendulum slider_crank fourbar ...]
                                                          [--top 12] [--repeats 2]

Writes ``results/compile_breakdown.md``.
"""

import argparse
import collections
import functools
import importlib
import inspect
import os
import re
import sys
import time
from unittest import mock

import jax

jax.config.update("jax_enable_x64", True)

from nrrncf_jax.scenarios import mechanism_file  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.dirname(HERE)]
from _machine import machine, pin_to_one_core, report  # noqa: E402

sim = importlib.import_module("nrrncf_jax.integrate.simulate")  # the module (``integrate.simulate`` is the function)


class _Recorded(Exception):
    """Raised by the stand-in for ``simulate_timed`` once it has the run's arguments."""


def _run_setup_arguments(model: str) -> tuple:
    """``simulate``'s arguments as ``run_setup`` passes them for ``model``'s NR-RNCF setup: the
    call is made with ``simulate_timed`` replaced by a function that records them, so that the
    program measured is the one ``run_setup`` compiles, whatever its defaults become."""
    setup = mechanism_file.load_setup(model, {"formulation": "nr-rncf"})
    seen = {}

    def record(*args, **kwargs):
        seen.update(args=args, kwargs=kwargs)
        raise _Recorded

    with mock.patch.object(mechanism_file, "simulate_timed", record):
        try:
            mechanism_file.run_setup(setup)
        except _Recorded:
            pass
    return seen["args"], seen["kwargs"]


def _program(model: str):
    """``(jitted program, its arguments, DOFs)`` of ``model``'s run, as ``simulate_timed``
    compiles it (``simulate``'s checks and its choice of XLA options)."""
    if model == "pendulum":
        from nrrncf_jax.integrate import AdaptiveStepSize, GeneralizedAlphaIndex3
        from nrrncf_jax.scenarios.pendulum import PendulumSpec, build_reduced_pendulum

        system, _ = build_reduced_pendulum(PendulumSpec())
        args = (system, GeneralizedAlphaIndex3(0.9), AdaptiveStepSize(1e-4, 1e-5), jax.numpy.linspace(0.0, 0.1, 11))
        kwargs = {"observe": lambda t, z, v: z[:3], "y0": (system.reference(), 0.0 * system.reference())}
    else:
        args, kwargs = _run_setup_arguments(model)
    bound = inspect.signature(sim.simulate).bind(*args, **kwargs)
    bound.apply_defaults()
    a = bound.arguments
    prepared = sim._prepare(args[0], args[1], args[2], args[3], a["observe"], a["newton"], a["t0"], a["y0"],
                            a["adjoint"], a["max_steps"], a["progress"], a["step_ts"])
    return sim._single_run_program(prepared[0]), prepared, int(args[0].n_dof)


class _Locations:
    """The debug locations of a StableHLO module's text: each operation's call stack as
    (function, file, line) frames, innermost first."""

    def __init__(self, text: str):
        self.locs = dict(re.findall(r"^(#loc\d*) = loc\((.*)\)$", text, re.M))

    @functools.cache
    def frames(self, name: str) -> tuple:
        txt = self.locs.get(name, "")
        m = re.fullmatch(r"callsite\((#loc\d+) at (#loc\d+)\)", txt)
        if m:
            return self.frames(m.group(1)) + self.frames(m.group(2))
        m = re.fullmatch(r'"([^"]*)"\((#loc\d+)\)', txt)
        if m:
            inner = self.frames(m.group(2))
            if len(inner) == 1 and inner[0][0] is None:  # a function name around its source location
                return ((m.group(1),) + inner[0][1:],)
            return inner  # an operation's name around its stack
        m = re.match(r'"([^"]+)":(\d+)', txt)
        return ((None, m.group(1), int(m.group(2))),) if m else ()


_FREE = {"parameter", "constant", "get-tuple-element", "tuple", "bitcast", "while", "conditional", "call"}


def _kernels(hlo: str) -> collections.Counter:
    """The compiled program's kernels by kind: every instruction outside the fused computations
    (``fusion``, ``dot``, ``custom-call``, ...) but the free ones (parameters, constants, tuples,
    bitcasts, the loops' and conditionals' own instructions), the reductions' scalar
    computations left out."""
    kinds = collections.Counter()
    for block in re.split(r"\n(?=\S)", hlo):
        lines = block.splitlines()
        if not lines or "fused_computation" in lines[0] or len(lines) <= 6:  # fused, or a reduction's body
            continue
        for line in lines[1:]:
            m = re.match(r"\s+(?:ROOT )?%\S+ = \S+ ([a-z-]+)\(", line)
            if m and m.group(1) not in _FREE:
                kinds[m.group(1)] += 1
    return kinds


def breakdown(model: str, repeats: int = 2) -> dict:
    program, args, dofs = _program(model)
    lower_s, compile_s = [], []
    for _ in range(max(1, repeats)):
        jax.clear_caches()
        t0 = time.perf_counter()
        lowered = program.lower(*args).lowered
        t1 = time.perf_counter()
        compiled = lowered.compile()
        t2 = time.perf_counter()
        lower_s.append(t1 - t0)
        compile_s.append(t2 - t1)
    kernels = _kernels(compiled.as_text())
    text = lowered.as_text(debug_info=True)
    locs = _Locations(text)
    by_stage, by_line, total = collections.Counter(), collections.Counter(), 0
    for line in text.splitlines():
        op = re.search(r"= \"?stablehlo\.[a-z_]+", line)
        at = re.search(r"loc\((#loc\d*)\)\s*$", line)
        if not (op and at):
            continue
        total += 1
        frames = [f for f in locs.frames(at.group(1)) if "nrrncf_jax/" in f[1]]
        outer = [f for f in reversed(frames) if not f[1].endswith("integrate/simulate.py")]
        short = [f"{f[0]} ({f[1].split('nrrncf_jax/')[-1]})" for f in outer[:2]]
        by_stage[" → ".join(short) if short else "the adaptive loop itself (integrate/simulate.py)"] += 1
        if frames:
            f = frames[0]
            by_line[f"{f[1].split('nrrncf_jax/')[-1]}:{f[2]} ({f[0]})"] += 1
    return {"model": model, "dofs": dofs, "lower_s": min(lower_s), "compile_s": min(compile_s), "ops": total,
            "kernels": kernels, "by_stage": by_stage, "by_line": by_line}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", nargs="+", default=["pendulum", "slider_crank", "fourbar"])
    p.add_argument("--top", type=int, default=12)
    p.add_argument("--repeats", type=int, default=2, help="cold compilations a model; the best is reported")
    args = p.parse_args(argv)
    pin_to_one_core()
    out = ["# Where a reduced mechanism's compile time goes (issues 35 and 60)", "",
           f"Produced by `benchmarks/investigations/compile_breakdown.py`. Machine: {machine()}.", "",
           "The StableHLO operations of the lowered adaptive index-3 run of each NR-RNCF model (a bundled "
           "example's as `scenarios.mechanism_file.run_setup` compiles it, at the example's defaults; the "
           "pendulum with the output z[:3]), grouped by the library function that traced them as seen from "
           "the integrator (the first two frames below `integrate/simulate.py`), and by the innermost library "
           "line; and the kernels of the compiled program (fusions and `dot`s, each compiled on its own). "
           f"Times: the best of {args.repeats} cold compilations.", ""]
    out += ["| model | DOFs | operations | kernels (fusions, dots) | lowering [s] | XLA compile [s] |",
            "|---|---:|---:|---:|---:|---:|"]
    results = [breakdown(m, args.repeats) for m in args.model]
    for r in results:
        k = r["kernels"]
        out.append(f"| {r['model']} | {r['dofs']} | {r['ops']} | {sum(k.values())} ({k['fusion']}, {k['dot']}) | "
                   f"{r['lower_s']:.1f} | {r['compile_s']:.1f} |")
        print(out[-1], flush=True)
    for r in results:
        out += ["", f"## {r['model']} ({r['ops']} operations)", "", "| traced by | operations | share |",
                "|---|---:|---:|"]
        out += [f"| {k} | {v} | {100 * v / r['ops']:.0f} % |" for k, v in r["by_stage"].most_common(args.top)]
        out += ["", "| innermost library line | operations |", "|---|---:|"]
        out += [f"| {k} | {v} |" for k, v in r["by_line"].most_common(args.top)]
    report("\n".join(out) + "\n", os.path.join(os.path.dirname(HERE), "results", "compile_breakdown.md"),
           keep_notes="## Notes")


if __name__ == "__main__":
    main()
