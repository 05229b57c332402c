"""``nrrncf sweep``: one batched, jit-compiled run of the spin-up over a grid of (ωs, Ts, E).

Beyond one process (``studies.distributed``): ``--processes N`` runs the sweep as N local
processes of one multi-process runtime (the cases split over all of them, the results gathered;
process 0 prints and writes); ``--distributed`` joins a runtime that a cluster's launcher
started (``srun nrrncf sweep ... --distributed``, or ``mpirun``); ``--shard K/N`` runs only shard
K's cases (no collectives; the basis is the whole grid's) and writes its part, which
``nrrncf sweep-merge`` joins.
"""

import os
import subprocess
import sys

from .. import _validate
from . import _common

_FORCE = "--xla_force_host_platform_device_count"


def _rerun_with_host_devices(args) -> int | None:
    """On a CPU with fewer devices than ``--devices``, run this command again in a subprocess
    that forces that many host devices (XLA fixes the count when it starts, and changing JAX's
    global device-count option here would change it for the whole process)."""
    import jax

    n = args.devices
    if not n or n <= jax.device_count() or jax.default_backend() != "cpu" or _FORCE in os.environ.get("XLA_FLAGS", ""):
        return None
    env = dict(os.environ, XLA_FLAGS=f"{os.environ.get('XLA_FLAGS', '')} {_FORCE}={n}".strip())
    code = "import sys; from nrrncf_jax.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *args.argv], env=env).returncode


def _grid_values(args):
    """``(omega_s, T_s, E or None)`` from ``--omega``, ``--ts``, ``--E``: parsed and checked (NumPy only)."""
    from .._validate import parse_range

    values = []
    axes = (("--omega", args.omega, "steady spin rates omega_s"), ("--ts", args.ts, "spin-up times T_s"),
            ("--E", args.E, "Young's moduli"))
    for flag, spec, what in axes:
        if spec is None:
            values.append(None)
            continue
        v = parse_range(spec, flag)
        bad = [x for x in v if not 0.0 < x < float("inf")]
        if bad:
            raise ValueError(f"{flag} ({what}) must be finite and > 0, got {bad[0]:g}")
        values.append(v)
    return tuple(values)


def _shard(spec) -> tuple[int, int] | None:
    """``--shard K/N`` as (K, N), checked (0 <= K < N)."""
    if spec is None:
        return None
    k, sep, n = str(spec).partition("/")
    try:
        k, n = int(k), int(n)
    except ValueError:
        raise ValueError(f"--shard takes K/N (shard K of N, 0 <= K < N), got {spec!r}") from None
    if not sep or not 0 <= k < n:
        raise ValueError(f"--shard takes K/N with 0 <= K < N, got {spec!r}")
    return k, n


def _without_processes(argv) -> list:
    """The command's arguments without ``--processes N``: what each worker runs."""
    out, skip = [], False
    for a in argv:
        if skip:
            skip = False
        elif a == "--processes":
            skip = True
        elif not a.startswith("--processes="):
            out.append(a)
    return out


def _check(args) -> None:
    """Every argument, before anything runs (no JAX)."""
    _shard(args.shard)
    _common.at_least("--processes", args.processes, 1)
    if args.timeout is not None and not args.timeout > 0:
        raise ValueError(f"--timeout must be > 0, got {args.timeout:g}")
    if args.shard and args.processes and args.processes > 1:
        raise ValueError("--shard and --processes exclude each other: a shard runs as one process")
    _grid_values(args)
    _common.output_times(args.t_end, args.dt_out)
    _common.at_least("--elements", args.elements, 1)
    _common.at_least("--modes", args.modes, 1)
    _common.at_least("--max-dofs", args.max_dofs, 1)
    _validate.tolerances(args.rtol, rtol_name="--rtol (relative tolerance)")
    _common.at_least("--devices", args.devices, 1)
    _common.output_path("--out", args.out)
    _common.output_path("--plot", args.plot)


def _range_text(v) -> str:
    """The values of a grid axis for the header: one value, or how many and their span."""
    return f"{v[0]:g}" if v.size == 1 else f"{v.size} values {v.min():g}..{v.max():g}"


