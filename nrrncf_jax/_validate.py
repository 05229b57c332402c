"""Checks on user input that run before tracing: clear ``ValueError``s, never garbage.

A check only fires on concrete values; a traced value (inside ``jit``/``grad``) passes through,
because its value is unknown until run time.
"""

import jax
import numpy as np


def is_concrete(x) -> bool:
    return not isinstance(x, jax.core.Tracer)


def positive(name: str, value) -> None:
    """Raise ``ValueError`` unless ``value`` (if concrete) is finite and > 0."""
    if not is_concrete(value):
        return
    v = np.asarray(value)
    if v.size != 1:
        raise ValueError(f"{name} must be a scalar, got shape {v.shape}")
    v = float(v)
    if not np.isfinite(v) or v <= 0.0:
        raise ValueError(f"{name} must be a finite positive number, got {name}={v!r}")


def non_negative(name: str, value) -> None:
    if not is_concrete(value):
        return
    v = float(np.asarray(value))
    if not np.isfinite(v) or v < 0.0:
        raise ValueError(f"{name} must be finite and >= 0, got {name}={v!r}")


def positive_int(name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if value < 1:
        raise ValueError(f"{name} must be >= 1, got {name}={value}")
    return int(value)
