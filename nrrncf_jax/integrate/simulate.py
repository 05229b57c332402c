"""Adaptive time integration of a second-order model: ``simulate(model, solver, controller, ts)``,
one jit-compiled loop.

The loop rejects and retries steps, writes the outputs (cubic Hermite dense output) and batches
runs; the step itself is the solver's (diffrax-style ``solver.init``/``solver.step``,
``base.AbstractSolver``: ``GeneralizedAlpha`` (docs/theory.md, §8 Time integration), or ``GeneralizedAlphaIndex3`` for
constrained systems), the step size the controller's (``step_size``: ``AdaptiveStepSize``,
``ConstantStepSize``), and each step's implicit solve follows ``base.Newton``. Hand-written rather
than a diffrax solver because the step must solve for the acceleration with prescribed
coordinates, keep the auxiliary acceleration ā between steps, reuse the model's structured
factorisations inside Newton and carry index-3 constraints, none of which diffrax's ODE-term
interface expresses (``benchmarks/investigations/diffrax_vs_loop.py`` measures the diffrax route). The loop is
``equinox.internal.while_loop``: ``adjoint="forward"`` lowers to ``lax.while_loop`` (fastest;
forward-mode differentiable, vmappable); ``adjoint="reverse"`` lowers to a checkpointed loop
that ``jax.grad`` can differentiate with memory O(√max_steps) checkpoints, and differentiates
each step's Newton solve implicitly (``NewtonOptions.implicit``).
"""

import dataclasses
import functools
import inspect
import sys
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Literal

import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp
import jax.tree_util as jtu
import numpy as np
from jax import lax

from .. import _validate
from .._types import Array, Float, Int
from ..linalg.contract import as_einsum
from .base import AbstractSolver, IterationMatrix, Newton, NewtonOptions
from .forward_mode import forward_mode_only
from .generalized_alpha import hermite_interpolate
from .results import ENDINGS, SimulationError, SimulationResult, result_code, result_message
from .step_size import AbstractStepSizeController

if TYPE_CHECKING:  # the models import the integrator's users; annotations only
    from ..models.base import AbstractModel

FORWARD_ONLY_SINGLE = ("jax.grad cannot differentiate simulate(adjoint='forward'), the default, a forward-mode loop: "
                       "pass adjoint='reverse' (a checkpointed loop; unconstrained models), or differentiate in "
                       "forward mode (jax.jvp, jax.jacfwd)")
FORWARD_ONLY_BATCH = ("jax.grad cannot differentiate simulate_batch, a forward-mode loop: differentiate it in forward "
                      "mode (jax.jvp, jax.jacfwd), or vmap simulate(adjoint='reverse') for reverse mode")

_WINDOW = 8  # outputs that one step may cover; a step never crosses more than this many

STATE_OUTPUTS_MAX_BYTES = 64 * 2**20
"""A forward-mode run records its state (q, v) at the output times and observes them all after
the loop, in one vectorised call, where that buffer is at most this size (or no larger than the
observations'): see ``_Config.after``. Above it (a large body with many outputs) it observes in
the loop, step by step."""


class Solution(eqx.Module):
    """Output of ``simulate``: observations at ``ts`` and the integrator's statistics."""

    ts: Float[Array, " n_out"]
    ys: Any  # pytree, each leaf with leading axis n_out
    t_final: Float[Array, ""]
    result: SimulationResult
    num_steps: Int[Array, ""]
    num_rejected: Int[Array, ""]
    num_newton: Int[Array, ""]
    num_factorizations: Int[Array, ""]  # iteration matrices factored (per step; fewer with ``Newton(reuse=True)``)

    @property
    def message(self) -> str:
        """Why the run ended ('' when it reached its end time); one run, not a batch."""
        return SimulationResult[self.result]

    @property
    def code(self):
        """The result's integer code (``results.ENDINGS``: 0 successful), one a member for a batch."""
        return result_code(self.result)

    @property
    def succeeded(self):
        """Whether the run reached its end time (a boolean array, one a member for a batch)."""
        return self.result == SimulationResult.successful


class _Config(eqx.Module):
    """What the loop needs besides the model, solver and controller. ``observe`` is a pytree (a
    function, or a module such as ``TipObserver`` whose arrays are traced).

    ``after``: the loop records (q, v) at the output times and ``observe`` runs once over all of
    them after it (``_observe_after``), instead of in the loop. A step that covers output times
    observes its whole window of ``_WINDOW`` slots (one vectorised call, the slots past its end
    included), so in the loop each output costs up to ``_WINDOW`` observations, each a few small
    operations, in a program whose time is per operation; an observation with energies (a
    mechanism's) then costs as much as the step. After the loop it is one call over every output.
    Forward mode only (the reverse-mode loop checkpoints its output buffers), and only where the
    state buffer is small (``STATE_OUTPUTS_MAX_BYTES``)."""

    observe: Callable
    max_steps: int = eqx.field(static=True)
    adjoint: str = eqx.field(static=True)
    progress: bool = eqx.field(static=True)
    after: bool = eqx.field(static=True, default=False)
    step_ts: Any = None  # times at which steps must end (``simulate``'s ``step_ts``), sorted; None: none

    def recording(self) -> "_Config":
        """The loop's config: with ``after``, observing the state itself."""
        return eqx.tree_at(lambda c: c.observe, self, _observe_state) if self.after else self

    def with_after(self, n_dof: int, n_out: int, members: int = 1) -> "_Config":
        """``after`` set for a forward-mode run of ``members`` models of ``n_dof`` coordinates over
        ``n_out`` outputs (see the class docstring)."""
        if self.adjoint != "forward":
            return self
        q = jax.ShapeDtypeStruct((n_dof,), jnp.result_type(float))
        obs = jax.eval_shape(self.observe, jax.ShapeDtypeStruct((), q.dtype), q, q)
        obs_bytes = sum(int(np.prod(x.shape)) * np.dtype(x.dtype).itemsize for x in jtu.tree_leaves(obs))
        state_bytes = 2 * n_dof * q.dtype.itemsize
        small = members * (n_out + _WINDOW) * state_bytes <= STATE_OUTPUTS_MAX_BYTES
        return dataclasses.replace(self, after=small or state_bytes <= obs_bytes)


