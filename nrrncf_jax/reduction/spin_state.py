"""Modes of the spinning body: the basis enrichment for fast spin-ups (beyond the paper).

The paper's basis (vibration modes and modal derivatives at the rigid reference q̂, Eqs. 26-35)
is built at rest. Spun up to ωs, a beam is stiffened by its centrifugal tension and softened by
the frame's rotation (Eq. 8's ω×(ω×q)); in-plane the two nearly cancel, so the residual
vibration after the manoeuvre runs at a frequency that is a small difference of large terms. At
the paper's ωs = 40 rad/s the rest basis puts the first in-plane frequency of the spinning beam
2 % too high (8.66 against 8.48 rad/s) and the phase error of the residual vibration dominates
χ_rel. Adding the first mode of the spinning beam and the modal derivatives of its lowest
spinning modes fixes that shape (χ_rel 5.5 % → 0.5 % there, ``benchmarks/table3.py``).

Whether to enrich is decided without a full simulation (``ritz_frequencies``): the rest basis's
Rayleigh-Ritz estimate of the spinning body's dominant frequency is compared with the exact one;
the rest basis is enriched when it misses it by more than a tolerance.

- ``spinning_equilibrium``: q* with ``F(q*) + ω² (M ⊗ ẽẽ) q* = Q`` (steady spin, θ̈ = 0),
  by the library's static Newton (``integrate.static``).
- ``spinning_modes``: the modes of ``(K(q*) + ω² M ⊗ ẽẽ, M ⊗ I3)`` (Coriolis left out, so the
  modes are real), mass-normalised like ``vibration_modes``.
- ``ritz_frequencies``: the same eigenproblem projected on a basis Ψ.
- ``match_modes``: which spinning mode continues which rest mode (largest mass-weighted
  modal assurance criterion).
"""

import dataclasses

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import scipy.linalg

from .._types import Array, Float
from ..integrate.static import static_equilibrium
from ..motion import SteadySpin, skew
from .modes import VibrationModes, frame_stiffened, vibration_modes


def spinning_equilibrium(full, omega: float, steps: int = 4) -> Float[Array, "n 3"]:
    """The equilibrium q* of the RNCF model ``full`` spinning steadily at ``omega`` about its axis
    (its own loads included; gravity is taken at θ = 0), by continuation in ω² over ``steps``
    equal increments (a curved beam bends under its centrifugal load). Raises
    ``SimulationError`` if Newton does not converge."""
    q, _ = full.initial_state(0.0)  # an array from the start: one compiled Newton for every increment
    for k in range(1, steps + 1):
        steady = eqx.tree_at(lambda m: m.motion, full, SteadySpin(omega * np.sqrt(k / steps)))
        q = static_equilibrium(steady, load_steps=1, q0=q)
    return q.reshape(-1, 3)


def spinning_modes(full, omega: float, k: int) -> tuple[Float[Array, "n 3"], VibrationModes]:
    """``(q*, modes)``: the spinning equilibrium and the ``k`` lowest modes of the linearised,
    non-gyroscopic spinning body about it, ``(K(q*) + ω² M ⊗ ẽẽ − ω² M ⊗ I3) s = 0``."""
    q_star = spinning_equilibrium(full, omega)
    E = skew(full.axis)
    modes = vibration_modes(full.body, full.free_mask(), k, q_eq=q_star, frame_stiffness=omega**2 * (E @ E))
    return q_star, modes


def match_modes(body, phi_rest: Float[Array, "ndof k"], phi_spin: Float[Array, "ndof m"]) -> np.ndarray:
    """For each rest mode (column of ``phi_rest``), the index of the spinning mode most like it:
    the largest ``(φᵀ M s)²`` (both sets mass-normalised, so this is the modal assurance
    criterion in the mass metric)."""
    M3 = jnp.kron(body.mass_matrix(), jnp.eye(3))
    mac = np.asarray(jnp.asarray(phi_rest).T @ M3 @ jnp.asarray(phi_spin)) ** 2
    return np.argmax(mac, axis=1)


def spinning_stiffness(full, q_star: Float[Array, "n 3"], omega: float) -> Float[Array, "ndof ndof"]:
    """``K(q*) + ω² M ⊗ ẽẽ`` (all coordinates; restrict to the free ones)."""
    E = skew(full.axis)
    return frame_stiffened(full.body, q_star, omega**2 * (E @ E))


def ritz_frequencies(full, q_star: Float[Array, "n 3"], omega: float, Psi: Float[Array, "ndof km"]) -> np.ndarray:
    """Rayleigh-Ritz estimates (ascending, rad/s) of the spinning body's frequencies in the
    span of ``Psi``: the eigenvalues of ``(ΨᵀK*Ψ, ΨᵀMΨ)``, upper bounds of the exact ones."""
    free = np.flatnonzero(np.asarray(full.free_mask()))
    K = np.asarray(spinning_stiffness(full, q_star, omega))[np.ix_(free, free)]
    M = np.kron(np.asarray(full.body.mass_matrix()), np.eye(3))[np.ix_(free, free)]
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
