"""Batched spin-up sweeps: one jit-compiled, vmapped run over a grid of (ωs, Ts, E), optionally
split across devices with ``shard_map``.

    grid = sweep_grid(omega_s=np.linspace(2, 40, 64), T_s=15.0)
    red = sweep_reduction("paper", grid, t_end=30.0)        # one NR-RNCF basis for the whole grid
    res = spinup_sweep(red, grid, t_end=30.0)              # res.peak_uy, res.residual_uy, ...

**One basis for the whole grid.** The reduced model is built once (``sweep_reduction``: at the
grid's highest ωs and shortest Ts, the hardest case, and the model's own Young's modulus) and
held fixed; only the prescribed motion (Eq. 43) and the stiffness change from case to case. A
basis chosen for the hardest case holds the modes and derivatives the milder ones use, but it
is not the basis ``nr_rncf`` would pick for each case on its own.

**Young's modulus.** The elastic force is linear in E with the basis fixed, so a case with
E = s·E0 obeys the reduced equations with F(p) scaled by s. Rather than scale the elastic
tensors (Km⁴ numbers per case under ``vmap``), the sweep divides the other terms of the
equations (inertia, rotation and external loads, Km² numbers) by s: the same solution.

**Devices.** The batch is split with ``shard_map`` over a 1-D mesh of the devices (one device
is a mesh of one), and every device runs its own batched adaptive loop to the end
(``simulate_batch``: one loop whose step is ``vmap``-ped over ``lanes`` cases, each case with its
own step size, the device's other cases queued for a lane): the compiled program holds no
cross-device operation (``SweepResult.collectives``), so there is no per-step synchronisation (a
``jit`` over a sharded batch would all-reduce the loop condition every step). Cases are sorted by
expected cost, costliest first, and padded at the end with copies of the cheapest to a multiple
of the device count. Each device gets a contiguous block of that order (``balance='blocks'``):
when a device's cases all fit its lanes, its loop runs as long as its costliest case, and the
devices holding the cheap cases finish early (on a CPU whose cores the devices share, that time
goes to the others). ``balance='interleave'`` deals the sorted cases round-robin instead (every
device the same mix, which balances devices whose cases queue). Within a device the queue starts
with its costliest cases, so that the cheap ones fill the lanes at the end. The same call runs
on a multi-GPU host, or on every device of several processes and hosts after
``distributed.initialize()`` (the model broadcast from process 0, inputs placed as global arrays,
results gathered to every process; ``nrrncf sweep --processes N`` on one machine).
"""

import csv
import dataclasses
import json
import re
import time
from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _validate
from .._progress import note
from .._validate import parse_range as parse_range  # the CLI's grid syntax, checked without JAX
from ..integrate import AbstractStepSizeController, AdaptiveStepSize, GeneralizedAlpha
from ..integrate.results import SimulationError, result_message
from ..integrate.simulate import (
    SMALL_KERNEL_OPTIONS,
    batch_lanes,
    kernel_options,
    simulate,
    simulate_batch,
    simulate_timed,
)
from ..models.observe import beam_tip, tip_observer
from ..motion import SpinUp
from ..reduction.reduced_model import ReducedRotatingModel

_AXIS = "cases"
BALANCES = ("blocks", "interleave")


# --- the grid -----------------------------------------------------------------------------------

_GRID_NAMES = {"omega_s": "omega_s (steady spin rate)", "T_s": "T_s (spin-up time)",
               "E_scale": "E_scale (Young's modulus over the model's)"}


def _positive_values(name: str, values) -> np.ndarray:
    try:
        v = np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be numbers, got {values!r}") from None
    if v.size == 0:
        raise ValueError(f"{name}: the grid is empty (no values given)")
    bad = ~np.isfinite(v) | (v <= 0.0)
    if np.any(bad):
        raise ValueError(f"{name} must be finite and positive, got {v[bad][0]:g}")
    return v