def _observe_state(t, q, v):
    return q, v


def _observe_after(observe, ts, t0, k, states):
    """``observe`` at every output time from the recorded states (q, v) (``_Config.after``): the
    times at or before t0 observed at t0, as the loop's first observation is; slots the run did
    not reach (at index k and after: a run that stopped early) zero, as ``finish`` leaves them."""
    Q, V = states  # n_out rows each (``finish`` has cut the window's padding)
    written = jnp.arange(ts.shape[0]) < k
    Q, V = (jnp.where(written[:, None], x, x[0]) for x in (Q, V))  # unreached slots: a state observable
    obs = jax.vmap(observe)(jnp.where(ts <= t0, t0, ts), Q, V)
    return jtu.tree_map(lambda y: jnp.where(written.reshape((-1,) + (1,) * (y.ndim - 1)), y, 0), obs)


def _default_observe(t, q, v):
    return q


def simulate(
    model: "AbstractModel",
    solver: AbstractSolver,
    controller: AbstractStepSizeController,
    ts,
    *,
    observe: Callable | None = None,
    newton: Newton | None = None,
    t0: float = 0.0,
    y0: tuple | None = None,
    adjoint: Literal["forward", "reverse"] = "forward",
    max_steps: int = 200_000,
    progress: bool = False,
    step_ts=None,
    throw: bool = True,
) -> Solution:
    """Integrate ``model`` with ``solver`` and ``controller`` from ``t0`` and return
    ``observe(t, q, v)`` at the times ``ts`` (default: q).

    ``solver``: ``GeneralizedAlpha(rho_inf)``, or ``GeneralizedAlphaIndex3(rho_inf)`` for a
    constrained system. ``controller``: ``AdaptiveStepSize(rtol, atol)`` or ``ConstantStepSize(dt)``.
    ``newton``: each step's Newton (``Newton(tol, max_iter, kind)``); a Newton failure or a
    non-finite state retries the step at a quarter of its size. ``y0 = (q0, v0)`` overrides the
    model's initial state (prescribed coordinates are still imposed). ``adjoint="reverse"`` makes
    the run differentiable by ``jax.grad`` (a checkpointed loop; unconstrained models).

    ``step_ts``: times in [t0, t_end] at which a step must end (as diffrax's ``step_ts``): the
    step before each is cut to end exactly on it. An output at such a time is then the step's end
    state, which satisfies the model's equations to Newton's tolerance, where an output between
    steps is interpolated (``reduction.run_error`` evaluates equations at such states). A time
    within round-off of an output time is taken as that output time.

    ``throw=True`` raises ``SimulationError`` naming the time reached if the run stops early (or,
    inside a user's ``jit``/``vmap``, an ``eqx.error_if`` runtime error); ``throw=False`` returns
    the ``Solution`` with its ``result``.

    ``jax.vmap`` works through it; for a batch of models in forward mode, ``simulate_batch``
    gives the same results for less (see there).

    A model made of small kernels (``small_kernels``: the reduced ones), called outside any JAX
    transformation on a CPU, is compiled with ``SMALL_KERNEL_OPTIONS``, which compile it faster;
    the result is the same to the step decisions that another rounding may flip.

    Where ``observe`` runs: in forward mode with a small state, once over all the output times
    after the loop, on the states recorded there (``_Config.after``: the loop then costs no
    observation); otherwise inside the loop, in the steps that reach output times. The values
    are the same either way; a slot the run did not reach (it stopped early) is zero.
    """
    args = _prepare(model, solver, controller, ts, observe, newton, t0, y0, adjoint, max_steps, progress, step_ts)
    return _check(_single_run_program(args[0])(*args), throw)


