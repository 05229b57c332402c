"""Static equilibrium ``F(q) = λ Q`` by Newton's method with load stepping.

Hand-written rather than ``optimistix.root_find`` so that it reuses the model's own
(block-tridiagonal) factorisation of the tangent stiffness instead of a dense autodiff
Jacobian.
"""

from typing import TYPE_CHECKING

import equinox as eqx
import jax
import jax.numpy as jnp
from jax import lax

from .simulate import SimulationError

if TYPE_CHECKING:  # the models import the integrator's users; annotations only
    from ..models.base import AbstractModel


def _scale_loads(model, lam):
    loads = model.loads
    loads = eqx.tree_at(lambda l: (l.gravity, l.point_forces), loads, (lam * loads.gravity, lam * loads.point_forces))
    return eqx.tree_at(lambda m: m.loads, model, loads)


@eqx.filter_jit
def _static(model, load_steps: int, tol, max_iter: int, q0=None):
    if q0 is None:
        q0, _ = model.initial_state(0.0)
    z = jnp.zeros_like(q0)
    free = model.free_mask()

    def solve_at(q, lam):
        m = _scale_loads(model, lam)

        def cond(s):
            q, i, norm = s
            return (norm > tol) & (i < max_iter) & jnp.isfinite(norm)

        def body(s):
            q, i, _ = s
            q, _, _ = m.constrain(0.0, q, z, z)
            fac = m.factor_iteration_matrix(0.0, q, z, 0.0, 0.0, 1.0)
            dq = fac.solve(m.residual(0.0, q, z, z))
            q = q - jnp.where(free, dq, 0.0)
            norm = jnp.max(jnp.abs(dq)) / (1.0 + jnp.max(jnp.abs(q)))
            return q, i + 1, norm

        q, iters, norm = lax.while_loop(cond, body, (q, jnp.array(0), jnp.array(1.0)))
        return q, (iters, norm)

    lams = jnp.arange(1, load_steps + 1) / load_steps
    q, (iters, norms) = lax.scan(solve_at, q0, lams)
    return q, iters, norms


def static_equilibrium(model: "AbstractModel", load_steps: int = 10, tol: float = 1e-10, max_iter: int = 30,
                       q0=None):
    """Equilibrium of ``model`` under its loads (no inertia, t = 0), reached in ``load_steps``
    equal load increments from ``q0`` (default: the model's initial state). Returns the
    coordinates q; raises ``SimulationError`` if Newton does not converge at some increment."""
    if load_steps < 1:
        raise ValueError(f"load_steps must be >= 1, got {load_steps}")
    q, iters, norms = _static(model, int(load_steps), jnp.asarray(tol), int(max_iter), q0)
    if not isinstance(norms, jax.core.Tracer):
        bad = ~(norms <= tol)
        if bool(jnp.any(bad)):
            i = int(jnp.argmax(bad))
            raise SimulationError(
                f"static Newton did not converge at load increment {i + 1}/{load_steps} "
                f"(last relative update {float(norms[i]):.3g}); use more load_steps"
            )
    return q