@dataclasses.dataclass(frozen=True)
class SweepGrid:
    """The cases of a sweep: one (ωs, Ts, E/E0) per case, flat arrays of equal length.

    ``shape`` is (n_omega, n_T, n_E) for a grid made by ``sweep_grid`` (case index
    ``(i_omega·n_T + i_T)·n_E + i_E``), or ``(n,)`` for a list of cases.
    """

    omega_s: np.ndarray
    T_s: np.ndarray
    E_scale: np.ndarray
    shape: tuple[int, ...] = ()

    def __post_init__(self):
        vals = [_positive_values(_GRID_NAMES[k], getattr(self, k)) for k in ("omega_s", "T_s", "E_scale")]
        try:
            vals = np.broadcast_arrays(*vals)
        except ValueError:
            raise ValueError("omega_s, T_s and E_scale must have one value per case (or a single value), got "
                             f"lengths {[v.size for v in vals]}") from None
        for k, v in zip(("omega_s", "T_s", "E_scale"), vals):
            object.__setattr__(self, k, np.array(v, dtype=float))
        n = self.omega_s.size
        shape = tuple(int(s) for s in self.shape) or (n,)
        if int(np.prod(shape)) != n:
            raise ValueError(f"shape {shape} does not hold the grid's {n} cases")
        object.__setattr__(self, "shape", shape)

    @property
    def cases(self) -> int:
        return self.omega_s.size

    def expected_cost(self) -> np.ndarray:
        """A heuristic ordering key, larger for costlier cases: the step must follow frequencies
        that rise with the spin rate (centrifugal stiffening) and with √E, and a shorter spin-up
        excites more. Any order gives the same results; this one only balances the work."""
        return self.omega_s * np.sqrt(self.E_scale) * (1.0 + 1.0 / self.T_s)

    def subset(self, indices) -> "SweepGrid":
        """The cases ``indices`` of this grid, as a list of cases (a shard: ``distributed``)."""
        i = np.asarray(indices, dtype=int).reshape(-1)
        if i.size == 0 or i.min() < 0 or i.max() >= self.cases:
            raise ValueError(f"indices must select cases 0..{self.cases - 1}, got {i.tolist()[:10]}")
        return SweepGrid(self.omega_s[i], self.T_s[i], self.E_scale[i])


def sweep_grid(omega_s, T_s=15.0, E_scale=1.0) -> SweepGrid:
    """Every combination of the given spin rates ωs [rad/s], spin-up times Ts [s] and Young's
    modulus ratios E/E0 (each a number or a sequence); ``shape`` = (n_omega, n_T, n_E)."""
    w = _positive_values(_GRID_NAMES["omega_s"], omega_s)
    T = _positive_values(_GRID_NAMES["T_s"], T_s)
    E = _positive_values(_GRID_NAMES["E_scale"], E_scale)
    W, TT, EE = np.meshgrid(w, T, E, indexing="ij")
    return SweepGrid(W.reshape(-1), TT.reshape(-1), EE.reshape(-1), shape=W.shape)


# --- the per-case model -------------------------------------------------------------------------

def case_model(model: ReducedRotatingModel, omega_s, T_s, E_scale=1.0) -> ReducedRotatingModel:
    """The reduced model of one case: the motion ``SpinUp(omega_s, T_s)`` and Young's modulus
    ``E_scale`` times the model's, with the basis held fixed.

    For ``E_scale`` ≠ 1 the inertia, rotation and external-load terms are divided by it rather
    than the elastic tensors multiplied (see the module docstring); works under ``vmap``.
    """
    m = eqx.tree_at(lambda r: r.motion, model, SpinUp(omega_s, T_s, axis=model.motion.axis))
    if isinstance(E_scale, (int, float)) and E_scale == 1.0:
        return m
    inv = 1.0 / jnp.asarray(E_scale, dtype=m.Psi.dtype)
    return eqx.tree_at(
        lambda r: (r.inertia.I, r.inertia.G, r.inertia.C, r.inertia.g, r.inertia.c, r.gravity_map, r.point_load),
        m,
        tuple(inv * x for x in (m.inertia.I, m.inertia.G, m.inertia.C, m.inertia.g, m.inertia.c, m.gravity_map,
                                m.point_load)),
    )