def simulate_batch(model_fn: Callable, params, solver: AbstractSolver, controller: AbstractStepSizeController, ts, *,
                   observe: Callable | None = None, newton: Newton | None = None, t0: float = 0.0,
                   max_steps: int = 200_000, width: int | None = None, small_kernels: bool = False,
                   step_ts=None, throw: bool = True) -> Solution:
    """``simulate`` for a batch of models, ``model_fn(p)`` for each ``p`` along the leading axis of
    the pytree ``params``, in one loop: each member keeps its own adaptive steps. Returns a
    ``Solution`` whose fields have the batch axis first. The members start from their models'
    initial states, and the loop runs in forward mode (``jax.jvp``/``jacfwd`` pass through; use
    ``simulate`` with ``adjoint="reverse"`` for reverse mode).

    ``width``: how many members the loop advances together (its lanes; default ``batch_lanes``:
    all of them on an accelerator, at most ``CPU_BATCH_LANES`` on a CPU). With fewer lanes than
    members, the others wait in a queue, in their order in ``params``: a member that ends hands its
    lane to the next one, so the loop keeps ``width`` members busy until the queue is empty instead
    of running until its slowest member is done with the rest idle. Put the costliest members
    first.

    ``small_kernels=True`` compiles the batch with ``SMALL_KERNEL_OPTIONS`` on a CPU, as a single
    run of a reduced model is: it compiles faster, but a batch's wider fused kernels may run slower
    with them, so it pays where compilation dominates (short runs, a one-off batch) and is off by
    default. Inside a user's ``jit``,
    ``vmap`` or ``grad`` the outer program's options apply: pass
    ``compiler_options=kernel_options(True)`` to that ``jax.jit`` instead.

    ``jax.vmap(simulate)`` gives the same result but costs more: see ``_simulate_batch_program``.
    ``model_fn`` should be a pytree-aware callable (``jax.tree_util.Partial`` or an
    ``equinox.Module``) when it closes over arrays, so that they are traced rather than baked
    in. ``observe(t, q, v)`` and ``step_ts`` (see ``simulate``) are shared by the members.
    """
    leaves = jtu.tree_leaves(params)
    sizes = {int(np.shape(x)[0]) if np.ndim(x) else -1 for x in leaves}
    if not leaves or len(sizes) != 1 or -1 in sizes or 0 in sizes:
        raise ValueError("params must be a pytree of arrays sharing a non-empty leading batch axis, got leading "
                         f"sizes {sorted(sizes)}")
    (n,) = sizes
    width = batch_lanes(n, width)
    member = model_fn(jtu.tree_map(lambda x: x[0], params))  # one member, for the checks
    _, solver, controller, ts_, t0_, _, options, config = _prepare(member, solver, controller, ts, observe, newton,
                                                                   t0, None, "forward", max_steps, False, step_ts)
    config = config.with_after(member.n_dof, ts_.shape[0], n)
    _validate.boolean("small_kernels", small_kernels)
    program = _simulate_batch
    if small_kernels and kernel_options(True):
        if not _at_top_level():
            raise ValueError("simulate_batch(small_kernels=True) inside jit, vmap or grad: JAX applies compiler "
                             "options only to the outermost program; pass compiler_options=kernel_options(True) "
                             "to your jax.jit instead")
        program = _simulate_batch_small
    # traced per member under vmap, the models' small contractions stay matrix products on a CPU,
    # which run faster there than fused loops widened by the lanes (``linalg.contract``)
    with as_einsum(jax.default_backend() == "cpu"):
        sol = program(model_fn, params, solver, controller, ts_, t0_, options, config, width=width)
    return _check(sol, throw)


CPU_BATCH_LANES = 4
"""``simulate_batch``'s default lanes on a CPU. On one CPU core a batched member-step costs about
what it costs alone whatever the lane count, so what a batch gains or loses is its padding: lanes
that keep stepping, masked, after their member is done, while the slowest member runs on. A few
lanes fed from the queue leave little padding and still share each kernel's overhead, so on a CPU
a few lanes run a batch faster than a lane for every member. On an accelerator every member gets
a lane: its cost is time per batched step, which wide batches amortise."""


def batch_lanes(n: int, width: int | None = None, platform: str | None = None) -> int:
    """The lanes of a batched loop of ``n`` members: ``width`` (at most ``n``) when given; by
    default all ``n`` on an accelerator and at most ``CPU_BATCH_LANES`` on a CPU (``platform``,
    default JAX's default backend)."""
    if width is None:
        return n if (platform or jax.default_backend()) != "cpu" else min(n, CPU_BATCH_LANES)
    if isinstance(width, bool) or not isinstance(width, (int, np.integer)) or width < 1:
        raise ValueError(f"width must be a positive integer (lanes of the batched loop), got width={width!r}")
    return min(int(width), n)


def simulate_timed(model: "AbstractModel", solver: AbstractSolver, controller: AbstractStepSizeController, ts,
                   **kwargs) -> tuple[Solution, float, float]:
    """``simulate`` with compilation and execution timed apart: ``(solution, compile_s, run_s)``.

    Compiles ahead of time (``lower().compile()``, with ``simulate``'s choice of XLA options),
    then runs to ``block_until_ready``. The keyword arguments are ``simulate``'s.
    """
    # ``simulate``'s own keywords and defaults, read from its signature rather than copied
    try:
        bound = inspect.signature(simulate).bind(model, solver, controller, ts, **kwargs)
    except TypeError as e:
        raise TypeError(f"simulate_timed takes simulate's arguments: {e}") from None
    bound.apply_defaults()
    a = bound.arguments
    throw = a["throw"]
    args = _prepare(model, solver, controller, ts, a["observe"], a["newton"], a["t0"], a["y0"], a["adjoint"],
                    a["max_steps"], a["progress"], a["step_ts"])
    t0 = time.perf_counter()
    compiled = _single_run_program(args[0]).lower(*args).compile()
    t1 = time.perf_counter()
    sol = jax.block_until_ready(compiled(*args))
    t2 = time.perf_counter()
    return _check(sol, throw), t1 - t0, t2 - t1


