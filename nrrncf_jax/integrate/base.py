"""The adaptive loop's interface to its solver (docs/theory.md, §8 Time integration): the ``init``/``step`` contract
(``AbstractSolver``), the typed state a solver carries from step to step, and the Newton
settings of a step (``Newton``, the user's; ``NewtonOptions``, as a step receives them).

The loop (``simulate.py``) runs the step-size controller (``step_size``), rejects and retries
steps, interpolates the outputs and batches runs; the solver (``GeneralizedAlpha``,
``GeneralizedAlphaIndex3``) owns the discrete equations: what it carries, how a step is solved,
and its local error estimate.
"""

import abc
from collections.abc import Callable
from typing import Any, Literal

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import _validate
from .._types import Array, Bool, Float, Scalar
from .newton import NewtonSolution


class GeneralizedAlphaState(eqx.Module):
    """The generalized-α state at the end of a step (docs/theory.md, §8 Time integration):
    coordinates q, velocities v, the true acceleration a, the auxiliary acceleration ā (``abar``),
    and the Lagrange multipliers λ (``lam``; shape (0,) for an unconstrained model, the default).

    The adaptive loop carries it with (q, v, a, ā) stacked into one (4, n) array, one buffer
    in the ``while_loop`` rather than four (``simulate._Stacked``).
    """

    q: Float[Array, " n"]
    v: Float[Array, " n"]
    a: Float[Array, " n"]
    abar: Float[Array, " n"]
    lam: Float[Array, " m"]

    def __init__(self, q, v, a, abar, lam=None):
        self.q, self.v, self.a, self.abar = q, v, a, abar
        self.lam = jnp.zeros((0,), jnp.result_type(q)) if lam is None else lam


class Newton(eqx.Module):
    """How each step solves its implicit equations (``integrate.newton``), as the user sets it.

    ``tol``: Newton stops when its correction (or, with the contraction test, the error the
    correction leaves) is below ``tol`` times the step's error tolerance; ``max_iter``: the most
    corrections a step (default 10 with adaptive steps, where a Newton that wanders is better
    split, 50 with constant steps); ``kind``: ``"modified"`` (iteration matrix factored once a
    step), ``"full"`` (once a correction) or ``"auto"``, the model's ``preferred_newton``.

    ``reuse=True``: modified Newton whose iteration matrix is kept from step to step
    (``IterationMatrix``) and factored again only when the step size has moved by more than
    ``reuse_band`` (a fraction) from the one it was factored for, or when the last solve with it
    contracted worse than ``reuse_rate`` an iteration or failed; a step whose solve fails with a
    kept matrix is retried at the same size with a fresh one. Adaptive steps then keep their
    size where the controller would grow it by less than ``1 + reuse_band`` (Hairer & Wanner,
    *Solving ODEs II*, §IV.8: a step change too small to pay for a new factorisation). With
    ``ConstantStepSize`` this is the fixed-step mode: one matrix held while Newton contracts.
    Forward mode only. Which step refactors depends on the observed contraction, so a run is
    piecewise smooth in its parameters (the kept and the fresh matrix reach the same solution
    to Newton's tolerance), not smooth: for gradients keep the default ``reuse=False``.
    """

    tol: Scalar
    max_iter: int | None = eqx.field(static=True)
    kind: Literal["auto", "modified", "full"] = eqx.field(static=True)
    reuse: bool = eqx.field(static=True)
    reuse_band: float = eqx.field(static=True)
    reuse_rate: float = eqx.field(static=True)

    def __init__(self, tol=1e-3, max_iter: int | None = None, kind: Literal["auto", "modified", "full"] = "auto",
                 *, reuse: bool = False, reuse_band: float = 0.2, reuse_rate: float = 0.1):
        if isinstance(tol, (int, float, np.floating)) and not tol > 0.0:
            raise ValueError(f"Newton tol must be > 0, got tol={tol!r}")
        if max_iter is not None:
            max_iter = _validate.positive_int("Newton max_iter", max_iter)
        if kind not in ("auto", "modified", "full"):
            raise ValueError(f"Newton kind must be 'auto', 'modified' or 'full', got {kind!r}")
        _validate.boolean("Newton reuse", reuse)
        if reuse and kind == "full":
            raise ValueError("Newton(reuse=True) keeps one iteration matrix over several steps, which is "
                             "modified Newton: use kind='modified' or 'auto' with it, not 'full'")
        if not 0.0 < float(reuse_band) < 1.0:
            raise ValueError(f"Newton reuse_band must lie in (0, 1), got {reuse_band!r}")
        if not 0.0 < float(reuse_rate) < 1.0:
            raise ValueError(f"Newton reuse_rate must lie in (0, 1), got {reuse_rate!r}")
        self.tol = jnp.asarray(tol, dtype=float)
        self.max_iter = max_iter
        self.kind = kind
        self.reuse, self.reuse_band, self.reuse_rate = reuse, float(reuse_band), float(reuse_rate)

    def options(self, model, adaptive: bool, implicit: bool) -> "NewtonOptions":
        """The options a step receives: ``kind`` and ``max_iter`` resolved for this model and
        controller (``reuse`` makes it modified), the divergence test on with adaptive steps, and
        ``implicit`` in reverse mode."""
        if self.reuse and implicit:
            raise ValueError("Newton(reuse=True) runs in forward mode: use adjoint='forward', or reuse=False "
                             "to differentiate in reverse mode")
        max_iter = self.max_iter if self.max_iter is not None else (10 if adaptive else 50)
        variant = "modified" if self.reuse else (model.preferred_newton if self.kind == "auto" else self.kind)
        return NewtonOptions(tol=self.tol, max_iter=max_iter, variant=variant, divergence_test=adaptive,
                             implicit=implicit, reuse=self.reuse, reuse_band=self.reuse_band,
                             reuse_rate=self.reuse_rate)


