"""The interface every factorisation of the iteration matrix offers."""

import abc
from collections.abc import Sequence

import equinox as eqx

from .._types import Array, ArrayLike, Float, Int

Parts = Sequence[tuple[Float[Array, "n_el nd nd"], Int[ArrayLike, "n_el nd"]]]
"""Element groups: one ``(Ge, element_dofs)`` pair per group, the element matrices and the global
DOFs of each element's rows and columns (nd may differ between groups); all add into one matrix."""


class AbstractFactorization(eqx.Module):
    """A factored n × n matrix A. A pytree (an equinox Module), so it can be made inside ``jit``
    and inside a ``lax.while_loop`` body and solved with several times (modified Newton)."""

    @abc.abstractmethod
    def solve(self, b: Float[Array, " n"]) -> Float[Array, " n"]:
        """``A⁻¹ b``, differentiable in b and in the matrix the factorisation was made from."""
