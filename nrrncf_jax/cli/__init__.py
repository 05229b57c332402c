"""The ``nrrncf`` command: the paper's examples from a shell.

    nrrncf spinup --formulation rncf --beam paper --omega 40 --plot tip.png
    nrrncf spinup --formulation nr-rncf --omega 10 --reference rncf --plot tip.png
    nrrncf modes --beam paper --elements 8 --json
    nrrncf modes --beam curved-upwind --elements 8 --count 6 --mmi --omega 4 --plot mmi.png
    nrrncf identify --demo --json
    nrrncf truss modes --count 10 --json
    nrrncf truss dynamics --formulation nr-rncf --reference rncf --plot tip.png
    nrrncf membrane --case bending-torsion --formulation nr-rncf --reference rncf --plot rim.png
    nrrncf pendulum --elements 10 --out tips.csv --plot pendulum.png --animate pendulum.gif
    nrrncf run slider_crank --param formulation=nr-rncf --t-end 0.1 --out F.csv --json
    nrrncf static princeton_beam --param load=8.896 --param angle_deg=45 --json

Each subcommand lives in its own module of this package, with a ``register(subparsers)`` that
sets ``func`` (the run) and ``check`` (the checks of its arguments). ``main`` parses, runs the
checks, and only then starts JAX and the run: ``--help`` and a bad argument are answered at once,
a bad argument with one line (``nrrncf: error: ...``) and exit status 2, before anything is
printed about the run. Nothing in this package imports JAX when it is imported; the subcommands
import the library inside their run functions.

The command runs in float64 (a ``jax.enable_x64`` context around it), and keeps compiled
kernels in a persistent cache (``nrrncf_jax.compilation_cache``; ``NRRNCF_JAX_CACHE=DIR`` moves
it, ``NRRNCF_JAX_CACHE=off`` turns it off), so that a second command skips most compilation.
Mode indices in the tables and the JSON are 0-based, as in the Python API.

``nrrncf SUBCOMMAND --help`` lists every option with its default. Every argument is checked
before anything runs: a bad one (``--omega -5``, ``--rtol 5``, ``--vms 0``, ``--omega 40:2:4``, an
``--out`` or ``--plot`` file in a directory that does not exist, a mistyped option, for which the
closest option is suggested) gets its one line on stderr and exit status 2 at once. The long
commands report their progress on stderr, off with ``--no-progress``. A range ``start:stop:count``
is ``count`` values from ``start`` to ``stop`` inclusive, with ``start < stop``. ``--vtk DIR``
writes ParaView files (``post.vtk``).

``nrrncf spinup``: ANCF, RNCF or NR-RNCF (``--reference rncf``: with the full model's run, χ_rel
and the speed-up) on a beam preset (``scenarios.beams``); the default mesh for a speed follows the
paper's Table 2. ``--out`` writes ``t, theta, ux, uy, uz``, the tip displacement in the rotating
frame (ux axial, uy in-plane transverse, uz out of plane); ``--json`` prints one JSON object as
the last line (``formulation, beam, omega_s, dofs, steps, rejected, newton_iters, compile_s,
run_s, tip_uy_min, tip_uy_max, ...``; for nr-rncf also ``vms, mds, offline_s`` and, with a
reference, ``chi_rel_percent, speedup``). Compile and run times are measured apart (ahead-of-time
compilation, then a blocked run). ``--spin-state off`` leaves the spinning-state vectors out of
the basis (``reduction.spin_state``).

``nrrncf identify --demo --json`` prints ``E_true, E_identified, E_rel_err, zeta_true,
zeta_identified, zeta_rel_err, iterations, wall_s, ...``; ``nrrncf sweep --json`` prints ``cases,
devices, compile_s, run_s, single_run_s, ...`` and each case's peak transverse and axial tip
deflection and residual vibration amplitude after Ts (``--devices N`` splits the cases over N
devices, forcing N host devices on a CPU). ``truss``, ``membrane`` and ``pendulum`` describe their
outputs in their modules' docstrings.
"""

