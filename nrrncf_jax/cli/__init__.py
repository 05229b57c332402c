"""The ``nrrncf`` command: the paper's examples from a shell.

    nrrncf spinup --formulation rncf --beam paper --omega 40 --plot tip.png
    nrrncf spinup --formulation nr-rncf --omega 10 --reference rncf --plot tip.png
    nrrncf modes --beam paper --elements 8 --json
    nrrncf modes --beam curved-upwind --elements 8 --count 6 --mmi --omega 4 --plot mmi.png
    nrrncf identify --demo --json

Each subcommand lives in its own module of this package, with a ``register(subparsers)``.
The command runs in float64 (a ``jax.enable_x64`` context around it), and keeps compiled
kernels in a persistent cache (``nrrncf_jax.compilation_cache``; ``NRRNCF_JAX_CACHE=DIR`` moves
it, ``NRRNCF_JAX_CACHE=off`` turns it off), so that a second command skips most compilation.
"""

import argparse
import importlib
import sys

SUBCOMMANDS = ("spinup", "modes", "identify", "sweep")
"""Modules of this package, each with ``register(subparsers)``; their order is the help's."""


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="nrrncf", description="NR-RNCF flexible multibody simulation (JAX)")
    sub = p.add_subparsers(dest="command", required=True)
    for name in SUBCOMMANDS:
        importlib.import_module(f"{__name__}.{name}").register(sub)
    return p


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(argv)
    args.argv = argv  # for a subcommand that re-runs itself in a subprocess (sweep --devices)
    import contextlib

    import jax

    from ..compilation_cache import cli_cache_enabled, compilation_cache

    cache = compilation_cache() if cli_cache_enabled() else contextlib.nullcontext()
    try:
        # float64 and the compilation cache for this command only; the global settings are left alone
        with jax.enable_x64(True), cache:
            return args.func(args)
    except ValueError as e:
        print(f"nrrncf: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
