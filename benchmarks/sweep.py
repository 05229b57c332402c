"""Batched spin-up sweep: 64 speeds on the paper beam's reduced model, on 1, 2 and 4 devices.

    python benchmarks/sweep.py [--cases 64] [--omega-min 2] [--omega-max 40] [--t-end 30]
                               [--devices 1 2 4] [--out benchmarks/results/sweep.md]

The NR-RNCF basis is built once (paper beam, 24 elements, at ωs = 40 rad/s, Ts = 15 s: the
hardest case of the grid) and held fixed; the sweep runs ωs = 2 … 40 rad/s over 0–30 s in one
compiled, vmapped program (``nrrncf_jax.studies.sweep.spinup_sweep``). Each device count runs in its own
subprocess, because JAX fixes the number of (forced host) devices when it starts:
``XLA_FLAGS=--xla_force_host_platform_device_count=N``; on a GPU host a further row runs on the
GPUs. Compilation (ahead of time) and the run (to ``block_until_ready``) are timed apart. The
1-device worker also runs the slowest case alone, in the same process, for the target "the whole
sweep costs ≤ 10 single runs of the slowest case". With 4 devices the two schedules are compared:
cost-sorted contiguous blocks (the default) and round-robin interleaving.
"""

import argparse
import json
import os
import pickle
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))


def _log(msg):
    print(msg, file=sys.stderr, flush=True)


def _grid(a):
    import numpy as np

    from nrrncf_jax.studies.sweep import sweep_grid

    return sweep_grid(np.linspace(a.omega_min, a.omega_max, a.cases), a.ts)


