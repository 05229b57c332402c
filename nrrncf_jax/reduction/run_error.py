"""The error of a reduced run in its two parts, each estimated from reduced runs alone: the
basis's (``reduction.error_estimate`` at states of the run repeated to end exactly on the sample
times) and the time integration's (the run against that repetition, which goes at tightened
tolerances).

Why a repetition, and why it ends on the samples: the estimate of the basis's error evaluates the
full model's residual at the lifted reduced state, with the acceleration the reduced equations
give there. An output between two steps is interpolated (cubic Hermite); its error is within the
step's tolerance, but the reduced model's stiff coordinates (the modal derivatives, up to thousands
of rad/s) carry it as an elastic force out of balance, which the reduced equations turn into an
acceleration far above the motion's. The lifted residual, and the static correction with
it, then measure the interpolation, not the basis: on the paper beam's 40 rad/s spin-up, orders
of magnitude above the basis error at the run's tolerance, and at a hundred times tighter still
several times above it and changing with the number of samples
(``benchmarks/results/error_estimate.md``). At the end of a step the reduced equations hold with
the step's own acceleration, and the estimate is the same at the run's tolerance as at tighter
ones. ``integrate.states_at`` runs the model from one
sample time to the next, each piece ending on its sample.

The repetition goes at ``rtol / tighten``: the run's own time-integration error is then estimated
by the run's displacements against the repetition's at the samples (χ_rel over the samples, in
``ErrorEstimate.integration_percent``; the repetition's own error is about ``tighten`` times
smaller). A run's total error against the exact solution is at most the sum of the two parts (the
triangle inequality of the norm). Against a full run at the same tolerances it is not: the two
runs' integration errors are alike and partly cancel, so a measured χ_rel between equally loose
runs can lie below either part. ``method="dynamic"`` integrates the error equation over every
output, so its repetition is one run through all of them, as before."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from .. import _validate
from ..integrate import AdaptiveStepSize, GeneralizedAlpha, simulate_timed, states_at
from .error_estimate import METHODS, ErrorEstimate, estimate_error, sample_indices

TIGHTEN = 10.0
"""The repetition's tolerances are the run's divided by this: its own integration error is then
small next to the run's, whose estimate it gives. The basis's estimate does not need it (its
states end steps: module docstring); a larger value costs more steps."""


def observe_state(t, p, v):
    """A reduced run's observation of its state (p, ṗ) at each output: the lift and the estimate
    need both, and nothing larger is carried through the run's loop."""
    return p, v


def sampled_states(reduced, ts, samples: int, solver, controller, max_steps: int):
    """The reduced model run from t = 0 to end exactly on ``samples`` of the output times ``ts``
    (``error_estimate.sample_indices``; ``integrate.states_at``): ``(idx, P, V, compile_s, run_s,
    steps)``, the samples' indices in ``ts`` and the states (p, ṗ) there, each the end of a step."""
    idx = sample_indices(ts.shape[0], int(samples))
    start = [] if ts[idx[0]] == 0.0 else [0.0]  # the runs start at t = 0
    P, V, compile_s, run_s, steps = states_at(reduced, solver, controller, np.r_[start, ts[idx]], max_steps=max_steps)
    return idx, P[len(start):], V[len(start):], compile_s, run_s, steps


def estimate_run_error(full, reduced, ts, ps=None, *, rho_inf: float = 0.9, rtol: float = 1e-4,
                       atol: float = 1e-6, max_steps: int = 500_000, tighten: float = TIGHTEN,
                       samples: int = 16, output=(), norm_rows=None, method: str = "static") -> ErrorEstimate:
    """The error of the reduced run (module docstring) over the output times ``ts`` with the
    generalized-α settings ``rho_inf``, ``rtol``, ``atol``: the reduced model repeated at
    ``rtol / tighten``, ``atol / tighten``, ending exactly on ``samples`` of the output times
    (``method="static"``; every output with ``"dynamic"``), its basis's error estimated there
    (``estimate_error`` with ``output``, ``norm_rows``, ``method``), and, given the run's
    coordinates ``ps`` ((len(ts), k)), its integration error against the repetition in
    ``integration_percent`` (None with ``tighten`` = 1, where the repetition is no more accurate
    than the run). The repetition's compile and run times are in the estimate's."""
    _validate.positive("tighten", tighten)
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    ts = np.asarray(ts, dtype=float)
    solver, controller = GeneralizedAlpha(rho_inf), AdaptiveStepSize(rtol / tighten, atol / tighten)
    if ps is not None:
        ps = np.asarray(ps, dtype=float)
        if ps.shape != (ts.shape[0], reduced.n_dof):
            raise ValueError(f"ps must be (len(ts), {reduced.n_dof}) = {(ts.shape[0], reduced.n_dof)}, got {ps.shape}")
    if method == "static":
        idx, P, V, compile_s, run_s, _ = sampled_states(reduced, ts, samples, solver, controller, max_steps)
        est = estimate_error(full, reduced, ts[idx], P, V, samples=idx.size, output=output, norm_rows=norm_rows)
    else:
        idx = np.arange(ts.shape[0])
        sol, compile_s, run_s = simulate_timed(reduced, solver, controller, jnp.asarray(ts), observe=observe_state,
                                               max_steps=max_steps)
        P, V = (np.asarray(y) for y in jax.device_get(sol.ys))
        est = estimate_error(full, reduced, ts, P, V, samples=samples, output=output, norm_rows=norm_rows,
                             method=method)
    integration = None
    if ps is not None and tighten > 1.0:
        rows = np.arange(full.n_dof) if norm_rows is None else np.asarray(norm_rows, dtype=int).reshape(-1)
        lift = jax.vmap(lambda p: reduced.coordinates(p).reshape(-1)[rows])
        run, rep = np.asarray(lift(jnp.asarray(ps[idx]))), np.asarray(lift(jnp.asarray(P)))
        den = float(np.linalg.norm(rep - np.asarray(reduced.q_hat).reshape(-1)[rows]))  # w = q − q̂, as χ_rel
        integration = 100.0 * float(np.linalg.norm(run - rep)) / den if den > 0 else 0.0
    return dataclasses.replace(est, integration_percent=integration, compile_s=est.compile_s + compile_s,
                               run_s=est.run_s + run_s)


__all__ = ["TIGHTEN", "estimate_run_error", "observe_state", "sampled_states"]
