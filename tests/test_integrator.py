"""Generalized-α: order of accuracy, energy conservation at ρ∞ = 1, step control, errors,
vmap and gradients."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import FD_STEP, RTOL_FD, counts_close, paper_body, step_flip_bound

from nrrncf_jax import (
    AdaptiveStepSize,
    ConstantStepSize,
    GeneralizedAlpha,
    LinearModel,
    Newton,
    RotatingFrameModel,
    SimulationError,
    SimulationResult,
    SpinUp,
    Stationary,
    simulate,
    simulate_batch,
    vibration_modes,
)
from nrrncf_jax.integrate import STEP_CONTROLS, adaptive_step_size

OMEGA = 2.0 * np.pi  # oscillator: period 1 s
GA = GeneralizedAlpha(0.9)


def _oscillator(force=None):
    return LinearModel(M=[[1.0]], K=[[OMEGA**2]], q0=[1.0], v0=[0.0], force=force)


def _first(t, q, v):
    return q[0]


@pytest.mark.parametrize("rho_inf", [1.0, 0.8, 0.5])
def test_second_order_on_linear_oscillator(rho_inf):
    errs, hs = [], [0.02, 0.01, 0.005, 0.0025]
    T = 1.25  # a quarter period past a full one: the phase error shows at first order in q
    for h in hs:
        sol = simulate(_oscillator(), GeneralizedAlpha(rho_inf), ConstantStepSize(h), jnp.array([T]), observe=_first)
        errs.append(abs(float(sol.ys[0]) - np.cos(OMEGA * T)))
    order = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert 1.85 < order < 2.2, (order, errs)


def test_coefficients():
    s = GeneralizedAlpha(1.0)
    np.testing.assert_allclose([s.alpha_m, s.alpha_f, s.gamma, s.beta], [0.5, 0.5, 0.5, 0.25])
    s = GeneralizedAlpha(0.0)
    np.testing.assert_allclose([s.alpha_m, s.alpha_f, s.gamma, s.beta], [-1.0, 0.0, 1.5, 1.0])
    with pytest.raises(ValueError, match="rho_inf"):
        GeneralizedAlpha(1.5)


def test_adaptive_error_falls_with_tolerance():
    ts = jnp.linspace(0.0, 3.0, 31)
    exact = np.cos(OMEGA * np.asarray(ts))
    errs, steps = [], []
    for rtol in (1e-3, 1e-5, 1e-7):
        sol = simulate(_oscillator(), GA, AdaptiveStepSize(rtol, rtol), ts, observe=_first)
        errs.append(np.abs(np.asarray(sol.ys) - exact).max())
        steps.append(int(sol.num_steps))
    assert errs[0] > 10 * errs[1] > 100 * errs[2]
    assert steps[0] < steps[1] < steps[2]


PI = STEP_CONTROLS["pi"]  # Gustafsson's PI controller, in diffrax's terms


def test_pi_controller_follows_the_tolerance_and_rejects_fewer_steps():
    """The PI controller (``AdaptiveStepSize(pcoeff=, icoeff=)``) keeps what the tolerance means:
    its error falls with the tolerance as the plain controller's does, and at each tolerance it is
    no larger than twice the plain controller's. What it is for: the step no longer oscillates
    between accepted and rejected sizes, so over the three runs it rejects less than a third of the
    steps the plain one rejects (several times that margin here: far beyond the handful of decisions
    that round-off can flip at a threshold)."""
    ts = jnp.linspace(0.0, 3.0, 31)
    exact = np.cos(OMEGA * np.asarray(ts))
    errs, rejected = {}, {}
    for label, coeffs in (("plain", {}), ("PI", PI)):
        for rtol in (1e-3, 1e-5, 1e-7):
            sol = simulate(_oscillator(), GA, AdaptiveStepSize(rtol, rtol, **coeffs), ts, observe=_first)
            errs[label, rtol] = np.abs(np.asarray(sol.ys) - exact).max()
            rejected[label, rtol] = int(sol.num_rejected)
    assert errs["PI", 1e-3] > 10 * errs["PI", 1e-5] > 100 * errs["PI", 1e-7]
    for rtol in (1e-3, 1e-5, 1e-7):
        assert errs["PI", rtol] <= 2.0 * errs["plain", rtol]
    pi, plain = (sum(n for (label, _), n in rejected.items() if label == which) for which in ("PI", "plain"))
    assert 3 * pi < plain


def test_pi_controller_keeps_each_batch_member_s_memory():
    """Under ``simulate_batch`` each member's PI controller sees its own last accepted error (the
    loop carries it member by member): every member equals its own run, within what a flipped step
    decision allows (the batched and single programs round differently)."""
    ks = jnp.array([1.0, 9.0]) * OMEGA**2
    ts = jnp.linspace(0.0, 2.0, 21)
    rtol, atol = 1e-6, 1e-8
    run = (GA, AdaptiveStepSize(rtol, atol, **PI), ts)
    batch = simulate_batch(_oscillator_of, ks, *run, observe=_first)
    bound = step_flip_bound(rtol, atol, batch.ys)
    for i, k in enumerate(ks):
        one = simulate(_oscillator_of(k), *run, observe=_first)
        np.testing.assert_allclose(batch.ys[i], one.ys, rtol=0, atol=bound)
        assert counts_close(batch.num_steps[i], one.num_steps) and counts_close(batch.num_rejected[i], one.num_rejected)


@pytest.mark.slow
def test_energy_conserved_in_free_vibration_rho_inf_one():
    body = paper_body(4)
    model = RotatingFrameModel(body, Stationary())
    phi = vibration_modes(body, model.free_mask(), 1).phi[:, 0]
    tip = body.n_vectors - body.vectors_per_node
    M = jnp.kron(body.mass_matrix(), jnp.eye(3))

    def energy(t, q, v):
        return 0.5 * v @ M @ v + body.strain_energy(q.reshape(-1, 3))

    q0 = body.q_hat.reshape(-1)
    v0 = 0.1 / float(jnp.abs(phi.reshape(-1, 3)[tip]).max()) * 2.9 * phi  # 0.1 m tip amplitude
    h = 0.01
    sol = simulate(model, GeneralizedAlpha(1.0), ConstantStepSize(h), jnp.arange(1, 1001) * h, y0=(q0, v0),
                   observe=energy, newton=Newton(1e-8))
    E0 = float(energy(0.0, q0, v0))
    drift = np.abs(np.asarray(sol.ys) - E0).max() / E0
    assert drift < 1e-6
    # Numerical damping: ρ∞ = 0.5 removes energy (while ρ∞ = 1 does not).
    sol_d = simulate(model, GeneralizedAlpha(0.5), ConstantStepSize(h), jnp.arange(1, 1001) * h, y0=(q0, v0),
                     observe=energy, newton=Newton(1e-8))
    assert float(sol_d.ys[-1]) < E0 * (1 - 10 * drift)


def _nan_after_half(t):
    return jnp.where(t > 0.5, jnp.nan, 0.0) * jnp.ones(1)


def test_nan_stops_with_error_naming_time():
    with pytest.raises(SimulationError, match=r"t = 0\.5\d* s: .*non-finite"):
        simulate(_oscillator(_nan_after_half), GA, AdaptiveStepSize(), jnp.linspace(0, 1, 11), observe=_first)
    sol = simulate(_oscillator(_nan_after_half), GA, AdaptiveStepSize(), jnp.linspace(0, 1, 11), observe=_first,
                   throw=False)
    assert sol.result == SimulationResult.nonfinite and int(sol.code) == 3 and 0.49 < float(sol.t_final) <= 0.5
    assert "non-finite" in sol.message


def test_max_steps_is_an_error():
    with pytest.raises(SimulationError, match="max_steps"):
        simulate(_oscillator(), GA, AdaptiveStepSize(1e-8, 1e-8), jnp.array([10.0]), observe=_first, max_steps=20)


def test_observing_after_the_loop_equals_observing_in_it(monkeypatch):
    """A forward run records (q, v) at the output times and observes them after the loop where
    that buffer is small (``simulate._Config.after``), else in the loop step by step: the same
    observations (to round-off: the same steps, the same interpolated states), the output times
    passed as each observation's t, and, for a run that stops early, zeros in the slots it did not
    reach either way; alone and batched."""
    import importlib

    simulate_module = importlib.import_module("nrrncf_jax.integrate.simulate")  # the module, not the function

    def small(t, q, v):  # smaller than the state (q, v): observed after the loop only by the size rule
        return q[0] + 10.0 * t

    ts = jnp.linspace(0.0, 1.0, 11)
    ks = jnp.array([1.0, 4.0]) * OMEGA**2
    runs, modes = {}, []
    for limit in (simulate_module.STATE_OUTPUTS_MAX_BYTES, 0):
        monkeypatch.setattr(simulate_module, "STATE_OUTPUTS_MAX_BYTES", limit)
        config = simulate_module._prepare(_oscillator(), GA, AdaptiveStepSize(), ts, small, None, 0.0, None, "forward",
                                          100, False)[-1]
        modes.append(config.after)
        runs[limit] = (simulate(_oscillator(_nan_after_half), GA, AdaptiveStepSize(1e-6, 1e-8), ts, observe=small,
                                throw=False),
                       simulate_batch(_oscillator_of, ks, GA, AdaptiveStepSize(1e-6, 1e-8), ts, observe=small))
    assert modes == [True, False]
    (after, batch_after), (inside, batch_inside) = runs.values()
    for a, b in ((after, inside), (batch_after, batch_inside)):
        np.testing.assert_array_equal(np.asarray(a.num_steps), np.asarray(b.num_steps))
        np.testing.assert_allclose(np.asarray(a.ys), np.asarray(b.ys), rtol=0, atol=1e-12)
    reached = np.asarray(ts) <= float(after.t_final)
    assert 0 < reached.sum() < ts.size
    np.testing.assert_array_equal(np.asarray(after.ys[~reached]), 0.0)
    q = [simulate(_oscillator_of(k), GA, AdaptiveStepSize(1e-6, 1e-8), ts, observe=_first).ys for k in ks]
    np.testing.assert_allclose(np.asarray(batch_after.ys) - 10.0 * np.asarray(ts), np.asarray(q), rtol=0, atol=1e-12)


def _oscillator_of(k):
    """The oscillator with stiffness k (a traced scalar under ``simulate_batch``)."""
    return LinearModel(M=[[1.0]], K=k, q0=[1.0], v0=[0.0])


def test_batch_lanes_default_to_all_members_on_an_accelerator_and_a_few_on_a_cpu():
    """``batch_lanes``: a given width, capped at the members; by default every member on a GPU and
    at most ``CPU_BATCH_LANES`` on a CPU; a width that is not a positive integer is refused."""
    from nrrncf_jax.integrate import CPU_BATCH_LANES, batch_lanes

    assert batch_lanes(16, platform="gpu") == 16 and batch_lanes(16, platform="cpu") == CPU_BATCH_LANES
    assert batch_lanes(2, platform="cpu") == 2 and batch_lanes(16, 8, platform="cpu") == 8
    assert batch_lanes(3, 8, platform="gpu") == 3
    for bad in (0, -1, 2.5, True):
        with pytest.raises(ValueError, match="width must be a positive integer"):
            batch_lanes(4, bad)


@pytest.mark.slow
def test_batch_members_keep_their_own_steps_and_end():
    """``simulate_batch``: each member equals its own run (the stiffer ones take more steps and
    run on after the others are done, which must leave the finished ones untouched), also when
    members queue for fewer lanes; a member that needs more than ``max_steps`` alone ends with
    result 1. The batched and the single programs round differently, which can flip a step decision
    at its threshold: counts within ``counts_close``, solutions within ``step_flip_bound``."""
    ks = jnp.array([1.0, 4.0, 16.0]) * OMEGA**2
    ts = jnp.linspace(0.0, 2.0, 21)
    rtol, atol = 1e-6, 1e-8
    run, kw = (GA, AdaptiveStepSize(rtol, atol), ts), dict(observe=_first)
    batch = simulate_batch(_oscillator_of, ks, *run, **kw)
    assert batch.ys.shape == (3, 21) and batch.num_steps.shape == (3,)
    bound = step_flip_bound(rtol, atol, batch.ys)
    for i, k in enumerate(ks):
        one = simulate(_oscillator_of(k), *run, **kw)
        np.testing.assert_allclose(batch.ys[i], one.ys, rtol=0, atol=bound)
        assert counts_close(batch.num_steps[i], one.num_steps) and counts_close(batch.num_newton[i], one.num_newton)
    n = np.asarray(batch.num_steps + batch.num_rejected)
    assert n[0] < n[1] < n[2]
    # Fewer lanes than members: the third waits for a lane, and members end out of their order.
    for width in (1, 2):
        queued = simulate_batch(_oscillator_of, ks[::-1], *run, width=width, **kw)
        np.testing.assert_allclose(queued.ys[::-1], batch.ys, rtol=0, atol=bound)
        assert all(map(counts_close, np.asarray(queued.num_newton[::-1]), np.asarray(batch.num_newton)))
        np.testing.assert_array_equal(np.asarray(queued.t_final), 2.0)
    # A cap between the second member's steps and the third's (far from both: the third needs
    # about twice the second's), so that a flipped decision cannot move a member across it.
    cap = int(n[1] + n[2]) // 2
    cut = simulate_batch(_oscillator_of, ks, *run, max_steps=cap, throw=False, width=2, **kw)
    np.testing.assert_array_equal(np.asarray(cut.code), [0, 0, 1])  # the third: max_steps_reached
    np.testing.assert_allclose(cut.ys[:2], batch.ys[:2], rtol=0, atol=bound)
    with pytest.raises(SimulationError, match="max_steps"):
        simulate_batch(_oscillator_of, ks, *run, max_steps=cap, **kw)
    with pytest.raises(ValueError, match="leading batch axis"):
        simulate_batch(lambda p: _oscillator_of(p[0] + p[1]), (ks, ks[:2]), *run)
    with pytest.raises(ValueError, match="leading batch axis"):
        simulate_batch(_oscillator_of, jnp.zeros(0), *run)
    with pytest.raises(TypeError, match="adjoint"):  # a batch runs in forward mode: no such keyword
        simulate_batch(_oscillator_of, ks, *run, adjoint="reverse")
    with pytest.raises(ValueError, match="width"):
        simulate_batch(_oscillator_of, ks, *run, width=0)


@pytest.mark.slow
def test_solve_once_forms_agree_under_vmap_and_jvp():
    """The Newton solve: the CPU form (one LU of [A | b]) and the other platforms' (LU and
    lu_solve) against NumPy on matrices that need pivoting, batched (once and twice, and with an
    unbatched operand), and its derivative against the linear-solve identity
    dx = A⁻¹(db − dA x), also batched, and reverse mode. On a CPU a batch gives LAPACK one system per call: a
    batched getrf in jaxlib 0.10.2 can deadlock the CPU thread pool (``linalg``)."""
    import re

    from nrrncf_jax.linalg import _solve_augmented, _solve_factored, solve_once

    rng = np.random.default_rng(0)
    A = rng.normal(size=(5, 7, 7))
    A[:, 0, 0] = 1e-3  # the first pivot must come from another row
    b = rng.normal(size=(5, 7))
    x = np.linalg.solve(A, b[..., None])[..., 0]
    for f in (solve_once, _solve_augmented, _solve_factored):
        np.testing.assert_allclose(jax.vmap(f)(A, b), x, rtol=1e-10, atol=1e-12)
    twice = jax.vmap(jax.vmap(solve_once))(A.reshape(5, 1, 7, 7), b.reshape(5, 1, 7))
    np.testing.assert_allclose(twice[:, 0], x, rtol=1e-10, atol=1e-12)
    shared = jax.vmap(solve_once, in_axes=(None, 0))(A[1], b)  # one matrix, a batch of right-hand sides
    np.testing.assert_allclose(shared, np.linalg.solve(A[1], b.T).T, rtol=1e-10, atol=1e-12)
    dA, db = rng.normal(size=(7, 7)), rng.normal(size=7)
    x0, dx = jax.jvp(solve_once, (jnp.asarray(A[0]), jnp.asarray(b[0])), (jnp.asarray(dA), jnp.asarray(db)))
    np.testing.assert_allclose(dx, np.linalg.solve(A[0], db - dA @ np.asarray(x0)), rtol=1e-9, atol=1e-12)
    _, dxs = jax.vmap(lambda a, c: jax.jvp(solve_once, (a, c), (jnp.asarray(dA), jnp.asarray(db))))(A, b)
    np.testing.assert_allclose(dxs, np.linalg.solve(A, (db - np.einsum("ij,bj->bi", dA, x))[..., None])[..., 0],
                               rtol=1e-9, atol=1e-12)
    # Reverse mode, batched or not, against jnp.linalg.solve's gradient.
    loss = lambda f: lambda a, c: jnp.sum(jax.vmap(f)(a, c) ** 2)  # noqa: E731
    for g, ref in zip(jax.grad(loss(solve_once), argnums=(0, 1))(A, b),
                      jax.grad(loss(jnp.linalg.solve), argnums=(0, 1))(A, b)):
        np.testing.assert_allclose(g, ref, rtol=1e-9, atol=1e-11)
    if jax.default_backend() == "cpu":
        text = jax.jit(jax.vmap(solve_once)).lower(A, b).as_text()
        operands = re.findall(r"lapack_dgetrf_ffi.*?\((tensor<[^>]*>)", text)
        assert operands and all(t == "tensor<7x8xf64>" for t in operands), operands


def test_reverse_mode_through_the_default_loop_names_the_option():
    """``jax.grad`` through the default (forward-mode) loop fails with one line naming
    ``adjoint='reverse'`` instead of JAX's error about ``lax.while_loop``; forward mode through the
    same run still works, and the marker that does this changes no value."""
    ts = jnp.linspace(0.1, 1.0, 4)

    def tip(k, **kw):
        m = LinearModel(M=[[1.0]], K=[[k]], q0=[1.0], v0=[0.0])
        return jnp.sum(simulate(m, GA, ConstantStepSize(0.05), ts, observe=_first, **kw).ys ** 2)

    with pytest.raises(ValueError, match=r"^jax.grad cannot differentiate simulate\(adjoint='forward'\).*"
                                         r"adjoint='reverse'"):
        jax.grad(tip)(OMEGA**2)
    d_fwd = float(jax.jacfwd(tip)(OMEGA**2))
    d_rev = float(jax.grad(lambda k: tip(k, adjoint="reverse"))(OMEGA**2))
    assert d_fwd == pytest.approx(d_rev, rel=1e-9) and d_fwd != 0.0
    with pytest.raises(ValueError, match="simulate_batch, a forward-mode loop"):
        jax.grad(lambda k: jnp.sum(simulate_batch(_oscillator_of, k[None], GA, ConstantStepSize(0.05), ts,
                                                  observe=_first).ys))(jnp.asarray(OMEGA**2))


def test_a_controller_at_other_tolerances_keeps_its_step_control():
    """``with_tolerances`` (a run repeated at tightened tolerances, as the converged references
    do) changes a controller's tolerances alone, its PI coefficients and step limits kept;
    ``step_control_name`` names the coefficients as ``STEP_CONTROLS`` does (what a run's record
    says of its controller)."""
    from nrrncf_jax.integrate import step_control_name, with_tolerances

    pi = adaptive_step_size(1e-4, 1e-6, "pi", dt_max=0.5)
    tight = with_tolerances(pi, 1e-4 / 10, 1e-6 / 10)
    assert float(tight.rtol) == 1e-4 / 10 and float(tight.atol) == 1e-6 / 10
    assert (tight.pcoeff, tight.icoeff, float(tight.dt_max)) == (pi.pcoeff, pi.icoeff, 0.5)
    assert step_control_name(tight) == "pi" and step_control_name(AdaptiveStepSize()) == "plain"
    assert step_control_name(AdaptiveStepSize(pcoeff=0.2, icoeff=0.5)) == "pi(pcoeff=0.2, icoeff=0.5)"
    assert step_control_name(ConstantStepSize(0.1)) == "constant"
    with pytest.raises(ValueError, match="rtol"):
        with_tolerances(pi, 0.0, 1e-6)


def test_bad_integrator_input():
    m = _oscillator()
    ctrl = AdaptiveStepSize()
    with pytest.raises(ValueError, match="t_end"):
        simulate(m, GA, ctrl, jnp.array([0.0]))
    with pytest.raises(ValueError, match="t_end"):
        simulate(m, GA, ctrl, jnp.array([-1.0]))
    with pytest.raises(ValueError, match="increasing"):
        simulate(m, GA, ctrl, jnp.array([0.5, 0.2]))
    with pytest.raises(ValueError, match="rtol"):
        AdaptiveStepSize(rtol=0.0)
    with pytest.raises(ValueError, match="PI coefficients"):
        AdaptiveStepSize(pcoeff=-0.1)
    with pytest.raises(ValueError, match="PI coefficients"):
        AdaptiveStepSize(pcoeff=0.0, icoeff=0.0)
    with pytest.raises(ValueError, match="step_control"):
        adaptive_step_size(1e-4, 1e-6, "fast")
    assert adaptive_step_size(1e-4, 1e-6, "pi").pcoeff == STEP_CONTROLS["pi"]["pcoeff"]
    with pytest.raises(ValueError, match="dt"):
        ConstantStepSize(-1.0)
    with pytest.raises(ValueError, match="y0"):
        simulate(m, GA, ctrl, jnp.array([1.0]), y0=(jnp.zeros(2), jnp.zeros(2)))
    with pytest.raises(ValueError, match="solver must be"):
        simulate(m, jnp.array([1.0]), ctrl, jnp.array([1.0]))
    with pytest.raises(ValueError, match="controller must be"):
        simulate(m, GA, jnp.array([1.0]), jnp.array([1.0]))
    with pytest.raises(ValueError, match="Newton kind"):
        Newton(kind="exact")


# --- vmap and grad through the spin-up of a small RNCF beam ------------------------------------
# The tests that run ``_spin`` share an xdist group: one worker compiles its fixed-step run once.

def _tip_uy(t, q, v):
    return q.reshape(-1, 3)[-6, 1]


TS_SPIN = np.linspace(0.0, 3.0, 31)

MAX_SPLIT = 3
"""Of the violent spin-up's 60 fixed steps, how many may be split (rejected and retried smaller).
Its Newton wanders for up to 20 of its 50 corrections, along a path that another rounding changes;
a step that ran out under some CPU's arithmetic would be split. Issue 13's divergence test split 42
to 388 of them, which this still catches."""

NEWTON_FLIP = 1e-8
"""How far one Newton correction more or less in one step (a count flipped by round-off,
``counts_close``) moves the loss: up to newton_tol (1e-3) in units of the step's tolerance, ~1e-8
relative."""


def _spin(omega_s, E_scale=1.0, adjoint="forward", T_s=6.0):
    """The paper's beam (2 elements) spun up to ``omega_s`` in ``T_s`` (Eq. 43), fixed steps of
    0.05 s, full Newton at its default tolerance. With ``T_s = 2`` the manoeuvre is violent (the
    8 m beam is spun past its first bending frequency, 2.91 rad/s, within one period; the tip
    deflects 2.8 m) and its Newton wanders for up to 20 corrections in some steps; with
    ``T_s = 6`` each step converges in 2-3."""
    body = paper_body(2)
    body = eqx_scale_kappa(body, E_scale)
    model = RotatingFrameModel(body, SpinUp(omega_s, T_s))
    return simulate(model, GA, ConstantStepSize(0.05), TS_SPIN, observe=_tip_uy, adjoint=adjoint,
                    newton=Newton(kind="full"))


def eqx_scale_kappa(body, s):
    import equinox as eqx

    return eqx.tree_at(lambda b: b.groups[0].kappa, body, body.groups[0].kappa * s)


def _loss(sol):
    return float(jnp.sum(sol.ys**2))


@pytest.mark.slow
@pytest.mark.xdist_group("integrator_spin")
def test_vmap_over_spin_rate_matches_separate_runs():
    omegas = jnp.array([1.0, 2.0, 3.0, 4.0])
    batched = jax.vmap(lambda w: _spin(w).ys)(omegas)
    for i, w in enumerate(omegas):
        np.testing.assert_allclose(batched[i], _spin(w).ys, rtol=1e-9, atol=1e-12)
    assert float(jnp.abs(batched[-1]).max()) > float(jnp.abs(batched[0]).max())


@pytest.mark.xdist_group("integrator_spin")
def test_fixed_step_newton_converges_in_every_step():
    """Issue 13: a fixed-step run converges in every step, also where Newton wanders before it
    converges (the violent T_s = 2 spin-up). A divergence test that failed such steps split them,
    and which steps failed flipped with round-off: 121 steps (42 rejected) with AVX-512 arithmetic,
    590-808 (278-388 rejected) with AVX2 or SSE, for spin rates 1e-5 apart. Measured now: 60 steps,
    none rejected; bound ``MAX_SPLIT``."""
    for w in (3.0 - 1e-5, 3.0, 3.0 + 1e-5):
        sol = _spin(w, T_s=2.0)
        assert int(sol.num_rejected) <= MAX_SPLIT, (float(w), int(sol.num_steps), int(sol.num_rejected))


@pytest.mark.xdist_group("integrator_spin")
def test_fixed_step_run_is_a_smooth_function_of_its_parameters():
    """Nine spin rates 1e-5 apart: about the same Newton count in each (measured: the same; a
    count may flip by round-off, ``counts_close``), no rejected step (a split step would make the
    run a step function of ω), and a loss whose second differences are those of a smooth function.
    A step whose Newton converged in a different number of corrections moves the loss by up to
    ``NEWTON_FLIP``, which the second-difference check sees (the smooth function's second
    difference here is ~4e-6 of its first); a perturbation of 1e-12 (relative) moves the loss by
    its derivative's share (~1e-12) and round-off amplified by the run (two CPUs' arithmetics
    differ by ~2e-12, ``test_results_do_not_depend_on_the_cpu``): at most 1e-10, and
    ``NEWTON_FLIP`` more for each flipped correction."""
    sols = [_spin(3.0 + k * 1e-5) for k in range(-4, 5)]
    assert all(counts_close(s.num_newton, sols[4].num_newton) for s in sols), [int(s.num_newton) for s in sols]
    assert all(int(s.num_rejected) == 0 for s in sols)
    L = np.array([_loss(s) for s in sols])
    d1, d2 = np.diff(L), np.diff(L, 2)
    assert np.all(np.sign(d1) == np.sign(d1[0])) and np.abs(d2).max() < 1e-3 * np.abs(d1).min(), (d1, d2)
    for w, E in ((3.0 * (1 + 1e-12), 1.0), (3.0, 1.0 + 1e-12)):
        s = _spin(w, E)
        flips = abs(int(s.num_newton) - int(sols[4].num_newton))
        assert counts_close(s.num_newton, sols[4].num_newton)
        assert abs(_loss(s) - L[4]) <= (1e-10 + flips * NEWTON_FLIP) * L[4]


_OTHER_ARITHMETIC = """
import json, sys
sys.path.insert(0, {tests!r})
import jax
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp
from test_integrator import _spin
gentle, violent = _spin(3.0), _spin(3.0, T_s=2.0)
print(json.dumps(dict(loss=float(jnp.sum(gentle.ys ** 2)), newton=int(gentle.num_newton),
                      violent=[int(violent.num_steps), int(violent.num_rejected)])))