def _prepare(model, solver, controller, ts, observe, newton, t0, y0, adjoint, max_steps, progress, step_ts=None):
    """Check everything before tracing; return ``_simulate``'s arguments."""
    if not isinstance(solver, AbstractSolver):
        raise ValueError(f"solver must be an integrate solver (GeneralizedAlpha, GeneralizedAlphaIndex3), got "
                         f"{type(solver).__name__}: simulate(model, solver, controller, ts, ...)")
    if not isinstance(controller, AbstractStepSizeController):
        raise ValueError(f"controller must be a step-size controller (AdaptiveStepSize, ConstantStepSize), got "
                         f"{type(controller).__name__}: simulate(model, solver, controller, ts, ...)")
    newton = Newton() if newton is None else newton  # built here, not at import (no array before x64 is set)
    if not isinstance(newton, Newton):
        raise ValueError(f"newton must be an integrate.Newton, got {type(newton).__name__}")
    solver.check(model)
    ts_np = np.asarray(ts, dtype=float) if not isinstance(ts, jax.core.Tracer) else None
    if ts_np is not None:
        if ts_np.ndim != 1 or ts_np.size == 0:
            raise ValueError(f"ts must be a non-empty 1-D array of output times, got shape {ts_np.shape}")
        if not np.all(np.isfinite(ts_np)):
            raise ValueError("ts must be finite")
        if np.any(np.diff(ts_np) <= 0):
            raise ValueError("ts must be strictly increasing")
        if ts_np[-1] <= t0:
            raise ValueError(f"t_end = ts[-1] must be greater than t0 = {t0}, got t_end = {ts_np[-1]}")
    if adjoint not in ("forward", "reverse"):
        raise ValueError(f"adjoint must be 'forward' or 'reverse', got {adjoint!r}")
    options = newton.options(model, controller.adaptive, implicit=adjoint == "reverse")
    config = _Config(max_steps=_validate.positive_int("max_steps", max_steps), adjoint=adjoint,
                     observe=_default_observe if observe is None else observe, progress=bool(progress))
    if y0 is not None:
        y0 = tuple(jnp.asarray(x, dtype=float) for x in y0)
        if len(y0) != 2 or any(x.shape != (model.n_dof,) for x in y0):
            raise ValueError(f"y0 must be (q0, v0), each of shape ({model.n_dof},)")
    if step_ts is not None:
        config = dataclasses.replace(config, step_ts=_step_times(step_ts, ts_np, t0))
    f = jnp.asarray
    ts = f(ts, dtype=float)
    return model, solver, controller, ts, f(t0, dtype=float), y0, options, config.with_after(model.n_dof, ts.shape[0])


def _step_times(step_ts, ts_np, t0):
    """``simulate``'s ``step_ts`` checked (a non-empty 1-D array of finite, strictly increasing
    times in [t0, t_end]) and, where it is given as numbers, each time within round-off
    (1e-12 relative, the loop's snap onto a stop) of an output time replaced by that output time:
    two stops that close apart would make a step of round-off size."""
    if isinstance(step_ts, jax.core.Tracer) or ts_np is None:
        return jnp.asarray(step_ts, dtype=float)
    x = np.asarray(step_ts, dtype=float)
    if x.ndim != 1 or x.size == 0 or not np.all(np.isfinite(x)) or np.any(np.diff(x) <= 0):
        raise ValueError("step_ts must be a non-empty 1-D array of finite, strictly increasing times, got "
                         f"{x.tolist()}")
    if x[0] < t0 or x[-1] > ts_np[-1]:
        raise ValueError(f"step_ts must lie in [t0, t_end] = [{t0:g}, {ts_np[-1]:g}], got {x[0]:g} .. {x[-1]:g}")
    j = np.searchsorted(ts_np, x)
    lo, hi = np.clip(j - 1, 0, ts_np.size - 1), np.clip(j, 0, ts_np.size - 1)
    near = np.where(np.abs(ts_np[lo] - x) <= np.abs(ts_np[hi] - x), lo, hi)
    snap = np.abs(ts_np[near] - x) <= 1e-12 * (1.0 + np.abs(x))
    return jnp.asarray(np.where(snap, ts_np[near], x))


def _check(sol: Solution, throw: bool) -> Solution:
    if throw:
        failed = sol.result != SimulationResult.successful
        if isinstance(failed, jax.core.Tracer):
            sol = eqx.error_if(sol, failed, "simulation stopped early; inspect Solution.t_final")
        elif np.any(np.asarray(failed)):
            codes = np.asarray(result_code(sol.result)).reshape(-1)
            tf = np.asarray(sol.t_final).reshape(-1)
            bad = int(np.flatnonzero(codes)[0])
            raise SimulationError(f"simulation stopped at t = {tf[bad]:.6g} s: {result_message(codes[bad])}")
    return sol


class _Stacked(eqx.Module):
    """A pytree of arrays (the stepping method's state) stored with its leaves of one shape and
    dtype stacked: the generalized-α (q, v, a, ā) as one (4, n) array, one buffer in the loop's
    carry rather than four, selected (accept/reject) in one operation. ``unstack`` slices the
    rows back into the typed state at the start of a step; the new state is stacked where the
    step's result is selected. (Carrying the four arrays apart changes XLA's fusion of the step,
    and with it the round-off of the results.)"""

    arrays: tuple[Array, ...]  # one stacked array per group
    groups: tuple[tuple[int, ...], ...] = eqx.field(static=True)  # the leaves in each array's rows
    treedef: Any = eqx.field(static=True)

    @classmethod
    def of(cls, tree) -> "_Stacked":
        leaves, treedef = jtu.tree_flatten(tree)
        groups: dict = {}
        for i, x in enumerate(leaves):
            groups.setdefault((jnp.shape(x), jnp.result_type(x)), []).append(i)
        groups = tuple(tuple(g) for g in groups.values())
        return cls(tuple(jnp.stack([leaves[i] for i in g]) for g in groups), groups, treedef)

    def unstack(self):
        leaves = [None] * sum(len(g) for g in self.groups)
        for arr, g in zip(self.arrays, self.groups):
            for i, row in zip(g, arr):
                leaves[i] = row
        return jtu.tree_unflatten(self.treedef, leaves)


class _LoopState(eqx.Module):
    """The adaptive loop's carry: time, next step size, the solver's state, the first output slot
    not yet covered, statistics, status and the output buffer."""

    t: Float[Array, ""]
    h: Float[Array, ""]  # the next step's size
    state: _Stacked  # the solver's (``GeneralizedAlphaState``), stacked
    k: Int[Array, ""]  # the first output slot that no accepted step has covered
    counts: Int[Array, "4"]  # accepted steps, rejected steps, Newton iterations, factorisations
    result: Int[Array, ""]  # 0 while running, else the code of the ending (results.ENDINGS)
    ys: Any = None  # output buffer (n_out + K slots per leaf); None in batched runs (see step)
    matrix: Any = None  # the kept iteration matrix (``Newton(reuse=True)``), else None
    err_prev: Any = None  # the last accepted step's error norm (the PI controller's memory)


