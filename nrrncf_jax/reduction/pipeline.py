"""The NR-RNCF reduction pipeline (paper Fig. 2): modes → linear MMI simulation → selection →
modal derivatives → SVD deflation → reduced tensors."""

import dataclasses
import functools
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..models.full_order import RotatingFrameModel
from ..motion import AbstractAxisMotion
from .basis import modal_basis
from .modes import vibration_modes
from .reduced_model import ReducedRotatingModel, modal_loads, reduce_rotating_model
from .selection import Selection, align_degenerate_modes, mmi_matrix, modal_response, purify_close_modes, select
from .spin_state import SpinCheck, match_modes, ritz_frequencies, spinning_modes


@dataclasses.dataclass
class Reduction:
    """A reduced model with the record of how its basis was chosen."""

    model: ReducedRotatingModel
    omega: np.ndarray  # candidate natural frequencies [rad/s]
    selection: Selection
    n_vms: int
    n_mds: int
    offline_s: dict  # wall time per offline stage (compilation included)
    spin: SpinCheck | None = None  # the spinning-state check (None: not made)
    search: object = None  # ``basis_to_tolerance.BasisSearch`` when chosen to a tolerance (None: not)
    phi: np.ndarray | None = None  # the candidate modes the basis was built from (aligned and purified)

    @property
    def dofs(self) -> int:
        return self.model.n_dof

    @property
    def n_spin(self) -> int:
        """Columns added by the spinning-state enrichment (before deflation)."""
        return 0 if self.spin is None or not self.spin.enriched else len(self.spin.vms) + len(self.spin.pairs)

    def describe(self) -> str:
        """Where the reduced coordinates come from, e.g. ``14 DOFs (3 VMs + 6 MDs + 5 spinning-state
        vectors: 1 spinning mode + 4 MDs of spinning modes)``: every basis column, and how many the
        SVD deflation removed when it removed any."""
        parts = [f"{self.n_vms} VMs", f"{self.n_mds} MDs"]
        if self.n_spin:
            modes = len(self.spin.vms)
            parts.append(f"{self.n_spin} spinning-state vectors: {modes} spinning mode{'s' if modes > 1 else ''} + "
                         f"{len(self.spin.pairs)} MDs of spinning modes")
        removed = self.n_vms + self.n_mds + self.n_spin - self.dofs
        tail = f"; {removed} removed by the SVD deflation" if removed > 0 else ""
        return f"{self.dofs} DOFs ({' + '.join(parts)}{tail})"


def _modal_damping_ratio(full, omega):
    """ζ_i = α/(2ω_i) + βω_i/2 of the full model's Rayleigh damping (None when undamped)."""
    if full.damping is None:
        return None
    omega = np.asarray(omega)
    return float(full.damping.alpha) / (2.0 * omega) + float(full.damping.beta) * omega / 2.0