import argparse
import difflib
import importlib
import sys

from ._common import HelpFormatter

SUBCOMMANDS = ("spinup", "modes", "identify", "sweep", "sweep-merge", "truss", "membrane", "pendulum", "run",
               "static")
"""The subcommands, each a module of this package (its name with ``_`` for ``-``) with
``register(subparsers)``; their order is the help's."""


class UsageError(Exception):
    """A command-line error argparse found (unknown option, bad value, missing argument)."""


class Parser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose errors are one line (``main`` prints them), not usage + message."""

    def error(self, message):
        raise UsageError(f"{message} (see '{self.prog} --help')")


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog="nrrncf", description="NR-RNCF flexible multibody simulation (JAX)", formatter_class=HelpFormatter)
    sub = p.add_subparsers(dest="command", required=True, metavar="{" + ",".join(SUBCOMMANDS) + "}")
    for name in SUBCOMMANDS:
        importlib.import_module(f"{__name__}.{name.replace('-', '_')}").register(sub)
    return p


def _subparsers(parser: argparse.ArgumentParser) -> dict:
    return next(a.choices for a in parser._actions if isinstance(a, argparse._SubParsersAction))


def _unknown_options_first(parser: argparse.ArgumentParser, argv: list) -> None:
    """Report options no parser knows before missing required ones: a mistyped required option
    (``--omgea 10``) is a typo to point at, not a missing ``--omega``. Parses once with every
    option optional; raises ``UsageError`` naming the unknown arguments (and the closest option)."""
    if "-h" in argv or "--help" in argv:
        return  # the help, with the options as they are
    subs = _subparsers(parser)
    required = [a for s in subs.values() for a in s._actions if a.required and a.option_strings]
    for a in required:
        a.required = False
    try:
        ns, unknown = parser.parse_known_args(argv)
    finally:
        for a in required:
            a.required = True
    if not unknown:
        return
    sub = subs[ns.command]
    known = [o for a in sub._actions for o in a.option_strings]
    hint = difflib.get_close_matches(unknown[0], known, n=1) if unknown[0].startswith("-") else []
    sub.error(f"unrecognized arguments: {' '.join(unknown)}" + (f"; did you mean {hint[0]}?" if hint else ""))


def parse(argv: list) -> argparse.Namespace:
    """The parsed and checked arguments; raises ``UsageError`` or ``ValueError`` (one line each)
    before anything is run, or ``SystemExit(0)`` after ``--help``."""
    parser = build_parser()
    _unknown_options_first(parser, argv)
    args = parser.parse_args(argv)
    args.check(args)
    return args


def _run(args) -> int:
    import contextlib

    import jax

    from ..integrate.cache import cli_cache_enabled, compilation_cache

    cache = compilation_cache() if cli_cache_enabled() else contextlib.nullcontext()
    # float64 and the compilation cache for this command only; the global settings are left alone
    with jax.enable_x64(True), cache:
        return args.func(args)


def main(argv=None) -> int:
    """Run the command ``argv`` (default ``sys.argv[1:]``); returns the exit status: 0, 2 after
    one line ``nrrncf: error: ...`` on stderr for a bad argument, or 1 after one line
    ``nrrncf: the simulation stopped ...`` for a run that ended early (``integrate.SimulationError``:
    Newton failing at the smallest step, a non-finite state, the step limit)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        args = parse(argv)
        args.argv = argv  # for a subcommand that re-runs itself in a subprocess (sweep --devices)
        return _run(args)
    except SystemExit as e:  # --help
        return e.code
    except (UsageError, ValueError) as e:
        print(f"nrrncf: error: {e}", file=sys.stderr)
        return 2
    except RuntimeError as e:  # the library is imported lazily: its SimulationError is checked here
        from ..integrate.results import SimulationError

        if not isinstance(e, SimulationError):
            raise
        print(f"nrrncf: the simulation stopped early: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