class _AdaptiveLoop(eqx.Module):
    """One run's adaptive loop, built inside the trace: its initial carry (``init``), one attempted
    step (``step``), its condition (``cond``) and the ``Solution`` it ends in (``finish``)."""

    model: Any
    solver: AbstractSolver
    controller: AbstractStepSizeController
    ts: Float[Array, " n_out"]
    t0: Float[Array, ""]
    y0: tuple | None
    newton: NewtonOptions
    config: _Config
    ts_pad: Float[Array, " n_out+K"]  # the output times and K slots at infinity
    dt0: Float[Array, ""]  # the controller's first step

    def __init__(self, model, solver, controller, ts, t0, y0, newton, config):
        self.model, self.solver, self.controller, self.ts, self.t0, self.y0 = model, solver, controller, ts, t0, y0
        self.newton, self.config = newton, config
        self.ts_pad = jnp.concatenate([ts, jnp.full((_WINDOW,), jnp.inf)])
        self.dt0 = controller.first_step(t0, ts[-1])

    @property
    def t_end(self):
        return self.ts[-1]

    def error_coords(self, q):
        """The step's start in the model's error space, and which coordinates count."""
        x, _, mask = self.model.error_space(q, jnp.zeros_like(q))
        return x, mask

    @staticmethod
    def rms(ex, scale, mask):
        r = ex / scale
        return jnp.sqrt(jnp.sum(jnp.where(mask, r * r, 0.0)) / jnp.maximum(jnp.sum(mask), 1))

    def next_stop(self, t, k):
        """Where the step from ``t`` must end at the latest: the end of the output window (``k``,
        the first uncovered output), the end time, or the next of ``step_ts`` after ``t`` (a step
        ends exactly on a stop, so the one it ended on is not after it)."""
        stop = jnp.minimum(self.ts_pad[k + _WINDOW - 1], self.t_end)
        if self.config.step_ts is not None:
            stops = self.config.step_ts
            stop = jnp.minimum(stop, jnp.min(jnp.where(stops > t, stops, jnp.inf)))
        return stop

    def limit_step(self, t, h, k):
        rem = self.next_stop(t, k) - t
        return jnp.where(rem <= 1.1 * h, rem, jnp.where(rem < 2.0 * h, 0.5 * rem, h))

    def init(self, outputs=True) -> _LoopState:
        """The loop's first carry (``outputs=False``: without the output buffer), with the
        solver's consistent initial state."""
        t0 = self.t0
        q0, v0 = self.model.initial_state(t0) if self.y0 is None else self.y0
        state = self.solver.init(self.model, t0, q0, v0)
        k0 = jnp.sum(self.ts_pad <= t0).astype(int)
        h0 = self.limit_step(t0, jnp.minimum(self.dt0, self.controller.dt_max), k0)
        matrix = None
        if self.newton.reuse:  # a matrix of the factor's structure, invalid: the first step factors
            shapes = self.solver.matrix_shape(self.model, t0, state)
            matrix = IterationMatrix(jtu.tree_map(lambda x: jnp.zeros(x.shape, x.dtype), shapes), h0,
                                     jnp.asarray(False))
        c = _LoopState(t=t0, h=h0, state=_Stacked.of(state), k=k0, counts=jnp.zeros(4, int), result=jnp.array(0),
                       matrix=matrix, err_prev=jnp.ones((), jnp.result_type(float)))
        return dataclasses.replace(c, ys=self.outputs(c)) if outputs else c

    def outputs(self, c: _LoopState):
        """The output buffer (n_out + K slots): the initial observation at the times ≤ t0."""
        st = c.state.unstack()
        obs0 = self.config.observe(self.t0, st.q, st.v)
        n_out, K = self.ts.shape[0], _WINDOW
        at_start = self.ts_pad <= self.t0
        return jtu.tree_map(
            lambda x: jnp.where(at_start.reshape((-1,) + (1,) * jnp.ndim(x)), x,
                                jnp.zeros((n_out + K,) + jnp.shape(x), jnp.result_type(x))), obs0)

    def step(self, c: _LoopState, active=None):
        """One attempted step: ``(carry, window)``, the new carry and the step's output window
        (its observations at the K output slots from ``c.k`` on). ``active`` (batched runs, see
        ``_simulate_batch_program``): a member that is done steps at a harmless size and keeps its carry
        unchanged. A carry with the output buffer ``ys`` gets the window written into it; a carry
        without (``init(outputs=False)``, as batched runs use) leaves the window to the caller to
        write (or drop, for an inactive member)."""
        model, solver, controller, config, K = self.model, self.solver, self.controller, self.config, _WINDOW
        ts_pad, t_end = self.ts_pad, self.t_end
        t, h, k, st = c.t, c.h, c.k, c.state.unstack()
        if active is not None:
            h = jnp.where(active, h, self.dt0)
        h = lax.stop_gradient(h)
        t1 = t + h
        ns = self.next_stop(t, k)
        t1 = jnp.where(jnp.abs(t1 - ns) <= 1e-12 * (1.0 + jnp.abs(ns)), ns, t1)
        x0, mask = self.error_coords(st.q)
        x0 = lax.stop_gradient(x0)
        # Newton's corrections are measured in the model's Newton space (its error space unless
        # it says otherwise: every coordinate must converge, also those the step error leaves
        # out), in units of the tolerance at the step's start; in reverse mode without
        # derivatives (the step differentiates its solve implicitly).
        m_n, q_n = lax.stop_gradient((model, st.q)) if self.newton.implicit else (model, st.q)
        if model.newton_in_error_space:  # the common case: the step's error space and its scale
            newton_space, newton_scale, newton_mask = m_n.error_space, controller.scale(x0), mask
        else:
            newton_space = m_n.newton_space
            xn0, _, newton_mask = model.newton_space(st.q, jnp.zeros_like(st.q))
            newton_scale = controller.scale(lax.stop_gradient(xn0))

        def norm(dq):
            return self.rms(newton_space(q_n, dq)[1], newton_scale, newton_mask)

        st1, error, newton_sol = solver.step(model, t, t1, st, self.newton, norm, h=h, matrix=c.matrix)
        iters, done = newton_sol.iterations, newton_sol.converged
        q1, v1 = st1.q, st1.v

        x1, ex, _ = model.error_space(q1, error)
        err = lax.stop_gradient(self.rms(ex, controller.scale(x0, x1), mask))
        finite = jnp.isfinite(err) & jnp.all(jnp.isfinite(q1)) & jnp.all(jnp.isfinite(v1))
        ok = done & finite
        accept, h_new = controller.adapt(h, err, ok, c.err_prev)
        matrix = None
        if c.matrix is not None:
            # A growth too small to pay for a new factorisation is not taken (``Newton``).
            h_new = jnp.where(accept & (h_new > h) & (h_new <= (1.0 + self.newton.reuse_band) * h), h, h_new)
            matrix = newton_sol.matrix
            matrix = dataclasses.replace(matrix, valid=matrix.valid & finite)
        h_new = jnp.minimum(h_new, controller.dt_max)

        # Dense output at the requested times inside (t, t1]: the whole window of K output
        # slots in one vectorised write.
        idx = k + jnp.arange(K)
        tau = ts_pad[idx]
        write = accept & (tau <= t1)

        def observe_window():
            s = jnp.clip((tau - t) / h, 0.0, 1.0)
            qi, vi = hermite_interpolate(s[:, None], h, st.q, st.v, q1, v1)
            # An output on the step's end is its end state itself, not the interpolant there
            # (equal only to round-off where the step was snapped onto its stop): a state on
            # the equations (``step_ts``).
            end = (tau == t1)[:, None]
            qi, vi = jnp.where(end, q1, qi), jnp.where(end, v1, vi)
            return jax.vmap(config.observe)(jnp.where(write, tau, t1), qi, vi)

        # A run that carries its output buffer and is not differentiated in reverse observes only
        # in the steps that cover an output time: the observation (K slots of it) can cost more
        # than the step itself (e.g. a multibody system's energies).
        lazy = c.ys is not None and config.adjoint != "reverse"
        obs = None if lazy else observe_window()

        if config.adjoint == "reverse":
            # The checkpointed loop's buffers are written once per slot: slots past t1 (or
            # of a rejected step) keep what they hold.
            def write_window(x, buf):
                x = jnp.where(write.reshape((K,) + (1,) * (jnp.ndim(x) - 1)), x, buf[idx])
                return buf.at[idx].set(x, pred=accept)
        else:
            # Every slot of the window is written, without reading the buffer back: a slot
            # past t1, or any slot of a rejected step, is rewritten by the accepted step that
            # covers its time (the window starts at the first uncovered slot, which only
            # accepted steps advance). One in-place dynamic-update-slice: reading the old values
            # back, or a scatter, is an operation over the whole buffer to XLA's cost model,
            # which splits it across threads, a thread hand-off every step.
            def write_window(x, buf):
                return lax.dynamic_update_slice_in_dim(buf, x.astype(buf.dtype), k, axis=0)

        k_new = jnp.where(accept, k + jnp.sum(tau <= t1), k)

        t_new = jnp.where(accept, t1, t)
        h_new = lax.stop_gradient(self.limit_step(t_new, h_new, k_new))
        pick = lambda new, old: jnp.where(accept, new, old)  # noqa: E731, applied leaf by leaf
        result = jnp.where(~accept & (h_new < controller.dt_min), jnp.where(finite, 2, 3), 0)
        if config.progress:
            lax.cond(
                accept & (c.counts[0] % 200 == 0),
                lambda: jax.debug.callback(_print_progress, t_new, t_end, c.counts[0]),
                lambda: None,
            )
        new = _LoopState(
            t=t_new, h=h_new, state=jtu.tree_map(pick, _Stacked.of(st1), c.state), k=k_new,
            counts=c.counts + jnp.stack([accept, ~accept, iters, newton_sol.factorizations]).astype(int),
            result=result, matrix=matrix, err_prev=jnp.where(accept, err, c.err_prev),
        )
        if active is not None:
            new = jtu.tree_map(lambda val, old: jnp.where(active, val, old), new, c)
        if lazy:
            ys = lax.cond(jnp.any(write), lambda ys: jtu.tree_map(write_window, observe_window(), ys),
                          lambda ys: ys, c.ys)
            new = dataclasses.replace(new, ys=ys)
        elif c.ys is not None:
            new = dataclasses.replace(new, ys=jtu.tree_map(write_window, obs, c.ys))
        return new, obs

    def cond(self, c: _LoopState):
        return (c.t < self.t_end) & (c.result == 0)

    def finish(self, final: _LoopState, ys=None) -> Solution:
        """The Solution of the final carry (``ys``: its output buffer, when it carries none)."""
        ys = final.ys if ys is None else ys
        code = jnp.where((final.result == 0) & (final.t < self.t_end), 1, final.result)
        result = SimulationResult.successful
        for i, item in enumerate(ENDINGS[1:], start=1):
            result = SimulationResult.where(code == i, item, result)
        n_out = self.ts.shape[0]
        # A run that stopped early: its last window's slots past the time it reached hold
        # observations at that time; zero them, as the slots no step reached are.
        reached = jnp.arange(n_out) < final.k
        ys = jtu.tree_map(lambda y: jnp.where(reached.reshape((-1,) + (1,) * (jnp.ndim(y) - 1)), y[:n_out], 0), ys)
        return Solution(
            ts=self.ts, ys=ys, t_final=final.t, result=result,
            num_steps=final.counts[0], num_rejected=final.counts[1], num_newton=final.counts[2],
            num_factorizations=final.counts[3],
        )


