"""Operations a step: the optimized HLO of a compiled run, counted (issue 35's "fewer operations
a step", before and after).

    python benchmarks/investigations/hlo_ops.py [--out benchmarks/results/hlo_ops.md]

On a CPU the time of these small models is set by the number of XLA operations a step runs, each
costing about a microsecond whatever its size (``results/pendulum.md``). This compiles each
model's whole run (the program ``simulate`` compiles, with its options, as the scenarios call it)
and counts, in the optimized HLO, the operations of the adaptive loop's body outside the Newton
loop (run once per attempted step), of the Newton loop's body (once per iteration), and of the
output branch (only in the steps that reach an output time). A fusion counts as one operation;
parameters, constants, tuples and bitcasts are free. Nothing is run, so the table does not depend
on the machine's speed, only on JAX's and XLA's versions.
"""

import argparse
import collections
import os
import re
import sys

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from nrrncf_jax.examples.slider_crank import mechanism  # noqa: E402
from nrrncf_jax.integrate import AdaptiveStepSize, GeneralizedAlpha, GeneralizedAlphaIndex3, Newton  # noqa: E402
from nrrncf_jax.integrate.simulate import _prepare, _single_run_program  # noqa: E402
from nrrncf_jax.multibody.sensors import observe as observe_sensors  # noqa: E402
from nrrncf_jax.reduction import Basis, nr_rncf  # noqa: E402
from nrrncf_jax.scenarios.pendulum import PendulumSpec, build_reduced_pendulum  # noqa: E402
from nrrncf_jax.scenarios.spinup import build_spinup_model  # noqa: E402

sys.path[:0] = [os.path.dirname(__file__), os.path.dirname(os.path.dirname(os.path.abspath(__file__)))]
from _machine import machine, report  # noqa: E402

FREE = frozenset({"parameter", "constant", "tuple", "get-tuple-element", "bitcast", "after-all"})


def computations(hlo: str) -> tuple[dict[str, list[str]], str]:
    """The HLO module's computations, name → instruction lines, and the entry's name."""
    comps, cur, entry = {}, None, None
    for line in hlo.splitlines():
        m = re.match(r"^(ENTRY )?%?([\w.\-]+) .*\{$", line)
        if m and not line.startswith(" "):
            cur = m.group(2)
            comps[cur] = []
            entry = cur if m.group(1) else entry
        elif cur is not None and " = " in line:
            comps[cur].append(line)
    return comps, entry


def _opcode(line: str) -> str | None:
    m = re.search(r"\s([a-z][a-z0-9\-]*)\(", line.split("=", 1)[1])
    return m.group(1) if m else None


def counts(comps, name) -> collections.Counter:
    """The operations of one computation (its own instructions; a fusion is one)."""
    return collections.Counter(op for op in map(_opcode, comps[name]) if op and op not in FREE)


def _called(comps, name, kind):
    """The computations that ``name``'s ``while`` (kind 'while': its bodies) or ``conditional``
    (kind 'branches') instructions call."""
    out = []
    for line in comps[name]:
        if kind == "while" and " while(" in line:
            out.append(re.search(r"body=%?([\w.\-]+)", line).group(1))
        if kind == "branches" and " conditional(" in line:
            out.append([b.strip().lstrip("%") for b in re.search(r"branch_computations=\{([^}]+)\}", line)
                        .group(1).split(",")])
    return out


def loop_bodies(comps, entry) -> tuple[str, str]:
    """``(step, newton)``: the adaptive loop's body (the entry's largest ``while`` body) and the
    Newton loop's body inside it."""
    step = max(_called(comps, entry, "while"), key=lambda b: sum(counts(comps, b).values()))
    newton = _called(comps, step, "while")
    if len(newton) != 1:
        raise RuntimeError(f"expected one Newton loop in the step, found {len(newton)}")
    return step, newton[0]


def step_operations(hlo: str) -> dict:
    """``{step, newton, output, dots, custom_calls}``: the operations of the adaptive loop's body
    outside the Newton loop and the output branch, of the Newton loop's body, of the output
    branch (the larger of the conditional's branches), and the dots and LAPACK custom calls among
    the step's and the iteration's operations."""
    comps, entry = computations(hlo)
    step, newton = loop_bodies(comps, entry)
    c_step, c_newton = counts(comps, step), counts(comps, newton)
    output = 0
    for branches in _called(comps, step, "branches"):
        output = max(output, *(sum(counts(comps, b).values()) for b in branches))
    return {"step": sum(c_step.values()), "newton": sum(c_newton.values()), "output": output,
            "dots": c_step["dot"] + c_newton["dot"],
            "custom_calls": c_step["custom-call"] + c_newton["custom-call"]}


def _cases():
    ts = np.linspace(0.0, 30.0, 3001)
    red = nr_rncf(build_spinup_model("rncf", "paper", 10.0, 15.0, None), jnp.asarray(ts),
                  Basis(n_modes=24, max_dofs=25)).model
    yield "spin-up ω=10, NR-RNCF", red.n_dof, red, GeneralizedAlpha(0.9), ts, lambda t, p, v: p, None, Newton()
    pend = build_reduced_pendulum(PendulumSpec(elements=10))[0]
    yield ("pendulum, NR-RNCF", pend.n_dof, pend, GeneralizedAlphaIndex3(0.9), np.linspace(0.0, 2.0, 2001),
           lambda t, z, v: jnp.stack([x[-6] for x in pend.nodal_vectors(z)]), None, Newton(1e-2))
    crank = mechanism(formulation="nr-rncf")
    fn = observe_sensors(crank.system, crank.sensors)
    yield ("slider-crank, NR-RNCF", crank.system.n_dof, crank.system, GeneralizedAlphaIndex3(crank.rho_inf),
           np.linspace(0.0, 0.1, 201), fn, crank.y0, Newton())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="benchmarks/results/hlo_ops.md")
    args = ap.parse_args()
    rows = []
    for name, dofs, model, solver, ts, observe, y0, newton in _cases():
        # the program ``simulate`` itself compiles for this run (its single-run XLA options for a
        # model of small kernels), not a plain ``jax.jit`` of it, whose operations differ
        prepared = _prepare(model, solver, AdaptiveStepSize(1e-4, 1e-5), jnp.asarray(ts), observe, newton, 0.0, y0,
                            "forward", 200_000, False)
        hlo = _single_run_program(model).lower(*prepared).compile().compiled.as_text()
        ops = step_operations(hlo)
        rows.append((name, dofs, ops))
        print(name, dofs, ops, flush=True)
    lines = [
        "# Operations a step: the optimized HLO of compiled runs (issue 35)",
        "",
        f"Produced by `benchmarks/investigations/hlo_ops.py`. Machine: {machine()} "
        "(counts depend on JAX/XLA, not on speed).",
        "",
        "The adaptive loop's body outside the Newton loop runs once per attempted step; the Newton loop's "
        "body once per iteration; the output branch only in steps that reach an output time (its "
        "operations are inside the step's count as one conditional). Fusions count as one; dots and LAPACK "
        "custom calls are among the step's and the iteration's operations.",
        "",
        "| model | DOFs | step (outside Newton) | Newton iteration | output branch | dots | custom calls |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for name, dofs, o in rows:
        lines.append(f"| {name} | {dofs} | {o['step']} | {o['newton']} | {o['output']} | {o['dots']} "
                     f"| {o['custom_calls']} |")
    report("\n".join(lines) + "\n", args.out, keep_notes="## Notes")


if __name__ == "__main__":
    main()
