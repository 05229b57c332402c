"""A persistent XLA compilation cache across processes (opt-in; the CLI turns it on).

Most of a cold NR-RNCF offline stage is compilation: on the 24-element paper beam at
ωs = 40 rad/s its five compiled kernels take about 3 of its ~4 s on the 2-core CI CPU, while
the same stage run again in the same process takes about 0.4 s. JAX can keep compiled
executables on disk, so that a later process (a restarted notebook kernel, the next command)
loads them instead of compiling (about 1.3 s); ``benchmarks/offline.py`` measures the cases.

This changes JAX's global configuration, so the library never calls it on import: call
``enable_compilation_cache()`` yourself (before the first computation). The ``nrrncf`` command
calls it unless ``NRRNCF_JAX_CACHE=off``.
"""

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


def enable_compilation_cache(path: str | None = None) -> str:
    """Keep every compiled executable in ``path`` (default ``default_cache_dir()``), however
    short its compilation (JAX's default threshold of 1 s would skip the many small offline
    kernels); returns the directory. Entries are keyed by the program and the JAX/XLA
    versions and flags, so a stale entry is never used."""
    path = default_cache_dir() if path is None else str(path)
    os.makedirs(path, exist_ok=True)
    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    return path


def cli_cache_enabled() -> bool:
    """Whether the command line should use the cache (``NRRNCF_JAX_CACHE`` is not ``off``)."""
    return os.environ.get(ENV, "").lower() != "off"
