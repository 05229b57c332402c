"""The a-posteriori error estimate of a reduced run (``reduction.error_estimate``): at round-off
where the basis spans every free coordinate, growing when the basis loses its modal derivatives,
and within the effectivity band [0.5, 2] of the χ_rel measured against the full run."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import EPS, paper_body

from nrrncf_jax import (
    AdaptiveStepSize,
    Basis,
    GeneralizedAlpha,
    RotatingFrameModel,
    SpinUp,
    ToTolerance,
    chi_rel,
    nr_rncf,
    nr_rncf_to_tolerance,
    simulate,
)
from nrrncf_jax.reduction.basis_to_tolerance import greedy_order
from nrrncf_jax.reduction.error_estimate import RELIABLE_PERCENT, estimate_error, sample_indices
from nrrncf_jax.reduction.reduced_model import reduce_rotating_model
from nrrncf_jax.reduction.run_error import estimate_run_error

GA = GeneralizedAlpha(0.9)
TS = np.arange(0.0, 20.0 + 1e-9, 0.05)


@pytest.fixture(scope="module")
def spin():
    """The paper's beam on 4 elements spun up to 4 rad/s in 15 s, and its full RNCF run."""
    full = RotatingFrameModel(paper_body(4), SpinUp(4.0, 15.0))
    ref = simulate(full, GA, AdaptiveStepSize(1e-5, 1e-7), jnp.asarray(TS),
                   observe=lambda t, q, v: full.displacements(t, q))
    return full, np.asarray(ref.ys).reshape(TS.size, -1)


def _reduced_run(red):
    sol = simulate(red, GA, AdaptiveStepSize(1e-5, 1e-7), jnp.asarray(TS), observe=lambda t, p, v: (p, v))
    P, V = (np.asarray(y) for y in sol.ys)
    w = np.asarray(jax.vmap(lambda p: red.displacements(0.0, p))(P)).reshape(TS.size, -1)
    return P, V, w


@pytest.fixture(scope="module")
def exact(spin):
    """Ψ = the free coordinates' unit vectors, and the reduced model's run (shared by both
    methods' test: one compilation)."""
    full, _ = spin
    free = np.flatnonzero(np.asarray(full.free_mask()))
    red = reduce_rotating_model(full, np.eye(full.n_dof)[:, free])
    return free, red, _reduced_run(red)


@pytest.mark.xdist_group("error_estimate")
@pytest.mark.parametrize("method", ["static", "dynamic"])
def test_estimate_is_round_off_when_the_basis_spans_every_coordinate(spin, exact, method):
    """Ψ = the free coordinates' unit vectors: the reduced model is the full one, its lifted
    residual is round-off, and so is the correction: |e| ≲ cond(K_T) ε |q| (a residual of a few
    terms each with a relative error ε, through K_T⁻¹), with a factor 10 for the terms' count.
    The error equation (``method="dynamic"``) sums such corrections over its outputs: at most
    one more factor of the outputs' count, a growth no stable linear equation exceeds."""
    full, _ = spin
    free, red, (P, V, _) = exact
    est = estimate_error(full, red, TS, P, V, samples=20, method=method)
    q = np.asarray(red.q_eq).reshape(-1)
    K = np.asarray(jax.jacfwd(lambda x: full.residual(0.0, x, 0 * x, 0 * x))(jnp.asarray(q)))[np.ix_(free, free)]
    bound = 10 * np.linalg.cond(K) * EPS * np.abs(q).max() * np.sqrt(len(est.ts))
    bound *= len(est.ts) if method == "dynamic" else 1
    assert 0.01 * est.chi_rel_percent * np.sqrt(np.sum(est.displacement_norm**2)) <= bound, (est.chi_rel_percent, bound)
    assert est.reliable


