"""Static modal derivatives (mass terms neglected), Eqs. 33-36.

``θ_ij = −K|eq⁻¹ (∂K/∂η_j) φ_i`` on the free coordinates, with K|eq factored once for all
pairs. ``(∂K/∂η_j) φ_i`` comes either from the closed form of Eq. 35, applied element by
element without forming the matrix, or from automatic differentiation (the second
directional derivative of the elastic force, ``jax.jvp`` of ``jax.jvp``). The tests check
that the two agree.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np

from .._types import Array, Bool, Float
from .._validate import is_concrete
from ..bodies.body import Body
from ..linalg import ScaledSuperLU, assemble_sparse, uses_sparse


class ModalDerivatives(eqx.Module):
    """``theta[:, m]`` is θ_ij for ``pairs[m] = (i, j)``, i ≤ j (θ_ij = θ_ji)."""

    theta: Float[Array, "ndof npairs"]
    pairs: tuple[tuple[int, int], ...] = eqx.field(static=True)

    def get(self, i: int, j: int) -> Float[Array, " ndof"]:
        return self.theta[:, self.pairs.index((min(i, j), max(i, j)))]


def dK_deta_times(body: Body, q_eq: Float[Array, "n 3"], phi_j: Float[Array, "n 3"], phi_i: Float[Array, "n 3"]):
    """``(∂K/∂η_j)|eq φ_i`` by the closed form of Eq. 35, element by element:

    ``κ^{αβμν} ½(q°_μ·φ^j_ν + φ^j_μ·q°_ν) φ^i_β + κ^{αμβν}(q°_μ (φ^j_ν·φ^i_β) + φ^j_μ (q°_ν·φ^i_β))``.
    """
    out = jnp.zeros_like(q_eq)
    for g in body.groups:
        idx, kappa = g.elements, g.kappa
        q0, pj, pi = q_eq[idx], phi_j[idx], phi_i[idx]
        X = 0.5 * (jnp.einsum("emk,enk->emn", q0, pj) + jnp.einsum("emk,enk->emn", pj, q0))
        first = jnp.einsum("eabmn,emn,ebk->eak", kappa, X, pi)
        P = jnp.einsum("enk,ebk->enb", pj, pi)  # φ^j_ν·φ^i_β
        R = jnp.einsum("enk,ebk->enb", q0, pi)  # q°_ν·φ^i_β
        second = jnp.einsum("eambn,emk,enb->eak", kappa, q0, P) + jnp.einsum("eambn,emk,enb->eak", kappa, pj, R)
        out = out.at[idx].add(first + second)
    return out


def dK_deta_times_autodiff(body: Body, q_eq, phi_j, phi_i):
    """The same by automatic differentiation: d/dη [K(q° + η φ_j) φ_i] at η = 0."""

    def K_times_phi_i(q):
        return jax.jvp(body.elastic_force, (q,), (phi_i,))[1]

    return jax.jvp(K_times_phi_i, (q_eq,), (phi_j,))[1]


def mode_pairs(pairs, k: int) -> tuple[tuple[int, int], ...]:
    """``pairs`` of mode indices as sorted (i, j), i ≤ j (default: all k(k+1)/2 of ``k`` modes);
    ``ValueError`` for an index outside the k modes."""
    if pairs is None:
        pairs = [(i, j) for i in range(k) for j in range(i, k)]
    pairs = tuple((min(int(i), int(j)), max(int(i), int(j))) for i, j in pairs)
    if any(j >= k or i < 0 for i, j in pairs):
        raise ValueError(f"mode index out of range in pairs (have {k} modes): {pairs}")
    return pairs


def modal_derivatives(
    body: Body,
    free: Bool[Array, " ndof"],
    phi: Float[Array, "ndof k"],
    pairs=None,
    q_eq: Float[Array, "n 3"] | None = None,
    method: str = "closed_form",
    pad_to: int | None = None,
    solver="auto",
) -> ModalDerivatives:
    """Static modal derivatives θ_ij of the modes ``phi`` (columns, zero on constrained
    coordinates) for ``pairs`` (default: all i ≤ j, k(k+1)/2 of them).

    ``method`` is ``'closed_form'`` (Eq. 35) or ``'autodiff'``. From ``linalg.DENSE_MAX_DOFS``
    free coordinates on (or with a sparse ``solver``, ``linalg.uses_sparse``) K|eq is factored
    once by SuperLU and every pair solved with that factorisation on the host (concrete input;
    not differentiable); otherwise by a dense Cholesky inside one compiled kernel. ``pad_to`` solves for at least
    that many pairs (the last one repeated, the surplus dropped): the compiled kernel depends
    on the number of pairs, so calls with different counts can share one compilation.
    """
    if method not in ("closed_form", "autodiff"):
        raise ValueError(f"method must be 'closed_form' or 'autodiff', got {method!r}")
    q_eq = body.q_hat if q_eq is None else q_eq
    pairs = mode_pairs(pairs, phi.shape[1])
    # NumPy index arrays: jnp.array of a list outside a jit compiles a conversion kernel.
    idx = np.flatnonzero(np.asarray(free))
    padded = pairs + pairs[-1:] * max(0, (pad_to or 0) - len(pairs))
    ii = np.array([p[0] for p in padded], dtype=int)
    jj = np.array([p[1] for p in padded], dtype=int)
    if uses_sparse(solver, idx.size):
        theta = _sparse_modal_derivatives(body, q_eq, phi, idx, ii, jj, method)
    else:
        theta = _solve_modal_derivatives(body, q_eq, phi, idx, ii, jj, method)
    if len(padded) > len(pairs):
        # Dropped in NumPy when concrete (an eager jnp slice compiles a kernel of its own).
        n = len(pairs)
        theta = jnp.asarray(np.asarray(theta)[:, :n], dtype=theta.dtype) if is_concrete(theta) else theta[:, :n]
    return ModalDerivatives(theta=theta, pairs=pairs)


@eqx.filter_jit
def _solve_modal_derivatives(body, q_eq, phi, idx, ii, jj, method: str):
    K = body.stiffness_matrix(q_eq)[idx[:, None], idx[None, :]]
    chol = jsl.cho_factor(K)  # K|eq is symmetric positive definite on the free coordinates: factor once
    apply = dK_deta_times if method == "closed_form" else dK_deta_times_autodiff
    shape = q_eq.shape

    def one(i, j):
        rhs = apply(body, q_eq, phi[:, j].reshape(shape), phi[:, i].reshape(shape)).reshape(-1)[idx]
        return jnp.zeros(body.n_dof).at[idx].set(-jsl.cho_solve(chol, rhs))

    return jax.vmap(one)(ii, jj).T


@eqx.filter_jit
def _right_hand_sides(body, q_eq, phi, ii, jj, method: str):
    """(∂K/∂η_j) φ_i for each pair, as rows (n_pairs × n_dof), and the element blocks of K|eq."""
    apply = dK_deta_times if method == "closed_form" else dK_deta_times_autodiff
    shape = q_eq.shape
    rhs = jax.vmap(lambda i, j: apply(body, q_eq, phi[:, j].reshape(shape), phi[:, i].reshape(shape)).reshape(-1))
    return rhs(ii, jj), body.tangent_parts(q_eq)


def _sparse_modal_derivatives(body, q_eq, phi, idx, ii, jj, method: str):
    """Eq. 35 with one SuperLU factorisation of K|eq on the free coordinates for all pairs."""
    rhs, parts = _right_hand_sides(body, jnp.asarray(q_eq, dtype=float), jnp.asarray(phi), ii, jj, method)
    K = assemble_sparse([(np.asarray(G), np.asarray(d)) for G, d in parts], body.n_dof)
    Kf = K[idx][:, idx].tocsc()
    lu = ScaledSuperLU(Kf)
    theta = np.zeros((body.n_dof, len(ii)))
    theta[idx] = -lu.solve(np.ascontiguousarray(np.asarray(rhs)[:, idx].T))
    return jnp.asarray(theta)
