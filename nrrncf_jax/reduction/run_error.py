"""The error of a reduced run in its two parts, each estimated from reduced runs alone: the
basis's (``reduction.error_estimate`` at states that end the run's steps) and, on request, the time
integration's (the run against a repetition at tightened tolerances).

Why states at the ends of steps: the estimate of the basis's error evaluates the full model's
residual at the lifted reduced state, with the acceleration the reduced equations give there. An
output between two steps is interpolated (cubic Hermite); its error is within the step's
tolerance, but the reduced model's stiff coordinates (the modal derivatives, up to thousands of
rad/s) carry it as an elastic force out of balance, which the reduced equations turn into an
acceleration far above the motion's. The lifted residual, and the static correction with it, then
measure the interpolation, not the basis: they can lie orders of magnitude above the basis
error, still above it at far tighter tolerances, and change with the number of samples. At the
end of a step the reduced equations hold with the step's own acceleration, and the estimate is the
same at the run's tolerance as at tighter ones.

So the run itself ends steps on the estimate's samples: ``estimate_times`` gives them
(``run_step_ts``: where a run should take them), and the run takes them as ``simulate``'s
``step_ts``; ``estimate_run_error`` with the run's velocities ``vs`` then estimates from the run's
own states, at the cost of the estimate alone (a full residual and one sparse factorisation a
sample; the run's step before each stop is cut short). Without ``vs`` it repeats the run
(``integrate.states_at``) at its tolerances divided by ``tighten``, ending on the times, and estimates there; given
the run's coordinates ``ps`` it also estimates the run's own time-integration error by its
displacements against the repetition's at the samples (χ_rel over the samples, in
``ErrorEstimate.integration_percent``; the repetition's own error is about ``tighten`` times
smaller). A run's total error against the exact solution is at most the sum of the two parts (the
triangle inequality of the norm). Against a full run at the same tolerances it is not: the two
runs' integration errors are alike and partly cancel, so a measured χ_rel between equally loose
runs can lie below either part. ``method="dynamic"`` integrates the error equation over every
output, so its times are all of them, and it repeats the run rather than have the run stop on
every output (``run_step_ts``)."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from .. import _validate
from ..integrate import AbstractStepSizeController, AdaptiveStepSize, GeneralizedAlpha, states_at, tightened
from .error_estimate import METHODS, ErrorEstimate, estimate_error, estimate_indices, sample_indices

TIGHTEN = 10.0
"""The repetition's tolerances are the run's divided by this: its own integration error is then
small next to the run's, whose estimate it gives. The basis's estimate does not need it (its
states end steps: module docstring); a larger value costs more steps."""


def observe_state(t, p, v):
    """A reduced run's observation of its state (p, ṗ) at each output: the lift and the estimate
    need both, and nothing larger is carried through the run's loop."""
    return p, v


def estimate_times(ts, samples: int = 16, method: str = "static") -> np.ndarray:
    """The output times at which the estimate of ``method`` evaluates the reduced run: ``samples``
    of the output times ``ts`` (``error_estimate.sample_indices``) for ``"static"``, every one for
    ``"dynamic"``: where its states must end steps (the run's ``step_ts``, ``run_step_ts``, or
    a repetition's; module docstring)."""
    ts = np.asarray(ts, dtype=float).reshape(-1)
    return ts[estimate_indices(ts.shape[0], samples, method)]


def run_step_ts(ts, samples: int = 16, method: str = "static", integration: bool = False):
    """The ``step_ts`` for a run that ``estimate_run_error`` then estimates from its own states
    (passing its velocities): ``estimate_times`` for the static estimate, whose few stops cut a
    step each; None where the estimate repeats the run instead (then pass no velocities): for
    ``"dynamic"``, whose stop at every output would bound the run's steps by the output interval
    (several times the steps where the run's own are longer; the repetition costs little next to
    the error equation's factorisation an output), and where the run's ``integration`` error is
    wanted (the repetition at tightened tolerances gives the states too)."""
    times = estimate_times(ts, samples, method)  # checks method and samples
    return times if method == "static" and not integration else None


