"""``nrrncf pendulum``: the flexible three-beam pendulum of the paper's Sec. 4.4
(``scenarios.pendulum``).

    nrrncf pendulum [--formulation {ancf,rncf,nr-rncf}] [--elements 10] [--vms 5] [--mds all|none]
                    [--conditions {mean-axis,clamped,pinned}]
                    [--joint-modes | --craig-bampton | --tol P [--train-t 0.5]]
                    [--no-estimate | --estimate-method {static,dynamic} [--estimate-integration]]
                    [--reference {ancf,rncf}] [--reference-rtol R] [--t-end 2] [--dt-out 0.001]
                    [--out tips.csv] [--plot F] [--animate F.gif] [--vtk DIR] [--json] [--no-progress]

``ancf``: the full-order model, three ANCF beams (C1 elements) joined by revolute joints, an
index-3 DAE integrated by generalized-α. ``rncf``: the same beams in floating frames (Euler
parameters) with every nodal coordinate but the frame's reference conditions kept
(``multibody.full_order_frame``): the paper's full-order reference, the ANCF model in other
coordinates. ``nr-rncf``: each beam in its floating frame with its deformation reduced to its
first ``--vms`` vibration modes and their modal derivatives (``multibody.floating``) under the
reference ``--conditions`` (the paper's cantilever at the left hinge by default; ``mean-axis``,
free-free modes with the frame at the beam's centre of mass, about half the steps at equal
accuracy, estimated by ``--estimate-method dynamic`` only), or with
``--craig-bampton`` to the extended Craig-Bampton basis (``reduction.craig_bampton``, clamped);
``--tol P`` chooses the beams' basis instead, the smallest prefix of the ranked candidates whose
training run over 0-``--train-t`` has a dynamic error estimate of at most P / 2
(``scenarios.pendulum.pendulum_to_tolerance``), and reports every basis tried;
``--reference ancf|rncf`` runs that full model too, converged, and reports χ_rel and the
speed-up: the full model at ``--reference-rtol`` (by default a hundredth of its own default rtol,
or of the run's where that is tighter) is the reference, the full model at ten times that bounds
its own error (``reference_error_percent``) and gives the speed-up, and the reduced chain again at
a hundredth of its rtol splits χ_rel, the run's total error, into ``integration_error_percent``
and ``basis_error_percent``. An ``nr-rncf`` run carries its error
estimate from the run alone (``chi_rel_estimate_percent``, ``multibody.error_estimate``; with
``--reference`` its ``effectivity``) unless ``--no-estimate``. ``--estimate-method static``
(the default) sees each beam's deformation error, not the drift of the chain's swing that error
causes over time, and reads low where that drift dominates; ``dynamic`` integrates the
linearised error equation and follows the drift until its linearisation fails
(``estimate_valid_until_s``). ``--estimate-integration`` adds the run's own time-integration error
(off by default): the run repeated at rtol/10, its distance to the run over every node
(``integration_error_estimate_percent``; ``chi_rel_estimate_percent`` is then the total estimate,
``basis_error_estimate_percent`` its basis part) and at each beam's right end
(``integration_error_estimate_percent_tip<k>``).

``--out`` writes the columns ``t, x1, y1, x2, y2, x3, y3``: each beam's right end, global (the
hinge at the origin, the beams initially along +x). ``--plot`` draws the shapes at 0, 0.5, 1, 1.5
and 2 s (the paper's Fig. 17) and each right end's displacement and transverse deflection in the
frame of its beam's left end (Fig. 18). ``--json`` prints one JSON object as the last line with
``dofs, steps, newton_iters, compile_s, run_s`` and more.
"""

from .. import _validate
from . import _common

DEFAULTS = {"nr-rncf": (1e-3, "pi"), "ancf": (1e-4, "plain"), "rncf": (1e-4, "plain")}
"""Each formulation's default (rtol, step control); atol = rtol / 10. The reduced chain's error is
its basis's, well above the integration error at rtol 1e-3: with the PI controller that looser
tolerance takes far fewer steps and Newton iterations than the full-model settings for the same
χ_rel. A full model is the reference and keeps the tighter rtol."""

TRAIN_T = 0.5
"""``--train-t``'s default [s]: the basis search's training run, inside the span where the chain's
error equation holds (``scenarios.pendulum.pendulum_to_tolerance``)."""