def states_at(model: "AbstractModel", solver: AbstractSolver, controller: AbstractStepSizeController, times, *,
              newton: Newton | None = None,
              max_steps: int = 200_000) -> tuple[np.ndarray, np.ndarray, float, float, int]:
    """The run of ``model`` from ``times[0]`` (its initial state there) through the later times,
    its steps ending exactly on each (``simulate``'s ``step_ts``): ``(Q, V, compile_s, run_s,
    steps)`` with the states q and v at ``times`` (rows), compile and run times and the accepted
    steps.

    Each state is the end of a step, where the model's equations hold to Newton's tolerance with
    the step's acceleration, not an output interpolated between steps (cubic Hermite), which is
    accurate to the step's error but can sit off the equations' stiff directions by far more: a
    reduced model's stiff coordinates (its modal derivatives) carry the interpolation's error as an
    elastic force out of balance, which an equation-based acceleration at that state reads as a
    large one (``reduction.run_error``). Compiled through ``simulate``'s cache
    (``simulate_timed``): a later call for the same model structure and number of times does not
    compile again. Raises ``SimulationError`` if the run stops early."""
    times = np.asarray(times, dtype=float).reshape(-1)
    if times.size < 2 or not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
        raise ValueError(f"times must be at least two finite, strictly increasing times, got {times.tolist()}")
    y = tuple(jnp.asarray(x) for x in model.initial_state(times[0]))
    sol, compile_s, run_s = simulate_timed(model, solver, controller, times[1:], observe=_observe_state,
                                           newton=newton, t0=float(times[0]), max_steps=max_steps,
                                           step_ts=times[1:])
    Q, V = (np.concatenate([np.asarray(y0)[None], np.asarray(x)]) for y0, x in zip(y, sol.ys))
    return Q, V, compile_s, run_s, int(sol.num_steps)