@pytest.mark.xdist_group("error_estimate")
def test_estimate_tracks_the_measured_error_and_grows_without_mds(spin):
    full, w_ref = spin
    red = nr_rncf(full, jnp.asarray(TS), Basis(n_modes=12))
    vm_only = nr_rncf(full, jnp.asarray(TS), Basis(n_modes=12, vms=red.dofs, mds=0, spin_state=False))
    tip = full.body.n_vectors - full.body.vectors_per_node  # the tip node's position vector
    out = {}
    for name, r in (("mds", red), ("vms", vm_only)):
        P, V, w = _reduced_run(r.model)
        est = estimate_error(full, r.model, TS, P, V, output=3 * tip + np.arange(3))
        measured = float(chi_rel(w_ref, w))
        out[name] = (est.chi_rel_percent, measured)
        assert est.reliable == (est.chi_rel_percent <= RELIABLE_PERCENT)
        assert 0.5 <= est.chi_rel_percent / measured <= 2.0, (name, est.chi_rel_percent, measured)
        # the tip's rows of the correction, sample by sample
        assert est.output_error.shape == (len(est.ts), 3)
    assert out["vms"][0] > 5 * out["mds"][0], out


@pytest.mark.xdist_group("error_estimate")
def test_error_equation_tracks_the_measured_error_and_knows_where_it_fails(spin):
    """``method="dynamic"``: on the default basis the integrated error equation is valid over
    the whole run and within the effectivity band; on the VMs-only basis (χ_rel ≈ 86 %) the
    linearisation is not small, and the estimate says it stopped being valid before the end."""
    full, w_ref = spin
    red = nr_rncf(full, jnp.asarray(TS), Basis(n_modes=12))
    vm_only = nr_rncf(full, jnp.asarray(TS), Basis(n_modes=12, vms=red.dofs, mds=0, spin_state=False))
    P, V, w = _reduced_run(red.model)
    est = estimate_error(full, red.model, TS, P, V, method="dynamic")
    measured = float(chi_rel(w_ref, w))
    assert est.valid_until is None and est.reliable and len(est.ts) == TS.size
    assert 0.5 <= est.chi_rel_percent / measured <= 2.0, (est.chi_rel_percent, measured)
    P, V, _ = _reduced_run(vm_only.model)
    est = estimate_error(full, vm_only.model, TS, P, V, method="dynamic")
    assert est.valid_until is not None and est.valid_until < TS[-1] and not est.reliable


@pytest.mark.xdist_group("error_estimate")
def test_run_error_splits_basis_and_integration(spin):
    """``reduction.run_error``: a run at a loose tolerance (rtol 1e-3) has its basis's error
    estimated at the ends of steps of its repetition (rtol 1e-4, ending on the samples), which does
    not depend on that tolerance: the repetition at rtol 1e-5 gives the same estimate within 1 %
    (the two repetitions' states differ by their integration errors, about 1e-4 of the motion here,
    and the estimate is a smooth function of them). Its integration error, against the
    repetition at the samples, lies within [0.5, 2] of its distance to a run at rtol 1e-8 there;
    its measured χ_rel against the full run is at most the two parts' sum (the triangle
    inequality), with 10 % for the full run's own integration error and the samples' norm."""
    full, w_ref = spin
    red = nr_rncf(full, jnp.asarray(TS), Basis(n_modes=12)).model
    loose = simulate(red, GA, AdaptiveStepSize(1e-3, 1e-5), jnp.asarray(TS), observe=lambda t, p, v: p)
    P = np.asarray(loose.ys)
    est = estimate_run_error(full, red, TS, P, controller=AdaptiveStepSize(1e-3, 1e-5))
    tighter = estimate_run_error(full, red, TS, P, controller=AdaptiveStepSize(1e-3, 1e-5), tighten=100.0)
    assert est.chi_rel_percent == pytest.approx(tighter.chi_rel_percent, rel=1e-2)
    idx = sample_indices(TS.size, 16)
    np.testing.assert_allclose(est.ts, TS[idx])
    tight = simulate(red, GA, AdaptiveStepSize(1e-8, 1e-10), jnp.asarray(TS), observe=lambda t, p, v: p)
    disp = jax.vmap(lambda p: red.displacements(0.0, p).reshape(-1))
    w_loose, w_tight = np.asarray(disp(P)), np.asarray(disp(jnp.asarray(tight.ys)))
    truth = float(chi_rel(w_tight[idx], w_loose[idx]))
    assert 0.5 <= est.integration_percent / truth <= 2.0, (est.integration_percent, truth)
    assert float(chi_rel(w_ref, w_loose)) <= 1.1 * (est.chi_rel_percent + est.integration_percent)
    with pytest.raises(ValueError, match="ps must be"):
        estimate_run_error(full, red, TS, P[:, :2], controller=AdaptiveStepSize(1e-3, 1e-5))