def _run(args) -> int:
    import numpy as np

    from ..integrate import GeneralizedAlphaIndex3, adaptive_step_size, with_tolerances
    from ..scenarios.pendulum import SHAPE_TIMES, PendulumBasis, PendulumSpec, run_pendulum
    from ..scenarios.run_record import REFERENCE_TIGHTENING, with_step_settings

    spec = PendulumSpec(elements=args.elements)
    _common.say(args, f"three-beam pendulum, {spec.elements} elements a beam, {args.formulation}, "
                      f"0-{args.t_end:g} s ...")
    controller = adaptive_step_size(args.rtol, args.atol, args.step_control)
    kw = dict(t_end=args.t_end, dt_out=args.dt_out, solver=GeneralizedAlphaIndex3(args.rho_inf), controller=controller,
              progress=not (args.json or args.no_progress))

    def at(rtol, atol):  # the run's options at other tolerances, the same step control
        return kw | dict(controller=with_tolerances(kw["controller"], rtol, atol))

    full = args.formulation in ("ancf", "rncf")
    if full:
        run = run_pendulum(spec, **kw, error_on=args.error_on,
                           **({} if args.formulation == "ancf" else {"formulation": "rncf"}))
    elif args.tol is not None:
        from ..scenarios.pendulum import chain_to_tolerance, pendulum_to_tolerance, run_chain

        _common.say(args, f"basis to chi_rel <= {args.tol:g} %: trials over 0-{args.train_t:g} s ...")
        # the training runs: the run's own step control at its tolerances (tightened by the search)
        search = pendulum_to_tolerance(spec, args.tol, n_vms=args.vms, t_train=args.train_t, t_end=args.t_end,
                                       solver=kw["solver"], controller=controller)
        _common.say(args, search.describe())
        if args.no_estimate:
            run = run_chain(search.system, error_on=args.error_on, **kw)
        else:  # the step settings to the same target: the run's own integration error at most tol / 2
            run = chain_to_tolerance(search.system, args.tol, _common.estimator(args), error_on=args.error_on, **kw)
            kw["controller"] = with_step_settings(controller, run.step_tolerances)
        rtol, atol = float(kw["controller"].rtol), float(kw["controller"].atol)

        def chain_at(k, estimate):
            return run_chain(search.system, error_on=args.error_on, **at(rtol / k, atol / k))

        run.search = search
    else:
        basis = PendulumBasis(args.vms, "all" if args.mds == "all" else (), joint_modes=args.joint_modes,
                              craig_bampton=args.craig_bampton, conditions=args.conditions or "clamped")

        def chain_at(k, estimate):
            return run_pendulum(spec, formulation="nr-rncf", basis=basis, error_on=args.error_on,
                                estimator=_common.estimator(args) if estimate else None,
                                **at(args.rtol / k, args.atol / k))

        run = chain_at(1.0, not args.no_estimate)
    if args.reference is not None:
        # Against the full model converged (``RunRecord.compare_converged``): it runs at ten and at
        # one times the reference's tolerance, the reduced chain again at a hundredth of its own.
        tight = (min(float(kw["controller"].rtol), DEFAULTS[args.reference][0]) / REFERENCE_TIGHTENING**2
                 if args.reference_rtol is None else args.reference_rtol)
        base = tight * REFERENCE_TIGHTENING**2

        def full_at(k):
            rtol = base / k
            return run_pendulum(spec, **at(rtol, args.atol * rtol / args.rtol),
                                **({} if args.reference == "ancf" else {"formulation": "rncf"}))

        run.compare_converged(full_at, lambda k: chain_at(k, False).displacement_series(), rtol=base)
    if args.out:
        np.savetxt(args.out, run.table(), delimiter=",", header=run.table_header(), comments="", fmt="%.9g")
    if args.plot:
        from ..post.plotting import plot_pendulum

        plot_pendulum(args.plot, [run] + ([run.reference] if run.reference is not None else []), times=SHAPE_TIMES)
    if args.animate:
        from ..post.plotting import animate_pendulum

        animate_pendulum(args.animate, run)
    if args.vtk:
        from ..post.vtk import write_polyline_series

        every = max(1, len(run.ts) // 100)
        beams, nodes = run.nodes.shape[1:3]
        lines = [(b * nodes + i, b * nodes + i + 1) for b in range(beams) for i in range(nodes - 1)]
        write_polyline_series(args.vtk, run.nodes[::every].reshape(-1, beams * nodes, 3), lines, run.ts[::every])
    settings = {"rtol": args.rtol, "atol": args.atol, "rho_inf": args.rho_inf, "step_control": args.step_control}
    return _common.emit(args, run.summary() | settings)


def _check(args) -> None:
    rtol, control = DEFAULTS[args.formulation]
    args.rtol = rtol if args.rtol is None else args.rtol
    args.atol = args.rtol / 10 if args.atol is None else args.atol
    args.step_control = control if args.step_control is None else args.step_control
    if args.reference_rtol is not None and (args.reference is None or not args.reference_rtol > 0):
        raise ValueError("--reference-rtol needs --reference ancf|rncf and a positive value")
    if args.formulation != "nr-rncf" and (args.reference is not None or args.vms is not None or args.mds is not None
                                       or args.joint_modes or args.craig_bampton or args.no_estimate
                                       or args.conditions is not None):
        raise ValueError("--reference, --vms, --mds, --conditions, --joint-modes, --craig-bampton and --no-estimate "
                         "go with --formulation nr-rncf")
    _common.estimate_integration(args, args.formulation == "nr-rncf", default=False)
    if args.no_estimate and args.estimate_integration:
        raise ValueError("--estimate-integration adds the run's time-integration part to its error estimate; leave "
                         "out --no-estimate")
    if args.conditions == "mean-axis" and not args.no_estimate and args.estimate_method == "static":
        raise ValueError("--conditions mean-axis: the static error estimate holds each beam's frame, which no joint "
                         "holds under mean axes; pass --estimate-method dynamic or --no-estimate")
    if args.craig_bampton and args.conditions == "mean-axis":
        raise ValueError("--craig-bampton holds the beams' boundary coordinates: it goes with --conditions clamped "
                         "or pinned, not mean-axis")
    if args.tol is not None:
        if args.formulation != "nr-rncf":
            raise ValueError("--tol chooses a reduced basis; use it with --formulation nr-rncf")
        _validate.positive("--tol (target chi_rel in per cent)", args.tol)
        if args.mds is not None or args.joint_modes or args.craig_bampton or args.conditions is not None:
            raise ValueError("--tol chooses the modal derivatives and the joint modes itself: leave out --mds, "
                             "--conditions, --joint-modes and --craig-bampton (--vms sets the candidate vibration "
                             "modes)")
        _common.output_times(args.train_t, 0.01)
    elif args.train_t != TRAIN_T:
        raise ValueError("--train-t is the training window of --tol; give --tol too")
    _common.estimate_samples(args, args.formulation == "nr-rncf")
    if args.no_estimate and args.estimate_samples is not None:
        raise ValueError("--estimate-samples sets the error estimate's samples; leave out --no-estimate")
    if args.joint_modes and args.craig_bampton:
        raise ValueError("--craig-bampton already holds the joint's static modes: pass one of --joint-modes, "
                         "--craig-bampton")
    if args.vms is None:
        args.vms = 5
    if args.mds is None:
        args.mds = "all"
    _common.at_least("--elements", args.elements, 1)
    _common.at_least("--vms", args.vms, 1)
    _common.output_times(args.t_end, args.dt_out)
    _validate.tolerances(args.rtol, args.atol)
    if not 0.0 <= args.rho_inf <= 1.0:
        raise ValueError(f"--rho-inf must lie in [0, 1], got {args.rho_inf:g}")
    for flag, path in (("--out", args.out), ("--plot", args.plot), ("--animate", args.animate)):
        _common.output_path(flag, path)
    _common.output_folder("--vtk", args.vtk)


def register(sub) -> None:
    t = sub.add_parser("pendulum", help="the flexible three-beam pendulum (paper Sec. 4.4): full and NR-RNCF",
                       description="The three-beam pendulum of the paper's Sec. 4.4: three 1 m beams (radius 5 mm, "
                                   "E = 5 MPa, rho = 1100 kg/m^3) hinged to the ground and to each other about Z, "
                                   "released from rest along +x under gravity along -Y. "
                                   "ancf: the full-order model; rncf: the full-order model in floating frames; "
                                   "nr-rncf: NR-RNCF with each beam in its floating frame, reduced.",
                       formatter_class=_common.HelpFormatter)
    t.add_argument("--formulation", choices=("ancf", "rncf", "nr-rncf"), default="ancf",
                   help="the model: ancf (full order, inertial frame), rncf (full order, floating frames) or "
                        "nr-rncf (floating frames, reduced)")
    t.add_argument("--elements", type=int, default=10, help="C1 beam elements per beam")
    t.add_argument("--vms", type=int, default=None, help="nr-rncf: vibration modes a beam (default: 5)")
    t.add_argument("--mds", choices=("all", "none"), default=None,
                   help="nr-rncf: all modal derivatives of the VMs (i <= j), or none (default: all)")
    t.add_argument("--conditions", choices=("mean-axis", "clamped", "pinned"), default=None,
                   help="nr-rncf: the beams' reference conditions: clamped (the paper's cantilever at the left "
                        "hinge; the default), mean-axis (free-free modes, the frame at the beam's centre of mass: "
                        "about half the steps at equal accuracy; its error estimate needs --estimate-method dynamic "
                        "or --no-estimate) or pinned (the frame along the chord, simply supported)")
    t.add_argument("--joint-modes", action="store_true",
                   help="nr-rncf: add each beam's static modes under forces at its joints (the right end's, or under "
                        "mean axes both ends' inertia-relief modes)")
    t.add_argument("--craig-bampton", action="store_true",
                   help="nr-rncf: the extended Craig-Bampton basis: the right end's position as boundary coordinates, "
                        "fixed-interface VMs and their MDs")
    t.add_argument("--tol", type=float, default=None, metavar="P",
                   help="nr-rncf: choose the beams' basis to a target chi_rel of P per cent: the smallest prefix of "
                        "the candidates (the first VM, the joint's static modes, then VMs and MDs by modal "
                        "interaction) whose training run's dynamic error estimate is <= P/2")
    t.add_argument("--train-t", type=float, default=TRAIN_T, metavar="T",
                   help="nr-rncf with --tol: the training run's end time [s] (the error equation holds on this "
                        "chain only until its soft beams buckle in compression)")
    t.add_argument("--reference", choices=("ancf", "rncf"), default=None,
                   help="nr-rncf: also run this full model and report chi_rel, the speed-up and the error "
                        "estimate's effectivity, against the full model converged (run at --reference-rtol and ten "
                        "times it; the reduced chain again at a hundredth of its rtol): chi_rel splits into its "
                        "time-integration and basis parts, and the reference's own error is printed beside it")
    t.add_argument("--no-estimate", action="store_true",
                   help="nr-rncf: skip the error estimate from the run alone (chi_rel_estimate_percent)")
    _common.add_estimate_options(t, method_help=(
        "nr-rncf: static (each beam's quasi-static correction at 16 sampled outputs: cheap, blind to "
        "the drift of the chain's swing) or dynamic (the linearised error equation over every "
        "output: tracks the drift while its linearisation holds, reports where it stopped holding "
        "as estimate_valid_until_s; costs a few full-model steps an output)"))
    _common.add_estimate_integration(t, "nr-rncf", " (default: off); also each beam's right end's "
                                               "(integration_error_estimate_percent_tip<k>)")
    t.add_argument("--reference-rtol", type=float, default=None,
                   help="the converged reference's relative tolerance (default: a hundredth of the full model's "
                        "default, 1e-4, or of --rtol where tighter; its atol scaled alike); the full model runs at it "
                        "and at ten times it, whose distance bounds the reference's own error")
    t.add_argument("--t-end", type=float, default=2.0, help="end time [s]")
    t.add_argument("--dt-out", type=float, default=0.001, help="output interval [s]")
    t.add_argument("--rtol", type=float, default=None,
                   help="the step error's relative tolerance (default: 1e-3 with nr-rncf, 1e-4 with the full models)")
    t.add_argument("--atol", type=float, default=None,
                   help="the step error's absolute tolerance [m] (default: rtol / 10)")
    t.add_argument("--rho-inf", type=float, default=0.9, help="generalized-alpha spectral radius at infinity")
    _common.add_step_control(t, None, " (default: pi with nr-rncf, plain with the full models)")
    t.add_argument("--error-on", choices=("nodes", "tips"), default="nodes",
                   help="what the step error is measured on: every nodal vector, or the beams' right ends (the run's "
                        "outputs; a --reference run still measures every nodal vector)")
    t.add_argument("--out", help="write the right ends' positions (t, x1, y1, x2, y2, x3, y3) to this CSV file")
    t.add_argument("--plot", help="write the shapes (Fig. 17) and the right ends' motion (Fig. 18) as a PNG here")
    t.add_argument("--animate", help="write an animated GIF of the motion here")
    t.add_argument("--vtk", help="write the beams over time into this folder (.vtu files and a .pvd series)")
    t.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    t.add_argument("--no-progress", action="store_true", help="no progress messages on stderr")
    t.set_defaults(func=_run, check=_check)
