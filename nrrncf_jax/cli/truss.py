"""``nrrncf truss``: the beamlike truss of the paper's Sec. 4.5 (``scenarios.truss``).

    nrrncf truss modes [--count 10] [--plot F] [--vtk DIR] [--json] [--no-progress]
    nrrncf truss dynamics --formulation {rncf,nr-rncf} [--vms 4] [--mds 6]
                          [--estimate-method {static,dynamic}] [--estimate-integration] [--reference rncf]
                          [--plot F] [--vtk DIR] [--json]

``--json`` prints one JSON object as the last line: for ``modes`` ``frequencies_hz`` (ascending)
and ``mode_types``; for ``dynamics`` ``dofs, vms, mds, steps, compile_s, run_s, offline_s`` and
with ``--reference rncf`` also ``reference_dofs, reference_run_s, chi_rel_percent, speedup``: the
reference is the full model converged (run at a tenth and a hundredth of the tolerances:
``reference_error_percent`` bounds its own error), ``chi_rel_percent`` the run's total error
against it, split into
``integration_error_percent`` (the run against its repetition at the reference's tolerance) and
``basis_error_percent``; the speed-up is against the full run at a tenth of the tolerances.
The error estimate from the reduced run alone is ``chi_rel_estimate_percent``; with
``--estimate-integration`` it is the total of ``basis_error_estimate_percent`` and
``integration_error_estimate_percent`` (the run against its repetition at rtol/10), as ``nrrncf
spinup`` reports it. Mode indices are 0-based.
"""

import json

from .. import _validate
from . import _common


def _spec(args):
    from ..scenarios.truss import TrussSpec

    return TrussSpec(bays=args.bays, longeron_elements=args.longeron_elements, batten_elements=args.batten_elements)


def _modes(args) -> int:
    import numpy as np

    from ..models import RotatingFrameModel
    from ..motion import Stationary
    from ..reduction import vibration_modes
    from ..scenarios.truss import build_truss, equivalent_beam, mode_types

    spec = _spec(args)
    _common.say(args, f"building the truss ({spec.bays} bays) ...")
    truss = build_truss(spec)
    model = RotatingFrameModel(truss.body, Stationary(), clamped=truss.clamped)
    _common.say(args, f"{truss.body.n_dof} DOFs; the first {args.count} modes ...")
    modes = vibration_modes(truss.body, model.free_mask(), args.count)
    f = np.asarray(modes.omega) / (2 * np.pi)
    phi = np.asarray(modes.phi)
    types = mode_types(truss, phi)
    eq = equivalent_beam(spec)
    if args.plot:
        from ..post.plotting import plot_truss_modes

        plot_truss_modes(args.plot, truss, phi, f, types)
    if args.vtk:
        from ..post.vtk import write_frame_vtk

        write_frame_vtk(args.vtk, truss.frame, {f"mode_{i:02d}": phi[:, i] for i in range(phi.shape[1])})
    d = {"bays": spec.bays, "dofs": truss.body.n_dof, "beams": truss.frame.n_beams, "bars": truss.frame.n_bars,
         "frequencies_hz": f.tolist(), "mode_types": types,
         "equivalent_beam_hz": {"bending_euler_bernoulli": eq.f_bending_eb, "bending_with_shear": eq.f_bending,
                                "torsion_quarter_wave": eq.f_torsion}}
    if args.json:
        print(json.dumps(d))
        return 0
    print(f"truss: {spec.bays} bays, {truss.frame.n_beams} beams, {truss.frame.n_bars} bars, {truss.body.n_dof} DOFs")
    print("  mode   f [Hz]      type")
    for i, (fi, t) in enumerate(zip(f, types)):
        print(f"  {i:4d}  {fi:10.5f}  {t}")
    print(f"  equivalent beam: first bending {eq.f_bending_eb:.5f} Hz (Euler-Bernoulli), {eq.f_bending:.5f} Hz "
          f"(with shear); first torsion {eq.f_torsion:.5f} Hz (quarter-wave shaft)")
    return 0