def test_error_estimator_checks_its_fields():
    """``ErrorEstimator`` (``reduction.run_error``: how the scenario runners estimate a reduced
    run's error) holds the runners' defaults (static, 16 samples, no integration part), is
    exported beside ``Basis``, frozen and keyword-only; its ``step_ts`` stops the run on the static
    estimate's samples only where the estimate reads the run's own states. A bad field is a
    ``ValueError`` on construction that names it."""
    import dataclasses

    import nrrncf_jax
    from nrrncf_jax.reduction import ErrorEstimator
    from nrrncf_jax.reduction.run_error import estimate_times

    assert nrrncf_jax.ErrorEstimator is ErrorEstimator
    e = ErrorEstimator()
    assert (e.method, e.samples, e.integration) == ("static", 16, False)
    np.testing.assert_array_equal(e.step_ts(TS), estimate_times(TS, 16))
    np.testing.assert_array_equal(ErrorEstimator(samples=5).step_ts(TS), estimate_times(TS, 5))
    assert ErrorEstimator(integration=True).step_ts(TS) is None  # the repetition gives the states
    assert ErrorEstimator(method="dynamic").step_ts(TS) is None  # every output: on a repetition
    assert ErrorEstimator(samples=np.int64(4)).samples == 4
    with pytest.raises(dataclasses.FrozenInstanceError):
        e.samples = 8
    with pytest.raises(TypeError):
        ErrorEstimator("dynamic")  # keyword-only, as Basis
    for kw, says in ((dict(method="quasi-static"), r"ErrorEstimator\.method must be one of \('static', 'dynamic'\)"),
                     (dict(samples=1), r"ErrorEstimator\.samples must be an integer >= 2, got 1"),
                     (dict(samples=4.0), r"ErrorEstimator\.samples must be an integer >= 2, got 4\.0"),
                     (dict(samples=True), r"ErrorEstimator\.samples must be an integer >= 2, got True"),
                     (dict(integration=1), r"ErrorEstimator\.integration must be True or False, got 1"),
                     (dict(integration="yes"), r"ErrorEstimator\.integration must be True or False")):
        with pytest.raises(ValueError, match=says):
            ErrorEstimator(**kw)


@pytest.mark.xdist_group("error_estimate")
def test_run_error_from_the_runs_own_step_ends(spin):
    """A run that ends its steps on the estimate's times (``estimate_times`` as ``step_ts``) is
    estimated from its own states, with nothing run again: the same basis estimate as on a
    repetition ending on the samples at a ten times tighter tolerance, within the 1 % that the
    states' integration errors (about 1e-4 of the motion at rtol 1e-3, see above) allow; its
    states at the samples are ends of steps, so a run without the stops is not what it reads."""
    from nrrncf_jax.reduction.run_error import estimate_times

    full, _ = spin
    red = nr_rncf(full, jnp.asarray(TS), Basis(n_modes=12)).model
    stops = estimate_times(TS, 16)
    np.testing.assert_array_equal(stops, TS[sample_indices(TS.size, 16)])
    np.testing.assert_array_equal(estimate_times(TS, 16, "dynamic"), TS)
    sol = simulate(red, GA, AdaptiveStepSize(1e-3, 1e-5), jnp.asarray(TS), observe=lambda t, p, v: (p, v),
                   step_ts=stops)
    P, V = (np.asarray(y) for y in sol.ys)
    own = estimate_run_error(full, red, TS, P, V, controller=AdaptiveStepSize(1e-3, 1e-5))
    rep = estimate_run_error(full, red, TS, controller=AdaptiveStepSize(1e-3, 1e-5))
    assert own.integration_percent is None and rep.integration_percent is None  # no ps: no run to compare
    assert own.chi_rel_percent == pytest.approx(rep.chi_rel_percent, rel=1e-2), (own.chi_rel_percent,
                                                                                 rep.chi_rel_percent)
    with pytest.raises(ValueError, match="goes with ps"):
        estimate_run_error(full, red, TS, None, V)
    # Where a run should stop: on the samples for the static estimate; nowhere where it repeats
    # the run (the error equation over every output, or the run's integration error wanted).
    from nrrncf_jax.reduction.run_error import run_step_ts

    np.testing.assert_array_equal(run_step_ts(TS, 16), stops)
    assert run_step_ts(TS, 16, "dynamic") is None and run_step_ts(TS, 16, integration=True) is None
    with pytest.raises(ValueError, match="method"):
        estimate_times(TS, 16, "adjoint")


