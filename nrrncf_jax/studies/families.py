"""Parameterised reduced models: a family maps ``{E, zeta, omega_s, T_s}`` to a reduced model.

Two gradient paths:

- ``SpinupFamily`` (basis held fixed): κ is linear in E, so the reduced elastic tensors scale
  with E/E₀ (``ElasticTensors.scaled``); damping and spin-up enter the reduced equations
  directly. For a homogeneous body this is exact in E: K ∝ E and M does not depend on E, so
  the modes and the modal derivatives θ = −K⁻¹(∂K/∂η)φ do not change with E.
- ``OfflineSpinupFamily``: the reduced model is rebuilt from the parameters through the whole
  offline stage (element integrals, modes by ``eigh``, modal derivatives, deflation, tensors),
  with the discrete choices (which VMs and MD pairs, the deflation's rank) held at their
  nominal values. An eigenvector's derivative divides by its eigenvalue gaps, so a selected
  mode with a repeated eigenvalue (a tube's two bending planes) has no unique derivative:
  ``offline_family`` checks the nominal spectrum and, when a selected mode is degenerate,
  warns and returns the fixed-basis family instead.

The damping is Rayleigh damping with ratio ζ at two reference frequencies of the model
(``RayleighDamping.from_ratio``); they scale as √(E/E₀) with E, so ζ keeps its meaning —
"ζ in these two modes" — while E changes.
"""

import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _validate
from .._types import Array, Float
from ..bodies.body import beam_body
from ..elements.material import Material
from ..models.damping import RayleighDamping
from ..models.full_order import Loads, RotatingFrameModel
from ..reduction.basis import modal_basis
from ..reduction.modes import vibration_modes
from ..reduction.reduced_model import ReducedRotatingModel, reduce_rotating_model

PARAMETERS = ("E", "zeta", "omega_s", "T_s")
"""Parameters of a ``SpinupFamily``: Young's modulus [Pa], Rayleigh damping ratio ζ, steady
spin rate ωs [rad/s] and spin-up time Ts [s] of Eq. 43. All are positive."""

OFFLINE_PARAMETERS = PARAMETERS + ("nu",)
"""``OfflineSpinupFamily`` also takes Poisson's ratio, which changes the basis."""


class DegenerateModesWarning(UserWarning):
    """The offline gradient path met a repeated eigenvalue and fell back to the fixed basis."""


def check_params(params: dict, allowed) -> None:
    unknown = sorted(set(params) - set(allowed))
    if unknown:
        raise ValueError(f"unknown parameter(s) {unknown}; this family knows {list(allowed)}")
    for k, v in params.items():
        if k == "nu":
            continue
        _validate.positive(k, v)


class SpinupFamily(eqx.Module):
    """The reduced spin-up model as a function of ``{E, zeta, omega_s, T_s}`` with the basis
    held fixed (gradient path (a)); parameters left out keep the template's values."""

    template: ReducedRotatingModel
    E0: Float[Array, ""]
    omega_ref: Float[Array, " 2"]  # Rayleigh reference frequencies at E0 [rad/s]

    def __init__(self, template: ReducedRotatingModel, E0, omega_ref):
        _validate.positive("E0 (Young's modulus of the template)", E0)
        omega_ref = jnp.asarray(omega_ref, dtype=float).reshape(-1)
        if omega_ref.shape != (2,) or not bool(jnp.all(omega_ref > 0)):
            raise ValueError(f"omega_ref must be two positive frequencies [rad/s], got {omega_ref}")
        self.template = template
        self.E0 = jnp.asarray(E0, dtype=float)
        self.omega_ref = omega_ref

    @classmethod
    def from_reduction(cls, reduction, E0, omega_ref=None) -> "SpinupFamily":
        """The family of a ``Reduction`` whose body has Young's modulus ``E0``; ``omega_ref``
        defaults to the two lowest kept modes (``reference_frequencies``)."""
        return cls(reduction.model, E0, reference_frequencies(reduction) if omega_ref is None else omega_ref)

    def damping(self, zeta, E):
        return _rayleigh(zeta, E, self.E0, self.omega_ref)

    def __call__(self, params: dict) -> ReducedRotatingModel:
        check_params(params, PARAMETERS)
        m = self.template
        E = params.get("E", self.E0)
        if "E" in params:
            m = eqx.tree_at(lambda r: r.elastic, m, m.elastic.scaled(E / self.E0))
        if "zeta" in params:
            m = eqx.tree_at(lambda r: r.damping, m, self.damping(params["zeta"], E), is_leaf=lambda x: x is None)
        return _with_motion(m, params)


