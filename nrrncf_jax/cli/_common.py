"""What the subcommands share: the beam names, the help format and the checks of their
arguments that run before any work (and before JAX starts), so that a bad argument gets one
line and exit status 2 at once.

Nothing here imports JAX or the library's numerical modules (``_validate``, whose checks the
subcommands call directly, needs NumPy alone): ``--help`` and argument errors are instant. A check raises
``ValueError``; ``main`` prints it as ``nrrncf: error: ...``.
"""

import argparse
import os
import sys

from .. import _validate

BEAM_NAMES = ("classic", "curved-downwind", "curved-out-of-plane", "curved-upwind", "paper")
"""``sorted(nrrncf_jax.scenarios.BEAMS)``, spelt out so that building the parser imports no JAX
(a test checks that the two agree)."""

STEP_CONTROL_NAMES = ("plain", "pi")
"""``tuple(nrrncf_jax.integrate.STEP_CONTROLS)``, spelt out so that building the parser imports no
JAX."""

ESTIMATE_METHODS = ("static", "dynamic")
"""``nrrncf_jax.reduction.error_estimate.METHODS``, spelt out so that building the parser imports no
JAX (a test checks that the two agree)."""

MODE_INDICES = "Mode indices are 0-based (mode 0 is the lowest), as in the Python API"
"""The one convention for mode numbers in the command line's tables and JSON."""


class HelpFormatter(argparse.HelpFormatter):
    """Adds ``(default: X)`` to an option's help unless the help mentions its default already or
    the default says nothing (None, or False for a flag)."""

    def _get_help_string(self, action):
        text = action.help or ""
        if "default" in text or action.default in (None, False, argparse.SUPPRESS) or not action.option_strings:
            return text
        return text + " (default: %(default)s)"


def say(args, text: str) -> None:
    """A progress message on stderr, unless the command prints JSON or was told ``--no-progress``."""
    if not args.json and not args.no_progress:
        print(text, file=sys.stderr, flush=True)


def emit(args, record: dict) -> int:
    """A run's record: one JSON object as the last line under ``--json``, else ``key: value``
    lines. Returns the exit status 0."""
    import json

    if args.json:
        print(json.dumps(record))
        return 0
    for k, v in record.items():
        if isinstance(v, (list, tuple)) and v and all(isinstance(x, str) for x in v):
            print(f"  {k}:" + "".join(f"\n    {x}" for x in v))
        else:
            print(f"  {k}: {v}")
    return 0


def output_path(flag: str, path: str | None) -> None:
    """A file to be written after the run: its directory must exist and be writable, and it must
    not be a directory itself (checked now rather than after a long simulation)."""
    if path is None:
        return
    if not str(path).strip():
        raise ValueError(f"{flag} needs a file name")
    if os.path.isdir(path):
        raise ValueError(f"{flag} {path} is a directory; give a file name")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise ValueError(f"{flag} {path}: the directory {folder} does not exist")
    if not os.access(folder, os.W_OK):
        raise ValueError(f"{flag} {path}: the directory {folder} is not writable")






def output_folder(flag: str, path: str | None) -> None:
    """A folder to be written after the run (made if missing): it needs a name."""
    if path is not None and not str(path).strip():
        raise ValueError(f"{flag} needs a folder name")


def output_times(t_end: float, dt_out: float) -> None:
    """``--t-end`` and ``--dt-out``: positive, and at least one output interval in the run."""
    _validate.positive("--t-end (end time)", t_end)
    _validate.positive("--dt-out (output interval)", dt_out)
    if dt_out > t_end:
        raise ValueError(f"--dt-out (output interval) must not exceed --t-end, got {dt_out:g} > {t_end:g}")




def add_step_control(parser, default: str | None = "plain", default_help: str = "") -> None:
    """``--step-control``: the adaptive controller by name, as the scenario runners take it
    (``default`` None: the command resolves it, as ``default_help`` says)."""
    parser.add_argument("--step-control", choices=STEP_CONTROL_NAMES, default=default,
                        help="the adaptive step-size controller: plain, or Gustafsson's PI controller (fewer "
                             "rejected steps, more accurate at the same tolerance)" + default_help)


def add_estimate_options(parser, method_help: str) -> None:
    """``--estimate-method`` (``ESTIMATE_METHODS``, help ``method_help``: what each costs on the
    command's model) and ``--estimate-samples N``, the static estimate's sampled outputs (the
    ``samples`` of the runners' ``reduction.ErrorEstimator``; default 16; checked by
    ``estimate_samples``)."""
    parser.add_argument("--estimate-method", choices=ESTIMATE_METHODS, default="static", help=method_help)
    parser.add_argument("--estimate-samples", type=int, default=None, metavar="N",
                        help="nr-rncf: output times at which the static error estimate factors the full tangent, "
                             ">= 2 (default 16; fewer cost less and integrate the chi_rel norm more coarsely)")