"""


@pytest.mark.slow
@pytest.mark.xdist_group("integrator_spin")
def test_results_do_not_depend_on_the_cpu():
    """The same runs with another CPU's rounding: a subprocess limited to SSE4.2 (no FMA, no AVX),
    which rounds differently from the AVX2/AVX-512 code XLA emits for any x86-64 CPU of the last
    decade. Measured: the same Newton counts, no rejected step in the violent run, and the loss
    2e-12 relative apart between SSE4.2 and AVX-512. Bounds: the Newton counts ``counts_close``,
    at most ``MAX_SPLIT`` split steps, the loss within 1e-10 (``NEWTON_FLIP`` more for each
    flipped correction)."""
    import json
    import os
    import subprocess
    import sys

    if jax.default_backend() != "cpu" or os.uname().machine not in ("x86_64", "AMD64"):
        pytest.skip("an x86-64 CPU check")
    env = dict(os.environ, XLA_FLAGS=(os.environ.get("XLA_FLAGS", "") + " --xla_cpu_max_isa=SSE4_2").strip(),
               JAX_PLATFORMS="cpu")
    code = _OTHER_ARITHMETIC.format(tests=os.path.dirname(__file__))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    other = json.loads(out.stdout.strip().splitlines()[-1])
    here = _spin(3.0)
    flips = abs(other["newton"] - int(here.num_newton))
    assert counts_close(other["newton"], here.num_newton), (other["newton"], int(here.num_newton))
    assert other["violent"][1] <= MAX_SPLIT, other["violent"]
    assert abs(other["loss"] - _loss(here)) <= (1e-10 + flips * NEWTON_FLIP) * _loss(here)


@pytest.mark.slow
@pytest.mark.xdist_group("integrator_spin")
def test_reverse_gradient_matches_finite_differences():
    """jax.grad through the whole (fixed-step) simulation with respect to the spin rate ωs and
    a stiffness scale (κ ∝ E), against central differences (``FD_STEP`` relative: truncation error
    ~1e-10 relative, round-off ~1e-12/1e-5 = 1e-7 relative; agreement asked: ``RTOL_FD``). The
    reverse-mode run's values equal the forward-mode run's: it adds only the tangent of the
    implicit Newton derivative."""

    def loss(x, adjoint="reverse"):
        return jnp.sum(_spin(x[0], x[1], adjoint).ys ** 2)

    x0 = jnp.array([3.0, 1.0])
    assert float(loss(x0)) == pytest.approx(float(loss(x0, "forward")), rel=1e-12)
    g = np.asarray(jax.grad(loss)(x0))
    for i in range(2):
        eps = FD_STEP * float(x0[i])
        e = jnp.zeros(2).at[i].set(eps)
        fd = (float(loss(x0 + e)) - float(loss(x0 - e))) / (2 * eps)
        assert g[i] == pytest.approx(fd, rel=RTOL_FD)
        assert abs(g[i]) > 0


@pytest.mark.slow
def test_reverse_gradient_with_adaptive_steps_matches_finite_differences():
    """Adaptive steps (rtol 1e-6): jax.grad against central differences at ±1e-5, where the step
    sequence does not change (same accepted and rejected counts). The gradient holds the step
    sizes fixed (the controller is not differentiated) while the difference quotient also sees
    them move with ωs, which changes the result by the derivative of the integration error:
    O(rtol) relative per unit of sensitivity, measured 7.8e-5; bound 1e-3."""
    body = paper_body(2)

    def run(w, adjoint):
        return simulate(RotatingFrameModel(body, SpinUp(w, 6.0)), GA, AdaptiveStepSize(1e-6, 1e-8), TS_SPIN,
                        observe=_tip_uy, adjoint=adjoint)

    g = float(jax.grad(lambda w: jnp.sum(run(w, "reverse").ys ** 2))(3.0))
    eps = 1e-5
    plus, minus = run(3.0 + eps, "forward"), run(3.0 - eps, "forward")
    assert (int(plus.num_steps), int(plus.num_rejected)) == (int(minus.num_steps), int(minus.num_rejected))
    fd = (_loss(plus) - _loss(minus)) / (2 * eps)
    assert g == pytest.approx(fd, rel=1e-3) and abs(g) > 0


def test_reduced_models_compile_with_the_small_kernel_options():
    """A single run of a model made of small kernels (a reduced one: ``small_kernels``) is compiled
    with ``SMALL_KERNEL_OPTIONS`` on a CPU, any other with XLA's defaults; the reduced run equals the
    same run compiled with the defaults within the step decisions the other rounding may flip
    (``counts_close``, ``step_flip_bound``)."""
    import importlib

    from nrrncf_jax import reduce_rotating_model

    sim = importlib.import_module("nrrncf_jax.integrate.simulate")  # the module, not the function
    full = RotatingFrameModel(paper_body(2), SpinUp(2.0, 6.0))
    modes = vibration_modes(full.body, full.free_mask(), 4)
    reduced = reduce_rotating_model(full, modes.phi, force="tensor")
    projected = reduce_rotating_model(full, modes.phi, force="projected")
    assert reduced.small_kernels and not projected.small_kernels and not full.small_kernels
    on_cpu = jax.default_backend() == "cpu" and sim._small_kernel_options_known()
    assert (sim._single_run_program(reduced) is sim._simulate_small) == on_cpu
    assert sim._single_run_program(projected) is sim._simulate and sim._single_run_program(full) is sim._simulate
    ts, controller = jnp.linspace(0.0, 6.0, 61), AdaptiveStepSize(1e-5, 1e-7)
    small = simulate(reduced, GA, controller, ts)
    args = sim._prepare(reduced, GA, controller, ts, None, None, 0.0, None, "forward", 200_000, False)
    default = sim._simulate(*args)
    assert counts_close(small.num_steps, default.num_steps)
    assert float(jnp.abs(small.ys - default.ys).max()) <= step_flip_bound(1e-5, 1e-7, default.ys)
    assert float(jnp.abs(default.ys).max()) > 1e-3  # the run moves
    # inside a user's jit the options cannot apply (JAX refuses them on a nested jit): the defaults
    inside = jax.jit(lambda: simulate(reduced, GA, controller, ts).ys)()
    assert float(jnp.abs(inside - default.ys).max()) <= step_flip_bound(1e-5, 1e-7, default.ys)


def test_batches_compile_with_the_small_kernel_options_on_request():
    """``simulate_batch(small_kernels=True)`` compiles the batch with ``SMALL_KERNEL_OPTIONS`` (on a
    CPU): the same members' results as with XLA's defaults, within the step decisions the other
    rounding may flip. Inside a user's ``jit`` it cannot apply and says so; ``kernel_options`` gives
    the options for that outer ``jit``."""
    from nrrncf_jax.integrate import kernel_options

    ks = jnp.array([1.0, 4.0]) * OMEGA**2
    ts = jnp.linspace(0.0, 1.0, 11)
    rtol, atol = 1e-6, 1e-8
    run, kw = (GA, AdaptiveStepSize(rtol, atol), ts), dict(observe=_first)
    default = simulate_batch(_oscillator_of, ks, *run, **kw)
    small = simulate_batch(_oscillator_of, ks, *run, small_kernels=True, **kw)
    bound = step_flip_bound(rtol, atol, default.ys)
    np.testing.assert_allclose(small.ys, default.ys, rtol=0, atol=bound)
    assert all(map(counts_close, np.asarray(small.num_steps), np.asarray(default.num_steps)))
    options = kernel_options(True)
    on_cpu = jax.default_backend() == "cpu" and bool(options)
    assert options == ({"xla_cpu_use_fusion_emitters": False} if on_cpu else {})
    assert kernel_options(False) == {} and kernel_options(True, platform="gpu") == {}
    outer = jax.jit(lambda k: simulate_batch(_oscillator_of, k, *run, **kw).ys, compiler_options=options or None)
    np.testing.assert_allclose(outer(ks), default.ys, rtol=0, atol=bound)
    if on_cpu:
        with pytest.raises(ValueError, match="outermost program"):
            jax.jit(lambda k: simulate_batch(_oscillator_of, k, *run, small_kernels=True, **kw).ys)(ks)
    with pytest.raises(ValueError, match="small_kernels"):
        simulate_batch(_oscillator_of, ks, *run, small_kernels="yes", **kw)


def test_step_ts_end_steps_on_the_stops():
    """``step_ts``: the steps end exactly on the stops, so that a run's state at a stop is the one
    of a run that ends there. With constant steps (no decision that round-off could flip) the run
    with stops at 0.3 and 0.7 s matches, up to 0.7 s, the run that ends at 0.7 s with a stop at
    0.3 s, and to 0.3 s the run that ends there, all to round-off; without the stops the outputs
    there are interpolated between steps and differ by the step's error, far above round-off.
    A stop within round-off of an output time is that output time; a batch keeps the stops."""
    model, ctrl = _oscillator(), ConstantStepSize(0.07)
    ts = jnp.array([0.3, 0.7, 1.6])
    both = np.asarray(simulate(model, GA, ctrl, ts, observe=_first, step_ts=[0.3, 0.7]).ys)
    to_07 = np.asarray(simulate(model, GA, ctrl, ts[:2], observe=_first, step_ts=[0.3]).ys)
    to_03 = np.asarray(simulate(model, GA, ctrl, ts[:1], observe=_first).ys)
    # |q| ≤ 1, at most 25 steps, each adding a few ulps (another program's fusion rounds otherwise;
    # the linear step neither grows nor shrinks them): a wide margin below the 1e-6 it must tell apart.
    bound = 1e-13
    np.testing.assert_allclose(both[:2], to_07, rtol=0, atol=bound)
    np.testing.assert_allclose(both[:1], to_03, rtol=0, atol=bound)
    free = np.asarray(simulate(model, GA, ctrl, ts, observe=_first).ys)
    assert np.abs(free[:2] - both[:2]).min() > 1e-6  # interpolated: the stops did change the steps
    near = np.asarray(simulate(model, GA, ctrl, ts, observe=_first, step_ts=[0.3 + 1e-14, 0.7]).ys)
    np.testing.assert_array_equal(near, both)
    batch = simulate_batch(_oscillator_of, jnp.array([OMEGA**2, 4.0 * OMEGA**2]), GA, ctrl, ts, observe=_first,
                           step_ts=[0.3, 0.7])
    np.testing.assert_allclose(np.asarray(batch.ys)[0], both, rtol=0, atol=bound)
    for bad, match in (([0.7, 0.3], "increasing"), ([-0.1], r"\[t0, t_end\]"), ([2.0], r"\[t0, t_end\]"),
                       ([[0.3]], "1-D"), ([np.nan], "finite")):
        with pytest.raises(ValueError, match=match):
            simulate(model, GA, ctrl, ts, step_ts=bad)


def test_states_at_ends_a_step_on_each_time():
    """``states_at``: one run through the times with a stop on each (``step_ts``): the states are
    that run's outputs there, and as accurate as a run through the same times without the stops
    (about the same steps: the error within the half that another step sequence may move it)."""
    import importlib

    from nrrncf_jax.integrate import states_at

    model, ctrl = _oscillator(), AdaptiveStepSize(1e-6, 1e-8)
    times = np.array([0.0, 0.3, 0.7, 1.6])
    Q, V, compile_s, run_s, steps = states_at(model, GA, ctrl, times)
    assert Q.shape == V.shape == (4, 1) and steps > 3 and compile_s >= 0 and run_s > 0
    one = simulate(model, GA, ctrl, jnp.asarray(times), observe=_first)
    one_error = np.abs(np.asarray(one.ys) - np.cos(OMEGA * times)).max()
    assert np.abs(Q[:, 0] - np.cos(OMEGA * times)).max() <= 1.5 * one_error
    sim = importlib.import_module("nrrncf_jax.integrate.simulate")  # the module, not the function
    run = simulate(model, GA, ctrl, jnp.asarray(times[1:]), step_ts=times[1:], observe=sim._observe_state)
    np.testing.assert_array_equal(np.asarray(run.ys[0]), Q[1:])
    np.testing.assert_array_equal(np.asarray(run.ys[1]), V[1:])
    with pytest.raises(ValueError, match="increasing"):
        states_at(model, GA, ctrl, [0.0, 0.0])


def test_newton_prepare_carries_what_the_update_reads():
    """``newton(prepare=...)``: the update reads prepare(x) of the current iterate, carried by the
    loop, and the solve is the one that computes it inside the update (the same operations, so
    the same numbers)."""
    from nrrncf_jax.integrate.newton import newton

    b = jnp.array([0.5, 2.0, -1.0])
    J_inv = 1.0 / (1.0 + 3.0 * jnp.array([0.2, 1.0, -0.7]) ** 2)  # a fixed (modified Newton) inverse

    def cubic(x):
        return x ** 3

    inside = newton(lambda x: J_inv * (cubic(x) + x - b), lambda d: jnp.max(jnp.abs(d)), jnp.zeros(3), 1e-13, 200)

    def update(x, x3):  # x3 of a stale iterate would change the iterates, and the test would see it
        return J_inv * (x3 + x - b)

    carried = newton(update, lambda d: jnp.max(jnp.abs(d)), jnp.zeros(3), 1e-13, 200, prepare=cubic)
    assert bool(inside.converged) and int(carried.iterations) == int(inside.iterations) > 3
    np.testing.assert_array_equal(np.asarray(carried.x), np.asarray(inside.x))
    np.testing.assert_allclose(np.asarray(carried.x ** 3 + carried.x), np.asarray(b), rtol=0, atol=1e-12)
