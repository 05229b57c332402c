"""``nrrncf spinup``: the paper's spin-up manoeuvre (Section 4.1, Eq. 43), full or reduced."""

from .. import _validate
from . import _common


def _check(args) -> None:
    """Every argument, before anything runs (``_common``'s checks; no JAX)."""
    _validate.positive("--omega (steady spin rate)", args.omega)
    _validate.positive("--ts (spin-up time T_s)", args.ts)
    _common.output_times(args.t_end, args.dt_out)
    _common.at_least("--elements", args.elements, 1)
    if not 0.0 <= args.rho_inf <= 1.0:
        raise ValueError(f"--rho-inf (spectral radius) must lie in [0, 1], got {args.rho_inf:g}")
    _validate.tolerances(args.rtol, rtol_name="--rtol (relative tolerance)")
    _common.at_least("--modes", args.modes, 1)
    _common.at_least("--max-dofs", args.max_dofs, 1)
    if isinstance(args.vms, int) and args.vms > args.modes:
        raise ValueError(f"--vms {args.vms} asks for more vibration modes than the --modes {args.modes} candidates")
    if args.tol is not None:
        _validate.positive("--tol (target chi_rel in per cent)", args.tol)
        if args.formulation != "nr-rncf":
            raise ValueError("--tol chooses a reduced basis; use it with --formulation nr-rncf")
    if (args.estimate_method != "static" or args.estimate_integration) and args.formulation != "nr-rncf":
        raise ValueError("--estimate-method and --estimate-integration estimate a reduced run's error; use them "
                         "with --formulation nr-rncf")
    _common.estimate_integration(args, args.formulation == "nr-rncf", default=args.formulation == "nr-rncf")
    _common.estimate_samples(args, args.formulation == "nr-rncf")
    if args.reference and args.formulation != "nr-rncf":
        raise ValueError("--reference compares a reduced run against the full model; use it with "
                         "--formulation nr-rncf")
    _common.output_path("--out", args.out)
    _common.output_path("--plot", args.plot)


def _spinup(args) -> int:
    from ..scenarios import run_spinup
    from ..scenarios.spinup import default_elements, run_nr_rncf_spinup

    if args.elements is None:
        args.elements = default_elements(args.omega)
    reduced = args.formulation == "nr-rncf"
    if not args.json:
        choice = (f"to chi_rel estimate <= {args.tol:g} %" if args.tol is not None
                  else f"(VMs {args.vms}, MDs {args.mds})")
        basis = (f", basis from {args.modes} modes {choice}"
                 + (f", reference {args.reference.upper()}" if args.reference else "")) if reduced else ""
        print(f"nrrncf spinup: {args.formulation.upper()} {args.beam} beam, omega_s = {args.omega:g} rad/s, "
              f"T_s = {args.ts:g} s, t = 0..{args.t_end:g} s, {args.elements} elements{basis}", flush=True)
    from ..integrate import GeneralizedAlpha, adaptive_step_size

    common = dict(T_s=args.ts, t_end=args.t_end, elements=args.elements, dt_out=args.dt_out,
                  solver=GeneralizedAlpha(args.rho_inf),
                  controller=adaptive_step_size(args.rtol, 1e-6, args.step_control), progress=not args.no_progress)
    if reduced:
        from ..reduction import Basis

        basis = Basis(n_modes=args.modes, vms=args.vms, mds=args.mds, max_dofs=args.max_dofs,
                      spin_state={"auto": "auto", "on": True, "off": False}[args.spin_state])
        res = run_nr_rncf_spinup(args.beam, args.omega, basis=basis, estimator=_common.estimator(args), tol=args.tol,
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
    s = sub.add_parser("spinup", help="spin-up manoeuvre of a beam (paper Section 4.1, Eq. 43)",
                       description="The spin-up manoeuvre of Eq. 43 with the full RNCF or ANCF model, or the NR-RNCF "
                                   f"reduced model; tip table on stdout, progress on stderr. {_common.MODE_INDICES}.",
                       formatter_class=_common.HelpFormatter)
    s.add_argument("--formulation", choices=["rncf", "ancf", "nr-rncf"], default="rncf",
                   help="full-order RNCF or ANCF, or the NR-RNCF reduced model")
    s.add_argument("--beam", choices=_common.BEAM_NAMES, default="paper", help="beam preset")
    s.add_argument("--omega", type=float, required=True, help="steady spin rate omega_s [rad/s], > 0")
    s.add_argument("--ts", type=float, default=15.0, help="spin-up time T_s [s]")
    s.add_argument("--t-end", type=float, default=30.0, help="end time [s]")
    s.add_argument("--elements", type=int, default=None,
                   help="beam elements (default: the paper's Table 2 mesh for omega_s)")
    s.add_argument("--rho-inf", type=float, default=0.9, help="generalized-alpha spectral radius, in [0, 1]")
    s.add_argument("--rtol", type=float, default=1e-4, help="relative tolerance of the step control, in (0, 1)")
    _common.add_step_control(s)
    s.add_argument("--dt-out", type=float, default=0.01, help="output interval [s]")
    s.add_argument("--vms", type=_common.count_or_auto(1), default="auto",
                   help="nr-rncf: vibration modes kept, 'auto' (MMI, Eq. 39) or a count >= 1")
    s.add_argument("--mds", type=_common.count_or_auto(0), default="auto",
                   help="nr-rncf: modal derivatives kept, 'auto' (MMI) or a count >= 0")
    s.add_argument("--modes", type=int, default=24, help="nr-rncf: candidate vibration modes")
    s.add_argument("--max-dofs", type=int, default=25, help="nr-rncf: at most this many VMs + MDs")
    s.add_argument("--tol", type=float, default=None, metavar="P",
                   help="nr-rncf: choose the basis to a target chi_rel of P per cent: the smallest prefix of the MMI "
                        "ranking whose run's error estimate is <= P/2 (up to --max-dofs columns; --vms and --mds are "
                        "then not used, --spin-state checks each basis tried)")
    s.add_argument("--spin-state", choices=["auto", "on", "off"], default="auto",
                   help="nr-rncf: spinning-state enrichment (beyond the paper): 'auto' adds the spinning beam's "
                        "first mode and MDs when the rest basis misses its frequency by > 0.2 %%; 'off' is the "
                        "paper's basis")
    _common.add_estimate_options(s, method_help=(
        "nr-rncf: the error estimate's model: the quasi-static correction at 16 sampled outputs "
        "(static), or the linearised error equation over every output (dynamic; where it stops "
        "being valid the JSON says so in estimate_valid_until_s); static: the run ends a step on "
        "each sample; dynamic: on a repetition of the run that ends a step on every output"))
    _common.add_estimate_integration(s, "nr-rncf", " (default: on for nr-rncf)")
    s.add_argument("--reference", choices=["rncf"], default=None,
                   help="nr-rncf: also run the full RNCF model, converged (at rtol/10 and rtol/100); report the "
                        "total chi_rel (Eq. 40) against it, its time-integration and basis parts, the reference's "
                        "own error and the speed-up")
    s.add_argument("--out", help="write the tip displacement CSV (t, theta, ux, uy, uz) here")
    s.add_argument("--plot", help="write a PNG of the tip displacement here (with --reference: full and reduced)")
    s.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    s.add_argument("--no-progress", action="store_true", help="no progress line on stderr")
    s.set_defaults(func=_spinup, check=_check)
