"""``nrrncf run``: a mechanism of the user's own, from a model file or a bundled example
(``scenarios.mechanism_file``).

    nrrncf run MODEL [--param KEY=VALUE ...] [--t-end T] [--rtol R] [--dt H] [--error-on NAMES]
                     [--step-control plain|pi] [--rho-inf 0.9] [--n-out 201]
                     [--out F.csv] [--vtk DIR] [--animate F.gif] [--json] [--reference full]
                     [--estimate] [--estimate-method static|dynamic] [--estimate-samples N]
                     [--estimate-integration] [--tol P] [--no-progress]

``MODEL``: a Python file defining ``mechanism(**params) -> MechanismSetup``, or the name of a
bundled example (``nrrncf_jax/examples/``: ``slider_crank``, ``rotor``, ``two_link_arm``,
``fourbar``). ``--param`` passes keyword parameters (Python literals parsed as such: numbers,
lists such as ``mds=[(0,0),(0,1)]``, booleans; anything else as text). ``--dt H`` runs
fixed steps of H seconds (as the peers run stiff, quasi-static mechanisms) instead of error-controlled
ones. ``--error-on`` names the sensors whose values the step error is measured on (``nodes``: every
nodal vector; default: the model's ``error_on``). ``--out`` writes
the sensors at the output times as CSV columns ``t`` and each sensor's name (a vector sensor as
``name_0, name_1, ...``); ``--vtk`` the bodies' nodes and edges (``post.outline``) over time as a
ParaView series (.vtu files and a .pvd), ``--animate`` an animated GIF of them in the XY plane.
``--json`` prints one JSON object as the last line: ``formulation, dofs, steps, rejected,
newton_iters, compile_s, run_s``; with ``--reference full`` (the model run again with
``formulation=ancf``, its full-order model) also ``reference_dofs, reference_run_s, speedup`` and
``chi_rel_percent`` (Eq. 40, of each compared sensor's change from its initial value: the model's
``compare``, e.g. positions and deflections, not reactions, whose high-frequency content differs
between the models; the largest, and per sensor as ``chi_rel_percent_<name>``).

``--estimate`` (a model with reduced bodies) estimates the run's error from reduced runs alone
(``run_setup``'s ``estimator``): ``basis_error_estimate_percent`` over the reduced bodies' position
vectors, ``chi_rel_estimate_body_<b>_percent`` each one's on its deformation,
``basis_error_estimate_percent_<name>`` each compared sensor's; with ``--estimate-integration`` also
the run's own time-integration error, on those positions (``integration_error_estimate_percent``,
and ``chi_rel_estimate_percent`` the sum of the two parts) and on each sensor
(``integration_error_estimate_percent_<name>``), and ``chi_rel_estimate_percent_<name>`` the
estimate of what ``--reference full`` measures as ``chi_rel_percent_<name>``, and
``estimate_dominant_part`` which part dominates
(``--estimate-method``: ``dynamic`` by default, which carries the basis's error through the joints
to every sensor; ``static`` is cheaper, but it holds the frames).

``--tol P`` (a model with reduced bodies; implies ``--estimate-integration``) chooses the step
settings to a target χ_rel of P per cent on the compared sensors
(``scenarios.mechanism_file.run_to_tolerance``): the tolerances (from ``--rtol`` or the model's)
shrink until the run's own time-integration error on every compared sensor is at most P / 2, and
the output reports the chosen ``step_rtol``, ``step_atol``, ``tol_met`` (the estimated total at
most P on every compared sensor) and ``tol_verdict`` (in words, which part stands in the way where
it is not met). The basis is the model's own: where its part exceeds P / 2, the
output says so, and only a larger basis (the model's parameters, e.g. ``--param vms=...``) meets P.
"""

import ast

from . import _common


def _parse_params(items) -> dict:
    out = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"--param takes KEY=VALUE, got {item!r}")
        try:  # a Python literal (a number, a list of pairs, True), else the text itself
            value = ast.literal_eval(value.strip())
        except (ValueError, SyntaxError):
            pass
        out[key.strip()] = value
    return out


