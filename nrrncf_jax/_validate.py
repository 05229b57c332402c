"""Checks on user input that run before tracing: clear ``ValueError``s, never garbage.

A check only fires on concrete values; a traced value (inside ``jit``/``grad``) passes through,
because its value is unknown until run time.

The module does not import JAX (only NumPy): the command line checks its arguments with it before
JAX starts, so that a bad argument is reported at once. Messages name the value once, e.g.
``omega (steady spin rate) must be > 0, got -5``.
"""

import sys

import numpy as np


def is_concrete(x) -> bool:
    """False for a value traced by JAX (inside ``jit``/``grad``/``vmap``). Without JAX imported
    nothing can be traced, so the check never imports it."""
    jax = sys.modules.get("jax")
    return jax is None or not isinstance(x, jax.core.Tracer)


def _show(v: float) -> str:
    """A number as a user typed it: ``-5`` rather than ``-5.0``, ``1e-05``, ``nan``."""
    return f"{v:g}"


def _scalar(name: str, value) -> float:
    v = np.asarray(value)
    if v.size != 1:
        raise ValueError(f"{name} must be a scalar, got shape {v.shape}")
    try:
        return float(v.reshape(()))
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None


def positive(name: str, value) -> None:
    """Raise ``ValueError`` unless ``value`` (if concrete) is finite and > 0."""
    if not is_concrete(value):
        return
    v = _scalar(name, value)
    if not np.isfinite(v):
        raise ValueError(f"{name} must be finite and > 0, got {_show(v)}")
    if v <= 0.0:
        raise ValueError(f"{name} must be > 0, got {_show(v)}")


def non_negative(name: str, value) -> None:
    """Raise ``ValueError`` unless ``value`` (if concrete) is finite and >= 0."""
    if not is_concrete(value):
        return
    v = _scalar(name, value)
    if not np.isfinite(v):
        raise ValueError(f"{name} must be finite and >= 0, got {_show(v)}")
    if v < 0.0:
        raise ValueError(f"{name} must be >= 0, got {_show(v)}")


def boolean(name: str, value) -> bool:
    """``value``; raise ``ValueError`` unless it is ``True`` or ``False`` (not a truthy number or
    string, whose meaning would be a guess)."""
    if not isinstance(value, bool):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return value


def positive_int(name: str, value) -> int:
    """``value`` as an ``int``; raise ``ValueError`` unless it is an integer >= 1."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if value < 1:
        raise ValueError(f"{name} must be >= 1, got {value}")
    return int(value)


def tolerances(rtol, atol=None, rtol_name: str = "rtol", atol_name: str = "atol") -> None:
    """Step-control tolerances: ``0 < rtol < 1`` (a relative error of 100 % or more controls
    nothing) and ``atol > 0``; traced values pass."""
    positive(rtol_name, rtol)
    if is_concrete(rtol) and _scalar(rtol_name, rtol) >= 1.0:
        raise ValueError(f"{rtol_name} must be < 1 (a relative error; e.g. 1e-4), got {_show(float(rtol))}")
    if atol is not None:
        positive(atol_name, atol)


def parse_range(spec: str, name: str = "value") -> np.ndarray:
    """``'a:b:n'`` → n values evenly spaced from a to b inclusive (a < b, n an integer >= 1);
    ``'a,b,c'`` → those values; ``'a'`` → one value. Raises ``ValueError`` naming ``name`` on
    anything else."""
    form = f"{name} must be 'start:stop:count' (e.g. 2:40:64), a comma-separated list or one number, got {spec!r}"
    s = str(spec).strip()
    parts = s.split(":")
    if len(parts) == 1 and s:
        try:
            return np.array([float(x) for x in s.split(",")])
        except ValueError:
            raise ValueError(form) from None
    if len(parts) != 3:
        raise ValueError(form)
    try:
        a, b = float(parts[0]), float(parts[1])
    except ValueError:
        raise ValueError(form) from None
    try:
        n = int(parts[2])
    except ValueError:
        raise ValueError(f"{name}: the count in {spec!r} must be an integer >= 1, got {parts[2].strip()!r}") from None
    if n < 1:
        raise ValueError(f"{name}: the count in {spec!r} must be an integer >= 1, got {n}")
    if not (np.isfinite(a) and np.isfinite(b)):
        raise ValueError(form)
    if not a < b:
        raise ValueError(f"{name}: the start of {spec!r} must be smaller than its stop (start:stop:count), "
                         f"got {_show(a)} >= {_show(b)}")
    return np.linspace(a, b, n)


def output_times(t_end: float, dt_out: float) -> np.ndarray:
    """The output (and MMI sampling) times 0, dt_out, ..., t_end."""
    positive("t_end", t_end)
    positive("dt_out (output interval)", dt_out)
    ts = np.arange(0.0, t_end + 0.5 * dt_out, dt_out)
    return ts[ts <= t_end + 1e-12]
