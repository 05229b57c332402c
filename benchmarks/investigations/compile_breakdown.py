"""Where a reduced mechanism's compile time goes: its run's StableHLO operations, counted by the
part of the integrator step that traced them (issue 35's cold-compile target).

XLA's compile time grows with the number of operations it is handed. Each operation of the
lowered program (``jax.jit(run).lower(y0)``, the adaptive index-3 generalized-α run that
``scenarios.mechanism_file.run_setup`` compiles) carries its Python call stack in its debug
location; the operations are grouped by the library function that traced them, seen from the
integrator (the first frame below ``integrate/simulate.py``, and the frame below that), and by
the innermost library line. Times: lowering (tracing) and XLA's compilation apart.

    python benchmarks/investigations/compile_breakdown.py [--model pendulum|rotor|slider_crank ...] [--top 12]

Writes ``results/compile_breakdown.md``.
"""

import argparse
import collections
import functools
import os
import re
import sys
import time

import jax
import numpy as np

jax.config.update("jax_enable_x64", True)

from nrrncf_jax.integrate import AdaptiveStepSize, GeneralizedAlphaIndex3, simulate  # noqa: E402
from nrrncf_jax.multibody.sensors import observe  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.dirname(HERE)]
from _machine import machine, pin_to_one_core, report  # noqa: E402


def _system(model: str):
    """(system, observe function, y0) of a model: the paper's NR-RNCF pendulum (81 DOFs), or a
    bundled example's NR-RNCF setup (2 elements a beam)."""
    if model == "pendulum":
        from nrrncf_jax.scenarios.pendulum import PendulumSpec, build_reduced_pendulum

        system, _ = build_reduced_pendulum(PendulumSpec())
        return system, (lambda t, z, v: z[:3]), (system.reference(), 0.0 * system.reference())
    from nrrncf_jax.scenarios.mechanism_file import load_setup

    setup = load_setup(model, {"formulation": "nr-rncf", "elements": 2})
    y0 = setup.y0 if setup.y0 is not None else (setup.system.reference(), 0.0 * setup.system.reference())
    return setup.system, observe(setup.system, setup.sensors), y0


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


def breakdown(model: str) -> dict:
    system, fn, y0 = _system(model)
    ts = np.linspace(0.0, 0.1, 11)

    def run(y0):
        return simulate(system, GeneralizedAlphaIndex3(0.9), AdaptiveStepSize(1e-4, 1e-5), ts, observe=fn, y0=y0)

    t0 = time.perf_counter()
    lowered = jax.jit(run).lower(y0)
    t1 = time.perf_counter()
    lowered.compile()
    t2 = time.perf_counter()
    text = lowered.as_text(debug_info=True)
    locs = _Locations(text)
    by_stage, by_line, total = collections.Counter(), collections.Counter(), 0
    for line in text.splitlines():
        op = re.search(r"= \"?stablehlo\.[a-z_]+", line)
        at = re.search(r"loc\((#loc\d+)\)\s*$", line)
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
    return {"model": model, "dofs": int(system.n_dof), "lower_s": t1 - t0, "compile_s": t2 - t1, "ops": total,
            "by_stage": by_stage, "by_line": by_line}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", nargs="+", default=["pendulum", "rotor", "slider_crank"])
    p.add_argument("--top", type=int, default=12)
    args = p.parse_args(argv)
    pin_to_one_core()
    out = ["# Where a reduced mechanism's compile time goes (issue 35)", "",
           f"Produced by `benchmarks/investigations/compile_breakdown.py`. Machine: {machine()}.", "",
           "The StableHLO operations of the lowered adaptive index-3 run of each NR-RNCF model, grouped "
           "by the library function that traced them as seen from the integrator (the first two frames "
           "below `integrate/simulate.py`), and by the innermost library line. XLA's compile time grows "
           "with this count.", ""]
    out += ["| model | DOFs | operations | lowering [s] | XLA compile [s] |", "|---|---:|---:|---:|---:|"]
    results = [breakdown(m) for m in args.model]
    for r in results:
        out.append(f"| {r['model']} | {r['dofs']} | {r['ops']} | {r['lower_s']:.1f} | {r['compile_s']:.1f} |")
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
