"""The ``nrrncf`` command: the paper's examples from a shell.

    nrrncf spinup --formulation rncf --beam paper --omega 40 --plot tip.png
    nrrncf spinup --formulation nr-rncf --omega 10 --reference rncf --plot tip.png
    nrrncf modes --beam paper --elements 8 --json
    nrrncf modes --beam curved-upwind --elements 8 --count 6 --mmi --omega 4 --plot mmi.png

The command switches on float64 in its own entry point; the library itself never does.
"""

import argparse
import json
import sys


def _count_or_auto(name):
    def parse(s: str):
        if s == "auto":
            return s
        try:
            k = int(s)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be 'auto' or a non-negative integer, got {s!r}") from None
        if k < 0:
            raise argparse.ArgumentTypeError(f"{name} must be 'auto' or a non-negative integer, got {s!r}")
        return k

    return parse


def _spinup(args) -> int:
    from .scenarios import run_spinup
    from .scenarios.spinup import default_elements, run_nr_rncf_spinup

    if args.elements is None:
        args.elements = default_elements(args.omega) if args.omega > 0 else 6
    reduced = args.formulation == "nr-rncf"
    if args.reference and not reduced:
        raise ValueError("--reference compares a reduced run against the full model; use it with "
                         "--formulation nr-rncf")
    if not args.json:
        basis = (f", basis from {args.modes} modes (VMs {args.vms}, MDs {args.mds})"
                 + (f", reference {args.reference.upper()}" if args.reference else "")) if reduced else ""
        print(f"nrrncf spinup: {args.formulation.upper()} {args.beam} beam, omega_s = {args.omega:g} rad/s, "
              f"T_s = {args.ts:g} s, t = 0..{args.t_end:g} s, {args.elements} elements{basis}", flush=True)
    common = dict(T_s=args.ts, t_end=args.t_end, elements=args.elements, rho_inf=args.rho_inf, rtol=args.rtol,
                  dt_out=args.dt_out, progress=not args.no_progress)
    if reduced:
        res = run_nr_rncf_spinup(args.beam, args.omega, vms=args.vms, mds=args.mds, n_modes=args.modes,
                                 max_dofs=args.max_dofs,
                                 reference=args.reference == "rncf", **common)
    else:
        res = run_spinup(args.formulation, args.beam, args.omega, **common)
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


def _mmi(args) -> dict:
    """The MMI matrix (Eq. 39) of the spin-up at ``args.omega`` and the automatic selection."""
    import jax.numpy as jnp
    import numpy as np

    from .nr_rncf import nr_rncf
    from .plotting import mmi_quarter
    from .scenarios.spinup import build_spinup_model, output_times

    ts = output_times(args.t_end, args.dt_out)
    full = build_spinup_model("rncf", args.beam, args.omega, args.ts, args.elements)
    red = nr_rncf(full, jnp.asarray(ts), n_modes=args.count)
    sel = red.selection
    if args.plot:
        from .plotting import plot_mmi

        plot_mmi(args.plot, sel.W, sel, red.omega,
                 title=f"MMI, {args.beam} beam, {args.elements} el., $\\omega_s$ = {args.omega:g} rad/s")
    return {"omega_s": args.omega, "T_s": args.ts, "t_end": args.t_end,
            "W_quarter": np.round(mmi_quarter(sel.W), 6).tolist(),
            "selected_vms": [i + 1 for i in sel.vms], "selected_mds": [[i + 1, j + 1] for i, j in sel.pairs],
            "dofs": red.dofs, "offline_s": round(red.offline_s["total"], 3)}


def _print_mmi(d: dict) -> None:
    import numpy as np

    Wq = np.asarray(d["W_quarter"])
    k = Wq.shape[0]
    print(f"\nMMI matrix (Eq. 39) of the spin-up, omega_s = {d['omega_s']:g} rad/s, T_s = {d['T_s']:g} s, "
          f"t = 0..{d['t_end']:g} s: (W_ij / max W)^(1/4), upper triangle")
    print("  i\\j " + "".join(f"{j + 1:>6d}" for j in range(k)))
    for i in range(k):
        print(f"  {i + 1:4d}" + " " * 6 * i + "".join(f"{Wq[i, j]:6.2f}" for j in range(i, k)))
    print(f"  selected VMs (auto): {d['selected_vms']}")
    print("  selected MDs (auto): " + (" ".join(f"θ{i},{j}" for i, j in d["selected_mds"]) or "none"))
    print(f"  reduced DOFs after deflation: {d['dofs']}  (offline {d['offline_s']:.2f} s)")