def _simulate_program(model, solver, controller, ts, t0, y0, newton: NewtonOptions, config: _Config) -> Solution:
    """A single run's program: the adaptive loop, then the observations after it."""
    loop = _AdaptiveLoop(model, solver, controller, ts, t0, y0, newton, config.recording())
    final = eqxi.while_loop(
        loop.cond, lambda c: loop.step(c)[0], loop.init(), max_steps=config.max_steps,
        buffers=(lambda c: c.ys) if config.adjoint == "reverse" else None,
        kind="checkpointed" if config.adjoint == "reverse" else "lax",
    )
    if config.adjoint == "forward":
        final = forward_mode_only(final, FORWARD_ONLY_SINGLE)
    if config.progress:
        jax.debug.callback(_print_progress, final.t, ts[-1], final.counts[0], True)
    sol = loop.finish(final)
    if config.after:
        sol = eqx.tree_at(lambda s: s.ys, sol, _observe_after(config.observe, ts, t0, final.k, sol.ys))
    return sol


SMALL_KERNEL_OPTIONS = {"xla_cpu_use_fusion_emitters": False}
"""XLA's options for a run of a model made of small kernels (``AbstractModel.small_kernels``:
the reduced models) on a CPU: the older (LLVM IR) emitter for fused element-wise kernels instead of
the MLIR-based one: it compiles such a run's loop faster, and the loop runs as fast. The
full-order models' large fused kernels (element forces at every Gauss point) and a batch's wider
ones run slower with it, so those keep XLA's defaults. Per program (``jax.jit``'s
``compiler_options``): no global flag is changed, and inside a user's own ``jit`` the outer
program's options apply."""

_simulate = eqx.filter_jit(_simulate_program)
_SINGLE_RUN_OPTIONS = SMALL_KERNEL_OPTIONS | {"xla_cpu_experimental_ynn_fusion_type": "",
                                              "xla_backend_optimization_level": 1}
"""A single run's options: ``SMALL_KERNEL_OPTIONS``, no YNNPACK kernels for the small dot
products, and LLVM's optimisation level 1 instead of 2. YNNPACK plans its kernels when a program
first runs, a one-off cost comparable to a whole reduced mechanism's run, and its kernels are no
faster on products of a few tens of rows; a batch's wider products keep it. The lower
optimisation level compiles a reduced mechanism's loop in a sixth less time, and its kernels, a
few operations each, run about as fast (``benchmarks/results/xla_options.md``): where a single
run's compile time is a hundred times its run time, that is what a user waits for. A batch, whose
run is long, keeps XLA's level."""
_simulate_small = eqx.filter_jit(_simulate_program, compiler_options=_SINGLE_RUN_OPTIONS)


def kernel_options(small: bool, platform: str | None = None) -> dict:
    """``jax.jit``'s ``compiler_options`` for a program of small kernels (``small=True``):
    ``SMALL_KERNEL_OPTIONS`` on a CPU (``platform``, default JAX's default backend) whose XLA knows
    them; otherwise none (``{}``: XLA's defaults). For a user's own ``jax.jit`` around a batched
    run (``simulate_batch`` inside it), where the outer program's options apply:
    ``jax.jit(f, compiler_options=kernel_options(True))``."""
    if small and (platform or jax.default_backend()) == "cpu" and _small_kernel_options_known():
        return dict(SMALL_KERNEL_OPTIONS)
    return {}


def _single_run_program(model):
    """The jitted program for a single run of ``model``: compiled with ``SMALL_KERNEL_OPTIONS``
    for a model of small kernels on a CPU, called at the top level (JAX accepts compiler options
    only on a program it compiles itself, not on one traced into a user's ``jit``, ``vmap`` or
    ``grad``), where this jaxlib knows the options; with XLA's defaults otherwise."""
    if getattr(model, "small_kernels", False) and _at_top_level() and kernel_options(True):
        return _simulate_small
    return _simulate