# --- the kernel ---------------------------------------------------------------------------------

def _integration(solver, controller, ts) -> tuple:
    """A sweep's ``(solver, controller)``, checked before anything is traced: defaults
    ``GeneralizedAlpha(0.9)`` and ``AdaptiveStepSize(1e-4, 1e-6)``. An adaptive controller
    without a first step starts every case at a thousandth of the run (``dt0``), so that the
    cases, which differ in their motion only, start alike."""
    solver = GeneralizedAlpha(0.9) if solver is None else solver
    controller = AdaptiveStepSize(1e-4, 1e-6) if controller is None else controller
    if not isinstance(solver, GeneralizedAlpha):
        raise ValueError(f"solver must be an integrate.GeneralizedAlpha (the spin-up has no joints), got "
                         f"{type(solver).__name__}")
    if not isinstance(controller, AbstractStepSizeController):
        raise ValueError(f"controller must be an integrate step-size controller (AdaptiveStepSize, ConstantStepSize), "
                         f"got {type(controller).__name__}")
    if isinstance(controller, AdaptiveStepSize) and controller.dt0 is None:
        controller = eqx.tree_at(lambda c: c.dt0, controller, jnp.asarray(1e-3 * float(ts[-1])),
                                 is_leaf=lambda x: x is None)
    return solver, controller


@dataclasses.dataclass(frozen=True)
class _Config:
    """Static settings of the compiled sweep (hashable: part of the jit cache key); the solver and
    the step-size controller travel as arguments."""

    max_steps: int
    tip: int
    scale_E: bool
    lanes: int


def _case(model, scale_E: bool, p):
    """The reduced model of one case from its parameters ``p = (ωs, Ts, E/E0)``."""
    omega_s, T_s, E_scale = p
    return case_model(model, omega_s, T_s, E_scale if scale_E else 1.0)


def _local_sweep(model, solver, controller, omega_s, T_s, E_scale, ts, cfg):
    """The cases of one device, in its queue's order: one batched loop of ``cfg.lanes`` lanes."""
    sol = simulate_batch(jax.tree_util.Partial(_case, model, cfg.scale_E), (omega_s, T_s, E_scale),
                         solver, controller, ts, width=cfg.lanes, max_steps=cfg.max_steps,
                         observe=tip_observer(model, cfg.tip), throw=False)
    return dict(tip=sol.ys, steps=sol.num_steps, rejected=sol.num_rejected, newton=sol.num_newton,
                result=sol.code, t_final=sol.t_final)


def _sweep_program(integration, omega_s, T_s, E_scale, ts, cfg: _Config, mesh):
    """``integration``: (model, solver, controller), replicated on every device."""
    from jax import shard_map
    from jax.sharding import PartitionSpec as P

    dyn, static = eqx.partition(integration, eqx.is_array)

    def local(dyn, w, T, E, ts):
        return _local_sweep(*eqx.combine(dyn, static), w, T, E, ts, cfg)

    # Each device runs its own loop on its block; nothing crosses devices until the results.
    f = shard_map(local, mesh=mesh, in_specs=(P(), P(_AXIS), P(_AXIS), P(_AXIS), P()), out_specs=P(_AXIS),
                  check_vma=False)
    return f(dyn, omega_s, T_s, E_scale, ts)


_sweep_kernel = eqx.filter_jit(_sweep_program)
_sweep_kernel_small = eqx.filter_jit(_sweep_program, compiler_options=SMALL_KERNEL_OPTIONS)


_COLLECTIVES = re.compile(r"\b(all-reduce|all-gather|all-to-all|collective-permute|reduce-scatter)(-start)?\(")


# --- scheduling ---------------------------------------------------------------------------------

