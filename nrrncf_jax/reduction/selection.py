"""Maximum modal interaction (Eq. 39): which vibration modes and modal derivatives to keep.

``W_ij = ∫₀ᵀ |η_i(t) η_j(t)| dt`` from a *linear* simulation of the same load case with the
vibration-mode basis: ``Ī η̈ + K η = −θ̈ ḡ − θ̇² c̄ + Φᵀ Q`` (the elastic force linearised, the
rotation kept as the load it exerts; the parametric centrifugal and Coriolis terms are left
out, so the linear model stays stable above the first critical speed).
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import scipy.linalg
import scipy.optimize

from .._types import Array, Float


class Selection(eqx.Module):
    """W (k × k), the VMs kept (indices into the candidate modes) and the MD pairs kept."""

    W: Float[Array, "k k"]
    vms: tuple[int, ...] = eqx.field(static=True)
    pairs: tuple[tuple[int, int], ...] = eqx.field(static=True)


def modal_response(ts, loads, omega, zeta=None) -> np.ndarray:
    """η(t) of the decoupled modal oscillators ``η̈_i + 2ζ_i ω_i η̇_i + ω_i² η_i = l_i(t)``,
    starting from rest at ``ts[0]``, with the load ``loads`` (nt × k) varying linearly between
    the sample times (a first-order hold); returns η at ``ts`` (nt × k).

    This is the linear MMI simulation of Eq. 39 solved exactly: with mass-normalised modes
    ``Ī = I`` and ``K̄ = diag(ω²)``, and Rayleigh damping stays diagonal
    (``2ζ_i ω_i = α + β ω_i²``). Each oscillator's step map is the exponential of its 4 × 4
    augmented state matrix ``[[A, b, 0], [0, 0, 1], [0, 0, 0]]`` (state, load, load slope),
    one per distinct step size (Van Loan). Plain NumPy/SciPy rather than the time integrator:
    nothing to compile, and no step-size error in W.
    """
    ts = np.asarray(ts, dtype=float)
    loads = np.asarray(loads, dtype=float)
    omega = np.asarray(omega, dtype=float)
    k = omega.shape[0]
    if loads.shape != (ts.shape[0], k):
        raise ValueError(f"loads must have shape ({ts.shape[0]}, {k}), got {loads.shape}")
    zeta = np.zeros(k) if zeta is None else np.broadcast_to(np.asarray(zeta, dtype=float), (k,))
    h_all = np.diff(ts)
    if np.any(h_all <= 0):
        raise ValueError("ts must be strictly increasing")

    def step_maps(h):
        Z = np.zeros((k, 4, 4))
        Z[:, 0, 1] = 1.0
        Z[:, 1, 0] = -(omega**2)
        Z[:, 1, 1] = -2.0 * zeta * omega
        Z[:, 1, 2] = 1.0
        Z[:, 2, 3] = 1.0
        E = scipy.linalg.expm(Z * h)  # stacked: one 4 × 4 exponential per mode
        return E[:, :2, :2], E[:, :2, 2], E[:, :2, 3] / h  # Φ, Γ_load, Γ_slope·(1/h)

    maps = {}
    x = np.zeros((k, 2))
    eta = np.zeros((ts.shape[0], k))
    for n, h in enumerate(h_all):
        key = float(np.float32(h))  # grids from linspace differ in the last bits only
        if key not in maps:
            maps[key] = step_maps(h)
        Phi, G0, G1 = maps[key]
        x = np.einsum("kab,kb->ka", Phi, x) + G0 * loads[n, :, None] + G1 * (loads[n + 1] - loads[n])[:, None]
        eta[n + 1] = x[:, 0]
    return eta


def mmi_matrix(ts: Float[Array, " nt"], eta: Float[Array, "nt k"]) -> np.ndarray:
    """W_ij = ∫|η_i η_j| dt by the trapezoidal rule on the sample times: with the rule's
    weights w_t, ``W = |η|ᵀ diag(w) |η|`` (``|η_i η_j| = |η_i| |η_j|``).

    NumPy, like ``modal_response``: a one-off product on concrete data (op by op, jnp compiled
    a kernel for each of its steps on every cold start)."""
    ts = np.asarray(ts, dtype=float)
    A = np.abs(np.asarray(eta, dtype=float))
    dt = np.diff(ts)
    w = 0.5 * (np.concatenate([dt, [0.0]]) + np.concatenate([[0.0], dt]))
    return (A * w[:, None]).T @ A


def select(W, n_vms: int | str = "auto", n_mds: int | str = "auto", vm_tol: float = 1e-6,
           md_tol: float = 0.01, max_mds: int | None = None, omega=None, omega_band: float | None = None,
           vm_strong: float = 1e-3, max_dofs: int | None = None) -> Selection:
    """Choose VMs and MDs from the MMI matrix.

    - VMs: ``'auto'`` keeps the modes that take part, whose RMS amplitude is at least ``vm_tol``
      times the largest (``W_ii ≥ vm_tol² max W_kk``). Given the natural frequencies ``omega``
      and a band ``omega_band`` (e.g. a few times the spin rate: the frequencies the rotation's
      Coriolis and centrifugal coupling reach), only modes inside the band are kept, except
      strongly loaded ones (amplitude ratio ≥ ``vm_strong``, e.g. the axial mode under
      centrifugal load, which responds quasi-statically far above the band). An integer keeps
      that many of the most active modes; a list of mode indices keeps those. ``max_dofs`` caps
      VMs + MDs (before deflation).
    - MDs among the kept VMs, ranked by W_ij: ``'auto'`` keeps those with
      ``(W_ij / max W)^(1/4) ≥ md_tol`` (the fourth root as in the paper's bar plots), at most
      ``max_mds`` of them; an integer keeps that many; a list of (i, j) pairs is taken as given.
    """
    W = np.asarray(W)
    d = np.diag(W)
    order = np.argsort(-d)
    if n_vms == "auto":
        amp = np.sqrt(d / d.max())
        keep = amp >= vm_tol
        if omega is not None and omega_band is not None:
            keep &= (np.asarray(omega) <= omega_band) | (amp >= vm_strong)
        vms = sorted(int(i) for i in np.flatnonzero(keep))
    elif isinstance(n_vms, (int, np.integer)):
        vms = sorted(int(i) for i in order[: int(n_vms)])
    else:  # the modes given, e.g. the paper's choice by mode shape
        vms = sorted({int(i) for i in n_vms})
        if not vms or vms[0] < 0 or vms[-1] >= len(d):
            raise ValueError(f"the VMs given must be mode indices in 0..{len(d) - 1}, got {list(n_vms)}")
    cand = [(i, j) for a, i in enumerate(vms) for j in vms[a:]]
    w = np.array([W[i, j] for i, j in cand])
    rank = np.argsort(-w, kind="stable")
    if isinstance(n_mds, str):
        if n_mds != "auto":
            raise ValueError(f"n_mds must be 'auto', an integer or a list of pairs, got {n_mds!r}")
        pairs = [cand[r] for r in rank if (w[r] / w.max()) ** 0.25 >= md_tol][:max_mds]
        if max_dofs is not None:
            pairs = pairs[: max(0, int(max_dofs) - len(vms))]
    elif isinstance(n_mds, (int, np.integer)):
        pairs = [cand[r] for r in rank[: int(n_mds)]]
    else:
        pairs = [(min(i, j), max(i, j)) for i, j in n_mds]
    return Selection(W=jnp.asarray(W, dtype=float), vms=tuple(vms), pairs=tuple(pairs))


def align_degenerate_modes(phi: Float[Array, "ndof k"], omega, loads: Float[Array, "k m"], rtol: float = 1e-4):
    """Rotate each cluster of equal frequencies (a tube's two bending planes) so that the load
    acts on as few of its modes as possible.

    Inside a degenerate eigenspace any orthonormal mix is an eigenvector, and an arbitrary mix
    of in-plane and out-of-plane bending hides which motion a planar load excites. With
    ``loads`` the modal load vectors (rows: one per mode, e.g. φᵀḡ, φᵀc̄, φᵀϱ), the left
    singular vectors of a cluster's rows give the rotation: the first mode takes the most load,
    the last the least. The rotated modes stay mass-orthonormal eigenvectors.
    """
    omega = np.asarray(omega)
    loads = np.asarray(loads)
    phi = np.asarray(phi).copy()
    i = 0
    while i < len(omega):
        j = i + 1
        while j < len(omega) and omega[j] - omega[i] <= rtol * omega[j]:
            j += 1
        if j - i > 1:
            U, _, _ = np.linalg.svd(loads[i:j], full_matrices=True)
            phi[:, i:j] = phi[:, i:j] @ U
        i = j
    return jnp.asarray(phi, dtype=float)


PURIFY_REMOVES = 1e-3
"""``purify_close_modes`` turns a mode only where the rotation leaves at most this fraction of
its load: where the load is (all but) the eigensolver's mixing, not a physical load."""


def purify_close_modes(phi: Float[Array, "ndof k"], omega, loads: Float[Array, "k m"], lambda_max,
                       rtol: float = 1e-4):
    """Take the eigensolver's round-off out of the modes: mix into each mode as much of the more
    strongly loaded modes as the solver's accuracy leaves undetermined, so that it carries as
    little of ``loads`` as it can.

    A backward-stable eigensolver returns mode i only within an angle of about
    ``θ_ij = ε λ_max / |ω_i² − ω_j²|`` of the exact one towards mode j (Davis-Kahan with a
    backward error ε λ_max; ``lambda_max`` is ``VibrationModes.lambda_max``). For close
    frequencies (a curved beam's out-of-plane and in-plane first modes, 1 % apart) that angle is
    far above round-off, so a mode that the loads leave alone carries a load that depends on the
    CPU's rounding, and with it an MMI amplitude that can straddle ``select``'s ``vm_tol`` from
    run to run. Each mode i, from the least loaded up, takes the coefficients δ_j ∈ [−θ_ij, θ_ij]
    on the more strongly loaded, non-degenerate modes j that minimise its load
    ``|l_i + Σ_j δ_j l_j|`` (a bounded least-squares problem, ``scipy.optimize.lsq_linear``), and
    the modes turn by the rotation ``exp(S)`` with ``S_ji = δ_j = −S_ij`` where that removes all
    but ``PURIFY_REMOVES`` of the load. The rotation moves every mode by less than the solver's
    own uncertainty, so they stay mass-orthonormal eigenvectors to the solver's accuracy; a load
    that no such rotation removes is physical, and its mode is left alone (a loaded mode is not
    nudged to its bounds). Pairs within ``rtol`` (degenerate: ``align_degenerate_modes``) are left out.
    ``loads``: the modal loads, one row per mode (e.g. the MMI load history's transpose).
    NumPy, on concrete modes.
    """
    eps = np.finfo(float).eps
    omega = np.asarray(omega)
    L = np.asarray(loads, dtype=float).copy()
    phi = np.asarray(phi).copy()
    if L.ndim != 2 or L.shape[0] != omega.shape[0] or phi.shape[1] != omega.shape[0]:
        raise ValueError(f"loads must hold one row per mode ({omega.shape[0]} modes, phi of shape {phi.shape}), "
                         f"got loads of shape {L.shape}")
    w2 = omega**2
    norms = np.linalg.norm(L, axis=1)
    k = len(omega)
    for i in np.argsort(norms, kind="stable"):
        gap = np.abs(w2 - w2[i])
        others = np.flatnonzero((norms > norms[i]) & (gap > 2.0 * rtol * np.maximum(w2, w2[i])))
        theta = eps * float(lambda_max) / gap[others]
        others, theta = others[theta >= eps], theta[theta >= eps]
        if others.size == 0 or norms[i] == 0.0:
            continue
        fit = scipy.optimize.lsq_linear(L[others].T, -L[i], bounds=(-theta, theta), method="bvls")
        if np.linalg.norm(L[i] + L[others].T @ fit.x) > PURIFY_REMOVES * norms[i]:
            continue  # the load is not the solver's mixing: a physical load, the mode stays
        delta = fit.x
        S = np.zeros((k, k))
        S[others, i] = delta
        S[i, others] = -delta
        R = scipy.linalg.expm(S)
        phi = phi @ R
        L = R.T @ L
    return jnp.asarray(phi, dtype=float)


def plane_loads(body, normal=(0.0, 0.0, 1.0)) -> np.ndarray:
    """The inertial loads ``(M ⊗ I₃) u`` (n_dof × 4) of the body's rigid motions in the plane
    normal to ``normal``: its two translations in the plane, the rotation about ``normal``
    (n × q̂_α on every nodal vector) and that rotation's centrifugal field n × (n × q̂_α). A body
    in a frame that moves in this plane (a planar mechanism's link) is loaded by combinations of
    these alone, so the modes they leave unloaded are the out-of-plane ones (``excited_modes``).
    NumPy, on the concrete reference."""
    n = np.asarray(normal, dtype=float)
    n = n / np.linalg.norm(n)
    e1 = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    pos = np.asarray(body.is_position, dtype=float)[:, None]
    q_hat = np.asarray(body.q_hat)
    rot = np.cross(n, q_hat)
    fields = [pos * e1, pos * e2, rot, np.cross(n, rot)]
    M = np.asarray(body.mass_matrix())
    return np.stack([(M @ u).reshape(-1) for u in fields], axis=1)


def excited_modes(phi: Float[Array, "ndof k"], omega, loads: Float[Array, "ndof m"], n: int,
                  tol: float = 1e-6, rtol: float = 1e-4) -> tuple[np.ndarray, Float[Array, "ndof n"]]:
    """The ``n`` lowest of the modes ``phi`` that the physical ``loads`` (columns) excite:
    ``(indices, modes)``.

    Each cluster of equal frequencies is first rotated to the loads
    (``align_degenerate_modes``), so that a tube's two bending planes separate into the mode
    the loads drive and the one they leave alone; then a mode counts as excited when its largest
    modal load |φ_iᵀ f| is at least ``tol`` times the largest over all modes. With
    ``plane_loads`` this keeps a planar mechanism's in-plane modes: the lowest ``n`` of *these*
    are the reduction's vibration modes, rather than the lowest ``n`` overall, half of which
    (the out-of-plane pairs) the motion never reaches. Raises ``ValueError`` if fewer than
    ``n`` are excited (give more candidate modes)."""
    omega = np.asarray(omega)
    F = np.asarray(loads, dtype=float)
    phi = align_degenerate_modes(phi, omega, np.asarray(phi).T @ F, rtol)
    modal = np.abs(np.asarray(phi).T @ F).max(axis=1)
    idx = np.flatnonzero(modal >= tol * modal.max())
    if len(idx) < n:
        raise ValueError(f"only {len(idx)} of the {len(omega)} candidate modes are excited by the loads; "
                         f"give more candidates to find {n}")
    idx = idx[:n]
    return idx, phi[:, idx]