def _sweep(args) -> int:
    from ..studies import distributed

    if args.processes and args.processes > 1 and not distributed.launched():
        try:
            distributed.launch_local(_without_processes(args.argv), args.processes, timeout_s=args.timeout or 3600.0)
        except distributed.LaunchError as e:
            print(f"nrrncf: error: {e}", file=sys.stderr)
            return 1
        return 0
    if distributed.launched() or args.distributed:
        distributed.initialize()
    else:
        rc = _rerun_with_host_devices(args)
        if rc is not None:
            return rc
    import jax

    primary = jax.process_index() == 0  # the process that prints and writes

    from .._progress import note
    from ..integrate import AdaptiveStepSize
    from ..scenarios import beam_preset
    from ..scenarios.spinup import sweep_reduction
    from ..studies.sweep import spinup_sweep, sweep_grid

    progress = not args.no_progress and primary
    preset = beam_preset(args.beam)
    omega, ts, E = _grid_values(args)
    grid = sweep_grid(omega, ts, 1.0 if E is None else E / preset.E)
    shard = _shard(args.shard)
    if not args.json and primary:
        print(f"nrrncf sweep: {args.beam} beam, {grid.cases} cases (omega_s {_range_text(omega)} rad/s "
              f"x T_s {_range_text(ts)} s" + (f" x E {_range_text(E)} Pa" if E is not None else "")
              + f"), t = 0..{args.t_end:g} s", flush=True)
    note(progress, f"reduced basis at omega_s = {grid.omega_s.max():g} rad/s, T_s = {grid.T_s.min():g} s: modes, "
                   "MMI simulation, modal derivatives, tensors ...")
    red = sweep_reduction(preset, grid, t_end=args.t_end, elements=args.elements, dt_out=args.dt_out,
                          n_modes=args.modes, max_dofs=args.max_dofs)
    if not args.json and primary:
        print(f"  basis at omega_s = {grid.omega_s.max():g} rad/s, T_s = {grid.T_s.min():g} s: {red.describe()}, "
              f"offline {red.offline_s['total']:.1f} s", flush=True)
    cases = None
    if shard is not None:  # the basis is the whole grid's; only this shard's cases run
        from ..studies.distributed import shard_indices

        cases = shard_indices(grid.expected_cost(), *shard)
        note(progress, f"shard {shard[0]}/{shard[1]}: cases {cases.tolist()}")
    res = spinup_sweep(red, grid if cases is None else grid.subset(cases), t_end=args.t_end, dt_out=args.dt_out,
                       controller=AdaptiveStepSize(args.rtol, 1e-6), devices=args.devices, time_single=True,
                       progress=progress)
    if cases is not None:
        res.case_index, res.cases_total = cases, grid.cases
    if not primary:
        return 0
    if args.out:
        res.to_csv(args.out)
    if args.plot:
        res.plot(args.plot, title=f"{args.beam} beam spin-up sweep ({grid.cases} cases, {res.dofs} reduced DOFs)")
    if args.json:
        d = res.summary()
        d.update(beam=args.beam, vms=red.n_vms, mds=red.n_mds, spin_vectors=red.n_spin,
                 offline_s=round(red.offline_s["total"], 3), processes=jax.process_count(),
                 E=None if E is None else (res.grid.E_scale * preset.E).tolist())
        if cases is not None:
            d.update(shard=args.shard, case_index=cases.tolist(), cases_total=grid.cases)
        import json

        print(json.dumps(d))
    else:
        print(res.table())
        if args.out:
            print(f"  per-case CSV -> {args.out}")
        if args.plot:
            print(f"  plot         -> {args.plot}")
    return 0


def register(sub) -> None:
    s = sub.add_parser("sweep", help="batched spin-up over a grid of speeds (and T_s, E): peaks and residual "
                       "vibration per case, vmapped and sharded across devices",
                       description="The spin-up of Eq. 43 for every (omega_s, T_s, E) of a grid, on one NR-RNCF "
                                   "basis, in one compiled, vmapped run split across devices. Results on stdout; "
                                   "each stage on stderr unless --no-progress.",
                       formatter_class=_common.HelpFormatter)
    s.add_argument("--beam", choices=_common.BEAM_NAMES, default="paper", help="beam preset")
    s.add_argument("--omega", required=True,
                   help="steady spin rates omega_s [rad/s]: 'start:stop:count' (start < stop, count >= 1 values "
                        "from start to stop inclusive, e.g. 2:40:64), 'a,b,c' or one value")
    s.add_argument("--ts", default="15", help="spin-up times T_s [s], same forms as --omega")
    s.add_argument("--E", default=None, help="Young's moduli [Pa], same forms (default: the beam's)")
    s.add_argument("--t-end", type=float, default=30.0, help="end time [s]")
    s.add_argument("--elements", type=int, default=None,
                   help="beam elements (default: the paper's Table 2 mesh for the largest omega_s)")
    s.add_argument("--modes", type=int, default=24, help="candidate vibration modes of the basis")
    s.add_argument("--max-dofs", type=int, default=25, help="at most this many VMs + MDs")
    s.add_argument("--dt-out", type=float, default=0.01, help="output interval [s]")
    s.add_argument("--rtol", type=float, default=1e-4, help="relative tolerance of the step control, in (0, 1)")
    s.add_argument("--devices", type=int, default=None,
                   help="devices to split the batch over (default: all JAX sees; on a CPU this many host devices "
                        "are requested)")
    s.add_argument("--out", help="write the per-case CSV (omega_s, T_s, E_scale, peaks, residual, steps) here")
    s.add_argument("--plot", help="write a PNG of peak deflection against omega_s here")
    s.add_argument("--processes", type=int, default=None,
                   help="run as this many local processes of one multi-process runtime (cases split, results "
                        "gathered; process 0 prints and writes)")
    s.add_argument("--distributed", action="store_true",
                   help="join a multi-process runtime started by a cluster launcher (srun, mpirun)")
    s.add_argument("--shard", default=None, metavar="K/N",
                   help="run only shard K of N of the cases (no collectives); --out writes its part, which "
                        "'nrrncf sweep-merge' joins")
    s.add_argument("--timeout", type=float, default=None,
                   help="with --processes: stop the workers after this many seconds (default 3600)")
    s.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    s.add_argument("--no-progress", action="store_true", help="no progress lines (stages) on stderr")
    s.set_defaults(func=_sweep, check=_check)
