"""``nrrncf sweep``: one batched, jit-compiled run of the spin-up over a grid of (ωs, Ts, E)."""

import os
import subprocess
import sys

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


def _sweep(args) -> int:
    rc = _rerun_with_host_devices(args)
    if rc is not None:
        return rc

    from ..scenarios import beam_preset
    from ..sweep import parse_range, spinup_sweep, sweep_grid, sweep_reduction

    preset = beam_preset(args.beam)
    omega = parse_range(args.omega, "--omega")
    ts = parse_range(args.ts, "--ts")
    E = parse_range(args.E, "--E") if args.E is not None else None
    if E is not None and not (E.size and (E > 0).all() and (E < float("inf")).all()):
        raise ValueError(f"--E must be finite and positive (Young's modulus in Pa), got {args.E!r}")
    grid = sweep_grid(omega, ts, 1.0 if E is None else E / preset.E)
    if not args.json:
        print(f"nrrncf sweep: {args.beam} beam, {grid.cases} cases (omega_s {omega.min():g}..{omega.max():g} rad/s "
              f"x {ts.size} T_s" + (f" x {E.size} E" if E is not None else "") + f"), t = 0..{args.t_end:g} s",
              flush=True)
    red = sweep_reduction(preset, grid, t_end=args.t_end, elements=args.elements, dt_out=args.dt_out,
                          n_modes=args.modes, max_dofs=args.max_dofs)
    if not args.json:
        print(f"  basis at omega_s = {grid.omega_s.max():g} rad/s, T_s = {grid.T_s.min():g} s: {red.dofs} DOFs "
              f"({red.n_vms} VMs + {red.n_mds} MDs), offline {red.offline_s['total']:.1f} s", flush=True)
    res = spinup_sweep(red, grid, t_end=args.t_end, dt_out=args.dt_out, rtol=args.rtol, devices=args.devices,
                       time_single=True)
    if args.out:
        res.to_csv(args.out)
    if args.plot:
        res.plot(args.plot, title=f"{args.beam} beam spin-up sweep ({grid.cases} cases, {res.dofs} reduced DOFs)")
    if args.json:
        d = res.summary()
        d.update(beam=args.beam, vms=red.n_vms, mds=red.n_mds, offline_s=round(red.offline_s["total"], 3),
                 E=None if E is None else (grid.E_scale * preset.E).tolist())
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
    from ..scenarios import BEAMS

    s = sub.add_parser("sweep", help="batched spin-up over a grid of speeds (and T_s, E): peaks and residual "
                       "vibration per case, vmapped and sharded across devices")
    s.add_argument("--beam", choices=sorted(BEAMS), default="paper")
    s.add_argument("--omega", required=True,
                   help="steady spin rates omega_s [rad/s]: 'start:stop:count' (e.g. 2:40:64), 'a,b,c' or one value")
    s.add_argument("--ts", default="15", help="spin-up times T_s [s], same forms as --omega (default 15)")
    s.add_argument("--E", default=None, help="Young's moduli [Pa], same forms (default: the beam's)")
    s.add_argument("--t-end", type=float, default=30.0, help="end time [s] (default 30)")
    s.add_argument("--elements", type=int, default=None,
                   help="beam elements (default: the paper's Table 2 mesh for the largest omega_s)")
    s.add_argument("--modes", type=int, default=24, help="candidate vibration modes of the basis (default 24)")
    s.add_argument("--max-dofs", type=int, default=25, help="at most this many VMs + MDs (default 25)")
    s.add_argument("--dt-out", type=float, default=0.01, help="output interval [s] (default 0.01)")
    s.add_argument("--rtol", type=float, default=1e-4, help="relative tolerance of the step control")
    s.add_argument("--devices", type=int, default=None,
                   help="devices to split the batch over (default: all JAX sees; on a CPU this many host devices "
                        "are requested)")
    s.add_argument("--out", help="write the per-case CSV (omega_s, T_s, E_scale, peaks, residual, steps) here")
    s.add_argument("--plot", help="write a PNG of peak deflection against omega_s here")
    s.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    s.set_defaults(func=_sweep)
