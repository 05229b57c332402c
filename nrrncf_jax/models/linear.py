"""A linear second-order model ``M a + C v + K q = f(t)`` with dense constant matrices.

Used for linear (modal) simulations and as the integrator's closed-form test problem.
"""

from collections.abc import Callable

import equinox as eqx
import jax.numpy as jnp

from .._types import Array, Float
from ..linalg import DenseLU
from .base import AbstractModel


class LinearModel(AbstractModel):
    M: Float[Array, "n n"]
    K: Float[Array, "n n"]
    C: Float[Array, "n n"]
    q0: Float[Array, " n"]
    v0: Float[Array, " n"]
    force: Callable | None = eqx.field(static=True, default=None)

    def __init__(self, M, K, C=None, q0=None, v0=None, force: Callable | None = None):
        self.M = jnp.atleast_2d(jnp.asarray(M, dtype=float))
        n = self.M.shape[0]
        if self.M.shape != (n, n):
            raise ValueError(f"M must be square, got shape {self.M.shape}")
        self.K = jnp.asarray(K, dtype=float).reshape(n, n)
        self.C = jnp.zeros((n, n)) if C is None else jnp.asarray(C, dtype=float).reshape(n, n)
        self.q0 = jnp.zeros(n) if q0 is None else jnp.asarray(q0, dtype=float).reshape(n)
        self.v0 = jnp.zeros(n) if v0 is None else jnp.asarray(v0, dtype=float).reshape(n)
        self.force = force

    @property
    def n_dof(self) -> int:
        return self.M.shape[0]

    def free_mask(self):
        return jnp.ones(self.n_dof, bool)

    def initial_state(self, t0):
        return self.q0, self.v0

    def constrain(self, t, q, v, a):
        return q, v, a

    def residual(self, t, q, v, a):
        r = self.M @ a + self.C @ v + self.K @ q
        return r if self.force is None else r - self.force(t)

    def factor_iteration_matrix(self, t, q, v, c_M, c_C, c_K):
        return DenseLU.factor(c_M * self.M + c_C * self.C + c_K * self.K)
