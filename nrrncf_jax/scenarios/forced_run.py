"""One run of a large body's example with the full RNCF model or NR-RNCF, and its comparison with a
full reference run: what the truss (Sec. 4.5) and the rotating membrane (Sec. 4.3) share.

The run records the displacements (in the reference frame) of every position vector at the output
times, so that χ_rel (docs/theory.md, §9 Accuracy measures and checks) covers the whole body, and of
one observed point (the mean of a few position vectors: the truss's free-end centroid, the
membrane's rim point).
"""

import dataclasses
from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from ..integrate import AdaptiveStepSize, GeneralizedAlpha, step_control_name, with_tolerances
from ..integrate.simulate import simulate, simulate_timed
from ..models import RotatingFrameModel
from ..reduction.basis_choice import Basis
from ..reduction.basis_to_tolerance import ToTolerance, nr_rncf_to_tolerance
from ..reduction.pipeline import nr_rncf
from ..reduction.run_error import ErrorEstimator
from .run_record import RunRecord, chosen_step_settings, reduction_targets, run_integrator, step_tolerances_to

FORMULATIONS = ("rncf", "nr-rncf")

DEFAULT_BASIS = Basis(n_modes=12, vms=4, mds=6, max_dofs=None)
"""``run_forced``'s (and ``run_truss``'s) basis: 4 VMs and 6 MDs chosen by MMI among 12 candidate
modes, no cap on the size."""


