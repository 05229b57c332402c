"""Offline-stage time of the NR-RNCF basis, cold and with the persistent compilation cache.

    python benchmarks/offline.py [--omega 40] [--repeats 2] [--out benchmarks/results/offline.md]

The straight paper beam at the paper's mesh for ωs (24 elements at 40 rad/s), T_s = 15 s,
0-30 s: the offline stage of ``nr_rncf`` (modes, closed-form MMI, selection, MDs,
spinning-state check, deflation, tensors), timed stage by stage in fresh processes:

- *cold*: no persistent cache; every kernel compiles (what a first-ever run pays);
- *cache, first*: ``compilation_cache`` on an empty directory (compiles and stores);
- *cache, warm*: a new process on the filled directory (a restarted kernel, the next command);
- *in process*: the same stage called again in the warm process (nothing left to compile).

The full model's construction (element integrals) is timed apart as ``build``.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile

WORKER = r"""
import json, sys, time
import jax
jax.config.update("jax_enable_x64", True)
cache = sys.argv[2]
if cache != "none":
    import nrrncf_jax
    # for the whole worker process; the block is kept referenced, else its generator is collected
    # at once and its exit restores the settings (so it did from 45e41f6 to 2026-12-02: no cache)
    block = nrrncf_jax.compilation_cache(cache)
    block.__enter__()
import jax.numpy as jnp
from nrrncf_jax.reduction.pipeline import nr_rncf
from nrrncf_jax.scenarios.spinup import build_spinup_model, default_elements, output_times
omega = float(sys.argv[1])
t0 = time.perf_counter()
full = build_spinup_model("rncf", "paper", omega, 15.0, default_elements(omega))
jax.block_until_ready(full.M)
build = time.perf_counter() - t0
ts = jnp.asarray(output_times(30.0, 0.01))
red = nr_rncf(full, ts)
again = nr_rncf(full, ts)
print(json.dumps(dict(build=build, stages=red.offline_s, again=again.offline_s["total"], dofs=red.dofs)))
"""


def run(omega, cache):
    out = subprocess.run([sys.executable, "-c", WORKER, str(omega), cache], capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--omega", type=float, default=40.0)
    ap.add_argument("--repeats", type=int, default=2, help="repetitions of each case (the table shows the best)")
    ap.add_argument("--out", default="benchmarks/results/offline.md")
    a = ap.parse_args(argv)
    sys.path.insert(0, os.path.dirname(__file__))
    from _machine import machine, report

    rows = {"cold": [], "cache, first": [], "cache, warm": []}
    for _ in range(a.repeats):
        rows["cold"].append(run(a.omega, "none"))
        with tempfile.TemporaryDirectory() as d:
            rows["cache, first"].append(run(a.omega, d))
            rows["cache, warm"].append(run(a.omega, d))
    best = {k: min(v, key=lambda r: r["stages"]["total"]) for k, v in rows.items()}
    stages = [s for s in best["cold"]["stages"] if s != "total"]
    head = ["case", "build [s]"] + [f"{s} [s]" for s in stages] + ["offline total [s]"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for k, r in best.items():
        lines.append("| " + " | ".join([k, f"{r['build']:.2f}"] + [f"{r['stages'].get(s, 0.0):.2f}" for s in stages]
                                        + [f"**{r['stages']['total']:.2f}**"]) + " |")
    again = min(r["again"] for v in rows.values() for r in v)
    lines.append("| in process (second call) | – | " + " | ".join("" for _ in stages) + f" | **{again:.2f}** |")
    totals = {k: [round(r["stages"]["total"], 2) for r in v] for k, v in rows.items()}
    text = "\n".join([
        f"# NR-RNCF offline stage, paper beam, ωs = {a.omega:g} rad/s ({best['cold']['dofs']} reduced DOFs)", "",
        "Produced by `benchmarks/offline.py`. Machine: " + machine(), "",
        f"Best of {a.repeats} fresh processes per case (all totals: {json.dumps(totals)}).", "",
        *lines, "",
        "cold: no persistent cache; cache, first: `compilation_cache` on an empty directory; "
        "cache, warm: a new process reusing it; in process: `nr_rncf` called again after the first.", ""])
    report(text, a.out)


if __name__ == "__main__":
    main()
