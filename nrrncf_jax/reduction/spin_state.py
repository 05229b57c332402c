"""Modes of the spinning body: the basis enrichment for fast spin-ups (beyond the paper).

The paper's basis (vibration modes and modal derivatives at the rigid reference q̂, Eqs. 26-35)
is built at rest. Spun up to ωs, a beam is stiffened by its centrifugal tension and softened by
the frame's rotation (Eq. 8's ω×(ω×q)); in-plane the two nearly cancel, so the residual
vibration after the manoeuvre runs at a frequency that is a small difference of large terms. At
the paper's ωs = 40 rad/s the rest basis puts the first in-plane frequency of the spinning beam
too high, and the phase error of the residual vibration dominates χ_rel. Adding the first mode of
the spinning beam and the modal derivatives of its lowest spinning modes fixes that shape.

Whether to enrich is decided without a full simulation (``ritz_frequencies``): the rest basis's
Rayleigh-Ritz estimate of the spinning body's dominant frequency is compared with the exact one;
the rest basis is enriched when it misses it by more than a tolerance.

- ``spinning_equilibrium``: q* with ``F(q*) + ω² (M ⊗ ẽẽ) q* = Q`` (steady spin, θ̈ = 0),
  by Newton's method on the full model's own static residual.
- ``spinning_modes``: the modes of ``(K(q*) + ω² M ⊗ ẽẽ, M ⊗ I3)`` (Coriolis left out, so the
  modes are real), mass-normalised like ``vibration_modes``.
- ``ritz_frequencies``: the same eigenproblem projected on a basis Ψ.
- ``match_modes``: which spinning mode continues which rest mode (largest mass-weighted
  modal assurance criterion).

All of it runs once per reduction on concrete arrays, and cold-start compilation dominates its
cost: the equilibrium is one compiled Newton solve (``integrate.static.newton_static``) called
once per ω² increment, and the small projections and the matching are NumPy/SciPy (each jnp
operation outside a jit compiles a kernel of its own).
"""

import dataclasses

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import scipy.linalg

from .._types import Array, Float
from ..integrate.newton import NewtonResult
from ..integrate.results import SimulationError
from ..integrate.static import newton_static
from ..motion import AbstractAxisMotion, SteadySpin
from .modes import VibrationModes, frame_stiffened, vibration_modes


def spinning_equilibrium(full, omega: float, steps: int = 4, tol: float = 1e-10,
                         max_iter: int = 30) -> Float[Array, "n 3"]:
    """The equilibrium q* of the RNCF model ``full`` spinning steadily at ``omega`` about its
    motion's axis (its own loads included; gravity is taken at θ = 0), by continuation in ω² over
    ``steps`` equal increments (a curved beam bends under its centrifugal load).

    At each increment the library's static Newton (``integrate.static.newton_static``, on the
    one Newton of ``integrate.newton``) solves ``r(q) = 0`` for the model's residual at rest in
    the frame spinning steadily (``RotatingFrameModel.residual`` with q̇ = q̈ = 0: Eq. 41's
    ``θ̇² M ẼẼ q + F(q) − Q``) with the model's own factorisation of its exact tangent
    ``K(q) + θ̇² M ⊗ ẽẽ``, until the correction is below ``tol`` relative to ``1 + max|q|``.
    Raises ``SimulationError`` naming the increment and the ``NewtonResult`` if Newton does not
    converge."""
    axis = _axis(full)
    q = jnp.asarray(full.body.q_hat, dtype=float).reshape(-1)  # the rigid reference; fixed entries stay
    for k in range(1, steps + 1):
        steady = full.with_motion(SteadySpin(omega * np.sqrt(k / steps), axis=axis))
        sol = _solve(steady, q, jnp.asarray(tol, dtype=float), max_iter)
        if not bool(sol.converged):
            raise SimulationError(
                f"spinning equilibrium: Newton did not converge at increment {k}/{steps} of ω² "
                f"({NewtonResult[sol.result]}); use more steps"
            )
        q = sol.x
    return q.reshape(-1, 3)


