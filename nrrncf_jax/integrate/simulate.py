"""Adaptive generalized-α time integration of a second-order model: one jit-compiled loop.

The loop controls the step size, rejects and retries steps, writes the outputs (cubic Hermite
dense output) and batches runs; the step itself is the stepping method's, diffrax-style
``solver.init``/``solver.step`` (``state.AbstractStepper``; ``GeneralizedAlpha``, THEORY §8),
and the loop carries the method's typed state (``state.GeneralizedAlphaState``) in its own
typed carry, ``_LoopState``. Hand-written rather than a diffrax solver because the step must
solve for the acceleration with prescribed coordinates, keep the auxiliary acceleration ā
between steps, reuse a block-tridiagonal factorisation inside Newton, and (later) carry index-3
constraints, none of which diffrax's ODE-term interface expresses; see
``benchmarks/diffrax_galpha.py`` for the cost of the diffrax route. The loop is
``equinox.internal.while_loop``: ``adjoint="forward"`` lowers to ``lax.while_loop`` (fastest;
forward-mode differentiable, vmappable); ``adjoint="reverse"`` lowers to a checkpointed loop
that ``jax.grad`` can differentiate with memory O(√max_steps) checkpoints, and differentiates
each step's Newton solve implicitly (in the step, ``NewtonOptions.implicit``).
"""

import dataclasses
import inspect
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Literal, NamedTuple

import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp
import jax.tree_util as jtu
import numpy as np
from jax import lax

from .. import _validate
from .._types import Array, Float, Int
from .generalized_alpha import GeneralizedAlpha, hermite_interpolate
from .state import AbstractStepper, NewtonOptions

if TYPE_CHECKING:  # the models import the integrator's users; annotations only
    from ..models.base import AbstractModel

RESULTS = {
    0: "success",
    1: "max_steps reached before t_end",
    2: "step size fell below dt_min: Newton failed to converge or the error could not be controlled",
    3: "the state became non-finite (NaN/Inf) and no smaller step recovered it",
}

_WINDOW = 8  # outputs that one step may cover; a step never crosses more than this many


class SimulationError(RuntimeError):
    """A simulation stopped before its end time; the message names the time reached."""


class Solution(eqx.Module):
    """Output of ``simulate``: observations at ``ts`` and the integrator's statistics."""

    ts: Float[Array, " n_out"]
    ys: Any  # pytree, each leaf with leading axis n_out
    t_final: Float[Array, ""]
    result: Int[Array, ""]
    num_steps: Int[Array, ""]
    num_rejected: Int[Array, ""]
    num_newton: Int[Array, ""]

    @property
    def message(self) -> str:
        return RESULTS[int(self.result)]


class _Config(eqx.Module):
    solver: AbstractStepper  # GeneralizedAlpha: its ρ∞ is an array, traced, not static
    adaptive: bool
    max_steps: int
    max_newton: int
    newton: str
    adjoint: str
    observe: Callable
    progress: bool


def _default_observe(t, q, v):
    return q


def simulate(
    model: "AbstractModel",
    ts,
    *,
    t0: float = 0.0,
    y0: tuple | None = None,
    solver: AbstractStepper | None = None,
    rtol: float = 1e-4,
    atol: float = 1e-6,
    dt0: float | None = None,
    dt_min: float = 1e-10,
    dt_max: float = np.inf,
    adaptive: bool = True,
    max_steps: int = 200_000,
    newton_tol: float = 1e-3,
    max_newton: int | None = None,
    newton: Literal["auto", "modified", "full"] = "auto",
    observe: Callable | None = None,
    adjoint: Literal["forward", "reverse"] = "forward",
    progress: bool = False,
    throw: bool = True,
) -> Solution:
    """Integrate ``model`` from ``t0`` and return ``observe(t, q, v)`` at the times ``ts``.

    Newton solves each step for the new acceleration (``integrate.newton``); ``newton="modified"``
    factors the iteration matrix once per step, ``"full"`` once per iteration (each update from
    one ``model.newton_update``), ``"auto"`` takes the model's ``preferred_newton``. The step size
    follows the local error estimate (RMS over the free coordinates, weighted by
    ``atol + rtol|q|``); a Newton failure or a non-finite state retries the step at a quarter of
    the size. With ``adaptive=False`` the step is ``dt0`` (shortened only to land on output
    times), and Newton runs until it converges or ``max_newton`` corrections (default 50, against
    10 for adaptive runs, where a Newton whose corrections grow from the third on fails at once:
    a smaller step is cheaper than a wandering Newton). A fixed-step run whose Newton converges
    in every step is a smooth function of its parameters; ``num_rejected > 0`` says that some
    step did not, and was split.

    ``y0 = (q0, v0)`` overrides the model's initial state (prescribed coordinates are still
    imposed).

    ``throw=True`` raises ``SimulationError`` naming the time reached if the run stops early
    (or, inside a user's ``jit``/``vmap``, an ``eqx.error_if`` runtime error).

    ``jax.vmap`` works through it; for a batch of models in forward mode, ``simulate_batch``
    gives the same results for less (see there).
    """
    args = _prepare(model, ts, t0, y0, solver, rtol, atol, dt0, dt_min, dt_max, adaptive, max_steps, newton_tol,
                    max_newton, newton, observe, adjoint, progress)
    sol = _simulate(*args)
    return _check(sol, throw)


