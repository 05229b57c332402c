"""Assembly and factorisation of the integrator's iteration matrix.

Two storage formats, both built from element matrices ``(n_el, ne·3, ne·3)``:

- ``dense``: any mesh; LU of the whole matrix.
- ``block_tridiagonal``: a chain of nodes (beams). Block LU by ``lax.scan`` over the nodes.
  Hand-written because neither JAX nor lineax has a banded or block-tridiagonal direct
  solver; on the 24-element beam (450 DOF, blocks of 18) it factors and solves in about
  0.4 ms against 6.5 ms for dense LU on the 2-core CI CPU.

Constrained rows and columns become identity rows and columns (their increments are zero).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
from jax import lax

from ._types import Array, Bool, Float, Int


class DenseLU(eqx.Module):
    lu: Float[Array, "n n"]
    piv: Int[Array, " n"]

    @classmethod
    def factor(cls, A: Float[Array, "n n"]) -> "DenseLU":
        """LU with partial pivoting of ``A``."""
        lu, piv = jsl.lu_factor(A)
        return cls(lu=lu, piv=piv)

    def solve(self, b: Float[Array, " n"]) -> Float[Array, " n"]:
        return jsl.lu_solve((self.lu, self.piv), b)


@jax.custom_jvp
def solve_once(A: Float[Array, "n n"], b: Float[Array, " n"]) -> Float[Array, " n"]:
    """``A⁻¹ b`` for one right-hand side, by LU with partial pivoting, in the form that batches
    best on the platform it runs on (``lax.platform_dependent``; the same result to round-off).

    On a CPU, one LU factorisation of the augmented matrix ``[A | b]``: LAPACK's getrf pivots on
    A's columns and carries b along, so ``P [A | b] = L [U | c]`` and ``x = U⁻¹ c`` is one
    triangular solve. ``lu_factor`` + ``lu_solve`` would turn the pivots into a permutation with
    a loop of n scatter steps, which under ``vmap`` dominated the solve (a batch of 32 systems
    with n = 23: that loop cost more than the factorisation). Under ``vmap`` the systems are
    factored one after another (``_solve_on_cpu``).

    Elsewhere, the square factorisation and ``lu_solve``: jaxlib's GPU getrf batches square
    matrices only (cuBLAS getrfBatched) and factors a batch of rectangular ones one by one, and
    on a GPU the pivots become a permutation in one kernel.

    Its derivative is the linear-solve identity ``dx = A⁻¹ (db − dA x)``.
    """
    return lax.platform_dependent(A, b, cpu=_solve_on_cpu, default=_solve_factored)


@solve_once.defjvp
def _solve_once_jvp(primals, tangents):
    # The tangent by ``lu_solve``, which is linear in its right-hand side and transposes, so that
    # reverse mode works too (``_solve_on_cpu``'s batching rule has no transpose).
    A, b = primals
    dA, db = tangents
    x = solve_once(A, b)
    return x, DenseLU.factor(A).solve(db - dA @ x)


@jax.custom_batching.custom_vmap
def _solve_on_cpu(A, b):
    return _solve_augmented(A, b)


@_solve_on_cpu.def_vmap
def _solve_on_cpu_batched(axis_size, in_batched, A, b):
    """A batch of systems, one LAPACK call each (``lax.map``), not one batched call: jaxlib
    0.10.2's batched getrf splits the batch across XLA's CPU thread pool and blocks a pool
    thread until the parts are done, which deadlocks when every pool thread does so at once:
    two host devices (``--xla_force_host_platform_device_count``) each in a batched LU on a
    2-core machine hung a sweep with every thread in ``ParallelBatchMap``'s wait (jaxlib 0.11
    builds without that path). The one-by-one form costs about 18 % more per batched solve
    (23 × 23, batch of 32: 184 µs against 156 µs)."""
    A, b = (x if batched else jnp.broadcast_to(x, (axis_size,) + x.shape) for x, batched in zip((A, b), in_batched))
    return lax.map(lambda Ab: _solve_on_cpu(*Ab), (A, b)), True


def _solve_augmented(A, b):
    lu, _ = jsl.lu_factor(jnp.concatenate([A, b[:, None]], axis=1))
    return jsl.solve_triangular(lu[:, :-1], lu[:, -1], lower=False)


def _solve_factored(A, b):
    return DenseLU.factor(A).solve(b)


class BlockTridiagonalLU(eqx.Module):
    """Factors of a block-tridiagonal matrix with diagonal blocks D_i, sub-diagonal L_i
    (row i, column i-1) and super-diagonal U_i (row i, column i+1)."""

    lu: Float[Array, "nb m m"]
    piv: Int[Array, "nb m"]
    L: Float[Array, "nb m m"]
    G: Float[Array, "nb m m"]  # S_i⁻¹ U_i

    def solve(self, b: Float[Array, " n"]) -> Float[Array, " n"]:
        nb, m = self.piv.shape
        b = b.reshape(nb, m)

        def forward(y_prev, x):
            lu, piv, L, bi = x
            y = jsl.lu_solve((lu, piv), bi - L @ y_prev)
            return y, y

        _, y = lax.scan(forward, jnp.zeros(m, b.dtype), (self.lu, self.piv, self.L, b))

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
        lu, piv = jsl.lu_factor(S)
        G = jsl.lu_solve((lu, piv), Ui)
        return G, (lu, piv, G)

    _, (lu, piv, G) = lax.scan(step, jnp.zeros((m, m), D.dtype), (D, L, U))
    return BlockTridiagonalLU(lu=lu, piv=piv, L=L, G=G)


def assemble_and_factor(
    Ge: Float[Array, "n_el nd nd"],
    element_dofs: Int[Array, "n_el nd"],
    free: Bool[Array, " n"],
    chain_block: int | None,
) -> DenseLU | BlockTridiagonalLU:
    """Assemble element matrices, make constrained DOFs identity, and factor.

    ``chain_block`` is the number of DOFs per node of a chain mesh (element e on nodes e, e+1,
    DOFs numbered node by node); ``None`` selects dense storage.
    """
    n = free.shape[0]
    if chain_block is None:
        A = jnp.zeros((n, n), Ge.dtype).at[element_dofs[:, :, None], element_dofs[:, None, :]].add(Ge)
        f = free.astype(Ge.dtype)
        A = A * f[:, None] * f[None, :] + jnp.diag(1.0 - f)
        return DenseLU.factor(A)
    m = chain_block
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
    return factor_block_tridiagonal(D, L, U)
