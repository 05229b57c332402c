"""SVD deflation of a reduction basis (paper Algorithm 1)."""

import jax.numpy as jnp

from .._types import Array, Float


def deflate(Psi: Float[Array, "ndof s"], tol: float = 1e-6) -> Float[Array, "ndof km"]:
    """``Ψ = UΣVᵀ``; keep the columns of U with ``σ_i > tol · σ_1`` (ϑ = 1e-6 in the paper).

    The columns of Ψ are normalised first so that no mode dominates merely by its scale
    (mass-normalised modes and modal derivatives have unrelated magnitudes).
    """
    Psi = jnp.asarray(Psi)
    norms = jnp.linalg.norm(Psi, axis=0)
    if bool(jnp.any(norms == 0)):
        raise ValueError("the basis has a zero column")
    U, s, _ = jnp.linalg.svd(Psi / norms, full_matrices=False)
    km = int(jnp.sum(s > tol * s[0]))
    return U[:, :km]