def schedule(cost: np.ndarray, n_devices: int, balance: str = "blocks") -> np.ndarray:
    """The case order fed to the devices: indices into the grid, costliest first by ``cost``, and
    padded at the end with copies of the cheapest case to a multiple of ``n_devices``. Device d
    gets the d-th of ``n_devices`` equal slices, and runs it as a queue in that order.

    ``'blocks'``: contiguous slices (device 0 the costliest cases); ``'interleave'``: the sorted
    cases dealt round-robin, every slice the same mix.
    """
    if balance not in BALANCES:
        raise ValueError(f"balance must be one of {BALANCES}, got {balance!r}")
    order = np.argsort(-np.asarray(cost), kind="stable")
    pad = (-order.size) % n_devices
    order = np.concatenate([order, np.full(pad, order[-1])])
    if balance == "interleave":
        order = order.reshape(-1, n_devices).T.reshape(-1)
    return order


def _resolve_devices(devices) -> list:
    avail = jax.devices()
    if devices is None:
        return list(avail)
    if isinstance(devices, (int, np.integer)) and not isinstance(devices, bool):
        n = int(devices)
        if n < 1:
            raise ValueError(f"devices must be >= 1, got devices={n}")
        if n > len(avail):
            raise ValueError(f"devices={n} but only {len(avail)} {avail[0].platform.upper()} device(s) are "
                             "available (on a CPU, set XLA_FLAGS=--xla_force_host_platform_device_count=N "
                             "before JAX starts)")
        return list(avail[:n])
    devs = list(devices)
    if not devs:
        raise ValueError("devices is an empty sequence")
    return devs


def _put(x, sharding):
    x = np.asarray(x)
    if jax.process_count() == 1:
        return jax.device_put(x, sharding)
    return jax.make_array_from_callback(x.shape, sharding, lambda idx: x[idx])


def _fetch(x) -> np.ndarray:
    if jax.process_count() > 1 and not x.is_fully_addressable:
        from jax.experimental import multihost_utils

        return np.asarray(multihost_utils.process_allgather(x, tiled=True))
    return np.asarray(x)


# --- the result ---------------------------------------------------------------------------------

