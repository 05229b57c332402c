"""The integrator's typed state and its diffrax-style ``init``/``step`` (docs/theory.md, §8 Time
integration): the state is a pytree, ``init`` solves for the consistent acceleration, a loop of
``step`` calls is the fixed-step ``simulate``, and an unconstrained model carries no multipliers."""

import functools

import jax
import jax.numpy as jnp
import jax.tree_util as jtu
import numpy as np
import pytest
from conftest import EPS, counts_close, paper_body

from nrrncf_jax import GeneralizedAlpha, LinearModel, RotatingFrameModel, SpinUp, simulate
from nrrncf_jax.integrate import (
    AbstractSolver,
    ConstantStepSize,
    GeneralizedAlphaState,
    Newton,
    NewtonOptions,
)

H = 2.0**-4  # a binary fraction: t = i·H and the output times are exact, so is every step's size
N_STEPS = 8
RTOL, ATOL, NEWTON_TOL = 1e-4, 1e-6, 1e-3  # simulate's defaults


@functools.cache
def _model():
    """The paper's beam (2 elements) spun up gently: each fixed step of H converges."""
    return RotatingFrameModel(paper_body(2), SpinUp(2.0, 6.0))


@functools.cache
def _init():
    return jax.jit(lambda m, t0, q0, v0: GeneralizedAlpha(0.9).init(m, t0, q0, v0))


def _rms(ex, scale, mask):
    r = ex / scale
    return jnp.sqrt(jnp.sum(jnp.where(mask, r * r, 0.0)) / jnp.maximum(jnp.sum(mask), 1))


@functools.partial(jax.jit, static_argnames="variant")
def _step(model, t0, t1, state, variant):
    """One fixed step as ``simulate`` with ``ConstantStepSize`` takes it: Newton to ``NEWTON_TOL`` in the
    error space's units of ``ATOL + RTOL|q|`` at the step's start, at most 50 corrections."""
    x0, _, mask = model.error_space(state.q, jnp.zeros_like(state.q))
    scale = ATOL + RTOL * jnp.abs(x0)

    def norm(dq):
        return _rms(model.error_space(state.q, dq)[1], scale, mask)

    newton = NewtonOptions(tol=jnp.asarray(NEWTON_TOL), max_iter=50, variant=variant, divergence_test=False,
                           implicit=False)
    state1, _, sol = GeneralizedAlpha(0.9).step(model, t0, t1, state, newton, norm, h=t1 - t0)
    return state1, sol.iterations, sol.converged


def _steps_and_simulate(model, variant):
    """``(q after each of N_STEPS manual steps, Newton iterations, final state, simulate's Solution)``."""
    sol = simulate(model, GeneralizedAlpha(0.9), ConstantStepSize(H, rtol=RTOL, atol=ATOL),
                   H * jnp.arange(1, N_STEPS + 1), newton=Newton(NEWTON_TOL, kind=variant))
    assert int(sol.num_rejected) == 0  # no step split: the manual steps are simulate's
    t0 = jnp.asarray(0.0)
    st = _init()(model, t0, *model.initial_state(t0))
    qs, iters = [], 0
    for i in range(N_STEPS):
        st, it, ok = _step(model, jnp.asarray(i * H), jnp.asarray((i + 1) * H), st, variant)
        assert bool(ok)
        qs.append(np.asarray(st.q))
        iters += int(it)
    return np.stack(qs), iters, st, sol


def test_state_is_a_typed_pytree():
    q, v, a, abar = (jnp.arange(3.0) + k for k in range(4))
    s = GeneralizedAlphaState(q, v, a, abar)
    leaves, treedef = jtu.tree_flatten(s)
    assert len(leaves) == 5 and leaves[-1].shape == (0,)  # q, v, a, ā and the empty λ
    back = jtu.tree_unflatten(treedef, leaves)
    assert isinstance(back, GeneralizedAlphaState)
    for name in ("q", "v", "a", "abar", "lam"):
        assert np.array_equal(getattr(back, name), getattr(s, name))
    through = jax.jit(lambda st: jtu.tree_map(lambda x: 2.0 * x, st))(s)
    assert isinstance(through, GeneralizedAlphaState) and np.array_equal(through.abar, 2.0 * abar)
    lam = jnp.ones(2)
    assert np.array_equal(GeneralizedAlphaState(q, v, a, abar, lam).lam, lam)
    assert isinstance(GeneralizedAlpha(0.9), AbstractSolver)


