"""SVD deflation of a reduction basis (paper Algorithm 1).

NumPy rather than jnp: the deflation runs once, on a small concrete matrix, outside any trace,
and op by op jnp compiled a dozen small XLA kernels (norm, svd, comparisons, slices) on every
cold start. The differentiable offline path (``studies.families.offline_family``) holds the deflation
map fixed at its nominal value; ``deflation_map`` gives it from the same SVD.
"""

import jax.numpy as jnp
import numpy as np

from .._types import Array, Float


def _scaled_svd(Psi) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(‖ψ_j‖, U, σ, Vᵀ)`` of ``Ψ diag(1/‖ψ_j‖) = U Σ Vᵀ`` (thin SVD)."""
    Psi = np.asarray(Psi, dtype=float)
    norms = np.linalg.norm(Psi, axis=0)
    if np.any(norms == 0):
        raise ValueError("the basis has a zero column")
    U, s, Vt = np.linalg.svd(Psi / norms, full_matrices=False)
    return norms, U, s, Vt


def deflate(Psi: Float[Array, "ndof s"], tol: float = 1e-6) -> Float[Array, "ndof km"]:
    """``Ψ = UΣVᵀ``; keep the columns of U with ``σ_i > tol · σ_1`` (ϑ = 1e-6 in the paper).

    The columns of Ψ are normalised first so that no mode dominates merely by its scale
    (mass-normalised modes and modal derivatives have unrelated magnitudes).
    """
    _, U, s, _ = _scaled_svd(Psi)
    km = int(np.sum(s > tol * s[0]))
    return jnp.asarray(U[:, :km], dtype=float)


def deflation_map(Psi: Float[Array, "ndof s"], km: int) -> np.ndarray:
    """``T = diag(1/‖ψ_j‖) V_r Σ_r⁻¹`` (s × km) with ``Ψ T = U_r``, the first ``km`` columns of
    ``deflate``'s basis, column signs included (the same SVD)."""
    norms, _, s, Vt = _scaled_svd(Psi)
    return (Vt[:km].T / s[:km]) / norms[:, None]