@dataclasses.dataclass
class SweepResult:
    """Per-case results of a sweep (in the grid's order) and its timings.

    ``peak_uy``, ``peak_ux``: largest |transverse (in-plane)| and |axial| tip displacement over
    the run; ``residual_uy``: the residual vibration amplitude after the spin-up, half the
    peak-to-peak transverse tip displacement over the output times t ≥ Ts (NaN if there are
    fewer than two). ``tip`` holds the series, (cases, n_out, 3): ux, uy, uz in the rotating frame.
    ``single_s`` (with ``time_single=True``): the run time of the slowest case run alone,
    measured in the same process, and ``single_case`` its index.
    """

    grid: SweepGrid
    ts: np.ndarray
    tip: np.ndarray
    peak_uy: np.ndarray
    peak_ux: np.ndarray
    residual_uy: np.ndarray
    steps: np.ndarray
    rejected: np.ndarray
    newton: np.ndarray
    dofs: int
    devices: int
    platform: str
    balance: str
    lanes: int  # cases each device's batched loop advances together (the rest queue)
    padded: int  # copies of a case added to give every device as many cases
    collectives: int  # cross-device operations in the compiled program (0: none)
    compile_s: float
    run_s: float
    single_case: int | None = None
    single_s: float | None = None
    single_compile_s: float | None = None
    single_steps: int | None = None
    case_index: np.ndarray | None = None  # a shard's cases' indices in the whole grid (None: all)
    cases_total: int | None = None  # the whole grid's size, for a shard

    @property
    def cases(self) -> int:
        return self.grid.cases

    @property
    def throughput(self) -> float:
        """Manoeuvres per second of run time (compilation excluded)."""
        return self.cases / self.run_s

    @property
    def cost_in_single_runs(self) -> float | None:
        """The sweep's run time in units of a single run of its slowest case."""
        return None if self.single_s is None else self.run_s / self.single_s

    def summary(self) -> dict:
        g = self.grid
        s = {"cases": self.cases, "devices": self.devices, "platform": self.platform, "balance": self.balance,
             "lanes": self.lanes, "padded": self.padded, "collectives": self.collectives,
             "dofs": self.dofs, "t_end": float(self.ts[-1]), "compile_s": round(self.compile_s, 3),
             "run_s": round(self.run_s, 4), "throughput_per_s": round(self.throughput, 3),
             "single_run_s": None if self.single_s is None else round(self.single_s, 4),
             "single_compile_s": None if self.single_compile_s is None else round(self.single_compile_s, 3),
             "sweep_over_single": None if self.single_s is None else round(self.cost_in_single_runs, 3),
             "max_steps_case": int(np.argmax(self.steps + self.rejected)),
             "omega_s": g.omega_s.tolist(), "T_s": g.T_s.tolist(), "E_scale": g.E_scale.tolist(),
             "peak_uy": self.peak_uy.tolist(), "peak_ux": self.peak_ux.tolist(),
             "residual_uy": [None if not np.isfinite(x) else float(x) for x in self.residual_uy],
             "steps": self.steps.tolist(), "rejected": self.rejected.tolist()}
        if self.single_case is not None:
            i = self.single_case
            s["single_case"] = {"index": i, "omega_s": float(g.omega_s[i]), "T_s": float(g.T_s[i]),
                                "E_scale": float(g.E_scale[i]), "steps": self.single_steps}
        return s

    def json(self) -> str:
        return json.dumps(self.summary())

    def table(self, max_rows: int = 12) -> str:
        g = self.grid
        idx = np.arange(self.cases)
        if self.cases > max_rows:
            idx = np.unique(np.linspace(0, self.cases - 1, max_rows).round().astype(int))
        lines = [f"  {'case':>5s} {'omega_s':>8s} {'T_s':>6s} {'E/E0':>6s} {'peak |uy|':>10s} {'peak |ux|':>10s} "
                 f"{'resid. uy':>10s} {'steps':>6s}"]
        for i in idx:
            lines.append(f"  {i:5d} {g.omega_s[i]:8.3f} {g.T_s[i]:6.2f} {g.E_scale[i]:6.3f} {self.peak_uy[i]:10.5f} "
                         f"{self.peak_ux[i]:10.5f} {self.residual_uy[i]:10.5f} {self.steps[i]:6d}")
        if idx.size < self.cases:
            lines.append(f"  ({idx.size} of {self.cases} cases shown)")
        lines.append(f"  {self.cases} cases on {self.devices} {self.platform.upper()} device(s), {self.dofs} reduced "
                     f"DOFs: compile {self.compile_s:.2f} s, run {self.run_s:.3f} s "
                     f"({self.throughput:.1f} manoeuvres/s)")
        if self.single_s is not None:
            lines.append(f"  slowest case alone (case {self.single_case}, {self.single_steps} steps): run "
                         f"{self.single_s:.3f} s; the sweep costs {self.cost_in_single_runs:.2f} single runs")
        return "\n".join(lines)

    def to_csv(self, path: str) -> None:
        """One row a case: its index in the whole grid and the grid's size (``case``, ``cases``:
        a shard's parts merge by them, ``distributed.merge_parts``), its parameters and results."""
        index = np.arange(self.cases) if self.case_index is None else self.case_index
        total = self.cases if self.cases_total is None else self.cases_total
        with open(path, "w", newline="") as f:
            wr = csv.writer(f)
            wr.writerow(["case", "cases", "omega_s", "T_s", "E_scale", "peak_uy", "peak_ux", "residual_uy", "steps",
                         "rejected"])
            g = self.grid
            for i in range(self.cases):
                wr.writerow([int(index[i]), int(total), f"{g.omega_s[i]:.10g}", f"{g.T_s[i]:.10g}",
                             f"{g.E_scale[i]:.10g}",
                             f"{self.peak_uy[i]:.10g}", f"{self.peak_ux[i]:.10g}", f"{self.residual_uy[i]:.10g}",
                             int(self.steps[i]), int(self.rejected[i])])

    def plot(self, path: str, title: str | None = None, dpi: int = 120) -> None:
        """Peak transverse and axial tip deflection, and the residual vibration amplitude, against
        ωs: one line per (Ts, E) of the grid."""
        from ..post.plotting import _pyplot

        plt = _pyplot()
        g = self.grid
        shape = g.shape if len(g.shape) == 3 else (g.cases, 1, 1)
        order = np.arange(g.cases).reshape(shape)
        if len(g.shape) != 3:  # a list of cases: sort by ωs
            order = np.argsort(g.omega_s, kind="stable").reshape(shape)
        panels = [(self.peak_uy, "peak |tip $u_y$| (transverse) [m]"), (self.peak_ux, "peak |tip $u_x$| (axial) [m]"),
                  (self.residual_uy, "residual $u_y$ amplitude after $T_s$ [m]")]
        fig, axes = plt.subplots(len(panels), 1, figsize=(7, 7.5), sharex=True)
        for iT in range(shape[1]):
            for iE in range(shape[2]):
                sel = order[:, iT, iE]
                label = f"$T_s$ = {g.T_s[sel[0]]:g} s" + (f", E/E0 = {g.E_scale[sel[0]]:g}" if shape[2] > 1 else "")
                for ax, (y, _) in zip(axes, panels):
                    ax.plot(g.omega_s[sel], y[sel], "o-", ms=3, label=label)
        for ax, (_, ylabel) in zip(axes, panels):
            ax.set_ylabel(ylabel)
            ax.grid(alpha=0.3)
        if shape[1] * shape[2] > 1:
            axes[0].legend(fontsize="small")
        axes[-1].set_xlabel(r"$\omega_s$ [rad/s]")
        axes[0].set_title(title or f"Spin-up sweep: {g.cases} cases, {self.dofs} reduced DOFs")
        fig.tight_layout()
        fig.savefig(path, dpi=dpi)
        plt.close(fig)