def test_init_gives_the_consistent_acceleration():
    """M a0 = −g at t0 = 1 s (mid spin-up: the frame accelerates, so g ≠ 0). A backward-stable
    solve leaves a residual of a few ε·n relative to |M||a0| + |g| (componentwise); the bound
    is n·ε, n the number of coordinates."""
    model = _model()
    t0 = jnp.asarray(1.0)
    st = _init()(model, t0, *model.initial_state(t0))
    assert st.lam.shape == (0,)
    assert np.array_equal(st.a, st.abar)  # ā0 = a0

    @jax.jit
    def parts(model, st):
        res = functools.partial(model.residual, t0, st.q, st.v)
        return res(st.a), res(jnp.zeros_like(st.a)), jax.jacfwd(res)(st.a)

    r, g, M = parts(model, st)
    scale = np.abs(M) @ np.abs(st.a) + np.abs(g)
    assert float(np.max(np.abs(g))) > 1e-3  # a real load to balance
    assert np.all(np.abs(r) <= model.n_dof * EPS * scale), float(np.max(np.abs(r) / np.maximum(scale, 1e-300)))


@pytest.mark.slow
def test_steps_are_simulate_op_for_op():
    """``init`` and N ``step`` calls at a fixed step H are ``simulate(adaptive=False, dt0=H)``:
    run op by op (``jax.disable_jit``, so that XLA neither fuses nor contracts a·b + c into an
    FMA differently in the two programs), the states at the output times are the same bit for
    bit (at s = 1 the Hermite interpolant is the step's end exactly), and so are the Newton
    iterations. A 3-DOF damped, forced chain: op by op, the beam would take a minute."""
    k = jnp.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]]) * 400.0
    model = LinearModel(M=jnp.diag(jnp.array([1.0, 2.0, 0.5])), K=k, C=1e-3 * k, q0=[0.01, 0.0, -0.02],
                        v0=[0.0, 0.3, 0.0], force=lambda t: jnp.array([0.0, 0.0, jnp.sin(5.0 * t)]))
    with jax.disable_jit():
        qs, iters, st, sol = _steps_and_simulate(model, "modified")
    assert np.array_equal(qs, np.asarray(sol.ys))
    assert iters == int(sol.num_newton)
    assert st.lam.shape == (0,)


def test_compiled_steps_match_simulate_to_roundoff():
    """The same on the 2-element beam (prescribed root coordinates), compiled: the loop of
    ``step`` and ``simulate`` are two XLA programs, fused differently, so a·b + c may be an FMA
    in one and not in the other; each step then rounds its update of q (and its Newton solve)
    differently by about an ulp of ‖q‖∞, and over this gentle run the differences add up
    without growing: after i steps they stay below i·ε‖q‖∞ (measured: 0.8 ε‖q‖∞ after 8), and
    the Newton iterations are the same. Where a step's last correction lay within round-off of the
    tolerance, one program could take one correction more (``counts_close``): that moves q by less
    than the correction, NEWTON_TOL (ATOL + RTOL‖q‖∞), which the bound then allows for each flip.
    No multipliers are carried."""
    qs, iters, st, sol = _steps_and_simulate(_model(), "full")
    ys = np.asarray(sol.ys)
    i = np.arange(1, N_STEPS + 1)
    assert counts_close(iters, sol.num_newton), (iters, int(sol.num_newton))
    flips = abs(iters - int(sol.num_newton))
    q_max = np.max(np.abs(ys), axis=1)
    assert np.all(np.max(np.abs(qs - ys), axis=1) <= i * EPS * q_max + flips * NEWTON_TOL * (ATOL + RTOL * q_max))
    assert st.lam.shape == (0,)