def _rayleigh(zeta, E, E0, omega_ref) -> RayleighDamping:
    """Ratio ζ at the two reference modes, whose frequencies scale as √(E/E0)."""
    w = omega_ref * jnp.sqrt(E / E0)
    return RayleighDamping.from_ratio(zeta, w[0], w[1])


def _with_motion(m: ReducedRotatingModel, params: dict) -> ReducedRotatingModel:
    if "omega_s" in params or "T_s" in params:
        motion = type(m.motion)(params.get("omega_s", m.motion.omega_s), params.get("T_s", m.motion.T_s),
                                axis=m.motion.axis)
        m = eqx.tree_at(lambda r: r.motion, m, motion)
    return m




def reference_frequencies(reduction) -> tuple[float, float]:
    """The Rayleigh reference frequencies of a reduction: its two lowest kept vibration modes."""
    w = sorted(float(reduction.omega[i]) for i in reduction.selection.vms)
    if len(w) < 2:
        raise ValueError("the reduction keeps fewer than two vibration modes; give omega_ref explicitly")
    return w[0], w[1]


class OfflineSpinupFamily(eqx.Module):
    """The reduced spin-up model rebuilt from ``{E, nu, zeta, omega_s, T_s}`` through the whole
    offline stage (gradient path (b)); build it with ``offline_family``.

    Held at their nominal values: the selected VMs and MD pairs, the deflation map
    ``T0 = diag(1/‖x‖) V_r Σ_r⁻¹`` of Algorithm 1 (so Ψ = X T0 is U_r at the nominal point and
    a smooth function of the parameters nearby), each mode's sign (aligned with the nominal
    mode through M, since ``eigh`` may flip it), and the rotation ``R0`` (k × k, near the
    identity) from the nominal eigenvectors to the reduction's candidate modes, which
    ``nr_rncf`` aligned and purified of the eigensolver's round-off (``purify_close_modes``):
    Φ(parameters) R0 is the reduction's Φ at the nominal point.
    """

    preset: object = eqx.field(static=True)  # scenarios.BeamPreset (frozen, hashable)
    elements: int = eqx.field(static=True)
    n_modes: int = eqx.field(static=True)
    vms: tuple = eqx.field(static=True)
    pairs: tuple = eqx.field(static=True)
    template: ReducedRotatingModel
    loads: Loads
    phi0: Float[Array, "ndof k"]
    R0: Float[Array, "k k"]
    T0: Float[Array, "s km"]
    E0: Float[Array, ""]
    nu0: Float[Array, ""]
    omega_ref: Float[Array, " 2"]

    def damping(self, zeta, E):
        return _rayleigh(zeta, E, self.E0, self.omega_ref)

    def basis(self, body, free):
        """Ψ(parameters) = [Φ_vms, Θ_pairs] T0 with the nominal signs."""
        modes = vibration_modes(body, free, self.n_modes)
        M = jnp.kron(body.mass_matrix(), jnp.eye(3))
        sign = jax.lax.stop_gradient(jnp.sign(jnp.sum(self.phi0 * (M @ modes.phi), axis=0)))
        return modal_basis(body, free, (modes.phi * sign) @ self.R0, self.pairs, vms=self.vms).columns @ self.T0

    def __call__(self, params: dict) -> ReducedRotatingModel:
        check_params(params, OFFLINE_PARAMETERS)
        E = params.get("E", self.E0)
        nu = params.get("nu", self.nu0)
        p = self.preset
        body = beam_body(Material(E, p.rho, nu), p.section, p.reference(self.elements))
        m = self.template
        damping = self.damping(params["zeta"], E) if "zeta" in params else m.damping
        if damping is not None and "zeta" not in params:
            damping = self.damping(damping.ratio(self.omega_ref[0]), E)
        full = RotatingFrameModel(body, m.motion, loads=self.loads, damping=damping)
        Psi = self.basis(body, full.free_mask())
        red = reduce_rotating_model(full, Psi, force="tensor")
        return _with_motion(red, params)


