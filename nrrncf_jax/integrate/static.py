"""Static equilibrium by the integrator's Newton (``integrate.newton``) with load stepping.

- ``static_equilibrium``: ``F(q) = λ Q`` of a model with prescribed coordinates; ``newton_static``
  is its one Newton solve, shared with the spinning equilibrium. Hand-written rather than
  ``optimistix.root_find`` so that it reuses the model's own (block-tridiagonal) factorisation of
  the tangent stiffness instead of a dense autodiff Jacobian.
- ``constrained_equilibrium``: a mechanism's (``models.constrained``) static state, the
  index-3 DAE with no inertia, ``r(t, z, 0, 0) + C_zᵀ λ = 0``, ``C(z, t) = 0``: coordinates and
  joint reactions together, drivers at their value at t. Its Newton takes the exact Jacobian of
  the augmented equations by forward-mode differentiation (the joints' Hessian λ·C_zz included,
  which the dynamic step leaves to modified Newton but a static solve cannot: without inertia it
  is what makes a buckled or driven mechanism's tangent), dense: a static solve is run once, and
  a mechanism's few hundred to few thousand coordinates factor in milliseconds.
"""

from typing import TYPE_CHECKING

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.tree_util as jtu
import numpy as np
from jax import lax

from .. import _validate
from .._types import Array, Float, Int
from ..linalg import DenseLU
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


def _check_increments(iters, results, load_steps: int, what: str, advice: str) -> None:
    """``SimulationError`` naming the first load increment whose Newton failed, and how."""
    if not _validate.is_concrete(iters):
        return
    failed = np.flatnonzero(~np.asarray(results == NewtonResult.converged))
    if failed.size:
        i = int(failed[0])
        raise SimulationError(f"{what} did not converge at load increment {i + 1}/{load_steps} "
                              f"({NewtonResult[jtu.tree_map(lambda x: x[i], results)]}): {advice}")


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
    _check_increments(iters, results, load_steps, "static Newton", "use more load_steps")
    return q


class Equilibrium(eqx.Module):
    """A mechanism's static state (``constrained_equilibrium``): coordinates ``z``, the joints'
    multipliers ``lam`` (their reactions, ``multibody.joints`` gives the sign), and Newton's
    corrections at each load increment."""

    z: Float[Array, " n"]
    lam: Float[Array, " m"]
    iterations: Int[Array, " k"]


@eqx.filter_jit
def _constrained(model, t, load_steps: int, tol, max_iter: int, z0, lam0):
    n = z0.shape[0]
    zero = jnp.zeros_like(z0)
    scale = 1.0 + jnp.max(jnp.abs(z0))

    def solve_at(y, s):
        loaded = eqx.tree_at(lambda m: m.gravity, model, s * model.gravity)

        def equations(y):
            r, C = loaded.dae_residual(s * t, y[:n], zero, zero, y[n:])
            return jnp.concatenate([r, C])

        def update(y):
            return DenseLU.factor(jax.jacfwd(equations)(y)).solve(equations(y))

        sol = newton(update, lambda d: jnp.max(jnp.abs(d[:n])) / scale, y, tol, max_iter)
        return sol.x, (sol.iterations, sol.result)

    lams = jnp.arange(1, load_steps + 1) / load_steps
    y, (iters, results) = lax.scan(solve_at, jnp.concatenate([z0, lam0]), lams)
    return y, iters, results