def test_sample_indices_and_bad_input(spin):
    np.testing.assert_array_equal(sample_indices(5, 60), np.arange(5))
    idx = sample_indices(401, 60)
    assert idx[0] == 0 and idx[-1] == 400 and len(idx) == 60 and np.all(np.diff(idx) > 0)
    with pytest.raises(ValueError, match="samples"):
        sample_indices(10, 1)
    full, _ = spin
    red = reduce_rotating_model(full, np.eye(full.n_dof)[:, :3])
    with pytest.raises(ValueError, match="ps and vs"):
        estimate_error(full, red, TS, np.zeros((3, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="output"):
        estimate_error(full, red, TS[:2], np.zeros((2, 3)), np.zeros((2, 3)), output=[full.n_dof])
    with pytest.raises(ValueError, match="norm_rows"):
        estimate_error(full, red, TS[:2], np.zeros((2, 3)), np.zeros((2, 3)), norm_rows=[-1])
    with pytest.raises(ValueError, match="method"):
        estimate_error(full, red, TS[:2], np.zeros((2, 3)), np.zeros((2, 3)), method="adjoint")
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="tol"):
            nr_rncf_to_tolerance(full, TS, bad)
    with pytest.raises(ValueError, match="safety"):
        ToTolerance(tol=1.0, safety=0.0)
    with pytest.raises(ValueError, match="prune must be True or False"):
        ToTolerance(tol=1.0, prune=1)
    with pytest.raises(ValueError, match="reduction.Basis"):
        nr_rncf_to_tolerance(full, TS, 1.0, dict(n_modes=4))


def test_greedy_order_ranks_by_interaction_and_breaks_ties_by_index():
    """The greedy order (``basis_to_tolerance.greedy_order``): by weight, an MD only once both
    of its modes are in, and weights equal to within ``TIE`` (round-off, as between two CPUs)
    ranked by index, so that the order is the same for W perturbed by round-off."""
    W = np.array([[9.0, 2.0, 0.5], [2.0, 4.0, 3.0], [0.5, 3.0, 4.0]])
    assert greedy_order(W, [0, 1, 2]) == [0, (0, 0), 1, 2, (1, 1), (2, 2), (1, 2), (0, 1), (0, 2)]
    # Modes 1 and 2 tie (W_11 = W_22): ranked by index, whichever is larger by round-off.
    for sign in (1.0, -1.0):
        Wp = W.copy()
        Wp[2, 2] *= 1.0 + sign * 64 * EPS
        assert greedy_order(Wp, [0, 1, 2]) == greedy_order(W, [0, 1, 2])
    # A real MMI matrix, |η|ᵀ|η| of a random response, perturbed relatively by a few ulps.
    rng = np.random.default_rng(0)
    A = np.abs(rng.standard_normal((200, 6))) * np.array([1.0, 0.5, 0.5, 0.2, 0.1, 0.05])
    W = A.T @ A
    base = greedy_order(W, range(6))
    assert len(base) == 6 + 21 and base[:2] == [0, (0, 0)]
    for _ in range(5):
        assert greedy_order(W * (1.0 + 8 * EPS * rng.standard_normal(W.shape)), range(6)) == base
    with pytest.raises(ValueError, match="at least one candidate"):
        greedy_order(W, [])


def test_pruning_drops_what_the_prefix_does_not_need():
    """``_pruned``: from the lowest ranked up, a candidate goes where the basis without it still
    passes with no more DOFs; a VM stays while an MD of its pairs does; the first never goes, and
    the last is not tried alone (that is the shorter prefix, which failed)."""
    from nrrncf_jax.reduction.basis_to_tolerance import BasisSearch, Trial, _pruned

    needed = {0, (0, 0), 2}
    calls = []

    def evaluate(items, dropped):
        calls.append(dropped)
        spun = dropped[-1] == (1, 1)  # as if the spinning-state check enriched this one: more DOFs
        return Trial(columns=len(items), dofs=len(items) + (3 if spun else 0), vms=(), pairs=(),
                     chi_rel_estimate_percent=0.1 + sum(c not in items for c in needed), reliable=True,
                     steps=1, seconds=0.0, dropped=dropped)

    items = [0, (0, 0), 1, (0, 1), (1, 1), 2]
    start = Trial(columns=6, dofs=6, vms=(), pairs=(), chi_rel_estimate_percent=0.1, reliable=True, steps=1,
                  seconds=0.0)
    key = _pruned(evaluate, items, start, limit=0.5)
    assert key == ("pruned", (0, 1))
    # The last (φ2) is the failing shorter prefix's; dropping θ1,1 passes but adds DOFs; θ0,1 goes;
    # φ1 stays for θ1,1; θ0,0 is needed.
    assert calls == [((1, 1),), ((0, 1),), ((0, 1), (0, 0))]
    search = BasisSearch(tol=1.0, safety=2.0, met=True, trials=[start, evaluate(items[:-1], ((0, 1),))],
                         chosen=start, order=items, estimate=None)
    assert search.trials_line() == "6→6: 0.1, −θ0,1→5: 1.1"  # the second lacks φ2: 0.1 + 1


@pytest.mark.slow
@pytest.mark.xdist_group("error_estimate")
def test_basis_to_a_tolerance_meets_it_measured(spin):
    """``nr_rncf_to_tolerance(..., 0.5)``: the basis grows along the MMI order until the estimate of its
    training run is at most 0.25 % (the default safety factor 2); every shorter prefix tried was
    above that, pruning kept no more DOFs than the passing prefix, and the χ_rel measured against
    the full run is below the tolerance."""
    full, w_ref = spin
    # The search from 5 columns (a 2-column start is the command line test's): 5, 8, then 6 and 7.
    red = nr_rncf_to_tolerance(full, jnp.asarray(TS), ToTolerance(tol=0.5, start=5), Basis(n_modes=12, max_dofs=8),
                               controller=AdaptiveStepSize(1e-5, 1e-7))
    s = red.search
    assert s.met and s.safety == 2.0 and s.chosen.chi_rel_estimate_percent <= 0.25
    assert red.dofs == s.chosen.dofs and red.selection.vms == s.chosen.vms
    prefix = s.chosen.columns + len(s.chosen.dropped)  # the passing prefix's length
    assert all(t.chi_rel_estimate_percent > 0.25 for t in s.trials if not t.dropped and t.columns < prefix)
    assert any(t.columns == prefix - 1 for t in s.trials if not t.dropped)  # the next shorter prefix was tried
    assert s.chosen.dofs <= next(t.dofs for t in s.trials if not t.dropped and t.columns == prefix)
    _, _, w = _reduced_run(red.model)
    assert float(chi_rel(w_ref, w)) <= 0.5
    assert "the first" in s.describe()


def test_valid_outputs_reads_the_start_against_the_motions_scale():
    """``valid_outputs``: an error above ``RELIABLE_PERCENT`` of the displacement so far ends the
    validity, except while the displacement is below ``START_FRACTION`` of the run's largest (a
    run from rest: both far below the motion's scale); an error growing by ``BLOWUP_FACTOR`` within
    1/ω ends it where the growth began, one that only oscillates (near zero and back) does not."""
    from nrrncf_jax.reduction.error_estimate import BLOWUP_FACTOR, START_FRACTION, valid_outputs

    ts = np.linspace(0.0, 1.0, 101)
    w = np.minimum((ts / 0.5) ** 3, 1.0)  # the displacement grows from rest to 1 by t = 0.5 s
    start = 0.5 * START_FRACTION * RELIABLE_PERCENT / 100.0  # below the scale's floor
    e = np.where(ts < 0.1, start, 1e-3 * w)
    e[0] = 0.0
    assert np.all(e[1:8] > RELIABLE_PERCENT / 100.0 * w[1:8])  # large against the displacement so far
    assert valid_outputs(ts, e, w, omega=0.0) == ts.size
    late = e.copy()
    late[60:] = 2 * RELIABLE_PERCENT / 100.0  # past the linearisation's range from t = 0.6 s
    assert valid_outputs(ts, late, w, omega=0.0) == 60
    blow = 1e-3 * w * np.where(ts >= 0.8, 2 * BLOWUP_FACTOR, 1.0)  # a jump within 1/ω = 0.05 s
    assert valid_outputs(ts, blow, w, omega=20.0) < 80
    # A blow-up after an early peak is seen where it begins, not once it passes the peak tenfold.
    bump = np.maximum(0.015 * np.sin(np.pi * ts / 0.4) * (ts < 0.4), 1e-4)  # slow: no blow-up
    spike = bump * np.exp(100.0 * np.maximum(ts - 0.7, 0.0))  # tenfold in 0.023 s from t = 0.7 s
    assert 68 <= valid_outputs(ts, spike, np.ones_like(ts), omega=20.0) <= 71
    # A phase error: it oscillates, passing near zero and back within 1/ω, without growing.
    ring = 1e-3 * np.abs(np.sin(2 * np.pi * ts / 0.2)) + 1e-7
    assert valid_outputs(ts, ring, np.ones_like(ts), omega=20.0) == ts.size


def test_error_equation_in_windows_equals_step_by_step():
    """``integrate_error_equation(..., batch=k)`` (the factors of k steps made together) integrates
    the same equations as one step after another: a damped 3-DOF system driven by a given defect,
    with 10 steps in windows of 4 (the last padded), agrees to round-off: ten steps, each a solve
    with a matrix of condition ≈ 10, allow some hundreds of ε of the solution."""
    from nrrncf_jax.linalg import DenseLU
    from nrrncf_jax.reduction.error_estimate import NEWMARK_BETA, NEWMARK_GAMMA, integrate_error_equation

    M = jnp.diag(jnp.array([1.0, 2.0, 0.5]))
    C = 0.1 * jnp.eye(3)
    K0 = jnp.array([[4.0, -1.0, 0.0], [-1.0, 3.0, -0.5], [0.0, -0.5, 2.0]])
    ts = jnp.linspace(0.0, 1.0, 11)
    states = ts  # the "run's state": the time itself, which scales the stiffness and drives the defect

    def linearised(t, h, state):
        K = K0 * (1.0 + 0.5 * state)
        force = jnp.array([jnp.sin(3.0 * t), 1.0, t])

        def defect(e, ed, edd, mu):
            return M @ edd + C @ ed + K @ e - force

        return defect, DenseLU.factor(M + NEWMARK_GAMMA * h * C + NEWMARK_BETA * h**2 * K), None

    def measure(_, e):
        return e

    one = integrate_error_equation(ts, states, linearised, measure, 3)
    windows = integrate_error_equation(ts, states, linearised, measure, 3, batch=4)
    assert one.shape == windows.shape == (11, 3) and float(jnp.abs(one).max()) > 1e-3
    np.testing.assert_allclose(windows, one, rtol=0, atol=1000 * EPS * float(jnp.abs(one).max()))