@dataclasses.dataclass(kw_only=True)
class ForcedRun(RunRecord):
    """One run (``RunRecord``): the observed point's displacement and those of all position
    vectors in the reference frame, integrator statistics and timings; for NR-RNCF also the basis
    and the offline time. ``compare`` gives χ_rel on the displacements of every position vector
    over all output times."""

    point: np.ndarray  # (nt, 3) displacement of the observed point
    positions: np.ndarray  # (nt, n_positions, 3) displacements of all position vectors
    vms: tuple | None = None
    mds: tuple | None = None
    offline_s: float | None = None
    reduction: object = None

    REFERENCE: ClassVar[str] = "a full RNCF run of the same body and output times"

    def displacement_series(self) -> np.ndarray:
        """The displacements of every position vector (nt, n_positions, 3)."""
        return self.positions

    def summary(self) -> dict:
        """The JSON-ready record (``--json`` of the commands)."""
        return {"formulation": self.formulation, "dofs": self.dofs,
                "vms": None if self.vms is None else list(self.vms),
                "mds": None if self.mds is None else [list(p) for p in self.mds],
                **self.statistics(newton_key="newton_iterations"),
                "offline_s": None if self.offline_s is None else round(self.offline_s, 2), **self.comparison(),
                **self.estimate_summary(), **self.step_tolerance_fields()}

    def command_record(self, **extra) -> dict:
        """What the commands' ``--json`` prints: ``dofs, vms, mds, steps, compile_s, run_s,
        offline_s``, after a comparison also ``reference_dofs, reference_run_s, chi_rel_percent,
        speedup``, the formulation, and ``extra``."""
        s = self.summary()
        keys = ["dofs", "vms", "mds", "steps", "compile_s", "run_s", "offline_s", *self.comparison(),
                *self.estimate_summary(), *self.step_tolerance_fields()]
        return {**{k: s[k] for k in keys}, "formulation": self.formulation, **extra}

    def displacement_fields(self, body, count: int = 50) -> tuple[dict, np.ndarray]:
        """The displacements of every nodal vector of ``body`` (n_vectors × 3, zero on the
        gradient vectors) at about ``count`` evenly spaced output times, for VTK output:
        ``({"t_00000": u, ...}, times)``."""
        pos = np.flatnonzero(np.asarray(body.is_position))
        every = max(1, len(self.ts) // count)
        fields = {}
        for k in range(0, len(self.ts), every):
            u = np.zeros((body.n_vectors, 3))
            u[pos] = self.positions[k]
            fields[f"t_{k:05d}"] = u
        return fields, self.ts[::every]


def run_forced(full: RotatingFrameModel, formulation: str, ts, point_vectors, *, basis: Basis = DEFAULT_BASIS,
               modes=None, solver: GeneralizedAlpha | None = None, controller: AdaptiveStepSize | None = None,
               estimator: ErrorEstimator | None = ErrorEstimator(), tol: float | ToTolerance | None = None,
               reference: "bool | ForcedRun" = False, progress: bool = False, max_steps: int = 500_000,
               cls=ForcedRun, **fields) -> ForcedRun:
    """Run ``full`` (``'rncf'``) or its NR-RNCF reduction (``'nr-rncf'``: ``nr_rncf`` with
    ``basis``, a ``reduction.Basis``, default ``DEFAULT_BASIS``: MMI over ``ts``; ``modes``: see
    ``nr_rncf``) to the output times ``ts`` with ``solver`` (default ``GeneralizedAlpha(0.9)``)
    and ``controller`` (default ``AdaptiveStepSize(1e-4, 1e-6)``), observing the mean displacement
    of ``point_vectors``. Returns a ``cls`` (a ``ForcedRun``) with ``fields`` added.

    ``estimator`` (a ``reduction.ErrorEstimator``; None: none): an NR-RNCF run's a-posteriori
    error estimate from reduced runs alone (``reduction.run_error``), over the position vectors
    as χ_rel is. The static one at its samples, on which the run then ends steps, costs one
    sparse factorisation of the full model per sample; the dynamic one a factorisation an
    output, far costlier on a large body, but the one that flags a basis whose error grows over
    the run as drift; with ``integration`` the run's own time-integration error too, by a
    repetition at tightened tolerances.

    ``tol`` (a target χ_rel in per cent, or a ``reduction.ToTolerance``; a number takes the
    estimator's samples): the basis chosen to it instead (``nr_rncf_to_tolerance``, the run itself
    the training manoeuvre, the basis's ``max_dofs`` the largest basis tried; its ``vms`` and
    ``mds`` are then not used, its ``spin_state`` governs the spinning-state check of each basis
    tried); the search's training runs take the run's step control.
    With an estimator the step tolerances are chosen to ``tol`` as well
    (``run_record.step_tolerances_to``: the run's own time-integration error, against its
    repetition at a tenth of them, at most ``tol`` / 2; ``step_tolerances`` holds the chosen pair),
    so that the total error meets ``tol``; the estimate is then that of the run kept, both parts.

    ``reference`` (an NR-RNCF run): ``True`` compares it with the full model converged
    (``RunRecord.compare_converged``: the full run at a tenth and a hundredth of the tolerances,
    the reduced model again at the tighter, and the error split into its time-integration and
    basis parts; each with the same solver and step control); a full ``ForcedRun`` of the same
    body and output times is compared as it is."""
    if formulation not in FORMULATIONS:
        raise ValueError(f"formulation must be one of {FORMULATIONS}, got {formulation!r}")
    if formulation == "rncf" and reference is not False and reference is not None:
        raise ValueError("reference compares an NR-RNCF run with the full model; formulation 'rncf' is the full model")
    solver, controller = run_integrator(solver, controller)
    tol, stops = reduction_targets(basis, estimator, tol, ts)
    pos = np.flatnonzero(np.asarray(full.body.is_position))
    red = None
    if formulation == "rncf":
        model = full
    else:
        # The step error on the position vectors' coordinates (what χ_rel measures): mapping it to
        # all of a large body's coordinates every step costs more than the reduced step itself.
        rows = (3 * pos[:, None] + np.arange(3)).reshape(-1)
        red = (nr_rncf(full, jnp.asarray(ts), basis, error_rows=rows, modes=modes) if tol is None else
               nr_rncf_to_tolerance(full, jnp.asarray(ts), tol, basis, solver=solver,
                                    controller=controller,
                                    max_steps=max_steps, error_rows=rows, norm_rows=rows, modes=modes))
        model = red.model

    def observe(t, q, v):
        # The reduced model's (p, ṗ) alone keeps the loop's carry small (the output buffer is
        # carried through every step); its displacements are rebuilt afterwards.
        return (q, v) if red is not None else model.displacements(t, q)[pos]

    def positions(sol):
        if red is None:
            return np.asarray(jax.device_get(sol.ys))
        return np.asarray(jax.vmap(lambda p: model.displacements(0.0, p)[pos])(sol.ys[0]))

    own = red is not None and red.search is None and estimator is not None  # the estimate reads the run's step ends
    sol, compile_s, run_s = simulate_timed(model, solver, controller, jnp.asarray(ts), observe=observe,
                                           progress=progress, max_steps=max_steps, step_ts=stops if own else None)
    chosen = None
    if red is not None and tol is not None and estimator is not None:  # the step tolerances to tol too
        with_integration = dataclasses.replace(estimator, integration=True)

        def estimate(c):
            P, V = (np.asarray(y) for y in jax.device_get(sol.ys))
            return with_integration.estimate(full, model, ts, P, V, solver, c, max_steps=max_steps, norm_rows=rows)

        def rerun(c):
            nonlocal sol, run_s
            sol, _, run_s = simulate_timed(model, solver, c, jnp.asarray(ts), observe=observe, progress=progress,
                                           max_steps=max_steps)

        chosen, controller = step_tolerances_to(tol.tol, controller, estimate, rerun, float(np.diff(ts).min()))
    w = positions(sol)
    if red is not None:
        P, V = (np.asarray(y) for y in jax.device_get(sol.ys))
    where = {int(p): i for i, p in enumerate(pos)}
    run = cls(formulation=formulation, dofs=int(np.sum(np.asarray(full.free_mask()))) if red is None else red.dofs,
              ts=np.asarray(ts), point=w[:, [where[int(p)] for p in np.atleast_1d(point_vectors)]].mean(axis=1),
              positions=w, steps=int(sol.num_steps), rejected=int(sol.num_rejected),
              newton_iters=int(sol.num_newton), compile_s=compile_s, run_s=run_s,
              step_control=step_control_name(controller), **fields)
    if red is not None:
        run.vms, run.mds, run.reduction = red.selection.vms, red.selection.pairs, red
        run.offline_s = red.offline_s["total"]  # nr_rncf's own timing of its stages
        if chosen is not None:
            # the estimate made as the step tolerances were chosen: the basis's and the run's own
            # integration error, of the run kept
            run.estimate, run.step_tolerances = chosen, chosen_step_settings(controller)
        elif red.search is not None:
            # The search ran the chosen basis over these output times with these settings: its
            # estimate is this run's, and a second one would cost a sparse factorisation a sample.
            run.estimate = red.search.estimate
        elif own:
            run.estimate = estimator.estimate(full, model, ts, P, V, solver, controller, max_steps=max_steps,
                                              norm_rows=rows)
    if reference is False or reference is None:
        return run
    if reference is not True:
        return run.compare(reference)
    rtol, atol = float(controller.rtol), float(controller.atol)

    def full_at(k):
        return run_forced(full, "rncf", ts, point_vectors, solver=solver,
                          controller=with_tolerances(controller, rtol / k, atol / k), progress=progress,
                          max_steps=max_steps, cls=cls, **fields)

    def repeat_at(k):
        return positions(simulate(model, solver, with_tolerances(controller, rtol / k, atol / k), jnp.asarray(ts),
                                  observe=observe, max_steps=max_steps))

    return run.compare_converged(full_at, repeat_at, rtol=rtol)


__all__ = ["DEFAULT_BASIS", "FORMULATIONS", "ForcedRun", "run_forced"]
