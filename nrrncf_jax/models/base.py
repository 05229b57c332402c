"""What the integrator needs from a model of ``M(q) a + g(t, q, v) = 0`` (second order).

A model is an ``equinox.Module`` (a pytree): jit, vmap and grad pass straight through it. It
never knows which integrator runs it.
"""

import abc
from typing import ClassVar

import equinox as eqx

from .._types import Array, Bool, Float, Scalar


class AbstractModel(eqx.Module):
    """Second-order model with coordinates q ∈ Rⁿ, some of them prescribed.

    Prescribed coordinates (constraints eliminated as prescribed motion) have zero residual
    rows and identity rows/columns in the iteration matrix; ``constrain`` sets their values.
    """

    preferred_newton: ClassVar[str] = "modified"
    """The integrator's Newton variant under ``newton="auto"``: ``"modified"`` (factor once
    per step) suits models whose factorisation costs more than a residual."""

    @property
    def small_kernels(self) -> bool:
        """Whether the model's step is made of small kernels only (a reduced model's few
        contractions, not element forces over a mesh): ``simulate`` then compiles a single run
        with ``integrate.simulate.SMALL_KERNEL_OPTIONS`` on a CPU. False unless a model says so."""
        return False

    @property
    @abc.abstractmethod
    def n_dof(self) -> int: ...

    @abc.abstractmethod
    def free_mask(self) -> Bool[Array, " n"]:
        """True for coordinates the integrator solves for."""

    @abc.abstractmethod
    def initial_state(self, t0: Scalar) -> tuple[Float[Array, " n"], Float[Array, " n"]]:
        """``(q0, v0)`` at ``t0``."""

    @abc.abstractmethod
    def constrain(self, t: Scalar, q: Float[Array, " n"], v: Float[Array, " n"], a: Float[Array, " n"]):
        """Overwrite the prescribed coordinates with their values at t; returns ``(q, v, a)``."""

    @abc.abstractmethod
    def residual(
        self, t: Scalar, q: Float[Array, " n"], v: Float[Array, " n"], a: Float[Array, " n"]
    ) -> Float[Array, " n"]:
        """r = M a + g(t, q, v); zero on prescribed rows."""

    @abc.abstractmethod
    def factor_iteration_matrix(
        self, t: Scalar, q: Float[Array, " n"], v: Float[Array, " n"], c_M, c_C, c_K
    ):
        """Factor ``c_M ∂r/∂a + c_C ∂r/∂v + c_K ∂r/∂q``; returns an object with ``.solve(b)``."""

    def newton_update(self, t: Scalar, q: Float[Array, " n"], v: Float[Array, " n"], a: Float[Array, " n"], c_M,
                      c_C, c_K) -> Float[Array, " n"]:
        """One full-Newton update: ``S⁻¹ r`` with ``r = residual(t, q, v, a)`` and ``S`` the
        iteration matrix ``c_M ∂r/∂a + c_C ∂r/∂v + c_K ∂r/∂q`` at the same state. Models whose
        residual and tangent share their costly part (the reduced model's cubic force) override
        it to evaluate that part once."""
        return self.factor_iteration_matrix(t, q, v, c_M, c_C, c_K).solve(self.residual(t, q, v, a))

    def error_space(self, q: Float[Array, " n"], e: Float[Array, " n"]):
        """Where the step's error is measured: ``(q_err, e_err, mask)``, the coordinates that
        scale the tolerance, the error in them, and which of them count. The default is the
        model's own coordinates; a reduced model maps back to the physical ones so that the
        same rtol means the same accuracy for full and reduced models."""
        return q, e, self.free_mask()

    newton_in_error_space: ClassVar[bool] = True
    """Whether Newton's corrections are measured in ``error_space`` (the default), or in
    ``newton_space`` (a model whose step error leaves coordinates out, such as a mechanism whose
    step error is on its sensors: Newton must converge in all of them)."""

    def newton_space(self, q: Float[Array, " n"], e: Float[Array, " n"]):
        """Where Newton's corrections are measured when ``newton_in_error_space`` is False, as
        ``error_space`` returns it (the error space itself by default)."""
        return self.error_space(q, e)
