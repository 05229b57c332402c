"""Block-tridiagonal LU of the iteration matrix of a chain mesh (beams: element e on nodes e, e+1,
DOFs numbered node by node).

Block LU by ``lax.scan`` over the nodes. Hand-written because neither JAX nor lineax has a banded
or block-tridiagonal direct solver. O(n m²) time and O(n m) memory for blocks of m, against dense
LU's O(n³) and O(n²), so it is much faster than dense LU on all but the smallest beams. Everything
is JAX: it works under ``jit``, ``vmap`` and both modes of differentiation, on any platform.
"""

import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
from jax import lax

from .._types import Array, Bool, Float
from .base import AbstractFactorization
from .dense import pivoted_lu


class BlockTridiagonalLU(AbstractFactorization):
    """Factors of a block-tridiagonal matrix with diagonal blocks D_i, sub-diagonal L_i
    (row i, column i-1) and super-diagonal U_i (row i, column i+1)."""

    lu: Float[Array, "nb m m"]  # each S_i's U (``dense.pivoted_lu``)
    inv_lower: Float[Array, "nb m m"]  # each S_i's L⁻¹P
    L: Float[Array, "nb m m"]
    G: Float[Array, "nb m m"]  # S_i⁻¹ U_i

    def solve(self, b: Float[Array, " n"]) -> Float[Array, " n"]:
        nb, m = self.lu.shape[:2]
        b = b.reshape(nb, m)

        def forward(y_prev, x):
            lu, C, L, bi = x
            y = jsl.solve_triangular(lu, C @ (bi - L @ y_prev), lower=False)
            return y, y

        _, y = lax.scan(forward, jnp.zeros(m, b.dtype), (self.lu, self.inv_lower, self.L, b))

        def backward(x_next, x):
            G, yi = x
            xi = yi - G @ x_next
            return xi, xi

        _, x = lax.scan(backward, jnp.zeros(m, b.dtype), (self.G, y), reverse=True)
        return x.reshape(-1)


def factor_block_tridiagonal(
    D: Float[Array, "nb m m"], L: Float[Array, "nb m m"], U: Float[Array, "nb m m"]
) -> BlockTridiagonalLU:
    m = D.shape[1]

    def step(G_prev, x):
        Di, Li, Ui = x
        S = Di - Li @ G_prev
        lu, C = pivoted_lu(S)
        G = jsl.solve_triangular(lu, C @ Ui, lower=False)
        return G, (lu, C, G)

    _, (lu, C, G) = lax.scan(step, jnp.zeros((m, m), D.dtype), (D, L, U))
    return BlockTridiagonalLU(lu=lu, inv_lower=C, L=L, G=G)


def assemble_block_tridiagonal(
    Ge: Float[Array, "n_el nd nd"], free: Bool[Array, " n"], m: int
) -> tuple[Float[Array, "nb m m"], Float[Array, "nb m m"], Float[Array, "nb m m"]]:
    """The blocks (D, L, U) of a chain's matrix from its element matrices (nd = 2m, element e on
    nodes e and e+1, so n_el = n/m − 1), constrained rows and columns made identity."""
    n = free.shape[0]
    nb = n // m
    n_el = Ge.shape[0]
    Gb = Ge.reshape(n_el, 2, m, 2, m)
    D = jnp.zeros((nb, m, m), Ge.dtype).at[:-1].add(Gb[:, 0, :, 0, :]).at[1:].add(Gb[:, 1, :, 1, :])
    U = jnp.zeros((nb, m, m), Ge.dtype).at[:-1].set(Gb[:, 0, :, 1, :])
    L = jnp.zeros((nb, m, m), Ge.dtype).at[1:].set(Gb[:, 1, :, 0, :])
    f = free.reshape(nb, m).astype(Ge.dtype)
    f_prev = jnp.concatenate([jnp.zeros((1, m), f.dtype), f[:-1]])
    f_next = jnp.concatenate([f[1:], jnp.zeros((1, m), f.dtype)])
    D = D * f[:, :, None] * f[:, None, :] + jax.vmap(jnp.diag)(1.0 - f)
    L = L * f[:, :, None] * f_prev[:, None, :]
    U = U * f[:, :, None] * f_next[:, None, :]
    return D, L, U