def simulate_batch(model_fn: Callable, params, ts, *, width: int | None = None, **kwargs) -> Solution:
    """``simulate`` for a batch of models, ``model_fn(p)`` for each ``p`` along the leading axis of
    the pytree ``params``, in one loop: each member keeps its own adaptive steps. Returns a
    ``Solution`` whose fields have the batch axis first. The keyword arguments are ``simulate``'s
    (same defaults), except ``y0``, ``adjoint`` and ``progress``: the members start from their
    models' initial states, and the loop runs in forward mode (``jax.jvp``/``jacfwd`` pass
    through; use ``simulate`` with ``adjoint="reverse"`` for reverse mode).

    ``width``: how many members the loop advances together (its lanes; default all of them).
    With fewer lanes than members, the others wait in a queue, in their order in ``params``: a
    member that ends hands its lane to the next one, so the loop keeps ``width`` members busy
    until the queue is empty instead of running until its slowest member is done with the rest
    idle. Put the costliest members first.

    ``jax.vmap(simulate)`` gives the same result but costs more: see ``_simulate_batch``.
    ``model_fn`` should be a pytree-aware callable (``jax.tree_util.Partial`` or an
    ``equinox.Module``) when it closes over arrays, so that they are traced rather than baked
    in. ``observe(t, q, v)`` is shared by the members.
    """
    for name in ("y0", "adjoint", "progress"):
        if name in kwargs:
            raise ValueError(f"simulate_batch takes no {name!r} (see its docstring)")
    a, throw = _simulate_arguments(None, ts, kwargs)
    leaves = jtu.tree_leaves(params)
    sizes = {int(np.shape(x)[0]) if np.ndim(x) else -1 for x in leaves}
    if not leaves or len(sizes) != 1 or -1 in sizes or 0 in sizes:
        raise ValueError("params must be a pytree of arrays sharing a non-empty leading batch axis, got leading "
                         f"sizes {sorted(sizes)}")
    (n,) = sizes
    if width is None:
        width = n
    elif isinstance(width, bool) or not isinstance(width, (int, np.integer)) or width < 1:
        raise ValueError(f"width must be a positive integer (lanes of the batched loop), got width={width!r}")
    a["model"] = model_fn(jtu.tree_map(lambda x: x[0], params))  # one member, for the checks
    _, ts_, t0_, _, *rest = _prepare(**a)
    sol = _simulate_batch(model_fn, params, ts_, t0_, *rest, width=min(int(width), n))
    return _check(sol, throw)


def simulate_timed(model: "AbstractModel", ts, **kwargs) -> tuple[Solution, float, float]:
    """``simulate`` with compilation and execution timed apart: ``(solution, compile_s, run_s)``.

    Compiles ahead of time (``lower().compile()``), then runs to ``block_until_ready``.
    """
    import time

    a, throw = _simulate_arguments(model, ts, kwargs)
    args = _prepare(**a)
    t0 = time.perf_counter()
    compiled = _simulate.lower(*args).compile()
    t1 = time.perf_counter()
    sol = jax.block_until_ready(compiled(*args))
    t2 = time.perf_counter()
    return _check(sol, throw), t1 - t0, t2 - t1


def _simulate_arguments(model, ts, kwargs: dict) -> tuple[dict, bool]:
    """``simulate``'s arguments with its defaults filled in (``_prepare``'s keywords), and ``throw``."""
    bound = inspect.signature(simulate).bind(model, ts, **kwargs)
    bound.apply_defaults()
    a = dict(bound.arguments)
    return a, a.pop("throw")


