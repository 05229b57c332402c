"""``nrrncf membrane``: the rotating membrane of the paper's Sec. 4.3 (``scenarios.membrane``).

    nrrncf membrane --case {in-plane,bending-torsion} [--omega W] --formulation {rncf,nr-rncf}
                    [--vms I ...] [--mds I,J ...] [--estimate-method {static,dynamic}]
                    [--estimate-integration] [--reference rncf] [--plot F] [--vtk DIR] [--json]

The defaults reproduce the paper's bases: VM 19 + θ19,19 in-plane, VMs 3, 8, 19 and their six
MDs in bending-torsion, found by mode shape. ``--json`` prints one JSON object as the last line
with ``dofs, vms, mds, steps, compile_s, run_s, offline_s`` and with ``--reference rncf`` also
``reference_dofs, reference_run_s, chi_rel_percent, speedup``: the reference is the full model
converged (run at a tenth and a hundredth of the tolerances: ``reference_error_percent`` bounds
its own error), ``chi_rel_percent`` the run's total error against it, split into
``integration_error_percent`` (the run against its repetition at the reference's tolerance) and
``basis_error_percent``; the speed-up is against the full run at a tenth of the tolerances. The
error estimate from the reduced run alone is ``chi_rel_estimate_percent``; with
``--estimate-integration`` it is the total of ``basis_error_estimate_percent`` and
``integration_error_estimate_percent`` (the run against its repetition at rtol/10), as ``nrrncf
spinup`` reports it. Mode indices are 0-based (the paper's 19th mode is 18).
"""

from .. import _validate
from . import _common


def _pair(s: str) -> tuple[int, int]:
    import argparse

    try:
        i, j = (int(x) for x in s.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"a modal derivative is a pair of mode indices 'i,j', got {s!r}") from None
    if i < 0 or j < 0:
        raise argparse.ArgumentTypeError(f"mode indices are >= 0, got {s!r}")
    return i, j


def _run(args) -> int:
    import dataclasses

    from ..integrate import AdaptiveStepSize
    from ..scenarios.membrane import DEFAULT_BASIS, DEFAULT_OMEGA, MembraneSpec, build_membrane, run_membrane

    spec = MembraneSpec(rings=args.rings, thickness=args.thickness)
    omega = DEFAULT_OMEGA[args.case] if args.omega is None else args.omega
    _common.say(args, f"rotating membrane ({spec.rings} rings), {args.case}, omega_s = {omega:g} rad/s, "
                      f"{args.formulation}, 0-{args.t_end:g} s ...")
    kw = dict(T_s=args.ts, t_end=args.t_end, dt_out=args.dt_out, controller=AdaptiveStepSize(args.rtol, args.atol),
              progress=not (args.json or args.no_progress))
    if args.formulation == "rncf":
        run = run_membrane(args.case, omega, "rncf", spec, **kw)
    else:  # --reference rncf: against the full model converged, the error split into its parts
        # not given: the paper's ("auto" stands for it in run_membrane)
        mds = "auto" if args.mds is None else ([] if args.mds == ["none"] else args.mds)
        basis = dataclasses.replace(DEFAULT_BASIS, n_modes=args.modes, vms="auto" if args.vms is None else args.vms,
                                    mds=mds)
        run = run_membrane(args.case, omega, "nr-rncf", spec, basis, estimator=_common.estimator(args), tol=args.tol,
                           reference=args.reference == "rncf", **kw)
    if args.plot:
        from ..post.plotting import plot_membrane_rim

        plot_membrane_rim(args.plot, [run] + ([run.reference] if run.reference is not None else []))
    if args.vtk:
        from ..post.vtk import write_plate_vtk

        m = build_membrane(spec)
        fields, times = run.displacement_fields(m.body)
        write_plate_vtk(args.vtk, m.plate, fields, times=times)
    out = run.command_record(case=args.case, omega_s=omega, rim_max_m=run.summary()["rim_max_m"])
    return _common.emit(args, out)


