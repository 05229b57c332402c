"""A persistent XLA compilation cache across processes (opt-in; the CLI turns it on).

Most of a cold NR-RNCF offline stage is compilation: run again in the same process, the stage
takes a small fraction of its first run's time. JAX can keep compiled executables on disk, so
that a later process (a restarted notebook kernel, the next command) loads them instead of
compiling; ``benchmarks/offline.py`` measures the cases.

The cache is JAX configuration, so the library never sets it on its own: ``compilation_cache()``
is a context manager that sets it for the code inside and restores the previous settings on
exit (as ``jax.enable_x64`` does for float64); the ``nrrncf`` command runs each command inside
it unless ``NRRNCF_JAX_CACHE=off``. In a notebook, wrap the offline stage:
``with nrrncf_jax.compilation_cache(): red = nrrncf_jax.nr_rncf(...)``. JAX opens the cache
directory once per process: later blocks reuse the first directory.
"""

import contextlib
import os

import jax

ENV = "NRRNCF_JAX_CACHE"
"""Environment variable: a cache directory, or ``off`` to disable it in the command line."""


def default_cache_dir() -> str:
    """``$NRRNCF_JAX_CACHE`` if set, else ``$XDG_CACHE_HOME/nrrncf_jax/xla`` (``~/.cache/...``)."""
    env = os.environ.get(ENV)
    if env and env.lower() != "off":
        return env
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "nrrncf_jax", "xla")


_SETTINGS = ("jax_compilation_cache_dir", "jax_persistent_cache_min_compile_time_secs",
             "jax_persistent_cache_min_entry_size_bytes")


@contextlib.contextmanager
def compilation_cache(path: str | None = None):
    """Within the block, keep every compiled executable in ``path`` (default
    ``default_cache_dir()``), however short its compilation (JAX's default threshold of 1 s would
    skip the many small offline kernels); yields the directory and restores JAX's previous
    cache settings on exit. Entries are keyed by the program and the JAX/XLA versions and
    flags, so a stale entry is never used."""
    path = default_cache_dir() if path is None else str(path)
    os.makedirs(path, exist_ok=True)
    previous = {name: getattr(jax.config, name) for name in _SETTINGS}
    try:
        for name, value in zip(_SETTINGS, (path, 0.0, 0)):
            jax.config.update(name, value)
        yield path
    finally:
        for name, value in previous.items():
            jax.config.update(name, value)


def cli_cache_enabled() -> bool:
    """Whether the command line should use the cache (``NRRNCF_JAX_CACHE`` is not ``off``)."""
    return os.environ.get(ENV, "").lower() != "off"