def _peaks(ts, tip, T_s):
    peak_uy = np.abs(tip[:, :, 1]).max(axis=1)
    peak_ux = np.abs(tip[:, :, 0]).max(axis=1)
    after = ts[None, :] >= T_s[:, None]
    uy = tip[:, :, 1]
    hi = np.where(after, uy, -np.inf).max(axis=1)
    lo = np.where(after, uy, np.inf).min(axis=1)
    residual = np.where(after.sum(axis=1) >= 2, 0.5 * (hi - lo), np.nan)
    return peak_uy, peak_ux, residual


# --- the public entry points --------------------------------------------------------------------

def _as_model(model_or_reduction) -> ReducedRotatingModel:
    m = getattr(model_or_reduction, "model", model_or_reduction)
    if not isinstance(m, ReducedRotatingModel):
        raise ValueError("spinup_sweep runs a reduced NR-RNCF model (a ReducedRotatingModel or the Reduction "
                         f"from nr_rncf), got {type(model_or_reduction).__name__}")
    if m.linear:
        raise ValueError("spinup_sweep needs the nonlinear reduced model, got the linear MMI model")
    return m


def spinup_sweep(model_or_reduction, grid: SweepGrid, *, t_end: float, dt_out: float = 0.01,
                 solver: GeneralizedAlpha | None = None, controller: AbstractStepSizeController | None = None,
                 max_steps: int = 500_000,
                 devices: int | Sequence | None = None, lanes: int | None = None, balance: str = "blocks",
                 tip: int | None = None, time_single: bool = False, small_kernels: bool = True,
                 throw: bool = True, progress: bool = False) -> SweepResult:
    """Run the spin-up of Eq. 43 for every case of ``grid`` in one compiled, vmapped loop.

    ``model_or_reduction``: a ``ReducedRotatingModel`` (or the ``Reduction`` from ``nr_rncf``);
    its basis is held fixed across the grid, only the motion and E change (``case_model``).
    Outputs at 0, ``dt_out``, ..., ``t_end``; every case integrated with ``solver`` and
    ``controller`` (``_integration``: default ``GeneralizedAlpha(0.9)`` and
    ``AdaptiveStepSize(1e-4, 1e-6)``; a ``ConstantStepSize`` takes fixed steps, every case then
    the same ones), each keeping its own adaptive step. ``devices``: a count or a list of
    devices (default: every device JAX sees); with more than one the batch is split by
    ``shard_map`` and ``balance`` (see ``schedule``). ``lanes``: cases each device's batched loop
    advances together (``simulate_batch``'s ``width``); the device's other cases wait in a queue
    and take the lane of a case that ends (default ``integrate.batch_lanes``: all of a device's
    cases at once on an accelerator, at most ``integrate.CPU_BATCH_LANES`` on a CPU).

    Results do not depend on the device count beyond round-off: XLA may sum a batched
    contraction in another order for another local batch shape or partitioning, and the
    adaptive step control carries such round-off into differences far below its tolerance
    (with fixed steps they stay at round-off). ``tip``: the nodal vector observed
    (default the beam's tip position vector). Compilation (ahead of time) and the run are timed
    apart; with ``time_single=True`` the slowest case is then run alone for comparison.
    ``small_kernels``: compile with ``integrate.SMALL_KERNEL_OPTIONS`` on CPU devices, as a single
    reduced run is (``simulate_batch``'s option of that name): the sweep's loop compiles faster and
    runs as fast; False: XLA's defaults.
    ``throw=True`` raises ``SimulationError`` naming a case that stopped early. ``progress=True``
    prints each stage (compilation, the run, the single run) on stderr.

    Returns a ``SweepResult``. Every check on the input runs before anything is traced.
    """

    model = _as_model(model_or_reduction)
    if not isinstance(grid, SweepGrid):
        raise ValueError(f"grid must be a SweepGrid (see sweep_grid), got {type(grid).__name__}")
    ts = _validate.output_times(t_end, dt_out)
    if ts.size < 2:
        raise ValueError(f"t_end={t_end!r} must be at least one output interval dt_out={dt_out!r}")
    solver, controller = _integration(solver, controller, ts)
    max_steps = _validate.positive_int("max_steps", max_steps)
    if balance not in BALANCES:
        raise ValueError(f"balance must be one of {BALANCES}, got {balance!r}")
    _validate.boolean("small_kernels", small_kernels)
    n_vec = model.q_hat.shape[0]
    tip = beam_tip(model) if tip is None else int(tip)
    if not 0 <= tip < n_vec:
        raise ValueError(f"tip must index one of the model's {n_vec} nodal vectors, got tip={tip}")
    devs = _resolve_devices(devices)

    n_dev = len(devs)
    per_dev = -(-grid.cases // n_dev)
    # One lane policy for every batched loop (``integrate.batch_lanes``): all of a device's cases
    # at once on an accelerator, a few on a CPU, where a batched step costs each lane about what
    # it costs alone and what wider batches add is padding.
    c = batch_lanes(per_dev, None if lanes is None else _validate.positive_int("lanes", lanes),
                    platform=devs[0].platform)
    cfg = _Config(max_steps=max_steps, tip=tip, scale_E=bool(np.any(grid.E_scale != 1.0)), lanes=c)
    order = schedule(grid.expected_cost(), n_dev, balance)
    params = [x[order] for x in (grid.omega_s, grid.T_s, grid.E_scale)]
    # One device is a mesh of one: a single code path whatever the device count.
    from jax.sharding import Mesh, NamedSharding
    from jax.sharding import PartitionSpec as P

    if jax.process_count() > 1:
        # every process holds the same model: process 0's (bases built apart on different hosts
        # may differ by round-off, and the replicated arrays must be one)
        from jax.experimental import multihost_utils

        arrays, static = eqx.partition(model, eqx.is_array)
        model = eqx.combine(multihost_utils.broadcast_one_to_all(arrays), static)
    mesh = Mesh(np.array(devs), (_AXIS,))
    rep, split = NamedSharding(mesh, P()), NamedSharding(mesh, P(_AXIS))
    integration = jax.tree_util.tree_map(lambda x: _put(x, rep) if eqx.is_array(x) else x, (model, solver, controller))
    args = (integration, *(_put(x, split) for x in params), _put(ts, rep))

    note(progress, f"sweep: compiling the batched loop ({grid.cases} cases on {n_dev} {devs[0].platform.upper()} "
                   f"device(s), {c} lanes each) ...")
    t0 = time.perf_counter()
    kernel = _sweep_kernel_small if kernel_options(small_kernels, devs[0].platform) else _sweep_kernel
    compiled = kernel.lower(*args, cfg, mesh).compile()
    t1 = time.perf_counter()
    note(progress, f"sweep: compiled in {t1 - t0:.1f} s; running the {grid.cases} cases ...")
    out = jax.block_until_ready(compiled(*args, cfg, mesh))
    t2 = time.perf_counter()
    note(progress, f"sweep: ran in {t2 - t1:.1f} s")
    collectives = len(_COLLECTIVES.findall(compiled.compiled.as_text()))  # the jax.stages.Compiled inside
    out = {k: _fetch(v) for k, v in out.items()}

    # Back to the grid's order: the first slot holding each case (padding copies come later).
    _, slot = np.unique(order, return_index=True)
    out = {k: v[slot] for k, v in out.items()}
    if throw and np.any(out["result"] != 0):
        i = int(np.flatnonzero(out["result"])[0])
        raise SimulationError(f"sweep case {i} (omega_s = {grid.omega_s[i]:g}, T_s = {grid.T_s[i]:g}, "
                              f"E_scale = {grid.E_scale[i]:g}) stopped at t = {out['t_final'][i]:.6g} s: "
                              f"{result_message(out['result'][i])}")
    tipw = out["tip"]
    peak_uy, peak_ux, residual = _peaks(ts, tipw, grid.T_s)
    res = SweepResult(
        grid=grid, ts=ts, tip=tipw, peak_uy=peak_uy, peak_ux=peak_ux, residual_uy=residual,
        steps=out["steps"].astype(int), rejected=out["rejected"].astype(int), newton=out["newton"].astype(int),
        dofs=model.n_dof, devices=n_dev, platform=devs[0].platform, balance=balance, lanes=c,
        padded=order.size - grid.cases, collectives=collectives, compile_s=t1 - t0, run_s=t2 - t1,
    )
    if time_single:
        i = int(np.argmax(res.steps + res.rejected))
        note(progress, f"sweep: the slowest case (case {i}, omega_s = {grid.omega_s[i]:g} rad/s) alone, for "
                       "comparison (compile and run) ...")
        sol, c_s, r_s = single_run(model, grid.omega_s[i], grid.T_s[i], grid.E_scale[i], t_end=t_end, dt_out=dt_out,
                                   solver=solver, controller=controller, max_steps=max_steps, tip=tip, timed=True)
        res.single_case, res.single_s, res.single_compile_s = i, r_s, c_s
        res.single_steps = int(sol.num_steps)
    return res


def single_run(model_or_reduction, omega_s: float, T_s: float, E_scale: float = 1.0, *, t_end: float,
               dt_out: float = 0.01, solver: GeneralizedAlpha | None = None,
               controller: AbstractStepSizeController | None = None, max_steps: int = 500_000,
               tip: int | None = None, timed: bool = False):
    """One case of a sweep run alone, exactly as the sweep runs it (``solver``, ``controller``:
    ``spinup_sweep``'s): the ``Solution`` (``ys`` the tip displacement series); with
    ``timed=True``, ``(solution, compile_s, run_s)``."""

    model = _as_model(model_or_reduction)
    ts = _validate.output_times(t_end, dt_out)
    m = case_model(model, jnp.asarray(float(omega_s)), jnp.asarray(float(T_s)),
                   1.0 if float(E_scale) == 1.0 else jnp.asarray(float(E_scale)))
    solver, controller = _integration(solver, controller, ts)
    args = (m, solver, controller, jnp.asarray(ts))
    kw = dict(max_steps=int(max_steps), observe=tip_observer(m, beam_tip(model) if tip is None else int(tip)))
    return simulate_timed(*args, **kw) if timed else simulate(*args, **kw)
