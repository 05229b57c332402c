"""The error of a reduced run in its two parts, each estimated from reduced runs alone: the
basis's (``reduction.error_estimate`` on the run repeated at tightened tolerances) and the time
integration's (the run against that repetition).

Why the repetition: the estimate of the basis's error evaluates the full model's residual at the
lifted reduced states, and the static correction answers it through the full tangent K_T. The
states carry the run's own time-integration error δp, and K_T⁻¹ of the residual's change with δp
is not small where K_T is nearly singular, as in a spin-up passing the beam's first bending
frequency. There the estimate measures the run's integration error magnified, not its basis
(the paper beam's 40 rad/s spin-up, at the run's tolerance, at ten and at a hundred times
tighter; more numerical damping does not remove it: ``benchmarks/results/error_estimate.md``). A
reduced run is cheap, so the estimate repeats it at ``rtol / tighten`` (and ``atol / tighten``)
and estimates the basis's error on that trajectory.

The comparison with the repetition is itself an estimate of the run's time-integration error
(the repetition's own is ``tighten`` times smaller): χ_rel of the run's displacements against
the repetition's over all output times, in ``ErrorEstimate.integration_percent``. A run's total
error against the exact solution is at most the sum of the two parts (the triangle inequality
of the norm). Against a full run at the same tolerances it is not: the two runs' integration
errors are alike and partly cancel, so a measured χ_rel between equally loose runs can lie
below either part."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from .. import _validate
from ..integrate import AdaptiveStepSize, GeneralizedAlpha, simulate_timed
from .error_estimate import ErrorEstimate, estimate_error

TIGHTEN = 100.0
"""The repetition's tolerances are the run's divided by this: its own integration error is then
small next to the run's, and next to the basis errors the estimate is asked about."""


def observe_state(t, p, v):
    """A reduced run's observation of its state (p, ṗ) at each output: the lift and the estimate
    need both, and nothing larger is carried through the run's loop."""
    return p, v


def estimate_run_error(full, reduced, ts, ps=None, *, rho_inf: float = 0.9, rtol: float = 1e-4,
                       atol: float = 1e-6, max_steps: int = 500_000, tighten: float = TIGHTEN,
                       samples: int = 16, output=(), norm_rows=None, method: str = "static") -> ErrorEstimate:
    """The error of the reduced run (module docstring) over the output times ``ts`` with the
    generalized-α settings ``rho_inf``, ``rtol``, ``atol``: the reduced model repeated at
    ``rtol / tighten``, ``atol / tighten``, its basis's error estimated on that repetition
    (``estimate_error`` with ``samples``, ``output``, ``norm_rows``, ``method``), and, given the
    run's coordinates ``ps`` ((len(ts), k)), its integration error against the repetition in
    ``integration_percent``. The repetition's compile and run times are in the estimate's."""
    _validate.positive("tighten", tighten)
    ts = np.asarray(ts, dtype=float)
    sol, compile_s, run_s = simulate_timed(reduced, GeneralizedAlpha(rho_inf),
                                           AdaptiveStepSize(rtol / tighten, atol / tighten), jnp.asarray(ts),
                                           observe=observe_state, max_steps=max_steps)
    P, V = (np.asarray(y) for y in jax.device_get(sol.ys))
    est = estimate_error(full, reduced, ts, P, V, samples=samples, output=output, norm_rows=norm_rows, method=method)
    integration = None
    if ps is not None:
        ps = np.asarray(ps, dtype=float)
        if ps.shape != P.shape:
            raise ValueError(f"ps must be (len(ts), {reduced.n_dof}) = {P.shape}, got {ps.shape}")
        rows = np.arange(full.n_dof) if norm_rows is None else np.asarray(norm_rows, dtype=int).reshape(-1)
        lift = jax.vmap(lambda p: reduced.coordinates(p).reshape(-1)[rows])
        run, rep = np.asarray(lift(jnp.asarray(ps))), np.asarray(lift(jnp.asarray(P)))
        den = float(np.linalg.norm(rep - np.asarray(reduced.q_hat).reshape(-1)[rows]))  # w = q − q̂, as χ_rel
        integration = 100.0 * float(np.linalg.norm(run - rep)) / den if den > 0 else 0.0
    return dataclasses.replace(est, integration_percent=integration, compile_s=est.compile_s + compile_s,
                               run_s=est.run_s + run_s)


__all__ = ["TIGHTEN", "estimate_run_error", "observe_state"]