@eqx.filter_jit
def _solve(model, q, tol, max_iter: int):
    return newton_static(model, q, tol, max_iter)


def _axis(full) -> np.ndarray:
    """The unit spin axis of ``full``'s motion (a rotation about a fixed axis)."""
    if not isinstance(full.motion, AbstractAxisMotion):
        raise ValueError("the spinning state needs a model whose motion is a rotation about a fixed axis "
                         f"(motion.AbstractAxisMotion), got {type(full.motion).__name__}")
    return np.asarray(full.motion.axis, dtype=float)


def _spin_softening(full, omega: float) -> np.ndarray:
    """``ω² ẽẽ = ω² (eeᵀ − I)`` for the model's unit axis e (3 × 3, NumPy)."""
    e = _axis(full)
    return omega**2 * (np.outer(e, e) - np.eye(3))


def spinning_modes(full, omega: float, k: int) -> tuple[Float[Array, "n 3"], VibrationModes]:
    """``(q*, modes)``: the spinning equilibrium and the ``k`` lowest modes of the linearised,
    non-gyroscopic spinning body about it, ``(K(q*) + ω² M ⊗ ẽẽ − ω² M ⊗ I3) s = 0``."""
    q_star = spinning_equilibrium(full, omega)
    modes = vibration_modes(full.body, full.free_mask(), k, q_eq=q_star, frame_stiffness=_spin_softening(full, omega))
    return q_star, modes


def match_modes(M: Float[Array, "n n"], phi_rest: Float[Array, "ndof k"],
                phi_spin: Float[Array, "ndof m"]) -> np.ndarray:
    """For each rest mode (column of ``phi_rest``), the index of the spinning mode most like it:
    the largest ``(φᵀ (M ⊗ I3) s)²`` with M the scalar mass matrix M_αβ (the full model's ``M``;
    both sets mass-normalised, so this is the modal assurance criterion in the mass metric)."""
    mac = (np.asarray(phi_rest).T @ np.kron(np.asarray(M), np.eye(3)) @ np.asarray(phi_spin)) ** 2
    return np.argmax(mac, axis=1)


def spinning_stiffness(full, q_star: Float[Array, "n 3"], omega: float) -> Float[Array, "ndof ndof"]:
    """``K(q*) + ω² M ⊗ ẽẽ`` (all coordinates; restrict to the free ones)."""
    return frame_stiffened(full.body, jnp.asarray(q_star, dtype=float).reshape(-1, 3), _spin_softening(full, omega))


def ritz_frequencies(full, q_star: Float[Array, "n 3"], omega: float, Psi: Float[Array, "ndof km"]) -> np.ndarray:
    """Rayleigh-Ritz estimates (ascending, rad/s) of the spinning body's frequencies in the
    span of ``Psi``: the eigenvalues of ``(ΨᵀK*Ψ, ΨᵀMΨ)``, upper bounds of the exact ones."""
    free = np.flatnonzero(np.asarray(full.free_mask()))
    K = np.asarray(spinning_stiffness(full, q_star, omega))[np.ix_(free, free)]
    M = np.kron(np.asarray(full.body.mass_matrix()), np.eye(3))[np.ix_(free, free)]  # M_αβ ⊗ I3
    P = np.asarray(Psi)[free]
    Kr = P.T @ K @ P
    return np.sqrt(np.clip(scipy.linalg.eigh(0.5 * (Kr + Kr.T), P.T @ M @ P, eigvals_only=True), 0.0, None))


@dataclasses.dataclass
class SpinCheck:
    """The record of the spinning-state check in ``nr_rncf``: the spin rate, the spinning mode
    that continues the rest VM of largest MMI weight (``mode``, 0-based), its frequency and the
    rest basis's Rayleigh-Ritz estimate of it, and what was added (spinning-mode indices and
    modal-derivative pairs) when ``enriched``."""

    omega: float
    mode: int
    omega_spin: float
    omega_ritz: float
    enriched: bool
    vms: tuple[int, ...] = ()
    pairs: tuple[tuple[int, int], ...] = ()

    @property
    def rel_err(self) -> float:
        return self.omega_ritz / self.omega_spin - 1.0