def _modes(args) -> int:
    import numpy as np

    from .models import RotatingFrameModel
    from .motion import Stationary
    from .reduction import vibration_modes
    from .scenarios import beam_preset

    preset = beam_preset(args.beam)
    body = preset.body(args.elements)
    model = RotatingFrameModel(body, Stationary())
    if (args.omega is not None or args.plot) and not args.mmi:
        raise ValueError("--omega and --plot go with --mmi")
    if args.mmi and args.omega is None:
        raise ValueError("--mmi needs --omega (the steady spin rate of the spin-up)")
    modes = vibration_modes(body, model.free_mask(), args.count)
    omega = np.asarray(modes.omega)
    mmi = _mmi(args) if args.mmi else None
    if args.json:
        d = {"beam": args.beam, "elements": args.elements, "omega_rad_s": omega.tolist(),
             "frequency_hz": (omega / (2 * np.pi)).tolist()}
        if mmi is not None:
            d["mmi"] = mmi
        print(json.dumps(d))
    else:
        print(f"{args.beam} beam, {args.elements} elements, clamped at the hub "
              f"(Euler-Bernoulli first bending: {preset.first_frequency_eb:.4f} rad/s)" if preset.curve is None
              else f"{args.beam} beam, {args.elements} elements, clamped at the hub")
        print("  mode   omega [rad/s]   f [Hz]")
        for i, w in enumerate(omega, 1):
            print(f"  {i:4d}  {w:14.5f}  {w / (2 * np.pi):9.4f}")
        if mmi is not None:
            _print_mmi(mmi)
            if args.plot:
                print(f"  MMI plot -> {args.plot}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    from .scenarios import BEAMS

    p = argparse.ArgumentParser(prog="nrrncf", description="NR-RNCF flexible multibody simulation (JAX)")
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("spinup", help="spin-up manoeuvre of a beam (paper Section 4.1, Eq. 43)")
    s.add_argument("--formulation", choices=["rncf", "ancf", "nr-rncf"], default="rncf",
                   help="full-order RNCF or ANCF, or the NR-RNCF reduced model")
    s.add_argument("--beam", choices=sorted(BEAMS), default="paper")
    s.add_argument("--omega", type=float, required=True, help="steady spin rate omega_s [rad/s]")
    s.add_argument("--ts", type=float, default=15.0, help="spin-up time T_s [s] (default 15)")
    s.add_argument("--t-end", type=float, default=30.0, help="end time [s] (default 30)")
    s.add_argument("--elements", type=int, default=None, help="beam elements (default: the paper's Table 2)")
    s.add_argument("--rho-inf", type=float, default=0.9, help="generalized-alpha spectral radius (default 0.9)")
    s.add_argument("--rtol", type=float, default=1e-4, help="relative tolerance of the step control")
    s.add_argument("--dt-out", type=float, default=0.01, help="output interval [s] (default 0.01)")
    s.add_argument("--vms", type=_count_or_auto("--vms"), default="auto",
                   help="nr-rncf: vibration modes kept, 'auto' (MMI, Eq. 39) or a count (default auto)")
    s.add_argument("--mds", type=_count_or_auto("--mds"), default="auto",
                   help="nr-rncf: modal derivatives kept, 'auto' (MMI) or a count (default auto)")
    s.add_argument("--modes", type=int, default=24, help="nr-rncf: candidate vibration modes (default 24)")
    s.add_argument("--max-dofs", type=int, default=25, help="nr-rncf: at most this many VMs + MDs (default 25)")
    s.add_argument("--reference", choices=["rncf"], default=None,
                   help="nr-rncf: also run the full RNCF model; report chi_rel (Eq. 40) and the speed-up")
    s.add_argument("--out", help="write the tip displacement CSV (t, theta, ux, uy, uz) here")
    s.add_argument("--plot", help="write a PNG of the tip displacement here (with --reference: full and reduced)")
    s.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    s.add_argument("--no-progress", action="store_true", help="no progress line on stderr")
    s.set_defaults(func=_spinup)

    m = sub.add_parser("modes", help="natural frequencies of a beam clamped at the hub")
    m.add_argument("--beam", choices=sorted(BEAMS), default="paper")
    m.add_argument("--elements", type=int, default=8)
    m.add_argument("--count", type=int, default=10, help="modes to compute (with --mmi: the candidate modes)")
    m.add_argument("--mmi", action="store_true",
                   help="also the maximum-modal-interaction matrix (Eq. 39) of a spin-up and the automatic selection")
    m.add_argument("--omega", type=float, default=None, help="--mmi: steady spin rate omega_s [rad/s]")
    m.add_argument("--ts", type=float, default=15.0, help="--mmi: spin-up time T_s [s] (default 15)")
    m.add_argument("--t-end", type=float, default=30.0, help="--mmi: end time [s] (default 30)")
    m.add_argument("--dt-out", type=float, default=0.01, help="--mmi: sampling interval of W [s] (default 0.01)")
    m.add_argument("--plot", help="--mmi: write the MMI bar plot (PNG) here")
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
