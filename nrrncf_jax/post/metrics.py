"""Accuracy measures (docs/theory.md, §9 Accuracy measures and checks)."""

import jax.numpy as jnp
import numpy as np

from .._types import Array, Float


def chi_rel(w_ref: Float[Array, "nt ..."], w: Float[Array, "nt ..."]) -> Float[Array, ""]:
    """Global relative error in percent (Eq. 40):
    ``sqrt(Σ_t |w(t) − w̄(t)|²) / sqrt(Σ_t |w(t)|²) × 100``.

    ``w_ref`` is the reference (e.g. the full RNCF displacements q − q̂), ``w`` the compared
    solution on the same time instants. Use displacements, not positions.
    """
    w_ref, w = jnp.asarray(w_ref), jnp.asarray(w)
    if w_ref.shape != w.shape:
        raise ValueError(f"chi_rel needs arrays of equal shape, got {w_ref.shape} and {w.shape}")
    return 100.0 * jnp.sqrt(jnp.sum((w_ref - w) ** 2)) / jnp.sqrt(jnp.sum(w_ref**2))


def chi_rel_of_changes(series: dict, reference: dict) -> dict:
    """χ_rel (Eq. 40, %) of each history of ``series`` ({name: (nt, ...) array}) against the same
    name's in ``reference`` (the same times), on each one's change from its first value (a
    position's displacement, a deflection's change): ``{name: per cent}``; a history that does not
    change in ``reference`` is left out."""
    chis = {}
    for name, y in series.items():
        y, yr = np.asarray(y), np.asarray(reference[name])
        dy, dyr = y - y[:1], yr - yr[:1]
        if np.abs(dyr).max() > 0:
            chis[name] = float(chi_rel(dyr, dy))
    return chis
