"""``nrrncf identify --demo``: recover E and a damping ratio from a noisy spin-up record."""

from .. import _validate
from . import _common


def _check(args) -> None:
    """Every argument, before anything runs (no JAX)."""
    if not args.demo:
        raise ValueError("only the demonstration is available from the command line (--demo); use "
                         "nrrncf_jax.identify (the function) from Python for your own measurements")
    _common.at_least("--elements", args.elements, 1)
    _common.output_times(args.t_end, args.dt_out)
    _validate.non_negative("--noise (fraction of the record's std)", args.noise)
    _validate.positive("--start (starting guess / truth)", args.start)
    _common.at_least("--seed", args.seed, 0)
    _common.at_least("--adam-steps", args.adam_steps, 0)
    _common.at_least("--lbfgs-steps", args.lbfgs_steps, 0)
    _common.output_path("--plot", args.plot)


def _identify(args) -> int:
    from ..scenarios.identification import identification_demo
    from ..studies.identification import AdamLbfgs

    if not args.json:
        print(f"nrrncf identify --demo: classic beam, full RNCF measurement at omega_s = 10 rad/s with zeta = 2 %, "
              f"{100 * args.noise:g} % noise; reduced model from a start {100 * (args.start - 1):+g} % off", flush=True)
    demo = identification_demo(elements=args.elements, t_end=args.t_end, dt_out=args.dt_out, noise=args.noise,
                               start=args.start, seed=args.seed,
                               optimizer=AdamLbfgs(adam_steps=args.adam_steps, lbfgs_steps=args.lbfgs_steps),
                               progress=not args.no_progress)
    if args.plot:
        demo.plot(args.plot)
    if args.json:
        print(demo.json())
        return 0
    s = demo.summary()
    rows = [("reduced DOFs / samples", f"{s['reduced_dofs']} / {s['samples']}"),
            ("E true / start / identified [Pa]", f"{s['E_true']:.5g} / {s['E_initial']:.5g} / {s['E_identified']:.5g}"),
            ("E relative error", f"{100 * s['E_rel_err']:+.3f} %"),
            ("zeta true / start / identified", f"{s['zeta_true']:.4f} / {s['zeta_initial']:.4f} / "
                                               f"{s['zeta_identified']:.4f}"),
            ("zeta relative error", f"{100 * s['zeta_rel_err']:+.2f} %"),
            ("iterations (Adam + L-BFGS)", f"{s['iterations']} ({s['adam_iterations']} + {s['lbfgs_iterations']}), "
                                           f"{s['loss_evaluations']} loss+gradient evaluations"),
            ("final relative misfit", f"{s['final_loss']:.3e}"),
            ("wall time [s] (of which compile)", f"{s['wall_s']:.1f} ({s['compile_s']:.1f})"),
            ("measurement (full RNCF) / offline [s]", f"{s['measurement_s']:.1f} / {s['offline_s']:.1f}")]
    w = max(len(r[0]) for r in rows)
    print("\n".join(f"  {a:<{w}}  {b}" for a, b in rows))
    if args.plot:
        print(f"  plot -> {args.plot}")
    return 0


def register(sub) -> None:
    s = sub.add_parser("identify", help="parameter identification by gradient through the reduced model",
                       description="Identify Young's modulus and a damping ratio from a noisy spin-up record by "
                                   "gradients through the NR-RNCF reduced model (Adam, then L-BFGS). Results on "
                                   "stdout; each stage and iteration on stderr unless --no-progress.",
                       formatter_class=_common.HelpFormatter)
    s.add_argument("--demo", action="store_true",
                   help="the classic-beam demonstration: E and zeta from a noisy full-RNCF record (omega_s = 10)")
    s.add_argument("--elements", type=int, default=6, help="beam elements")
    s.add_argument("--t-end", type=float, default=30.0, help="record length [s]")
    s.add_argument("--dt-out", type=float, default=0.05, help="sampling interval [s]")
    s.add_argument("--noise", type=float, default=0.01, help="noise, fraction of the record's std")
    s.add_argument("--start", type=float, default=1.3, help="starting guess / truth for E and zeta")
    s.add_argument("--seed", type=int, default=0, help="seed of the noise's random generator (an integer >= 0)")
    s.add_argument("--adam-steps", type=int, default=15, help="Adam iterations before L-BFGS")
    s.add_argument("--lbfgs-steps", type=int, default=30, help="at most this many L-BFGS iterations")
    s.add_argument("--plot", help="write the fit and convergence plot (PNG) here")
    s.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    s.add_argument("--no-progress", action="store_true", help="no progress lines (stages, iterations) on stderr")
    s.set_defaults(func=_identify, check=_check)