def _run(args) -> int:
    import numpy as np

    from ..scenarios.mechanism_file import load_setup, run_setup

    params = _parse_params(args.param)
    setup = load_setup(args.model, params)
    _common.say(args, f"{args.model}: {setup.system.formulation}, {setup.system.n_dof} coordinates, "
                      f"0-{args.t_end or setup.t_end:g} s ...")
    kw = dict(t_end=args.t_end, n_out=args.n_out, error_on=args.error_on)
    options = dict(solver=setup.solver(args.rho_inf), positions=bool(args.vtk or args.animate),
                   controller=setup.controller(args.rtol, args.dt, args.step_control))
    estimator = _common.estimator(args) if args.estimate else None
    rtol = setup.rtol if args.rtol is None else args.rtol
    if args.tol is None:
        run = run_setup(setup, **kw, **options, estimator=estimator)
    else:
        from ..scenarios.mechanism_file import run_to_tolerance

        _common.say(args, f"the step settings to chi_rel <= {args.tol:g} % on the compared sensors ...")
        run = run_to_tolerance(setup, args.tol, estimator, **kw, **options)
        rtol = run.settings["step_rtol"]  # a --reference runs at the chosen tolerance's tightenings
    out = run.summary() | {"model": args.model, "params": params}
    if args.tol is not None:
        out["tol_verdict"] = _tolerance_verdict(run)
    if args.out:
        names, table = run.table()
        np.savetxt(args.out, table, delimiter=",", header=",".join(names), comments="", fmt="%.12g")
    if args.vtk:
        from ..post.vtk import write_polyline_series

        write_polyline_series(args.vtk, run.points, run.lines, run.ts)
    if args.animate:
        from ..post.plotting import animate_lines

        animate_lines(args.animate, run.ts, run.points, run.lines, f"{args.model}, " + "t = {t:.4f} s")
    if args.reference == "full":
        out |= _reference_errors(args, setup, params, run, kw, rtol)
    return _common.emit(args, out)


def _tolerance_verdict(run) -> str:
    """``--tol``'s line: whether the target was met, and which part stands in the way where not."""
    s = run.summary()
    tol, rtol = s["tol_percent"], s["step_rtol"]
    if s["tol_met"]:
        return f"target {tol:g} % met (estimated) at rtol {rtol:.3g}"
    basis = run.estimate.sensor_chi_percent or {}
    worst = max(basis, key=basis.get) if basis else None
    if worst is not None and basis[worst] > tol / 2:
        return (f"target {tol:g} % NOT MET: the basis's part on {worst} is {basis[worst]:.3g} % (more than half the "
                "target); the basis is the model's own, so only a larger one (its parameters, e.g. --param vms=...) "
                "can meet it")
    return (f"target {tol:g} % NOT MET at rtol {rtol:.3g}: the time-integration part stayed above half the target "
            "after the tightenings allowed (run_record.STEP_TOLERANCE_ROUNDS)")


def _reference_errors(args, setup, params, run, kw, rtol) -> dict:
    """``--reference full``: the run's error against a converged full-order reference, and its parts.

    The full model (``formulation=ancf``) runs twice, error-controlled at a tenth and a hundredth
    of the run's tolerance (``REFERENCE_TIGHTENING``), its step error on every nodal vector
    whatever the model's ``error_on``; the tighter one is the reference, and the
    two references' distance (``reference_error_percent``) bounds the looser one's own error, so
    it says how far the reference can be trusted. The model runs again at the reference's
    tighter tolerance: the run's distance to that is its own time-integration error
    (``integration_error_percent``), and that run's distance to the reference is the basis's
    (the model's) error (``basis_error_percent``). ``chi_rel_percent`` is the run's total error
    against the reference, what a user of its output gets: with a reference at the run's own
    tolerance it would be the difference of two runs' integration errors instead."""
    from ..scenarios.mechanism_file import compare_sensors, load_setup, run_setup
    from ..scenarios.run_record import REFERENCE_TIGHTENING

    loose, tight = rtol / REFERENCE_TIGHTENING, rtol / REFERENCE_TIGHTENING**2
    # error-controlled, converged in every coordinate, not only in the outputs the run's step error watches
    adaptive = dict(kw, error_on="nodes")
    _common.say(args, f"the full-order reference (formulation=ancf) at rtol {loose:g} and {tight:g} ...")
    ref_setup = load_setup(args.model, params | {"formulation": "ancf"})

    def at(model, r):
        return run_setup(model, **adaptive, solver=model.solver(args.rho_inf),
                         controller=model.controller(r, step_control=args.step_control))

    ref_loose, ref = at(ref_setup, loose), at(ref_setup, tight)
    _common.say(args, f"the model again at rtol {tight:g} (its time-integration error) ...")
    converged = at(setup, tight)
    total, own = compare_sensors(setup, run.series, ref.series), compare_sensors(setup, ref_loose.series, ref.series)
    integration = compare_sensors(setup, run.series, converged.series)
    basis = compare_sensors(setup, converged.series, ref.series)

    def largest(chis):
        return max(chis.values()) if chis else 0.0

    out = {"reference_dofs": ref.dofs, "reference_rtol": tight,
           "reference_run_s": ref_loose.run_s, "speedup": ref_loose.run_s / run.run_s,
           "chi_rel_percent": largest(total), "reference_error_percent": largest(own),
           "integration_error_percent": largest(integration), "basis_error_percent": largest(basis)}
    for key, chis in (("chi_rel_percent", total), ("integration_error_percent", integration),
                      ("basis_error_percent", basis)):
        out |= {f"{key}_{k}": v for k, v in chis.items()}
    return out