def _at_top_level() -> bool:
    """Whether no JAX transformation is tracing. ``jax._src.core.trace_state_clean`` is the test
    JAX itself applies before it refuses compiler options on a nested ``jit``; it has no public
    name, so a JAX without it keeps XLA's defaults."""
    try:
        from jax._src.core import trace_state_clean
    except ImportError:
        return False
    return bool(trace_state_clean())


@functools.cache
def _small_kernel_options_known() -> bool:
    """Whether this jaxlib's XLA knows ``_SINGLE_RUN_OPTIONS`` (``SMALL_KERNEL_OPTIONS`` among them;
    an unknown option fails the compilation): compiles a one-operation program with them, once a
    process."""
    try:
        jax.jit(lambda x: x + 1.0, compiler_options=_SINGLE_RUN_OPTIONS).lower(1.0).compile()
    except Exception:  # noqa: BLE001 - any refusal means: keep XLA's defaults
        return False
    return True


def _simulate_batch_program(model_fn, params, solver, controller, ts, t0, newton: NewtonOptions, config: _Config, *,
                            width: int) -> Solution:
    """``simulate_batch``'s program: one ``lax.while_loop`` whose body advances the member in each
    of ``width`` lanes by one attempted step (``vmap`` of the step), until every member is done.

    Written out rather than ``vmap(simulate)``: a vmapped ``while_loop`` with a per-member
    condition selects between the new and the old carry of every member at every step, the output
    buffers included: a copy and a select of every member's whole output buffer per step. Here the
    condition is one ``any``, and the lanes carry only the small state: each step's output window
    is written straight into its member's
    row of the results.

    The queue: a lane holds the index of its member (``n`` once the queue is empty) and that
    member's parameters. Every member's initial carry is computed before the loop; when a lane's
    member ends, its carry is stored and the next member waiting takes the lane. This is
    bookkeeping on small arrays, done every iteration rather than under a ``lax.cond``, whose
    branches would copy the loop's state.
    """
    n = jtu.tree_leaves(params)[0].shape[0]

    def loop(p):
        return _AdaptiveLoop(model_fn(p), solver, controller, ts, t0, None, newton, config.recording())

    def running(p, c):
        return loop(p).cond(c) & (c.counts[0] + c.counts[1] < config.max_steps)

    def take(tree, i):
        return jtu.tree_map(lambda x: x[jnp.clip(i, 0, n - 1)], tree)

    # Every member's initial carry, one after another: a batched initial solve would be one
    # batched LAPACK LU (see ``linalg._solve_on_cpu_batched`` for why the library avoids those).
    first = lax.map(lambda p: loop(p).init(outputs=False), params)
    ys = jax.vmap(lambda p, c: loop(p).outputs(c))(params, first)  # (n, n_out + K, ...)
    lane = jnp.arange(width)

    def body(state):
        C, lane_p, member, queued, final, ys = state
        active = (member < n) & jax.vmap(running)(lane_p, C)
        new, window = jax.vmap(lambda p, c, on: loop(p).step(c, active=on))(lane_p, C, active)
        # Each lane's window of outputs into its member's row, from the slot it started at (one
        # scatter); an idle lane's window is dropped.
        row = jnp.where(active, member, n)[:, None]  # out of range: dropped
        col = C.k[:, None] + jnp.arange(_WINDOW)
        ys = jtu.tree_map(lambda buf, w: buf.at[row, col].set(w.astype(buf.dtype), mode="drop"), ys, window)
        # Members that end: store their carry, and hand their lanes to the next ones waiting.
        ended = active & ~jax.vmap(running)(lane_p, new)
        final = jtu.tree_map(lambda f, x: f.at[jnp.where(ended, member, n)].set(x, mode="drop"), final, new)
        nxt = queued + jnp.cumsum(ended) - 1
        start = ended & (nxt < n)

        def pick(fresh, old):
            return jnp.where(start.reshape((-1,) + (1,) * (fresh.ndim - 1)), fresh, old)

        C = jtu.tree_map(pick, take(first, nxt), new)
        lane_p = jtu.tree_map(pick, take(params, nxt), lane_p)
        member = jnp.where(ended, jnp.where(start, nxt, n), member)
        return C, lane_p, member, queued + jnp.sum(start), final, ys

    state = (take(first, lane), take(params, lane), lane, jnp.array(width), first, ys)
    _, _, _, _, final, ys = lax.while_loop(lambda s: jnp.any(s[2] < n), body, state)
    final, ys = forward_mode_only((final, ys), FORWARD_ONLY_BATCH)
    sol = jax.vmap(lambda p, c, y: loop(p).finish(c, ys=y))(params, final, ys)
    if config.after:
        ys = jax.vmap(lambda k, y: _observe_after(config.observe, ts, t0, k, y))(final.k, sol.ys)
        sol = eqx.tree_at(lambda s: s.ys, sol, ys)
    return sol


_simulate_batch = eqx.filter_jit(_simulate_batch_program)
_simulate_batch_small = eqx.filter_jit(_simulate_batch_program, compiler_options=SMALL_KERNEL_OPTIONS)


def _print_progress(t, t_end, steps, last=False):
    t, t_end = np.asarray(t).reshape(-1), np.asarray(t_end).reshape(-1)
    frac = float(np.min(t / t_end))
    end = "\n" if last else ""
    print(f"\r  t = {float(np.min(t)):8.3f} / {float(t_end[0]):.3f} s  ({100 * frac:5.1f} %)  "
          f"steps {int(np.max(steps))}", end=end, file=sys.stderr, flush=True)
