"""The ``nrrncf`` command: the paper's examples from a shell.

    nrrncf spinup --formulation rncf --beam paper --omega 40 --plot tip.png
    nrrncf modes --beam paper --elements 8 --json

The command switches on float64 in its own entry point; the library itself never does.
"""

import argparse
import json
import sys


def _spinup(args) -> int:
    from .scenarios import run_spinup
    from .scenarios.spinup import default_elements

    if args.elements is None:
        args.elements = default_elements(args.omega) if args.omega > 0 else 6
    if not args.json:
        print(f"nrrncf spinup: {args.formulation.upper()} {args.beam} beam, omega_s = {args.omega:g} rad/s, "
              f"T_s = {args.ts:g} s, t = 0..{args.t_end:g} s, {args.elements} elements", flush=True)
    res = run_spinup(args.formulation, args.beam, args.omega, T_s=args.ts, t_end=args.t_end, elements=args.elements,
                     rho_inf=args.rho_inf, rtol=args.rtol, dt_out=args.dt_out, progress=not args.no_progress)
    if args.out:
        res.to_csv(args.out)
    if args.plot:
        res.plot(args.plot)
    if not args.json:
        print(res.table())
        if args.out:
            print(f"  tip CSV -> {args.out}")
        if args.plot:
            print(f"  plot    -> {args.plot}")
    else:
        print(res.json())
    return 0


def _modes(args) -> int:
    import numpy as np

    from .models import RotatingFrameModel
    from .motion import Stationary
    from .reduction import vibration_modes
    from .scenarios import beam_preset

    preset = beam_preset(args.beam)
    body = preset.body(args.elements)
    model = RotatingFrameModel(body, Stationary())
    modes = vibration_modes(body, model.free_mask(), args.count)
    omega = np.asarray(modes.omega)
    if args.json:
        print(json.dumps({"beam": args.beam, "elements": args.elements, "omega_rad_s": omega.tolist(),
                          "frequency_hz": (omega / (2 * np.pi)).tolist()}))
    else:
        print(f"{args.beam} beam, {args.elements} elements, clamped at the hub "
              f"(Euler-Bernoulli first bending: {preset.first_frequency_eb:.4f} rad/s)" if preset.curve is None
              else f"{args.beam} beam, {args.elements} elements, clamped at the hub")
        print("  mode   omega [rad/s]   f [Hz]")
        for i, w in enumerate(omega, 1):
            print(f"  {i:4d}  {w:14.5f}  {w / (2 * np.pi):9.4f}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    from .scenarios import BEAMS

    p = argparse.ArgumentParser(prog="nrrncf", description="NR-RNCF flexible multibody simulation (JAX)")
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("spinup", help="spin-up manoeuvre of a beam (paper Section 4.1, Eq. 43)")
    s.add_argument("--formulation", choices=["rncf", "ancf"], default="rncf")
    s.add_argument("--beam", choices=sorted(BEAMS), default="paper")
    s.add_argument("--omega", type=float, required=True, help="steady spin rate omega_s [rad/s]")
    s.add_argument("--ts", type=float, default=15.0, help="spin-up time T_s [s] (default 15)")
    s.add_argument("--t-end", type=float, default=30.0, help="end time [s] (default 30)")
    s.add_argument("--elements", type=int, default=None, help="beam elements (default: the paper's Table 2)")
    s.add_argument("--rho-inf", type=float, default=0.9, help="generalized-alpha spectral radius (default 0.9)")
    s.add_argument("--rtol", type=float, default=1e-4, help="relative tolerance of the step control")
    s.add_argument("--dt-out", type=float, default=0.01, help="output interval [s] (default 0.01)")
    s.add_argument("--out", help="write the tip displacement CSV (t, theta, ux, uy, uz) here")
    s.add_argument("--plot", help="write a PNG of the tip displacement here")
    s.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    s.add_argument("--no-progress", action="store_true", help="no progress line on stderr")
    s.set_defaults(func=_spinup)

    m = sub.add_parser("modes", help="natural frequencies of a beam clamped at the hub")
    m.add_argument("--beam", choices=sorted(BEAMS), default="paper")
    m.add_argument("--elements", type=int, default=8)
    m.add_argument("--count", type=int, default=10)
    m.add_argument("--json", action="store_true")
    m.set_defaults(func=_modes)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    import jax

    jax.config.update("jax_enable_x64", True)
    try:
        return args.func(args)
    except ValueError as e:
        print(f"nrrncf: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