def _prepare(model, ts, t0, y0, solver, rtol, atol, dt0, dt_min, dt_max, adaptive, max_steps, newton_tol, max_newton,
             newton, observe, adjoint, progress):
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
    for name, val in (("rtol", rtol), ("atol", atol), ("dt_min", dt_min), ("newton_tol", newton_tol)):
        if not (float(val) > 0.0):
            raise ValueError(f"{name} must be > 0, got {name}={val!r}")
    if dt0 is not None and not (float(dt0) > 0.0):
        raise ValueError(f"dt0 must be > 0, got dt0={dt0!r}")
    if not adaptive and dt0 is None:
        raise ValueError("adaptive=False needs a step size dt0")
    if max_newton is None:
        max_newton = 10 if adaptive else 50
    max_newton = _validate.positive_int("max_newton", max_newton)
    if newton not in ("auto", "modified", "full"):
        raise ValueError(f"newton must be 'auto', 'modified' or 'full', got {newton!r}")
    if newton == "auto":
        newton = model.preferred_newton
    if adjoint not in ("forward", "reverse"):
        raise ValueError(f"adjoint must be 'forward' or 'reverse', got {adjoint!r}")
    if ts_np is not None and dt0 is None:
        dt0 = 1e-3 * (ts_np[-1] - t0)
    constrained = getattr(model, "n_constraints", 0) > 0
    if solver is None:
        from .index3 import GeneralizedAlphaIndex3

        solver = GeneralizedAlphaIndex3(0.9) if constrained else GeneralizedAlpha(0.9)
    elif constrained and type(solver) is GeneralizedAlpha:
        raise ValueError("a model with joint constraints needs a constrained stepper (GeneralizedAlphaIndex3); "
                         "GeneralizedAlpha would ignore its joints")
    config = _Config(
        solver=solver,
        adaptive=bool(adaptive),
        max_steps=int(max_steps),
        max_newton=int(max_newton),
        newton=newton,
        adjoint=adjoint,
        observe=_default_observe if observe is None else observe,
        progress=bool(progress),
    )
    if y0 is not None:
        y0 = tuple(jnp.asarray(x, dtype=float) for x in y0)
        if len(y0) != 2 or any(x.shape != (model.n_dof,) for x in y0):
            raise ValueError(f"y0 must be (q0, v0), each of shape ({model.n_dof},)")
    f = jnp.asarray
    return (model, f(ts, dtype=float), f(t0, dtype=float), y0, f(dt0, dtype=float), f(rtol, dtype=float),
            f(atol, dtype=float), f(dt_min, dtype=float), f(dt_max, dtype=float), f(newton_tol, dtype=float), config)


def _check(sol: Solution, throw: bool) -> Solution:
    if throw:
        if isinstance(sol.result, jax.core.Tracer):
            sol = eqx.error_if(sol, sol.result != 0, "simulation stopped early; inspect Solution.t_final")
        elif int(np.max(np.asarray(sol.result))) != 0:
            res = np.asarray(sol.result).reshape(-1)
            tf = np.asarray(sol.t_final).reshape(-1)
            bad = int(np.flatnonzero(res)[0])
            raise SimulationError(f"simulation stopped at t = {tf[bad]:.6g} s: {RESULTS[int(res[bad])]}")
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
    """The adaptive loop's carry: time, next step size, the stepping method's state, the first
    output slot not yet covered, statistics, status and the output buffer."""

    t: Float[Array, ""]
    h: Float[Array, ""]  # the next step's size
    state: _Stacked  # the stepping method's (``GeneralizedAlphaState``), stacked
    k: Int[Array, ""]  # the first output slot that no accepted step has covered
    counts: Int[Array, "3"]  # accepted steps, rejected steps, Newton iterations
    result: Int[Array, ""]  # 0 while running, else a key of RESULTS
    ys: Any = None  # output buffer (n_out + K slots per leaf); None in batched runs (see step)


class _Loop(NamedTuple):
    """One run's adaptive loop: its initial carry, step, condition and the Solution it ends in."""

    init: Callable  # init(outputs=True) -> _LoopState (with its output buffer unless outputs=False)
    outputs: Callable  # outputs(carry) -> the output buffer of a run starting from this carry
    step: Callable  # step(carry, active=None) -> (carry, window) (see step)
    cond: Callable  # cond(carry) -> bool
    finish: Callable  # finish(final carry, ys=None) -> Solution