def sampled_states(reduced, ts, samples: int, solver, controller, max_steps: int):
    """The reduced model run from t = 0 with its steps ending exactly on ``samples`` of the output
    times ``ts`` (``error_estimate.sample_indices``; ``integrate.states_at``): ``(idx, P, V,
    compile_s, run_s, steps)``, the samples' indices in ``ts`` and the states (p, ṗ) there, each
    the end of a step."""
    idx = sample_indices(ts.shape[0], int(samples))
    return (idx, *_ending_on(reduced, ts[idx], solver, controller, max_steps))


def _ending_on(reduced, times, solver, controller, max_steps):
    """``states_at`` from t = 0 (the runs' start) through ``times``: the states at ``times`` only."""
    start = [] if times[0] == 0.0 else [0.0]
    P, V, compile_s, run_s, steps = states_at(reduced, solver, controller, np.r_[start, times], max_steps=max_steps)
    return P[len(start):], V[len(start):], compile_s, run_s, steps


def estimate_run_error(full, reduced, ts, ps=None, vs=None, *, solver: GeneralizedAlpha | None = None,
                       controller: AbstractStepSizeController | None = None, max_steps: int = 500_000,
                       tighten: float = TIGHTEN, samples: int = 16, output=(), norm_rows=None,
                       method: str = "static") -> ErrorEstimate:
    """The error of the reduced run (module docstring) over the output times ``ts``, its
    coordinates ``ps`` and velocities ``vs`` ((len(ts), k) each) recorded there, made with
    ``solver`` and ``controller`` (``simulate``'s objects; default ``GeneralizedAlpha(0.9)`` and
    ``AdaptiveStepSize(1e-4, 1e-6)``).

    Given ``vs``, the run must have ended its steps on ``estimate_times(ts, samples, method)``
    (its ``step_ts``): the basis's error is estimated at its own states there (``estimate_error``
    with ``output``, ``norm_rows``, ``method``), and nothing is run again. Without ``vs``, the
    reduced model is repeated with the run's solver and step control, its tolerances divided by
    ``tighten`` (``integrate.tightened``: the PI coefficients and the step limits kept), ending on
    those times, the basis's error is estimated on the repetition, and, given ``ps``, the run's
    integration error against it in ``integration_percent`` (None with ``tighten`` = 1, where the
    repetition is no more accurate than the run). A repetition's compile and run times are in the
    estimate's."""
    solver = GeneralizedAlpha(0.9) if solver is None else solver
    controller = AdaptiveStepSize(1e-4, 1e-6) if controller is None else controller
    _validate.positive("tighten", tighten)
    ts = np.asarray(ts, dtype=float)
    idx = estimate_indices(ts.shape[0], samples, method)
    ps = None if ps is None else np.asarray(ps, dtype=float)
    vs = None if vs is None else np.asarray(vs, dtype=float)
    for name, x in (("ps", ps), ("vs", vs)):
        if x is not None and np.shape(x) != (ts.shape[0], reduced.n_dof):
            raise ValueError(f"{name} must be (len(ts), {reduced.n_dof}) = {(ts.shape[0], reduced.n_dof)}, got "
                             f"{np.shape(x)}")
    if vs is not None and ps is None:
        raise ValueError("vs (the run's velocities) goes with ps (its coordinates)")
    compile_s = run_s = 0.0
    if vs is not None:
        P, V = ps[idx], vs[idx]
    else:
        P, V, compile_s, run_s, _ = _ending_on(reduced, ts[idx], solver, tightened(controller, tighten), max_steps)
    est = estimate_error(full, reduced, ts[idx], P, V, samples=idx.size, output=output, norm_rows=norm_rows,
                         method=method)
    integration = None
    if ps is not None and vs is None and tighten > 1.0:
        rows = np.arange(full.n_dof) if norm_rows is None else np.asarray(norm_rows, dtype=int).reshape(-1)
        lift = jax.vmap(lambda p: reduced.coordinates(p).reshape(-1)[rows])
        run, rep = np.asarray(lift(jnp.asarray(ps[idx]))), np.asarray(lift(jnp.asarray(P)))
        den = float(np.linalg.norm(rep - np.asarray(reduced.q_hat).reshape(-1)[rows]))  # w = q − q̂, as χ_rel
        integration = 100.0 * float(np.linalg.norm(run - rep)) / den if den > 0 else 0.0
    return dataclasses.replace(est, integration_percent=integration, compile_s=est.compile_s + compile_s,
                               run_s=est.run_s + run_s)


