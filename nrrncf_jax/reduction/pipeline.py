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
from .basis_choice import Basis, SpinState
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


def nr_rncf(full: RotatingFrameModel, ts_mmi, basis: Basis = Basis(), *, force: str = "auto", error_rows=None,
            modes=None) -> Reduction:
    """Build the NR-RNCF reduced model of ``full`` for its load case (paper Fig. 2), with the
    columns that ``basis`` (a ``Basis``) describes.

    Its ``n_modes`` candidate vibration modes enter the linear MMI simulation over ``ts_mmi``; its
    ``vms``/``mds`` choose among them (``selection.select``): with ``vms='auto'`` the modes kept lie
    below ``band`` times the largest spin rate θ̇ of the manoeuvre, or are strongly loaded; with
    ``mds='auto'`` the MDs of largest weight are added while VMs + MDs ≤ ``max_dofs``. Its
    ``spin_state`` (a ``SpinState``) checks the basis against the spinning state and enriches it
    where the check fails (``reduction.spin_state``; ``spin`` of the result holds the check).

    Returns a ``Reduction``. ``force``: the reduced elastic force's form (``reduce_rotating_model``).
    ``error_rows``: see ``reduce_rotating_model``. ``modes``: the full model's vibration modes at
    rest (``vibration_modes`` on its free coordinates, at least ``n_modes`` of them), when the
    caller has computed them already; their time is then not in ``offline_s``. A basis chosen to a
    target error instead is ``nr_rncf_to_tolerance``'s.
    """
    if not isinstance(basis, Basis):
        raise ValueError(f"basis must be a reduction.Basis, got {type(basis).__name__}")
    if not isinstance(full, RotatingFrameModel):
        raise ValueError("nr_rncf reduces a RotatingFrameModel (RNCF); got " + type(full).__name__)
    b, spin_state = basis, basis.spin_state
    n_modes, max_dofs, md_method, deflation_tol = b.n_modes, b.max_dofs, b.md_method, b.deflation_tol
    body, free = full.body, full.free_mask()
    modes, W, spin, times = modal_interaction(full, ts_mmi, n_modes, modes)
    choose = functools.partial(select, W, b.vms, b.mds, vm_tol=b.vm_tol, md_tol=b.md_tol, max_mds=b.max_mds,
                               omega=modes.omega, omega_band=b.band * spin if b.band else None)
    t0 = time.perf_counter()
    sel = choose(max_dofs=max_dofs)
    times["mmi"] += time.perf_counter() - t0

    t0 = time.perf_counter()
    basis = rest = modal_basis(body, free, modes.phi, sel.pairs, vms=sel.vms, md_method=md_method,
                               deflation_tol=deflation_tol)
    times["modal_derivatives"] = time.perf_counter() - t0

    check = None
    if spin_checked(full, spin_state.check, spin, bool(sel.pairs)):
        t0 = time.perf_counter()
        sel, extra, check = _spin_enrichment(full, modes, sel, rest.Psi, spin, n_modes, spin_state, choose,
                                             max_dofs, md_method)
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
    """Whether a basis gets the spinning-state check (``SpinState.check``, ``spin_state``): always with
    ``True``; with ``"auto"`` for a basis with MDs under a steady spin about a fixed axis that
    spins (a structure excited by loads in a stationary frame has no spinning state).
    ``ValueError`` for ``True`` under a manoeuvre that does not spin."""
    if spin_state is True and spin <= 0.0:
        raise ValueError("spin_state=True needs a manoeuvre that spins (its largest spin rate is 0)")
    return spin_state is True or (spin_state == "auto" and has_mds and spin > 0.0
                                  and isinstance(full.motion, AbstractAxisMotion))


def _spin_enrichment(full, modes, sel, Psi_rest, spin, n_modes, options: SpinState, choose, max_dofs, md_method,
                     spinning=None):
    """The spinning-state check and, if it fails (or ``options.check is True``), the enrichment:
    returns the (possibly trimmed) rest selection, the spinning-state columns (``options.vms``
    spinning modes and the modal derivatives of ``options.mds`` pairs of them, ``modal_basis``;
    None when not enriched) and the ``SpinCheck``. ``spinning``: ``spinning_modes(full, spin, n_modes)`` when the
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
    enrich = options.check is True or abs(estimate / exact - 1.0) > options.tol
    if not enrich:
        return sel, None, SpinCheck(spin, dominant, exact, estimate, False)
    svms = list(dict.fromkeys(int(match[i]) for i in by_weight))[:options.vms]
    ranked = sorted(((i, j) for a, i in enumerate(sel.vms) for j in sel.vms[a:]), key=lambda ij: -W[ij])
    spairs = list(dict.fromkeys(tuple(sorted((int(match[i]), int(match[j])))) for i, j in ranked))[:options.mds]
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