def _build_loop(model, ts, t0, y0, dt0, rtol, atol, dt_min, dt_max, newton_tol, config: _Config) -> _Loop:
    solver = config.solver
    t_end = ts[-1]
    K = _WINDOW
    ts_pad = jnp.concatenate([ts, jnp.full((K,), jnp.inf)])

    def error_coords(q):
        """The step's start in the model's error space, and which coordinates count."""
        x, _, mask = model.error_space(q, jnp.zeros_like(q))
        return x, mask

    def rms(ex, scale, mask):
        r = ex / scale
        return jnp.sqrt(jnp.sum(jnp.where(mask, r * r, 0.0)) / jnp.maximum(jnp.sum(mask), 1))

    n_out = ts.shape[0]

    def next_stop(k):
        return jnp.minimum(ts_pad[k + K - 1], t_end)

    def limit_step(t, h, k):
        rem = next_stop(k) - t
        return jnp.where(rem <= 1.1 * h, rem, jnp.where(rem < 2.0 * h, 0.5 * rem, h))

    def initial_carry(outputs=True):
        """The loop's first carry; a function, so that tracing the step or the condition does not
        trace the initial solve too. ``outputs=False``: without the output buffer."""
        q0, v0 = model.initial_state(t0) if y0 is None else y0
        state = solver.init(model, t0, q0, v0)  # with the consistent acceleration M a0 = −g
        k0 = jnp.sum(ts_pad <= t0).astype(int)
        h0 = limit_step(t0, jnp.minimum(dt0, dt_max), k0)
        c = _LoopState(t=t0, h=h0, state=_Stacked.of(state), k=k0, counts=jnp.zeros(3, int), result=jnp.array(0))
        return dataclasses.replace(c, ys=initial_outputs(c)) if outputs else c

    def initial_outputs(c):
        """The output buffer (n_out + K slots): the initial observation at the times ≤ t0."""
        st = c.state.unstack()
        obs0 = config.observe(t0, st.q, st.v)
        at_start = ts_pad <= t0
        return jtu.tree_map(
            lambda x: jnp.where(at_start.reshape((-1,) + (1,) * jnp.ndim(x)), x,
                                jnp.zeros((n_out + K,) + jnp.shape(x), jnp.result_type(x))), obs0)

    newton_options = NewtonOptions(tol=newton_tol, max_iter=config.max_newton, variant=config.newton,
                                   divergence_test=config.adaptive, implicit=config.adjoint == "reverse")

    def step(c, active=None):
        """One attempted step: ``(carry, window)``, the new carry and the step's output window
        (its observations at the K output slots from ``c.k`` on). ``active`` (batched runs, see
        ``_simulate_batch``): a member that is done steps at a harmless size and keeps its carry
        unchanged. A carry with the output buffer ``ys`` gets the window written into it; a carry
        without (``init(outputs=False)``, as batched runs use) leaves the window to the caller to
        write (or drop, for an inactive member)."""
        t, h, k, st = c.t, c.h, c.k, c.state.unstack()
        if active is not None:
            h = jnp.where(active, h, dt0)
        h = lax.stop_gradient(h)
        t1 = t + h
        ns = next_stop(k)
        t1 = jnp.where(jnp.abs(t1 - ns) <= 1e-12 * (1.0 + jnp.abs(ns)), ns, t1)
        x0, mask = error_coords(st.q)
        x0 = lax.stop_gradient(x0)
        newton_scale = atol + rtol * jnp.abs(x0)
        # Newton's corrections are measured in the step's error space, in units of the
        # tolerance at the step's start; in reverse mode without derivatives (the step
        # differentiates its solve implicitly).
        m_n, q_n = lax.stop_gradient((model, st.q)) if newton_options.implicit else (model, st.q)

        def norm(dq):
            return rms(m_n.error_space(q_n, dq)[1], newton_scale, mask)

        st1, error, newton_sol = solver.step(model, t, t1, st, newton_options, norm, h=h)
        iters, done = newton_sol.iterations, newton_sol.converged
        q1, v1 = st1.q, st1.v

        x1, ex, _ = model.error_space(q1, error)
        err = lax.stop_gradient(rms(ex, atol + rtol * jnp.maximum(jnp.abs(x0), jnp.abs(x1)), mask))
        finite = jnp.isfinite(err) & jnp.all(jnp.isfinite(q1)) & jnp.all(jnp.isfinite(v1))
        ok = done & finite
        if config.adaptive:
            accept = ok & (err <= 1.0)
            grow = jnp.clip(0.9 * jnp.where(err > 0, err, 1e-10) ** (-1.0 / 3.0), 0.2, 5.0)
            h_new = jnp.where(ok, h * grow, 0.25 * h)
        else:
            accept = ok
            h_new = jnp.where(ok, jnp.minimum(2.0 * h, dt0), 0.25 * h)
        h_new = jnp.minimum(h_new, dt_max)

        # Dense output at the requested times inside (t, t1]: the whole window of K output
        # slots in one vectorised write.
        idx = k + jnp.arange(K)
        tau = ts_pad[idx]
        write = accept & (tau <= t1)

        def observe_window():
            s = jnp.clip((tau - t) / h, 0.0, 1.0)
            qi, vi = hermite_interpolate(s[:, None], h, st.q, st.v, q1, v1)
            return jax.vmap(config.observe)(jnp.where(write, tau, t1), qi, vi)

        # A run that carries its output buffer and is not differentiated in reverse observes only
        # in the steps that cover an output time: the observation (K slots of it) can cost more
        # than the step itself (the pendulum's energies: 4 ms against a 1 ms step).
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
        h_new = lax.stop_gradient(limit_step(t_new, h_new, k_new))
        pick = lambda new, old: jnp.where(accept, new, old)  # noqa: E731, applied leaf by leaf
        result = jnp.where(~accept & (h_new < dt_min), jnp.where(finite, 2, 3), 0)
        if config.progress:
            lax.cond(
                accept & (c.counts[0] % 200 == 0),
                lambda: jax.debug.callback(_print_progress, t_new, t_end, c.counts[0]),
                lambda: None,
            )
        new = _LoopState(
            t=t_new, h=h_new, state=jtu.tree_map(pick, _Stacked.of(st1), c.state), k=k_new,
            counts=c.counts + jnp.stack([accept, ~accept, iters]).astype(int), result=result,
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

    def cond(c):
        return (c.t < t_end) & (c.result == 0)

    def finish(final, ys=None):
        """The Solution of the final carry (``ys``: its output buffer, when it carries none)."""
        ys = final.ys if ys is None else ys
        result = jnp.where((final.result == 0) & (final.t < t_end), 1, final.result)
        return Solution(
            ts=ts, ys=jtu.tree_map(lambda y: y[:n_out], ys), t_final=final.t, result=result,
            num_steps=final.counts[0], num_rejected=final.counts[1], num_newton=final.counts[2],
        )

    return _Loop(init=initial_carry, outputs=initial_outputs, step=step, cond=cond, finish=finish)


@eqx.filter_jit
def _simulate(model, ts, t0, y0, dt0, rtol, atol, dt_min, dt_max, newton_tol, config: _Config) -> Solution:
    loop = _build_loop(model, ts, t0, y0, dt0, rtol, atol, dt_min, dt_max, newton_tol, config)
    final = eqxi.while_loop(
        loop.cond, lambda c: loop.step(c)[0], loop.init(), max_steps=config.max_steps,
        buffers=(lambda c: c.ys) if config.adjoint == "reverse" else None,
        kind="checkpointed" if config.adjoint == "reverse" else "lax",
    )
    if config.progress:
        jax.debug.callback(_print_progress, final.t, ts[-1], final.counts[0], True)
    return loop.finish(final)


@eqx.filter_jit
def _simulate_batch(model_fn, params, ts, t0, dt0, rtol, atol, dt_min, dt_max, newton_tol, config: _Config, *,
                    width: int) -> Solution:
    """``simulate_batch``'s program: one ``lax.while_loop`` whose body advances the member in each
    of ``width`` lanes by one attempted step (``vmap`` of the step), until every member is done.

    Written out rather than ``vmap(simulate)``: a vmapped ``while_loop`` with a per-member
    condition selects between the new and the old carry of every member at every step, the
    output buffers included (for 32 members with 3001 outputs, a copy and a select of 2.3 MB per
    step, ~10 % of a sweep). Here the condition is one ``any``, and the lanes carry only the
    small state: each step's output window is written straight into its member's row of the
    results.

    The queue: a lane holds the index of its member (``n`` once the queue is empty) and that
    member's parameters. Every member's initial carry is computed before the loop; when a lane's
    member ends, its carry is stored and the next member waiting takes the lane. This is
    bookkeeping on small arrays, done every iteration rather than under a ``lax.cond``, whose
    branches would copy the loop's state.
    """
    n = jtu.tree_leaves(params)[0].shape[0]

    def loop(p):
        return _build_loop(model_fn(p), ts, t0, None, dt0, rtol, atol, dt_min, dt_max, newton_tol, config)

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
    return jax.vmap(lambda p, c, y: loop(p).finish(c, ys=y))(params, final, ys)


def _print_progress(t, t_end, steps, last=False):
    t, t_end = np.asarray(t).reshape(-1), np.asarray(t_end).reshape(-1)
    frac = float(np.min(t / t_end))
    end = "\n" if last else ""
    print(f"\r  t = {float(np.min(t)):8.3f} / {float(t_end[0]):.3f} s  ({100 * frac:5.1f} %)  "
          f"steps {int(np.max(steps))}", end=end, file=sys.stderr, flush=True)
