"""The 64-case spin-up sweep on 1 and 2 processes of one ``jax.distributed`` runtime on this
machine (``studies.distributed.launch_local``, CPU collectives over gloo), against one plain
process: wall, compile and run seconds, the parallel efficiency and the largest difference of the
per-case peaks from the one-process sweep.

    python benchmarks/sweep_processes.py [--cases 64] [--t-end 30] [--out benchmarks/results/sweep_processes.md]

The basis is built once here and pickled for the workers (as ``benchmarks/sweep.py`` does); each
process has one CPU device, so N processes split the cases N ways. Parallel efficiency: the
one-process run time over N times the N-process run time (process 0's, which waits for the
gather).
"""

import argparse
import json
import os
import pickle
import sys
import tempfile
import textwrap
import time

HERE = os.path.dirname(os.path.abspath(__file__))

WORKER = textwrap.dedent("""
    import json, pickle, sys
    from nrrncf_jax.studies import distributed
    distributed.initialize(timeout_s=300)
    import jax
    import numpy as np
    jax.config.update("jax_enable_x64", True)
    from nrrncf_jax.studies.sweep import spinup_sweep, sweep_grid
    model = pickle.load(open(sys.argv[1], "rb"))
    cases, t_end, out = int(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
    res = spinup_sweep(model, sweep_grid(np.linspace(2.0, 40.0, cases), 15.0), t_end=t_end, dt_out=0.01)
    if jax.process_index() == 0:
        json.dump(dict(processes=jax.process_count(), devices=res.devices, compile_s=res.compile_s,
                       run_s=res.run_s, peak_uy=res.peak_uy.tolist(), steps=int(res.steps.sum())), open(out, "w"))
""")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", type=int, default=64)
    p.add_argument("--t-end", type=float, default=30.0)
    p.add_argument("--out", default=os.path.join(HERE, "results", "sweep_processes.md"))
    a = p.parse_args(argv)
    import jax
    import numpy as np

    jax.config.update("jax_enable_x64", True)
    sys.path.insert(0, HERE)
    from _machine import machine

    from nrrncf_jax.scenarios.spinup import sweep_reduction
    from nrrncf_jax.studies.distributed import launch_local
    from nrrncf_jax.studies.sweep import sweep_grid

    grid = sweep_grid(np.linspace(2.0, 40.0, a.cases), 15.0)
    red = sweep_reduction("paper", grid, t_end=a.t_end, dt_out=0.01)
    rows, ref = [], None
    with tempfile.TemporaryDirectory() as tmp:
        model = os.path.join(tmp, "model.pkl")
        with open(model, "wb") as f:
            pickle.dump(jax.tree_util.tree_map(np.asarray, red.model), f)
        for n in (1, 2):
            out = os.path.join(tmp, f"out{n}.json")
            t0 = time.perf_counter()
            launch_local([model, str(a.cases), str(a.t_end), out], n, timeout_s=3000, code=WORKER,
                         env={"JAX_PLATFORMS": "cpu"})
            wall = time.perf_counter() - t0
            d = json.load(open(out))
            ref = d if ref is None else ref
            eff = ref["run_s"] / (n * d["run_s"])
            diff = float(np.abs(np.asarray(d["peak_uy"]) - np.asarray(ref["peak_uy"])).max())
            rows.append(f"| {n} | {d['devices']} | {wall:.1f} | {d['compile_s']:.1f} | {d['run_s']:.2f} | {eff:.2f} | "
                        f"{d['steps']} | {diff:.1e} |")
            print(rows[-1], flush=True)
    text = "\n".join([
        "# The spin-up sweep on several processes (issue 36)", "",
        f"Produced by `benchmarks/sweep_processes.py`. {machine()}", "",
        f"{a.cases} cases, ωs = 2 … 40 rad/s, Ts = 15 s, 0-{a.t_end:g} s, the paper beam's NR-RNCF basis at ωs = 40 "
        f"rad/s ({red.dofs} DOFs), adaptive steps rtol 1e-4. Each process has one CPU device; the processes form one "
        "`jax.distributed` runtime on the loopback interface (gloo collectives) started by "
        "`studies.distributed.launch_local`. Wall: the launch, including the workers' start-up and the "
        "compilation; run: process 0's run to the gathered results. Efficiency: the one-process run time over N "
        "times the N-process one. Peak diff: the largest difference of a case's peak transverse tip deflection from "
        "the one-process run [m] (adaptive steps carry the round-off of other batch shapes below the tolerance).", "",
        "| processes | devices | wall [s] | compile [s] | run [s] | efficiency | steps (all cases) | peak diff [m] |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|", *rows, ""])
    with open(a.out, "w") as f:
        f.write(text)


if __name__ == "__main__":
    main()