def offline_family(full: RotatingFrameModel, reduction, preset, *, omega_ref=None, gap_rtol: float = 1e-6):
    """The offline-stage family (path (b)) of a reduction made by ``nr_rncf(full, ...)`` of the
    ``preset`` beam; with a repeated eigenvalue among the selected modes (relative gap below
    ``gap_rtol``), warns (``DegenerateModesWarning``) and returns the fixed-basis
    ``SpinupFamily`` instead. A basis with the spinning-state enrichment (``reduction.spin``)
    also falls back to the fixed basis, with a ``UserWarning``: its spinning equilibrium comes
    from a Newton loop this path does not differentiate."""
    body = full.body
    n_el = body.n_elements
    omega_ref = reference_frequencies(reduction) if omega_ref is None else omega_ref
    if reduction.n_spin:
        warnings.warn("the basis has the spinning-state enrichment, which the offline path does not "
                      "differentiate; using the fixed-basis family (exact for E of a homogeneous body)",
                      UserWarning, stacklevel=2)
        return SpinupFamily(reduction.model, preset.E, omega_ref)
    sel = reduction.selection
    used = sorted(set(sel.vms) | {i for pair in sel.pairs for i in pair})
    w = np.asarray(reduction.omega)
    modes = vibration_modes(body, full.free_mask(), len(w) + 1)  # one more: the gap above the last candidate
    all_w = np.asarray(modes.omega)
    for i in used:
        others = np.delete(all_w, i)
        gap = np.min(np.abs(others - w[i])) / w[i]
        if gap < gap_rtol:
            warnings.warn(
                f"mode {i} (0-based; {w[i]:.6g} rad/s) has a repeated eigenvalue (relative gap {gap:.1e}): its "
                "eigenvector has no unique derivative, so the gradient cannot go through the offline stage; "
                "using the fixed-basis family (exact for E of a homogeneous body)", DegenerateModesWarning,
                stacklevel=2)
            return SpinupFamily(reduction.model, preset.E, omega_ref)
    phi = modes.phi[:, : len(w)]
    if reduction.phi is None:
        R0 = jnp.eye(len(w))
    else:  # Φ0ᵀ M Φ_red: Φ_red lies in the span of Φ0 (rotated within the candidates)
        R0 = phi.T @ (jnp.kron(body.mass_matrix(), jnp.eye(3)) @ jnp.asarray(reduction.phi, dtype=float))
    basis = modal_basis(body, full.free_mask(), phi @ R0, sel.pairs, vms=sel.vms)
    T0 = jnp.asarray(basis.deflation_map(reduction.model.n_dof), dtype=float)  # X T0 = the reduction's Ψ
    return OfflineSpinupFamily(
        preset=preset, elements=n_el, n_modes=len(w), vms=tuple(sel.vms), pairs=tuple(sel.pairs),
        template=reduction.model, loads=full.loads, phi0=phi, R0=R0, T0=T0, E0=jnp.asarray(preset.E, dtype=float),
        nu0=jnp.asarray(preset.nu, dtype=float), omega_ref=jnp.asarray(omega_ref, dtype=float),
    )