def _check(args) -> None:
    _parse_params(args.param)
    if args.t_end is not None and not args.t_end > 0:
        raise ValueError(f"--t-end must be > 0, got {args.t_end:g}")
    if args.rtol is not None and not 0 < args.rtol < 1:
        raise ValueError(f"--rtol must lie in (0, 1), got {args.rtol:g}")
    if args.dt is not None and not args.dt > 0:
        raise ValueError(f"--dt must be > 0, got {args.dt:g}")
    if args.rho_inf is not None and not 0.0 <= args.rho_inf <= 1.0:
        raise ValueError(f"--rho-inf must lie in [0, 1], got {args.rho_inf:g}")
    _common.at_least("--n-out", args.n_out, 2)
    _common.output_path("--out", args.out)
    _common.output_path("--animate", args.animate)
    _common.output_folder("--vtk", args.vtk)
    if args.tol is not None:
        if not args.tol > 0:
            raise ValueError(f"--tol must be > 0 (a target chi_rel in per cent), got {args.tol:g}")
        if args.dt is not None:
            raise ValueError("--tol chooses error-controlled steps: a fixed step (--dt) has no tolerance to tighten")
        if args.estimate_integration is False:
            raise ValueError("--tol needs the run's time-integration error: not with --no-estimate-integration")
        args.estimate_integration = True
    if args.estimate_integration is None:
        args.estimate_integration = False
    args.estimate = bool(args.estimate or args.estimate_integration)
    if not args.estimate and (args.estimate_method is not None or args.estimate_samples is not None):
        raise ValueError("--estimate-method and --estimate-samples set the error estimate: add --estimate (or "
                         "--estimate-integration)")
    if args.estimate_method is None:  # a mechanism's default: the estimate that carries the error to its sensors
        args.estimate_method = "dynamic"
    _common.estimate_samples(args, True)


def register(sub) -> None:
    t = _common.model_parser(sub, "run",
                             "a mechanism from a model file or a bundled example (slider_crank, rotor, ...)",
                             "Run a mechanism defined in a Python file (mechanism(**params) returning a "
                             "scenarios.MechanismSetup) or a bundled example by name (slider_crank, rotor, "
                             "two_link_arm, fourbar).")
    t.add_argument("--t-end", type=float, default=None, help="end time [s] (default: the model's)")
    t.add_argument("--rtol", type=float, default=None, help="step tolerance (default: the model's; atol = rtol/10 m)")
    t.add_argument("--dt", type=float, default=None,
                   help="fixed steps of this size [s] instead of error control (rtol then scales Newton's test)")
    t.add_argument("--error-on", default=None, metavar="NAMES",
                   help="the sensors (comma-separated) on whose values the step error is measured, or 'nodes' for "
                        "every nodal vector (default: the model's)")
    t.add_argument("--step-control", choices=("plain", "pi"), default=None,
                   help="the adaptive step-size controller (default: the model's)")
    t.add_argument("--rho-inf", type=float, default=None,
                   help="generalized-alpha spectral radius at infinity (default: the model's)")
    t.add_argument("--n-out", type=int, default=201, help="equally spaced output times")
    t.add_argument("--out", help="write the sensors (t and one column each) to this CSV file")
    t.add_argument("--vtk", help="write the bodies over time into this folder (.vtu files and a .pvd series)")
    t.add_argument("--animate", help="write an animated GIF of the motion (XY plane) here")
    t.add_argument("--reference", choices=("full",), default=None,
                   help="also run the full model (formulation=ancf) to a converged reference and report the run's "
                        "error against it, split into time integration and basis, and the speed-up")
    t.add_argument("--estimate", action="store_true",
                   help="a model with reduced (nr-rncf) bodies: estimate the run's error from reduced runs alone "
                        "(multibody.error_estimate, against the bodies' full-order counterparts): over the reduced "
                        "bodies' positions (basis_error_estimate_percent) and each one's on its deformation")
    _common.add_estimate_options(t, method_help=(
        "with --estimate: the linearised error equation over every output (dynamic, the default: a repetition of "
        "the run, and a factorisation of the full model an output; it carries the basis's error through the joints "
        "to every sensor) or the quasi-static correction at sampled outputs (static: cheaper; it holds the frames, "
        "so a sensor on a rigid body reads none of the error)"))
    t.set_defaults(estimate_method=None)  # resolved by the check: dynamic where an estimate is asked for
    _common.add_estimate_integration(t, "with a reduced model (implies --estimate)",
                                     "; also each compared sensor's (integration_error_estimate_percent_<name>)")
    t.add_argument("--tol", type=float, default=None, metavar="P",
                   help="a model with reduced bodies: choose the step settings so that the run's own time-integration "
                        "error on every compared sensor is at most P/2 per cent, and report whether the estimated "
                        "total (with the model's basis's part) meets P (implies --estimate-integration)")
    t.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    t.add_argument("--no-progress", action="store_true", help="no progress messages on stderr")
    t.set_defaults(func=_run, check=_check)
