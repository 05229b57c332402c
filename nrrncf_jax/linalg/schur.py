"""The constrained iteration matrix of a jointed system, factored body by body:

    [S   Bᵀ] [z]   [r]
    [B   0 ] [μ] = [c],     S = blockdiag(S_1, …, S_nb),

each body's block S_b factored on its own (block-tridiagonal for a beam chain, dense for a
reduced body) and the joints through the m × m Schur complement B S⁻¹ Bᵀ:
``(B S⁻¹ Bᵀ) μ = B S⁻¹ r − c``, ``z = S⁻¹ r − S⁻¹ Bᵀ μ``. O(n) work in the bodies' sizes instead
of O(n³) for the whole matrix; a dense factor of the whole matrix is the other form.
"""

import equinox as eqx
import jax
import jax.numpy as jnp

from .._types import Array, Float
from .dense import EXPLICIT_INVERSE_MAX, DenseInverse, DenseLU


def factor_block(A: Float[Array, "k k"]) -> DenseLU | DenseInverse:
    """A body's dense block of the iteration matrix factored: its inverse up to
    ``EXPLICIT_INVERSE_MAX`` (a Newton iteration's solve one product), LU above."""
    return DenseInverse.factor(A) if A.shape[-1] <= EXPLICIT_INVERSE_MAX else DenseLU.factor(A)


def _stacked_inverses(factors, sizes) -> Float[Array, "nb k k"] | None:
    """The bodies' inverses stacked, when every factor is an inverse of one size (a chain of
    equal bodies): their solves are then one batched product."""
    if len(factors) > 1 and len(set(sizes)) == 1 and all(isinstance(f, DenseInverse) for f in factors):
        return jnp.stack([f.inverse for f in factors])
    return None


def solve_blocks(factors, offsets, sizes, X: Float[Array, "n ..."], stacked=None) -> Float[Array, "n ..."]:
    """S⁻¹ X for the block-diagonal S of the bodies' ``factors`` (X: n or n × k); ``stacked``:
    their inverses stacked (``_stacked_inverses``), one batched product."""
    if stacked is not None:
        nb, k = stacked.shape[:2]
        return jnp.einsum("bij,bj...->bi...", stacked, X.reshape((nb, k) + X.shape[1:])).reshape(X.shape)
    out = []
    for fac, o, n in zip(factors, offsets, sizes):
        Xb = X[o:o + n]
        out.append(fac.solve(Xb) if Xb.ndim == 1 else jax.vmap(fac.solve, in_axes=1, out_axes=1)(Xb))
    return jnp.concatenate(out)


class AugmentedFactor(eqx.Module):
    """A factored constrained iteration matrix: ``solve`` takes ``[r; c]`` (n + m) and returns
    ``[z; μ]``. Either ``dense`` (one LU of the whole matrix) or the bodies' factors with the
    joints' Schur complement (``schur_factor``)."""

    dense: DenseLU | None = None
    bodies: tuple | None = None
    offsets: tuple[int, ...] | None = eqx.field(static=True, default=None)
    sizes: tuple[int, ...] | None = eqx.field(static=True, default=None)
    B: Float[Array, "m n"] | None = None
    S_inv_Bt: Float[Array, "n m"] | None = None
    schur: DenseLU | None = None
    # the bodies' inverses stacked (``_stacked_inverses``), formed once with the factor rather
    # than in every Newton iteration's solve
    stacked: Float[Array, "nb k k"] | None = None

    def with_constraints(self, B: Float[Array, "m n"]) -> "AugmentedFactor":
        """The same bodies' factors with the constraint Jacobian ``B`` (its Schur complement
        refactored: m × m), for the velocity projection at a step's end
        (``integrate.GeneralizedAlphaIndex3``). The body-by-body form only."""
        return schur_factor(self.bodies, self.offsets, self.sizes, B)

    def solve(self, F: Float[Array, " nm"]) -> Float[Array, " nm"]:
        if self.dense is not None:
            return self.dense.solve(F)
        n = self.B.shape[1]
        r, c = F[:n], F[n:]
        y = solve_blocks(self.bodies, self.offsets, self.sizes, r, self.stacked)
        mu = self.schur.solve(self.B @ y - c)
        return jnp.concatenate([y - self.S_inv_Bt @ mu, mu])

    def solve_constraint_rows(self, c: Float[Array, " m"]) -> Float[Array, " nm"]:
        """``solve([0; c])``: a right-hand side only in the constraint rows (a projection onto
        the constraints' tangent space, ``integrate.index3``). In the body-by-body form the
        bodies' solves of a zero right-hand side drop out: z = −S⁻¹Bᵀ μ, (B S⁻¹ Bᵀ) μ = −c."""
        if self.dense is not None:
            return self.dense.solve(jnp.concatenate([jnp.zeros(self.dense.lu.shape[0] - c.shape[0], c.dtype), c]))
        mu = self.schur.solve(-c)
        return jnp.concatenate([-(self.S_inv_Bt @ mu), mu])


def schur_factor(factors, offsets, sizes, B: Float[Array, "m n"]) -> AugmentedFactor:
    """The ``AugmentedFactor`` of the bodies' block factors and the joints' Jacobian ``B``."""
    stacked = _stacked_inverses(factors, sizes)
    S_inv_Bt = solve_blocks(factors, offsets, sizes, B.T, stacked)
    return AugmentedFactor(bodies=tuple(factors), offsets=tuple(offsets), sizes=tuple(sizes), B=B,
                           S_inv_Bt=S_inv_Bt, schur=DenseLU.factor(B @ S_inv_Bt), stacked=stacked)


def dense_augmented(S: Float[Array, "n n"], B: Float[Array, "m n"]) -> AugmentedFactor:
    """The ``AugmentedFactor`` of one dense LU of ``[[S, Bᵀ], [B, 0]]``."""
    m = B.shape[0]
    return AugmentedFactor(dense=DenseLU.factor(jnp.block([[S, B.T], [B, jnp.zeros((m, m), S.dtype)]])))


__all__ = ["AugmentedFactor", "dense_augmented", "factor_block", "schur_factor", "solve_blocks"]
