"""Static equilibrium ``F(q) = λ Q`` by the integrator's Newton (``integrate.newton``) with load
stepping; ``newton_static`` is the one static Newton solve, shared with the spinning equilibrium.

Hand-written rather than ``optimistix.root_find`` so that it reuses the model's own
(block-tridiagonal) factorisation of the tangent stiffness instead of a dense autodiff
Jacobian.
"""

from typing import TYPE_CHECKING

import equinox as eqx
import jax.numpy as jnp
import jax.tree_util as jtu
import numpy as np
from jax import lax

from .. import _validate
from .newton import NewtonResult, NewtonSolution, newton
from .simulate import SimulationError

if TYPE_CHECKING:  # the models import the integrator's users; annotations only
    from ..models.base import AbstractModel


def _scale_loads(model, lam):
    loads = model.loads
    loads = eqx.tree_at(lambda l: (l.gravity, l.point_forces), loads, (lam * loads.gravity, lam * loads.point_forces))
    return eqx.tree_at(lambda m: m.loads, model, loads)


def newton_static(model, q, tol, max_iter: int) -> NewtonSolution:
    """One static Newton solve (no inertia, t = 0, q̇ = q̈ = 0) of ``model.residual`` from ``q``,
    with the model's own factorisation of its tangent (``factor_iteration_matrix`` with
    c_K = 1: K(q) plus, in a moving frame, M ⊗ (ω̇̃ + ω̃ω̃)), until the correction is below
    ``tol`` relative to ``1 + max|q|`` at the start. Traceable; the static equilibrium and the
    spinning equilibrium (``reduction.spin_state``) both use it."""
    z = jnp.zeros_like(q)
    free = model.free_mask()
    scale = 1.0 + jnp.max(jnp.abs(q))

    def update(q):
        fac = model.factor_iteration_matrix(0.0, q, z, 0.0, 0.0, 1.0)
        return jnp.where(free, fac.solve(model.residual(0.0, q, z, z)), 0.0)

    return newton(update, lambda dq: jnp.max(jnp.abs(dq)) / scale, q, tol, max_iter)


@eqx.filter_jit
def _static(model, load_steps: int, tol, max_iter: int, q0=None):
    if q0 is None:
        q0, _ = model.initial_state(0.0)
    z = jnp.zeros_like(q0)
    q0, _, _ = model.constrain(0.0, q0, z, z)

    def solve_at(q, lam):
        sol = newton_static(_scale_loads(model, lam), q, tol, max_iter)
        return sol.x, (sol.iterations, sol.result)

    lams = jnp.arange(1, load_steps + 1) / load_steps
    q, (iters, results) = lax.scan(solve_at, q0, lams)
    return q, iters, results


def static_equilibrium(model: "AbstractModel", load_steps: int = 10, tol: float = 1e-10, max_iter: int = 30,
                       q0=None):
    """Equilibrium of ``model`` under its loads (no inertia, t = 0), reached in ``load_steps``
    equal load increments from ``q0`` (default: the model's initial state), each solved by the
    integrator's Newton (``integrate.newton``) until the correction is below ``tol`` relative to
    ``1 + max|q|`` at the increment's start. Returns the coordinates q; raises
    ``SimulationError`` naming the increment and the ``NewtonResult`` if Newton does not
    converge at some increment."""
    load_steps = _validate.positive_int("load_steps", load_steps)
    max_iter = _validate.positive_int("max_iter", max_iter)
    _validate.positive("tol", tol)
    q, iters, results = _static(model, load_steps, jnp.asarray(tol, dtype=float), max_iter, q0)
    if _validate.is_concrete(iters):
        failed = np.flatnonzero(~np.asarray(results == NewtonResult.converged))
        if failed.size:
            i = int(failed[0])
            raise SimulationError(
                f"static Newton did not converge at load increment {i + 1}/{load_steps} "
                f"({NewtonResult[jtu.tree_map(lambda x: x[i], results)]}); use more load_steps"
            )
    return q