def _check(args) -> None:
    _common.at_least("--rings", args.rings, 2)
    _validate.positive("--thickness", args.thickness)
    _validate.positive("--ts (spin-up time)", args.ts)
    if args.omega is not None:
        _validate.positive("--omega (steady spin rate)", args.omega)
    _common.output_folder("--vtk", args.vtk)
    _common.output_path("--plot", args.plot)
    _common.output_times(args.t_end, args.dt_out)
    _validate.tolerances(args.rtol, args.atol)
    if args.tol is not None:
        _validate.positive("--tol (target chi_rel in per cent)", args.tol)
    if args.formulation == "rncf":
        if args.reference is not None or args.tol is not None or args.estimate_method != "static":
            raise ValueError("--reference, --tol and --estimate-method go with --formulation nr-rncf")
        if args.vms is not None or args.mds is not None:
            raise ValueError("--vms and --mds go with --formulation nr-rncf")
    _common.estimate_samples(args, args.formulation == "nr-rncf")
    _common.estimate_integration(args, args.formulation == "nr-rncf", default=False)
    if args.mds is not None and "none" in args.mds and len(args.mds) > 1:
        raise ValueError("--mds none stands alone")
    highest = max([*(args.vms or []), *(i for p in (args.mds or []) if p != "none" for i in p)], default=-1)
    if highest >= args.modes:
        raise ValueError(f"mode index {highest} is not among the --modes {args.modes} candidates")


def register(sub) -> None:
    t = sub.add_parser("membrane", help="the rotating membrane (paper Sec. 4.3): full RNCF and NR-RNCF",
                       description="The rotating membrane of the paper's Sec. 4.3: an aluminium disk (b = 1 m, "
                                   "h = 1.36 mm) clamped at its centre, 1350 plate elements, 18,912 DOFs, spun up "
                                   "about Z (Eq. 43), in bending-torsion also with its hub oscillating along Z. "
                                   f"{_common.MODE_INDICES}; the paper's 19th mode is 18.",
                       formatter_class=_common.HelpFormatter)
    t.add_argument("--case", choices=("in-plane", "bending-torsion"), default="in-plane",
                   help="in-plane: spin-up alone (case A); bending-torsion: with w_z = 0.012 sin(0.5 pi t) (case B)")
    t.add_argument("--omega", type=float, default=None,
                   help="steady spin rate [rad/s] (default: 7 in-plane, 4 bending-torsion)")
    t.add_argument("--ts", type=float, default=2.0, help="spin-up time T_s of Eq. 43 [s]")
    t.add_argument("--formulation", choices=("rncf", "nr-rncf"), default="nr-rncf", help="the model")
    t.add_argument("--vms", type=int, nargs="+", default=None,
                   help="nr-rncf: the vibration modes (0-based; default the paper's, found by mode shape)")
    t.add_argument("--mds", type=lambda s: s if s == "none" else _pair(s), nargs="+", default=None,
                   help="nr-rncf: modal derivatives as pairs i,j, or 'none' (default: all pairs of the VMs)")
    t.add_argument("--modes", type=int, default=24, help="nr-rncf: candidate modes (the MMI's)")
    _common.add_estimate_options(t, method_help=(
        "nr-rncf: the error estimate: static (the quasi-static correction at 16 sampled outputs, "
        "a factorisation each) or dynamic (the linearised error equation over every output, a "
        "factorisation each: minutes on the full mesh, but it flags a basis whose error grows as "
        "drift; estimate_valid_until_s says where its linearisation stopped holding)"))
    _common.add_estimate_integration(t, "nr-rncf", " (default: off)")
    _common.add_tol_and_reference_options(t, "nr-rncf")
    t.add_argument("--rings", type=int, default=15, help="rings of the hexagonal disk mesh (15: 1350 triangles)")
    t.add_argument("--thickness", type=float, default=1.36e-3, help="plate thickness [m]")
    t.add_argument("--t-end", type=float, default=3.0, help="end time [s]")
    t.add_argument("--dt-out", type=float, default=0.01, help="output interval [s]")
    t.add_argument("--rtol", type=float, default=1e-5, help="the step error's relative tolerance")
    t.add_argument("--atol", type=float, default=1e-7, help="the step error's absolute tolerance")
    t.add_argument("--plot", help="write a plot (PNG) of the rim deflections in the reference frame here")
    t.add_argument("--vtk", help="write the deformed mesh over time into this folder (.vtu files and a .pvd series)")
    t.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    t.add_argument("--no-progress", action="store_true", help="no progress messages on stderr")
    t.set_defaults(func=_run, check=_check)