def nr_rncf(full: RotatingFrameModel, ts_mmi, *, n_modes: int = 24, vms="auto", mds="auto",
            band: float = 6.0, vm_tol: float = 1e-6, md_tol: float = 0.01, max_mds: int | None = None,
            max_dofs: int | None = 25, md_method: str = "closed_form", deflation_tol: float = 1e-6,
            force: str = "auto", spin_state: bool | str = "auto", spin_vms: int = 1, spin_mds: int = 4,
            spin_tol: float = 2e-3, error_rows=None, modes=None, tol: float | None = None,
            training: dict | None = None) -> Reduction:
    """Build the NR-RNCF reduced model of ``full`` for its load case.

    ``n_modes`` candidate vibration modes enter the linear MMI simulation over ``ts_mmi``;
    ``vms``/``mds`` choose among them (see ``selection.select``); with ``vms='auto'`` the modes
    kept lie below ``band`` times the largest spin rate θ̇ of the manoeuvre, or are strongly
    loaded; with ``mds='auto'`` the MDs of largest weight are added while VMs + MDs ≤
    ``max_dofs``.

    Spinning-state enrichment (beyond the paper; ``reduction.spin_state``): at the largest spin
    rate of the manoeuvre the spinning equilibrium and its modes are computed, and the rest
    basis's Rayleigh-Ritz estimate of the frequency of the spinning mode that continues the
    dominant VM (largest W_ii) is compared with the exact one. With ``spin_state='auto'`` the
    basis is enriched when that estimate is off by more than ``spin_tol`` (relative), and only
    for bases with modal derivatives; ``True`` always enriches, ``False`` never checks. The
    enrichment is ``spin_vms`` spinning modes and the ``spin_mds`` modal derivatives (at rest)
    of spinning-mode pairs, both ranked by the MMI weight of the rest modes they continue; the
    rest MDs give way so that the total stays within ``max_dofs``. Returns a ``Reduction``
    (``spin`` holds the check). ``error_rows``: see ``reduce_rotating_model``. ``modes``: the
    full model's vibration modes at rest (``vibration_modes`` on its free coordinates, at least
    ``n_modes`` of them), when the caller has computed them already; their time is then not in
    ``offline_s``.

    ``tol``: a target χ_rel in per cent. The basis is then grown along the MMI ranking until the
    a-posteriori error estimate of a training run over ``ts_mmi`` is at most ``tol / safety``
    (``basis_to_tolerance.nr_rncf_to_tolerance``, safety 2 by default; with ``training`` its further keyword
    arguments: the run's ``rho_inf``, ``rtol``, ``atol``, ``samples``, ...); ``max_dofs`` caps
    the basis tried, ``vms``, ``mds``, ``max_mds``, ``md_tol`` and ``band`` are not used, the
    spinning-state enrichment is checked for every basis tried, and ``search`` of the result
    records every basis tried.
    """
    if spin_state not in ("auto", True, False):
        raise ValueError(f"spin_state must be 'auto', True or False, got {spin_state!r}")
    if tol is not None:
        from .basis_to_tolerance import nr_rncf_to_tolerance  # it builds on this module

        return nr_rncf_to_tolerance(full, ts_mmi, tol, n_modes=n_modes, vm_tol=vm_tol, max_dofs=max_dofs,
                                    md_method=md_method, deflation_tol=deflation_tol, modes=modes,
                                    error_rows=error_rows, spin_state=spin_state, spin_vms=spin_vms,
                                    spin_mds=spin_mds, spin_tol=spin_tol, **(training or {}))
    if not isinstance(full, RotatingFrameModel):
        raise ValueError("nr_rncf reduces a RotatingFrameModel (RNCF); got " + type(full).__name__)
    body, free = full.body, full.free_mask()
    modes, W, spin, times = modal_interaction(full, ts_mmi, n_modes, modes)
    choose = functools.partial(select, W, vms, mds, vm_tol=vm_tol, md_tol=md_tol, max_mds=max_mds,
                               omega=modes.omega, omega_band=band * spin if band else None)
    t0 = time.perf_counter()
    sel = choose(max_dofs=max_dofs)
    times["mmi"] += time.perf_counter() - t0

    t0 = time.perf_counter()
    basis = rest = modal_basis(body, free, modes.phi, sel.pairs, vms=sel.vms, md_method=md_method,
                               deflation_tol=deflation_tol)
    times["modal_derivatives"] = time.perf_counter() - t0

    check = None
    if spin_checked(full, spin_state, spin, bool(sel.pairs)):
        t0 = time.perf_counter()
        sel, extra, check = _spin_enrichment(full, modes, sel, rest.Psi, spin, n_modes, spin_state is True,
                                             spin_vms, spin_mds, spin_tol, choose, max_dofs, md_method)
        if extra is not None:
            # The rest MDs kept are the first ones of the rest basis (the same ranking, cut shorter).
            basis = modal_basis(body, free, modes.phi, sel.pairs, vms=sel.vms, extra=[extra],
                                theta=rest.theta[:, : len(sel.pairs)] if sel.pairs else None,
                                deflation_tol=deflation_tol)
        times["spin_state"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    model = _reduce(full, basis.Psi, force=force)
    if error_rows is not None:
        model = model.with_error_rows(error_rows)
    jax.block_until_ready(model.elastic.N)
    times["tensors"] = time.perf_counter() - t0
    times["total"] = sum(times.values())
    return Reduction(model=model, omega=np.asarray(modes.omega), selection=sel, n_vms=len(sel.vms),
                     n_mds=len(sel.pairs), offline_s=times, spin=check, phi=np.asarray(modes.phi))


def modal_interaction(full: RotatingFrameModel, ts_mmi, n_modes: int = 24, modes=None):
    """The maximum-modal-interaction data of ``full``'s load case (Eq. 39): its ``n_modes``
    vibration modes at rest (``modes`` when the caller has them: at least ``n_modes`` of them),
    each cluster of equal frequencies aligned to the loads and close pairs purified of the
    eigensolver's round-off (``align_degenerate_modes``), the MMI matrix ``W`` of the linear
    simulation over ``ts_mmi``, and the manoeuvre's largest spin rate. Returns
    ``(modes, W, spin, offline_s)`` with the wall time of the ``'modes'`` and ``'mmi'`` stages."""
    times = {}
    body, free = full.body, full.free_mask()
    t0 = time.perf_counter()
    if modes is None:
        modes = vibration_modes(body, free, n_modes)
    else:
        if modes.phi.shape[0] != body.n_dof or modes.omega.shape[0] < n_modes:
            raise ValueError(f"modes must hold at least n_modes={n_modes} modes of the full model's {body.n_dof} "
                             f"coordinates, got phi of shape {tuple(modes.phi.shape)}")
        modes = eqx.tree_at(lambda m: (m.omega, m.phi), modes, (modes.omega[:n_modes], modes.phi[:, :n_modes]))
    jax.block_until_ready(modes.phi)
    times["modes"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    ts_mmi = jnp.asarray(ts_mmi, dtype=float)
    _, vectors, _ = _mmi_loads(full, modes.phi, ts_mmi)
    phi = align_degenerate_modes(modes.phi, modes.omega, vectors)
    if modes.lambda_max is not None:
        history, _, _ = _mmi_loads(full, phi, ts_mmi)
        phi = purify_close_modes(phi, modes.omega, np.asarray(history).T, modes.lambda_max)
    modes = eqx.tree_at(lambda m: m.phi, modes, phi)
    history, _, spin = _mmi_loads(full, phi, ts_mmi)
    eta = modal_response(ts_mmi, history, modes.omega, _modal_damping_ratio(full, modes.omega))
    W = mmi_matrix(ts_mmi, eta)
    times["mmi"] = time.perf_counter() - t0
    return modes, W, float(spin), times


def spin_checked(full, spin_state, spin: float, has_mds: bool) -> bool:
    """Whether a basis gets the spinning-state check (``nr_rncf``'s ``spin_state``): always with
    ``True``; with ``"auto"`` for a basis with MDs under a steady spin about a fixed axis that
    spins (a structure excited by loads in a stationary frame has no spinning state).
    ``ValueError`` for ``True`` under a manoeuvre that does not spin."""
    if spin_state is True and spin <= 0.0:
        raise ValueError("spin_state=True needs a manoeuvre that spins (its largest spin rate is 0)")
    return spin_state is True or (spin_state == "auto" and has_mds and spin > 0.0
                                  and isinstance(full.motion, AbstractAxisMotion))


def _spin_enrichment(full, modes, sel, Psi_rest, spin, n_modes, always, n_vms, n_mds, tol, choose, max_dofs,
                     md_method, spinning=None):
    """The spinning-state check and, if it fails (or ``always``), the enrichment: returns the
    (possibly trimmed) rest selection, the spinning-state columns (``n_vms`` spinning modes and
    the modal derivatives of ``n_mds`` pairs of them, ``modal_basis``; None when not enriched)
    and the ``SpinCheck``. ``spinning``: ``spinning_modes(full, spin, n_modes)`` when the
    caller has it (a basis search checks many bases against one spinning state)."""
    body, free = full.body, full.free_mask()
    q_star, smodes = spinning_modes(full, spin, n_modes) if spinning is None else spinning
    sphi = np.asarray(smodes.phi)
    match = match_modes(full.body.mass_matrix() if full.M is None else full.M, modes.phi, sphi)
    W = np.asarray(sel.W)
    by_weight = sorted(sel.vms, key=lambda i: -W[i, i])
    dominant = int(match[by_weight[0]])
    exact = float(np.asarray(smodes.omega)[dominant])
    ritz = ritz_frequencies(full, q_star, spin, Psi_rest)
    estimate = float(ritz[np.argmin(np.abs(ritz - exact))])
    enrich = always or abs(estimate / exact - 1.0) > tol
    if not enrich:
        return sel, None, SpinCheck(spin, dominant, exact, estimate, False)
    svms = list(dict.fromkeys(int(match[i]) for i in by_weight))[:n_vms]
    ranked = sorted(((i, j) for a, i in enumerate(sel.vms) for j in sel.vms[a:]), key=lambda ij: -W[ij])
    spairs = list(dict.fromkeys(tuple(sorted((int(match[i]), int(match[j])))) for i, j in ranked))[:n_mds]
    n_rest_pairs = len(sel.pairs)
    if max_dofs is not None:
        trimmed = choose(max_dofs=max(len(sel.vms), max_dofs - len(svms) - len(spairs)))
        assert trimmed.pairs == sel.pairs[: len(trimmed.pairs)]  # the same ranking, cut shorter
        sel = trimmed
    # The MDs padded to the rest MDs' count: the kernel compiled for those serves these too.
    extra = modal_basis(body, free, smodes.phi, spairs, vms=svms, md_method=md_method, pad_to=n_rest_pairs).columns
    return sel, extra, SpinCheck(spin, dominant, exact, estimate, True, tuple(svms), tuple(spairs))


@eqx.filter_jit
def _mmi_loads(full, phi, ts):
    """``modal_loads`` (the loads of the linear MMI model and their load vectors) and the
    largest spin rate max|ω| over ``ts``: one compiled kernel (op by op, evaluating the
    motion on the time grid compiled a score of kernels on every cold start)."""
    history, vectors = modal_loads(full, phi, ts)
    w = jax.vmap(full.motion.angular_velocity)(ts)
    return history, vectors, jnp.max(jnp.sqrt(jnp.sum(w * w, axis=-1)))  # √(θ̇²) = |θ̇| exactly


@eqx.filter_jit
def _reduce(full, Psi, force):
    """``reduce_rotating_model`` as one compiled kernel: the tensors are compiled kernels
    already, and the load maps around them compiled op by op on every cold start."""
    return reduce_rotating_model(full, Psi, force=force)