def _dynamics(args) -> int:
    import dataclasses

    from ..scenarios.truss import DEFAULT_BASIS, run_truss

    spec = _spec(args)
    _common.say(args, f"truss ({spec.bays} bays), {args.formulation}, 0-{args.t_end:g} s ...")
    kw = dict(t_end=args.t_end, dt_out=args.dt_out, progress=not (args.json or args.no_progress))
    if args.formulation == "rncf":
        run = run_truss("rncf", spec, **kw)
    else:  # --reference rncf: against the full model converged, the error split into its parts
        basis = dataclasses.replace(DEFAULT_BASIS, n_modes=args.modes, vms=args.vms, mds=args.mds)
        run = run_truss("nr-rncf", spec, basis=basis, estimator=_common.estimator(args), tol=args.tol,
                        reference=args.reference == "rncf", **kw)
    if args.plot:
        from ..post.plotting import plot_truss_tip

        plot_truss_tip(args.plot, [run] + ([run.reference] if run.reference is not None else []))
    if args.vtk:
        from ..post.vtk import write_frame_vtk
        from ..scenarios.truss import build_truss

        truss = build_truss(spec)
        write_frame_vtk(args.vtk, truss.frame, run.displacement_fields(truss.body)[0])
    s = run.summary()
    out = run.command_record(tip_y_max_m=s["tip_y_max_m"], tip_z_max_m=s["tip_z_max_m"])
    return _common.emit(args, out)


def _check(args) -> None:
    _common.at_least("--bays", args.bays, 1)
    _common.at_least("--longeron-elements", args.longeron_elements, 1)
    _common.at_least("--batten-elements", args.batten_elements, 1)
    _common.output_folder("--vtk", args.vtk)
    _common.output_path("--plot", args.plot)
    if args.what == "modes":
        _common.at_least("--count", args.count, 1)
    else:
        _common.output_times(args.t_end, args.dt_out)
        if args.tol is not None:
            _validate.positive("--tol (target chi_rel in per cent)", args.tol)
        if args.formulation == "rncf" and (args.reference is not None or args.tol is not None
                                           or args.estimate_method != "static"):
            raise ValueError("--reference, --tol and --estimate-method go with --formulation nr-rncf")
        _common.estimate_samples(args, args.formulation == "nr-rncf")
        _common.estimate_integration(args, args.formulation == "nr-rncf", default=False)
        _common.at_least("--vms", args.vms, 1)
        _common.at_least("--mds", args.mds, 0)
        _common.at_least("--modes", args.modes, args.vms)


def register(sub) -> None:
    t = sub.add_parser("truss", help="the beamlike truss (paper Sec. 4.5): modes and forced response",
                       description="The cantilevered beamlike truss of the paper's Sec. 4.5 (36 bays, C1-beam "
                                   "longerons and battens rigidly joined, pinned bar diagonals). "
                                   f"{_common.MODE_INDICES}.",
                       formatter_class=_common.HelpFormatter)
    t.add_argument("what", choices=("modes", "dynamics"), help="modal analysis or forced response")
    t.add_argument("--bays", type=int, default=36, help="bays of 1 m")
    t.add_argument("--longeron-elements", type=int, default=6, help="beam elements per longeron bay")
    t.add_argument("--batten-elements", type=int, default=4, help="beam elements per batten")
    t.add_argument("--count", type=int, default=10, help="modes: how many")
    t.add_argument("--formulation", choices=("rncf", "nr-rncf"), default="nr-rncf", help="dynamics: the model")
    t.add_argument("--vms", type=int, default=4, help="dynamics, nr-rncf: vibration modes chosen by MMI")
    t.add_argument("--mds", type=int, default=6, help="dynamics, nr-rncf: modal derivatives chosen by MMI")
    t.add_argument("--modes", type=int, default=12, help="dynamics, nr-rncf: candidate modes for the MMI")
    _common.add_estimate_options(t, method_help=(
        "dynamics, nr-rncf: the error estimate: static (the quasi-static correction at 16 sampled "
        "outputs, a sparse factorisation each) or dynamic (the linearised error equation over every "
        "output, a factorisation each: minutes, but it flags a basis whose error grows as drift; "
        "estimate_valid_until_s says where its linearisation stopped holding)"))
    _common.add_estimate_integration(t, "dynamics, nr-rncf", " (default: off)")
    _common.add_tol_and_reference_options(t, "dynamics, nr-rncf")
    t.add_argument("--t-end", type=float, default=10.0, help="dynamics: end time [s]")
    t.add_argument("--dt-out", type=float, default=0.02, help="dynamics: output interval [s]")
    t.add_argument("--plot", help="write a plot (PNG) here: mode shapes, or the free end's y and z responses")
    t.add_argument("--vtk", help="write VTK files (.vtu, one per mode or output time) into this folder")
    t.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    t.add_argument("--no-progress", action="store_true", help="no progress messages on stderr")
    t.set_defaults(func=lambda a: _modes(a) if a.what == "modes" else _dynamics(a), check=_check)