def _build(a, path):
    """Build the shared basis (in this process) and pickle the reduced model for the workers."""
    import jax
    import numpy as np

    jax.config.update("jax_enable_x64", True)
    from nrrncf_jax.scenarios.spinup import sweep_reduction

    red = sweep_reduction("paper", _grid(a), t_end=a.t_end, dt_out=a.dt_out)
    with open(path, "wb") as f:
        pickle.dump(jax.tree_util.tree_map(np.asarray, red.model), f)
    return {"dofs": red.dofs, "vms": red.n_vms, "mds": red.n_mds, "offline_s": red.offline_s["total"],
            "elements": red.model.q_hat.shape[0] // 6 - 1}


def _worker(a):
    """One device count: the sweep (and, with --single, the slowest case alone); JSON on stdout."""
    import jax

    jax.config.update("jax_enable_x64", True)
    sys.path.insert(0, HERE)
    from _machine import machine

    from nrrncf_jax.studies.sweep import spinup_sweep

    with open(a.model, "rb") as f:
        model = pickle.load(f)
    res = spinup_sweep(model, _grid(a), t_end=a.t_end, dt_out=a.dt_out, devices=a.worker_devices,
                       balance=a.balance, time_single=a.single)
    s = res.summary()
    keep = ("cases", "devices", "platform", "balance", "lanes", "padded", "collectives", "compile_s",
            "run_s", "throughput_per_s", "single_run_s", "single_compile_s", "sweep_over_single", "single_case")
    d = {k: s.get(k) for k in keep}
    d.update(max_steps=int((res.steps + res.rejected).max()), min_steps=int((res.steps + res.rejected).min()),
             total_steps=int((res.steps + res.rejected).sum()), machine=machine(),
             device_kind=jax.devices()[0].device_kind,
             peak_uy_first_last=[float(res.peak_uy[0]), float(res.peak_uy[-1])])
    print(json.dumps(d))


def _spawn(a, model, devices, balance="blocks", single=False, forced=True):
    env = dict(os.environ, JAX_ENABLE_X64="1")
    flags = [f for f in env.get("XLA_FLAGS", "").split() if "force_host_platform_device_count" not in f]
    if forced:
        env["JAX_PLATFORMS"] = "cpu"
        flags.append(f"--xla_force_host_platform_device_count={devices}")
    env["XLA_FLAGS"] = " ".join(flags)
    cmd = [sys.executable, os.path.abspath(__file__), "--worker", "--model", model, "--balance", balance,
           "--cases", str(a.cases), "--omega-min", str(a.omega_min), "--omega-max", str(a.omega_max),
           "--ts", str(a.ts), "--t-end", str(a.t_end), "--dt-out", str(a.dt_out)]
    if devices:
        cmd += ["--worker-devices", str(devices)]
    if single:
        cmd.append("--single")
    out = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if out.returncode != 0:
        raise RuntimeError(f"worker ({devices} devices, {balance}) failed:\n{out.stderr[-4000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def _gpu_count() -> int:
    code = "import jax; print(sum(d.platform == 'gpu' for d in jax.devices()))"
    env = {k: v for k, v in os.environ.items() if k != "JAX_PLATFORMS"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    try:
        return int(out.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        return 0


def main(argv=None):
    p = argparse.ArgumentParser()
    p.add_argument("--cases", type=int, default=64)
    p.add_argument("--omega-min", type=float, default=2.0)
    p.add_argument("--omega-max", type=float, default=40.0)
    p.add_argument("--ts", type=float, default=15.0)
    p.add_argument("--t-end", type=float, default=30.0)
    p.add_argument("--dt-out", type=float, default=0.01)
    p.add_argument("--devices", type=int, nargs="+", default=[1, 2, 4])
    p.add_argument("--no-interleave", action="store_true", help="skip the interleaved-schedule row")
    p.add_argument("--out", default=os.path.join(HERE, "results", "sweep.md"))
    # worker mode (internal)
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--model", help=argparse.SUPPRESS)
    p.add_argument("--worker-devices", type=int, default=None, help=argparse.SUPPRESS)
    p.add_argument("--balance", default="blocks", help=argparse.SUPPRESS)
    p.add_argument("--single", action="store_true", help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.worker:
        return _worker(a)

    with tempfile.TemporaryDirectory() as tmp:
        model = os.path.join(tmp, "model.pkl")
        _log(f"building the basis at omega_s = {a.omega_max:g} rad/s ...")
        basis = _build(a, model)
        _log(f"  {basis['dofs']} DOFs ({basis['vms']} VMs + {basis['mds']} MDs), offline {basis['offline_s']:.1f} s")
        rows = []
        for n in a.devices:
            _log(f"sweep on {n} forced host device(s) ...")
            rows.append(_spawn(a, model, n, single=(n == min(a.devices))))
            _log(f"  compile {rows[-1]['compile_s']:.1f} s, run {rows[-1]['run_s']:.2f} s")
        if not a.no_interleave and max(a.devices) > 1:
            n = max(a.devices)
            _log(f"sweep on {n} forced host devices, interleaved schedule ...")
            rows.append(_spawn(a, model, n, balance="interleave"))
        n_gpu = _gpu_count()
        if n_gpu:
            _log(f"sweep on {n_gpu} GPU(s) ...")
            rows.append(_spawn(a, model, None, single=True, forced=False))

    base = rows[0]
    single = base["single_run_s"]
    head = ("devices", "platform", "schedule", "lanes per device (cases per device)", "compile [s]", "run [s]",
            "manoeuvres/s", "speed-up vs 1 device", "sweep / single run", "steps of the costliest case")
    lines = ["| " + " | ".join(head) + " |", "|---:|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append("| " + " | ".join(str(c) for c in (
            r["devices"], f"{r['platform'].upper()} ({r['device_kind']})", r["balance"],
            f"{r['lanes']} ({(r['cases'] + r['padded']) // r['devices']})", f"{r['compile_s']:.1f}",
            f"{r['run_s']:.2f}",
            f"{r['throughput_per_s']:.1f}",
            f"{base['run_s'] / r['run_s']:.2f}x" if r["platform"] == base["platform"] else "—",
            f"{r['run_s'] / (r['single_run_s'] or single):.1f}", r["max_steps"])) + " |")
    sc = base["single_case"]
    text = (
        f"# Batched spin-up sweep: {a.cases} speeds, paper beam, NR-RNCF ({basis['dofs']} DOFs)\n\n"
        f"Produced by `benchmarks/sweep.py`. Machine: {base['machine']}\n\n"
        f"Grid: ωs = {a.omega_min:g} … {a.omega_max:g} rad/s ({a.cases} speeds), Ts = {a.ts:g} s, 0–{a.t_end:g} s, "
        f"outputs every {a.dt_out:g} s, rtol = 1e-4, ρ∞ = 0.9. One basis for the whole grid: NR-RNCF of the "
        f"{basis['elements']}-element paper beam at ωs = {a.omega_max:g} rad/s ({basis['vms']} VMs + {basis['mds']} "
        f"MDs → {basis['dofs']} DOFs after deflation; offline {basis['offline_s']:.1f} s, compilation included, not "
        "in the table).\n\n" + "\n".join(lines) + "\n\n"
        f"Slowest case run alone (1-device worker, same process): ωs = {sc['omega_s']:g} rad/s, {sc['steps']} steps, "
        f"compile {base['single_compile_s']:.1f} s, run {single:.3f} s. **The whole sweep costs "
        f"{base['run_s'] / single:.1f} single runs of its slowest case** (target ≤ 10) on one device.\n\n"
        "Run time excludes compilation (ahead of time, `.lower().compile()`), and ends at `block_until_ready`. "
        "Manoeuvres/s = cases / run time. Each row is its own subprocess: the forced host devices "
        "(`XLA_FLAGS=--xla_force_host_platform_device_count=N`) are threads sharing this machine's cores: beyond "
        "the core count they add no cores, though their loops can fill each other's idle time between small "
        "kernels; they test the sharded program, whose compiled text holds "
        f"no cross-device operation (collectives per row: {', '.join(str(r['collectives']) for r in rows)}). "
        "Each device runs one batched loop (`simulate_batch`) that advances 'lanes' cases together; its other "
        "cases wait in a queue, costliest first, and take the lane of a case that ends. 'blocks': cases "
        "sorted by expected cost, each device a contiguous block; 'interleave': sorted cases dealt round-robin. "
        "'Steps of the costliest case' counts its accepted + rejected steps. The CPU is shared with other jobs, "
        "so timings are noisy (repeat runs differ by tens of per cent).\n"
    )
    sys.path.insert(0, HERE)
    from _machine import report

    report(text, a.out)


if __name__ == "__main__":
    main()
