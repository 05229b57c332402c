"""Dense LU of the iteration matrix: any mesh, on any platform, under ``jit``, ``vmap`` and both
modes of differentiation; O(n²) memory and O(n³) time, so for small models (``assembly`` picks it
below ``DENSE_MAX_DOFS``).

Constrained rows and columns become identity rows and columns (their increments are zero).
"""

import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
from jax import lax

from .._types import Array, Bool, Float, Int
from .base import AbstractFactorization, Parts


class DenseLU(AbstractFactorization):
    """LU with partial pivoting of a dense matrix (``jax.scipy.linalg.lu_factor``)."""

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


def assemble_dense(parts: Parts, free: Bool[Array, " n"]) -> Float[Array, "n n"]:
    """The n × n matrix from element matrices, group by group, constrained rows and columns made
    identity."""
    n = free.shape[0]
    dtype = jnp.result_type(*(Ge for Ge, _ in parts))
    A = jnp.zeros((n, n), dtype)
    for Ge, element_dofs in parts:
        A = A.at[element_dofs[:, :, None], element_dofs[:, None, :]].add(Ge)
    f = free.astype(dtype)
    return A * f[:, None] * f[None, :] + jnp.diag(1.0 - f)
