"""The NR-RNCF reduction pipeline (paper Fig. 2): modes → linear MMI simulation → selection →
modal derivatives → SVD deflation → reduced tensors."""

import dataclasses
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .integrate.simulate import simulate
from .models.full_order import RotatingFrameModel
from .models.reduced import ReducedRotatingModel, reduce_rotating_model
from .reduction.deflation import deflate
from .reduction.modal_derivatives import modal_derivatives
from .reduction.modes import vibration_modes
from .reduction.selection import Selection, align_degenerate_modes, mmi_matrix, select


@dataclasses.dataclass
class Reduction:
    """A reduced model with the record of how its basis was chosen."""

    model: ReducedRotatingModel
    omega: np.ndarray  # candidate natural frequencies [rad/s]
    selection: Selection
    n_vms: int
    n_mds: int
    offline_s: dict  # wall time per offline stage (compilation included)

    @property
    def dofs(self) -> int:
        return self.model.n_dof


def _eta(t, p, v):
    return p


def nr_rncf(full: RotatingFrameModel, ts_mmi, *, n_modes: int = 24, vms: int | str = "auto", mds="auto",
            band: float = 6.0, vm_tol: float = 1e-6, md_tol: float = 0.01, max_mds: int | None = None,
            max_dofs: int | None = 25, md_method: str = "closed_form", deflation_tol: float = 1e-6,
            force: str = "auto") -> Reduction:
    """Build the NR-RNCF reduced model of ``full`` for its load case.

    ``n_modes`` candidate vibration modes enter the linear MMI simulation over ``ts_mmi``;
    ``vms``/``mds`` choose among them (see ``selection.select``); with ``vms='auto'`` the modes
    kept lie below ``band`` times the largest spin rate θ̇ of the manoeuvre, or are strongly
    loaded; with ``mds='auto'`` the MDs of largest weight are added while VMs + MDs ≤
    ``max_dofs``. Returns a ``Reduction``.
    """
    if not isinstance(full, RotatingFrameModel):
        raise ValueError("nr_rncf reduces a RotatingFrameModel (RNCF); got " + type(full).__name__)
    times = {}
    body, free = full.body, full.free_mask()

    t0 = time.perf_counter()
    modes = vibration_modes(body, free, n_modes)
    jax.block_until_ready(modes.phi)
    times["modes"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    linear = reduce_rotating_model(full, modes.phi, linear=True)
    loads = jnp.column_stack([linear.inertia.g, linear.inertia.c, linear.gravity_map @ linear.gravity,
                              linear.point_load])
    phi = align_degenerate_modes(modes.phi, modes.omega, loads)
    modes = eqx.tree_at(lambda m: m.phi, modes, phi)
    linear = reduce_rotating_model(full, phi, linear=True)
    eta = simulate(linear, jnp.asarray(ts_mmi), observe=_eta, rtol=1e-5, atol=1e-9).ys
    spin = jnp.max(jnp.abs(jax.vmap(lambda t: full.motion(t)[1])(jnp.asarray(ts_mmi))))
    sel = select(mmi_matrix(jnp.asarray(ts_mmi), eta), vms, mds, vm_tol=vm_tol, md_tol=md_tol, max_mds=max_mds,
                 max_dofs=max_dofs,
                 omega=modes.omega, omega_band=band * float(spin) if band else None)
    times["mmi"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    theta = modal_derivatives(body, free, modes.phi, sel.pairs, method=md_method).theta if sel.pairs else None
    jax.block_until_ready(theta)
    times["modal_derivatives"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    cols = [modes.phi[:, list(sel.vms)]] + ([theta] if theta is not None else [])
    Psi = deflate(jnp.concatenate(cols, axis=1), deflation_tol)
    model = reduce_rotating_model(full, Psi, force=force)
    jax.block_until_ready(model.elastic.N)
    times["tensors"] = time.perf_counter() - t0
    times["total"] = sum(times.values())
    return Reduction(model=model, omega=np.asarray(modes.omega), selection=sel, n_vms=len(sel.vms),
                     n_mds=len(sel.pairs), offline_s=times)
