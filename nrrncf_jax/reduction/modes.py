"""Vibration modes of a body about its rigid-reference configuration (Eqs. 26-28).

``(K|eq − ω² M) φ = 0`` on the free coordinates. ``jax.scipy.linalg.eigh`` has no generalised
form, so the problem is reduced with the Cholesky factor of M: ``L⁻¹ K L⁻ᵀ y = ω² y``,
``φ = L⁻ᵀ y``; the modes come out mass-normalised (``ΦᵀMΦ = I``).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np

from .._types import Array, Bool, Float
from .._validate import is_concrete
from ..bodies.body import Body
from ..linalg import assemble_sparse, sparse_modes, uses_sparse


class VibrationModes(eqx.Module):
    """Natural angular frequencies ``omega`` [rad/s] (ascending) and mass-normalised mode
    shapes ``phi`` (n_dof × k, zero on constrained coordinates).

    ``lambda_max``: the largest eigenvalue ω²_max of the discretised problem on the free
    coordinates (the dense solver's exact value, the sparse solver's element-by-element upper
    bound), or None. It sets how well the eigensolver resolves close modes: a backward-stable
    solver returns each mode only to within an angle of about ε λ_max / |ω_i² − ω_j²| towards
    any other mode j (Davis-Kahan), which ``selection.purify_close_modes`` uses to purify close modes.
    """

    omega: Float[Array, " k"]
    phi: Float[Array, "ndof k"]
    lambda_max: Float[Array, ""] | None = None


def vibration_modes(
    body: Body, free: Bool[Array, " ndof"], k: int | None = None, q_eq: Float[Array, "n 3"] | None = None,
    frame_stiffness: Float[Array, "3 3"] | None = None, solver="auto",
) -> VibrationModes:
    """The ``k`` lowest modes of ``(K|eq, M ⊗ I3)`` restricted to the ``free`` coordinates.

    ``solver`` (``linalg.uses_sparse``): dense (``linalg.Dense()`` or ``"dense"``: a Cholesky
    reduction and ``eigh``: every mode, differentiable), sparse (``linalg.Sparse()`` or
    ``"sparse"``: shift-invert Lanczos on the assembled sparse matrices, ``linalg.sparse_modes``:
    the ``k`` lowest only, on concrete input, not differentiable), or ``"auto"``: sparse from
    ``linalg.DENSE_MAX_DOFS`` free coordinates on.

    ``frame_stiffness`` (3 × 3) adds ``M ⊗ frame_stiffness`` to K|eq: for a body spinning at
    the constant rate ω about e, ``ω² ẽẽ`` is the spin softening of Eq. 8's centrifugal term,
    and with ``q_eq`` the spinning equilibrium these are the modes of the spinning body (the
    Coriolis coupling left out), ``reduction.spin_state``.

    Raises ``ValueError`` if K|eq is singular on the free coordinates (missing reference
    conditions: a free body has six zero-frequency rigid modes). Differentiable (through
    ``eigh``) when the spectrum has no repeated eigenvalues; the checks run on concrete values.
    """
    q_eq = body.q_hat if q_eq is None else q_eq
    free_np = np.asarray(free)
    idx = np.flatnonzero(free_np)
    # A rigid motion that leaves every constrained coordinate alone is a zero-stiffness mode.
    R_fixed = body.rigid_modes()[~free_np]
    if R_fixed.size == 0:
        rank = 0
    else:
        rank = int(np.sum(np.linalg.svd(R_fixed, compute_uv=False) > 1e-8 * np.abs(R_fixed).max()))
    if rank < 6:
        raise ValueError(
            f"the stiffness matrix K|eq is singular: {6 - rank} rigid-body mode(s) are not removed by the "
            "constrained coordinates (missing reference conditions, e.g. no clamped root)"
        )
    if uses_sparse(solver, len(idx)):
        if k is None:
            raise ValueError(f"give the number of modes k: the sparse eigensolver ({len(idx)} free coordinates) "
                             "finds the lowest k, not all of them")
        return _sparse_modes(body, free_np, int(k), q_eq, frame_stiffness)
    k = len(idx) if k is None else min(int(k), len(idx))
    # NumPy constants and index arrays: jnp.zeros or jnp.asarray of an integer array outside a
    # jit each compile a small kernel.
    F = np.zeros((3, 3)) if frame_stiffness is None else jnp.asarray(frame_stiffness, dtype=float)
    w2_min, w2_max, omega, phi = _modes(body, idx, jnp.asarray(q_eq, dtype=float), F, k)
    if is_concrete(w2_min) and float(w2_min) <= 0.0:
        raise ValueError(
            f"K|eq is not positive definite on the free coordinates (lowest eigenvalue {float(w2_min):.3g}): "
            "the configuration is not a stable equilibrium"
        )
    return VibrationModes(omega=omega, phi=phi, lambda_max=w2_max)


def _sparse_modes(body: Body, free: np.ndarray, k: int, q_eq, frame_stiffness) -> VibrationModes:
    """The ``k`` lowest modes by ``linalg.sparse_modes`` (one sparse LU, shift-invert Lanczos)
    from the element blocks of K|eq (+ M ⊗ frame_stiffness) and M ⊗ I3."""
    K_parts, M_parts = _element_blocks(body, jnp.asarray(q_eq, dtype=float), frame_stiffness)
    K = assemble_sparse([(np.asarray(G), np.asarray(d)) for G, d in K_parts], body.n_dof)
    M = assemble_sparse([(np.asarray(G), np.asarray(d)) for G, d in M_parts], body.n_dof)
    omega, phi = sparse_modes(K, M, k, free=free)
    if not omega[0] > 0.0:
        raise ValueError(f"K|eq is not positive definite on the free coordinates (lowest eigenvalue "
                         f"{omega[0] ** 2:.3g}): the configuration is not a stable equilibrium")
    return VibrationModes(omega=jnp.asarray(omega), phi=jnp.asarray(phi),
                          lambda_max=jnp.asarray(_element_bound(K_parts, M_parts)))


def _element_bound(K_parts, M_parts) -> float:
    """An upper bound of the assembled problem's largest eigenvalue: the largest over the
    elements of their own ``(K_e, M_e)`` eigenvalues (the element-by-element bound: a Rayleigh
    quotient of the assembly is a weighted mean of the elements'). Elements without a positive
    definite mass (massless links) are left out of the bound. NumPy, on concrete blocks, one
    batched Cholesky reduction and ``eigvalsh`` per element group."""
    bound = 0.0
    for (Ke, _), (Me, _) in zip(K_parts, M_parts):
        Ke, Me = np.asarray(Ke), np.asarray(Me)
        mass_ok = np.linalg.eigvalsh(Me)[:, 0] > 0.0
        if not mass_ok.any():
            continue
        L = np.linalg.cholesky(Me[mass_ok])
        X = np.linalg.solve(L, Ke[mass_ok])
        A = np.linalg.solve(L, np.swapaxes(X, -1, -2))  # L⁻¹ K L⁻ᵀ (K symmetric)
        bound = max(bound, float(np.linalg.eigvalsh(0.5 * (A + np.swapaxes(A, -1, -2)))[:, -1].max()))
    return bound


@eqx.filter_jit
def _element_blocks(body: Body, q_eq, frame_stiffness):
    """Per group, the element blocks of K|eq + M ⊗ F and of M ⊗ I3 with their DOFs."""
    F = jnp.zeros((3, 3)) if frame_stiffness is None else jnp.asarray(frame_stiffness, dtype=float)
    K_parts, M_parts = [], []
    for (Ke, dofs), (M_e, _) in zip(body.tangent_parts(q_eq), body.mass_parts()):
        n_el, ne = M_e.shape[:2]
        kron = lambda B: jnp.einsum("eab,ij->eaibj", M_e, B).reshape(n_el, 3 * ne, 3 * ne)  # noqa: E731
        K_parts.append((Ke + kron(F), dofs))
        M_parts.append((kron(jnp.eye(3)), dofs))
    return K_parts, M_parts


@eqx.filter_jit
def _modes(body: Body, idx, q_eq, frame_stiffness, k: int):
    """The lowest and the largest eigenvalue, and the ``k`` lowest frequencies and mass-normalised modes on the
    coordinates ``idx``: one compiled kernel for rest and spinning modes alike (op by op, the
    assembly, the reduction and the slicing compiled dozens of primitives on every cold start)."""
    K = _frame_stiffened(body, q_eq, frame_stiffness)[idx[:, None], idx[None, :]]
    M = jnp.kron(body.mass_matrix(), jnp.eye(3))[idx[:, None], idx[None, :]]
    L = jnp.linalg.cholesky(M)
    A = jsl.solve_triangular(L, jsl.solve_triangular(L, K, lower=True).T, lower=True)
    A = 0.5 * (A + A.T)
    w2, Y = eigh(A)
    phi_free = jsl.solve_triangular(L.T, Y[:, :k], lower=False)
    return w2[0], w2[-1], jnp.sqrt(w2[:k]), jnp.zeros((body.n_dof, k)).at[idx].set(phi_free)


def frame_stiffened(body: Body, q_eq: Float[Array, "n 3"], frame_stiffness=None) -> Float[Array, "ndof ndof"]:
    """``K(q_eq) + M ⊗ frame_stiffness`` on all coordinates (just K without a frame term)."""
    F = jnp.zeros((3, 3)) if frame_stiffness is None else jnp.asarray(frame_stiffness, dtype=float)
    return _frame_stiffened(body, q_eq, F)


@eqx.filter_jit
def _frame_stiffened(body, q_eq, F):
    return body.stiffness_matrix(q_eq) + jnp.kron(body.mass_matrix(), F)


DEGENERACY_RTOL = 1e-8
"""Eigenvalues closer than this (relative) count as one repeated eigenvalue in ``eigh``'s
derivative."""


@jax.custom_jvp
def eigh(A: Float[Array, "n n"]) -> tuple[Float[Array, " n"], Float[Array, "n n"]]:
    """``jnp.linalg.eigh`` with a derivative that stays finite at repeated eigenvalues.

    The eigenvector derivative is ``dV = V (F ∘ Vᵀ dA V)`` with ``F_ij = 1/(λ_j − λ_i)``.
    Inside a repeated eigenvalue F is infinite — the eigenvectors there are not unique — and
    JAX's own rule returns NaN (even for eigenvectors that are not used, through ∞ · 0). Here
    F is set to zero for pairs closer than ``DEGENERACY_RTOL``: the derivative that does not
    rotate a repeated eigenspace within itself. It is exact for every eigenvector that is
    well separated from all others (F for its pairs is untouched), and it is the right
    derivative of a repeated eigenspace when the perturbation keeps the symmetry that causes
    the repetition (E, ρ or ν of a tube: both bending planes change alike).
    """
    w, V = jnp.linalg.eigh(A)
    return w, V  # a plain tuple, as the JVP rule returns (not jnp's EighResult)


@eigh.defjvp
def _eigh_jvp(primals, tangents):
    (A,), (dA,) = primals, tangents
    w, V = jnp.linalg.eigh(A)
    dA = 0.5 * (dA + dA.T)
    B = V.T @ dA @ V
    gap = w[None, :] - w[:, None]
    close = jnp.abs(gap) <= DEGENERACY_RTOL * jnp.maximum(jnp.abs(w[None, :]), jnp.abs(w[:, None]))
    F = jnp.where(close, 0.0, 1.0 / jnp.where(close, 1.0, gap))
    return (w, V), (jnp.diagonal(B), V @ (F * B))
