"""``nrrncf spinup``: the paper's spin-up manoeuvre (Section 4.1, Eq. 43), full or reduced."""

import argparse


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
    from ..scenarios import run_spinup
    from ..scenarios.spinup import default_elements, run_nr_rncf_spinup

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
                                 spin_state={"auto": "auto", "on": True, "off": False}[args.spin_state],
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


def register(sub) -> None:
    from ..scenarios import BEAMS

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
    s.add_argument("--spin-state", choices=["auto", "on", "off"], default="auto",
                   help="nr-rncf: spinning-state enrichment (beyond the paper): 'auto' adds the spinning beam's "
                        "first mode and MDs when the rest basis misses its frequency by > 0.2 %%; 'off' is the "
                        "paper's basis (default auto)")
    s.add_argument("--reference", choices=["rncf"], default=None,
                   help="nr-rncf: also run the full RNCF model; report chi_rel (Eq. 40) and the speed-up")
    s.add_argument("--out", help="write the tip displacement CSV (t, theta, ux, uy, uz) here")
    s.add_argument("--plot", help="write a PNG of the tip displacement here (with --reference: full and reduced)")
    s.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    s.add_argument("--no-progress", action="store_true", help="no progress line on stderr")
    s.set_defaults(func=_spinup)