def add_estimate_integration(parser, scope: str, default_help: str) -> None:
    """``--estimate-integration`` / ``--no-estimate-integration``: also estimate the run's own
    time-integration error (the ``integration`` of the runners' ``reduction.ErrorEstimator``);
    ``scope``: when it applies (the help's first words). Not given, it is None until the command's
    check resolves it (``estimate_integration``), as ``default_help`` says."""
    parser.add_argument("--estimate-integration", action=argparse.BooleanOptionalAction, default=None,
                        help=f"{scope}: also estimate the run's own time-integration error, by repeating the run at "
                             "rtol/10 (a few times the reduced run's cost), so that chi_rel_estimate_percent is the "
                             "total error's estimate and integration_error_estimate_percent its time-integration "
                             "part" + default_help)


def estimate_integration(args, reduced: bool, default: bool) -> None:
    """``--estimate-integration`` checked (a reduced run's) and, where not given, set to
    ``default``."""
    if args.estimate_integration is None:
        args.estimate_integration = default
    if args.estimate_integration and not reduced:
        raise ValueError("--estimate-integration estimates a reduced run's error; use it with --formulation nr-rncf")


def estimator(args):
    """The scenario runners' ``reduction.ErrorEstimator`` from ``--estimate-method``,
    ``--estimate-samples`` (not given: the estimator's default, 16) and
    ``--estimate-integration`` (off where the command has no such flag), after the checks
    (``estimate_samples``, ``estimate_integration``). Imports the library: call it when the run
    starts."""
    from ..reduction import ErrorEstimator

    samples = {} if args.estimate_samples is None else {"samples": args.estimate_samples}
    integration = bool(getattr(args, "estimate_integration", False))  # a command without the flag: off
    return ErrorEstimator(method=args.estimate_method, integration=integration, **samples)


def add_tol_and_reference_options(parser, scope: str) -> None:
    """``--tol P`` (the basis chosen to a target χ_rel) and ``--reference rncf`` (the full model
    converged, ``RunRecord.compare_converged``) of the large bodies' commands; ``scope``: when they
    apply (the help's first words)."""
    parser.add_argument("--tol", type=float, default=None, metavar="P",
                        help=f"{scope}: choose the basis to a target chi_rel of P per cent (the smallest prefix of the "
                             "MMI ranking whose run's error estimate is <= P/2; --vms and --mds are then not used)")
    parser.add_argument("--reference", choices=("rncf",), default=None,
                        help=f"{scope}: also run the full RNCF model converged and report chi_rel and the speed-up: "
                             "the full model at a tenth and a hundredth of the run's tolerances (their distance is "
                             "the reference's own error), the reduced model again at the tighter, so chi_rel splits "
                             "into its time-integration and basis parts")


def estimate_samples(args, reduced: bool) -> None:
    """Check ``--estimate-samples`` where given (``estimator`` passes it on): at least 2, a
    reduced run's, and the static estimate's (the dynamic one runs over every output)."""
    if args.estimate_samples is None:
        return
    at_least("--estimate-samples", args.estimate_samples, 2)
    if not reduced:
        raise ValueError("--estimate-samples goes with --formulation nr-rncf")
    if args.estimate_method != "static":
        raise ValueError("--estimate-samples sets the static estimate's samples; the dynamic estimate runs over "
                         "every output")


def model_parser(sub, name: str, help: str, description: str):
    """A subcommand on a model file or a bundled example (``run``, ``static``): its parser with the
    ``model`` argument and ``--param KEY=VALUE`` (``mechanism(**params)``'s keywords)."""
    t = sub.add_parser(name, help=help, description=description, formatter_class=HelpFormatter)
    t.add_argument("model", help="a model file (.py) or a bundled example's name")
    t.add_argument("--param", action="append", metavar="KEY=VALUE", help="a keyword parameter of mechanism()")
    return t


def at_least(flag: str, value: int | None, minimum: int) -> None:
    """An integer option (None: not given) that must be at least ``minimum``."""
    if value is not None and value < minimum:
        raise ValueError(f"{flag} must be >= {minimum}, got {value}")


def count_or_auto(minimum: int):
    """An argparse type: ``'auto'`` or an integer >= ``minimum`` (argparse names the option)."""

    def parse(s: str):
        if s == "auto":
            return s
        try:
            k = int(s)
        except ValueError:
            k = None
        if k is None or k < minimum:
            raise argparse.ArgumentTypeError(f"must be 'auto' or an integer >= {minimum}, got {s!r}")
        return k

    return parse