def constrained_equilibrium(model, t=0.0, load_steps: int = 1, tol: float = 1e-10, max_iter: int = 30,
                            z0=None) -> Equilibrium:
    """The static equilibrium of a constrained model (a ``multibody.Mechanism``; module
    docstring) at time ``t`` (what its drivers and force laws read), from ``z0`` (default: the
    reference) in ``load_steps`` increments along the path s = k/load_steps: gravity s·g and the
    time s·t (a driver's angle grows with it). Each increment is solved by Newton until the
    correction of the coordinates is below ``tol`` relative to ``1 + max|z0|``. Returns an
    ``Equilibrium``; raises ``SimulationError`` naming the increment where Newton failed (a
    mechanism that is not held, whose augmented matrix is singular, fails there as
    ``nonfinite``)."""
    load_steps = _validate.positive_int("load_steps", load_steps)
    max_iter = _validate.positive_int("max_iter", max_iter)
    _validate.positive("tol", tol)
    if not all(hasattr(model, name) for name in ("dae_residual", "gravity", "n_constraints")):
        raise ValueError(f"constrained_equilibrium takes a constrained model (a multibody.Mechanism), got "
                         f"{type(model).__name__}; a model without joints is static_equilibrium's")
    z0 = model.reference() if z0 is None else jnp.asarray(z0, dtype=float)
    if z0.shape != (model.n_dof,):
        raise ValueError(f"z0 must have shape ({model.n_dof},), got {tuple(z0.shape)}")
    lam0 = jnp.zeros(model.n_constraints, z0.dtype)
    y, iters, results = _constrained(model, jnp.asarray(t, dtype=z0.dtype), load_steps,
                                     jnp.asarray(tol, dtype=z0.dtype), max_iter, z0, lam0)
    _check_increments(iters, results, load_steps, "static Newton of the mechanism",
                      "use more load_steps, or check that the joints hold every rigid motion (a free mechanism "
                      "has no static state)")
    n = model.n_dof
    return Equilibrium(z=y[:n], lam=y[n:], iterations=iters)


def _tangent_space(model, equilibrium: Equilibrium, t):
    """The stiffness H (the augmented Jacobian's first block: the Hessian of the Lagrangian
    U − W + λ·C, the joints' curvature λ·C_zz included, symmetrised) and an orthonormal basis Z
    of C_z's null space, the joints' tangent space, at the equilibrium (NumPy)."""
    import scipy.linalg

    n = model.n_dof
    zero = jnp.zeros(n)

    def equations(y):
        r, C = model.dae_residual(t, y[:n], zero, zero, y[n:])
        return jnp.concatenate([r, C])

    J = np.asarray(jax.jacfwd(equations)(jnp.concatenate([equilibrium.z, equilibrium.lam])))
    H, B = J[:n, :n], J[n:, :n]
    return 0.5 * (H + H.T), scipy.linalg.null_space(B)


def stability(model, equilibrium: Equilibrium, t=0.0, count: int = 1) -> np.ndarray:
    """The ``count`` lowest eigenvalues of a mechanism's stiffness at its static ``equilibrium``
    (``constrained_equilibrium`` at time ``t``) on the joints' tangent space (``_tangent_space``).
    All positive: the equilibrium is stable; one crosses zero where it buckles (a limit or
    bifurcation point). Dense, on the host (SciPy)."""
    H, Z = _tangent_space(model, equilibrium, t)
    return np.linalg.eigvalsh(Z.T @ H @ Z)[:int(count)]


def vibration_frequencies(model, equilibrium: Equilibrium, t=0.0, count: int = 6) -> np.ndarray:
    """The ``count`` lowest natural frequencies ω [rad/s] of a mechanism's small vibration about its
    static ``equilibrium``: Zᵀ H Z v = ω² Zᵀ M Z v on the joints' tangent space (``_tangent_space``;
    M the mass matrix there), without gyroscopic or damping terms. A mechanism's free rigid motion
    gives ω = 0; an unstable equilibrium a negative ω² (returned as −√|ω²|). Dense (SciPy)."""
    import scipy.linalg

    H, Z = _tangent_space(model, equilibrium, t)
    M = np.asarray(model.mass_matrix(equilibrium.z))
    w2 = scipy.linalg.eigh(Z.T @ H @ Z, Z.T @ (0.5 * (M + M.T)) @ Z, eigvals_only=True)[:int(count)]
    return np.sign(w2) * np.sqrt(np.abs(w2))
