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

EXPLICIT_INVERSE_MAX = 128
"""Above this order ``DenseLU`` keeps the permutation instead of L⁻¹P: forming L⁻¹P costs n³
more flops, which for large n outweighs what it saves (the permutation's loop of n small steps,
which matters next to the factorisation only for small n). The threshold was set by timing the
two forms."""


class DenseLU(AbstractFactorization):
    """LU with partial pivoting of a dense matrix, ``P A = L U``. Up to ``EXPLICIT_INVERSE_MAX``
    kept as (U, L⁻¹P): a solve is ``x = U⁻¹ (L⁻¹P b)``, one product and one triangular solve
    (``pivoted_lu``); above it as (LU, the permutation): two triangular solves of the permuted
    right-hand side."""

    lu: Float[Array, "n n"]  # U in its upper triangle, L's multipliers below it
    inv_lower: Float[Array, "n n"] | None  # C = L⁻¹ P (small n), or None
    perm: Int[Array, " n"] | None = None  # P as a permutation of the rows (large n), or None

    @classmethod
    def factor(cls, A: Float[Array, "n n"]) -> "DenseLU":
        """LU with partial pivoting of ``A``."""
        if A.shape[-1] > EXPLICIT_INVERSE_MAX:
            lu, _, perm = lax.linalg.lu(A)
            return cls(lu=lu, inv_lower=None, perm=perm)
        lu, inv_lower = pivoted_lu(A)
        return cls(lu=lu, inv_lower=inv_lower)

    def solve(self, b: Float[Array, " n"]) -> Float[Array, " n"]:
        if self.perm is None:
            y = self.inv_lower @ b
        else:
            y = jsl.solve_triangular(self.lu, b[self.perm], lower=True, unit_diagonal=True)
        return jsl.solve_triangular(self.lu, y, lower=False)


class DenseInverse(AbstractFactorization):
    """A⁻¹ itself, formed from A's LU with partial pivoting (U⁻¹ L⁻¹P, ``pivoted_lu``): a solve
    is one matrix-vector product. For small blocks factored once and solved with several times
    (a jointed system's bodies in modified Newton, ``schur.schur_factor``): a solve by (U, L⁻¹P)
    is a product, a triangular solve and the change to LAPACK's column-major layout, three
    operations where this is one, and equal bodies' products batch into one. Forming the inverse
    costs a triangular solve with n right-hand sides, so up to ``EXPLICIT_INVERSE_MAX``. Its
    solves' forward error is of the order cond(A)·ε, as a triangular solve's is."""

    inverse: Float[Array, "n n"]

    @classmethod
    def factor(cls, A: Float[Array, "n n"]) -> "DenseInverse":
        lu, inv_lower = pivoted_lu(A)
        return cls(inverse=jsl.solve_triangular(lu, inv_lower, lower=False))

    def solve(self, b: Float[Array, " n"]) -> Float[Array, " n"]:
        return self.inverse @ b


def pivoted_lu(A: Float[Array, "n n"]) -> tuple[Float[Array, "n n"], Float[Array, "n n"]]:
    """``(lu, C)``: A's LU factors with partial pivoting (U in the upper triangle) and
    C = L⁻¹ P, so that A⁻¹ b = U⁻¹ (C b).

    Why not ``lu_factor``'s pivots and ``lu_solve``: ``lu_solve`` turns the pivots into a
    permutation with a loop of n scatter steps, each a few XLA operations, and on a CPU each
    operation has a fixed dispatch cost whatever its size, so for the small matrices of reduced
    models that loop can cost more than the factorisation.
    On a CPU, one LAPACK getrf of ``[A | I]`` pivots on A's columns and carries I along:
    ``P [A | I] = L [U | L⁻¹P]``, no permutation needed (``solve_once`` does the same with one
    right-hand side). Elsewhere (a GPU, where jaxlib's getrf factors rectangular matrices of a
    batch one by one but turns the pivots into a permutation in one kernel), the square
    factorisation and C from that permutation."""
    return lax.platform_dependent(A, cpu=_pivoted_lu_augmented, default=_pivoted_lu_square)


def _pivoted_lu_augmented(A):
    n = A.shape[-1]
    lu, _ = jsl.lu_factor(jnp.concatenate([A, jnp.eye(n, dtype=A.dtype)], axis=1))
    return lu[:, :n], lu[:, n:]


def _pivoted_lu_square(A):
    n = A.shape[-1]
    lu, _, perm = lax.linalg.lu(A)
    P = jnp.eye(n, dtype=A.dtype)[perm]
    return lu, jsl.solve_triangular(lu, P, lower=True, unit_diagonal=True)


@jax.custom_jvp
def solve_once(A: Float[Array, "n n"], b: Float[Array, " n"]) -> Float[Array, " n"]:
    """``A⁻¹ b`` for one right-hand side, by LU with partial pivoting, in the form that batches
    best on the platform it runs on (``lax.platform_dependent``; the same result to round-off).

    On a CPU, one LU factorisation of the augmented matrix ``[A | b]``: LAPACK's getrf pivots on
    A's columns and carries b along, so ``P [A | b] = L [U | c]`` and ``x = U⁻¹ c`` is one
    triangular solve. ``lu_factor`` + ``lu_solve`` would turn the pivots into a permutation with
    a loop of n scatter steps, which for small systems under ``vmap`` costs more than the
    factorisation. Under ``vmap`` the systems are factored one after another (``_solve_on_cpu``).

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
    """A batch of systems, one LAPACK call each (``lax.map``), not one batched call: jaxlib's
    batched getrf on the CPU may split the batch across XLA's CPU thread pool and block a pool
    thread until the parts are done, which deadlocks when every pool thread does so at once
    (several host devices, ``--xla_force_host_platform_device_count``, each in a batched LU, on
    as many cores). The one-by-one form costs a little more per batched solve."""
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