class NewtonOptions(eqx.Module):
    """How a step solves its implicit equations (``integrate.newton``), resolved (``Newton.options``).

    ``tol``: the stopping tolerance on a correction's size, as ``step``'s ``norm`` measures
    it; ``max_iter``: the most corrections; ``variant``: ``"modified"`` (iteration matrix
    factored once per step) or ``"full"`` (once per correction, with the contraction test);
    ``divergence_test``: fail a solve whose corrections grow from the third on; ``implicit``:
    the loop runs in reverse mode, so the step returns the solve's value with the tangent of
    the implicit function theorem (the solve itself is not differentiated); ``reuse``,
    ``reuse_band``, ``reuse_rate``: the iteration matrix kept across steps (``Newton``).
    """

    tol: Scalar
    max_iter: int = eqx.field(static=True)
    variant: Literal["modified", "full"] = eqx.field(static=True)
    divergence_test: bool = eqx.field(static=True)
    implicit: bool = eqx.field(static=True)
    reuse: bool = eqx.field(static=True, default=False)
    reuse_band: float = eqx.field(static=True, default=0.2)
    reuse_rate: float = eqx.field(static=True, default=0.1)

    def keep(self, matrix: "IterationMatrix | None", h):
        """Whether a step of size ``h`` may solve with ``matrix`` instead of factoring its own."""
        if matrix is None:
            return jnp.asarray(False)
        return matrix.valid & (jnp.abs(h / matrix.h - 1.0) <= self.reuse_band)


class IterationMatrix(eqx.Module):
    """A factored iteration matrix kept from one step to the next (``Newton(reuse=True)``): the
    factor (whatever the model's factorisation returns: a ``linalg`` factor, or an
    ``AugmentedFactor`` for a constrained system), the step size ``h`` it was factored for, and
    whether the last solve with it contracted well enough to use it again (``valid``)."""

    factor: Any
    h: Float[Array, ""]
    valid: Bool[Array, ""]


class AbstractSolver(eqx.Module):
    """A one-step method for ``M(q) a + g(t, q, v) = 0`` that the adaptive loop can drive.

    The contract (``GeneralizedAlpha`` and ``GeneralizedAlphaIndex3`` implement it):

    - ``init(model, t0, q0, v0) -> state``: the state at ``t0`` from the initial coordinates
      and velocities, with its accelerations (and multipliers) consistent with the equations
      of motion at ``t0``. ``state`` is an ``equinox.Module`` of arrays whose shapes and
      dtypes stay the same from step to step (the loop carries it in a ``while_loop``, its
      leaves of one shape stacked into one array), with attributes ``q`` and ``v``: the loop
      measures errors and interpolates outputs (cubic Hermite) from them alone. Multipliers
      λ belong in the state (``GeneralizedAlphaState.lam``).
    - ``step(model, t0, t1, state, newton, norm, *, h=None) -> (state1, error, solution)``:
      one step from ``t0`` to ``t1`` of size ``h`` (default ``t1 − t0``; the loop passes its
      own ``h``, which may differ from ``t1 − t0`` by round-off where ``t1`` was snapped onto
      an output time). ``state1`` is the state at ``t1`` (prescribed coordinates imposed);
      ``error`` is the local error estimate of ``q`` over the step, shape ``(n,)`` in the
      model's coordinates: the Lagrange multipliers (and velocities, accelerations) are not in
      the error norm, which the loop takes over ``model.error_space(state1.q, error)``;
      ``solution`` is the ``NewtonSolution`` of the step's solve (the loop reads its
      ``iterations`` and ``converged``; a step whose solve did not converge is rejected).
      ``norm(dq)`` measures a correction of ``q`` in units of the error tolerance; a method
      maps its Newton correction to one of ``q`` (multipliers excluded) before measuring it.
      Under ``newton.implicit`` the loop builds ``norm`` from stop-gradient inputs and the
      method must not differentiate through its Newton iteration: it solves with
      stop-gradient inputs and adds the implicit-function tangent of the solution.
      ``matrix`` (``Newton(reuse=True)``): the ``IterationMatrix`` the last step left, which the
      step may solve with (``NewtonOptions.keep``) instead of factoring its own; the step
      returns the one it used, valid or not for the next step, as ``solution.matrix``, and how
      many factorisations it made as ``solution.factorizations``.

    The step is a pure function of its inputs (``jit``, ``vmap`` and forward-mode
    differentiation pass through); step-size control, rejection and dense output are the loop's.
    """

    @abc.abstractmethod
    def init(self, model, t0: Scalar, q0: Float[Array, " n"], v0: Float[Array, " n"]):
        """The state at ``t0`` (see the class docstring)."""

    @abc.abstractmethod
    def step(self, model, t0: Scalar, t1: Scalar, state, newton: NewtonOptions,
             norm: Callable[[Float[Array, " n"]], Scalar], *, h: Scalar | None = None,
             matrix: "IterationMatrix | None" = None) -> tuple[eqx.Module, Float[Array, " n"], NewtonSolution]:
        """``(state1, error, solution)`` of one step (see the class docstring)."""

    @abc.abstractmethod
    def check(self, model) -> None:
        """Raise ``ValueError`` before tracing if this solver cannot run ``model``."""


__all__ = ["AbstractSolver", "GeneralizedAlphaState", "IterationMatrix", "Newton", "NewtonOptions"]