def estimate_own_run(full, reduced, ts, ps, vs, *, samples: int = 16, method: str = "static",
                     integration: bool = False, **kwargs) -> ErrorEstimate:
    """``estimate_run_error`` of a run made with ``step_ts=run_step_ts(ts, samples, method,
    integration)``, its coordinates ``ps`` and velocities ``vs`` recorded at ``ts``: from its own
    states where it stopped on the samples, else on a repetition (at ``rtol / TIGHTEN`` with the
    run's ``integration`` error, at the run's tolerances without). ``kwargs``: the rest of
    ``estimate_run_error``'s settings (the run's ``solver`` and ``controller``, ``max_steps``,
    ``output``, ``norm_rows``)."""
    stopped = run_step_ts(ts, samples, method, integration) is not None
    return estimate_run_error(full, reduced, ts, ps, vs if stopped else None, samples=samples, method=method,
                              tighten=TIGHTEN if integration else 1.0, **kwargs)


@dataclasses.dataclass(frozen=True, kw_only=True)
class ErrorEstimator:
    """How a scenario runner estimates its reduced run's error from reduced runs alone (module
    docstring); ``None`` in its place makes no estimate. The result is an ``ErrorEstimate``.

    ``method``: ``"static"`` lifts the reduced state to the full coordinates at ``samples`` of the
    output times, evaluates the full model's residual r there and solves K_T e = −r for the
    displacement error the basis leaves (the quasi-static correction, ``reduction.error_estimate``):
    one sparse factorisation of the full model per sample, and the run ends a step on each sample
    so that the estimate reads its own states, not an interpolation (``step_ts``). ``"dynamic"``
    integrates the linearised error equation M ë + R_q̇ ė + R_q e = −r over every output instead (a
    factorisation an output, on a repetition of the run that ends a step on each; ``samples`` is
    then not used): costlier, but it follows the error a basis lets grow over the run as drift,
    which the quasi-static correction cannot see. Either estimates χ_rel (Eq. 40; docs/theory.md,
    §9 Accuracy measures and checks) over the same displacements as the measured one.

    ``integration``: also estimate the run's own time-integration error, χ_rel of the run against
    its repetition at the tolerances divided by ``TIGHTEN`` at the samples (that repetition also
    gives the states the basis's part is estimated at): its cost is the repetition, more than the
    run itself. The two parts bound the run's total error (the triangle inequality), which a
    basis error alone does not where the steps are loose."""

    method: str = "static"
    samples: int = 16
    integration: bool = False

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"ErrorEstimator.method must be one of {METHODS}, got {self.method!r}")
        if isinstance(self.samples, bool) or not isinstance(self.samples, (int, np.integer)) or self.samples < 2:
            raise ValueError(f"ErrorEstimator.samples must be an integer >= 2, got {self.samples!r}")
        _validate.boolean("ErrorEstimator.integration", self.integration)

    def step_ts(self, ts):
        """The ``step_ts`` of the run to be estimated (``run_step_ts``): the static estimate's
        samples, or None where the estimate repeats the run."""
        return run_step_ts(ts, self.samples, self.method, self.integration)

    def estimate(self, full, reduced, ts, ps, vs, solver, controller, *, max_steps: int = 500_000, output=(),
                 norm_rows=None) -> ErrorEstimate:
        """The estimate (``estimate_own_run``) of the run of ``reduced`` made with ``solver`` (a
        ``GeneralizedAlpha``), ``controller`` (an ``AdaptiveStepSize``) and
        ``step_ts=self.step_ts(ts)``, its coordinates ``ps`` and velocities ``vs`` recorded at the
        output times ``ts``. A repetition runs with the run's solver and step control, at its
        tolerances (divided by ``TIGHTEN`` for ``integration``). ``output``, ``norm_rows``:
        ``estimate_error``'s."""
        return estimate_own_run(full, reduced, ts, ps, vs, samples=self.samples, method=self.method,
                                integration=self.integration, solver=solver, controller=controller,
                                max_steps=max_steps, output=output, norm_rows=norm_rows)


__all__ = ["TIGHTEN", "ErrorEstimator", "estimate_own_run", "estimate_run_error", "estimate_times", "observe_state",
           "run_step_ts", "sampled_states"]
