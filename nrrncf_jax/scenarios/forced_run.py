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

from .. import _validate
from ..integrate import AdaptiveStepSize, GeneralizedAlpha
from ..integrate.simulate import simulate, simulate_timed
from ..models import RotatingFrameModel
from ..reduction.run_error import estimate_own_run, run_step_ts
from .run_record import RunRecord

FORMULATIONS = ("rncf", "nr-rncf")


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
                **self.estimate_summary()}

    def command_record(self, **extra) -> dict:
        """What the commands' ``--json`` prints: ``dofs, vms, mds, steps, compile_s, run_s,
        offline_s``, after a comparison also ``reference_dofs, reference_run_s, chi_rel_percent,
        speedup``, the formulation, and ``extra``."""
        s = self.summary()
        keys = ["dofs", "vms", "mds", "steps", "compile_s", "run_s", "offline_s", *self.comparison(),
                *self.estimate_summary()]
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


def run_forced(full: RotatingFrameModel, formulation: str, ts, point_vectors, *, vms=4, mds=6, n_modes: int = 12,
               spin_state="auto", modes=None, rho_inf: float = 0.9, rtol: float = 1e-4, atol: float = 1e-6,
               progress: bool = False, max_steps: int = 500_000, estimate: bool = True, estimate_samples: int = 16,
               tol: float | None = None, estimate_integration: bool = False, estimate_method: str = "static",
               reference: "bool | ForcedRun" = False, cls=ForcedRun, **fields) -> ForcedRun:
    """Run ``full`` (``'rncf'``) or its NR-RNCF reduction (``'nr-rncf'``: ``nr_rncf`` with ``vms``,
    ``mds`` among ``n_modes`` candidates, MMI over ``ts``, no cap on the size; ``modes``: see
    ``nr_rncf``) to the output times
    ``ts``, observing the mean displacement of ``point_vectors``. Returns a ``cls`` (a
    ``ForcedRun``) with ``fields`` added. ``estimate``: an NR-RNCF run's a-posteriori error
    estimate from the reduced run alone (``reduction.run_error``, at ``estimate_samples`` output
    times, on which the run then ends steps, over the position vectors as χ_rel is): one sparse
    factorisation of the full model per sample.
    ``estimate_integration``: also the run's own time-integration error, by a repetition of the
    run at tightened tolerances. ``estimate_method``: ``"static"`` (the quasi-static correction at
    the samples, above) or ``"dynamic"`` (the linearised error equation over every output, on a
    repetition of the run ending a step on each: a sparse factorisation an output, far costlier
    on a large body, but the one that flags a basis whose error grows over the run as drift).
    ``tol``: the basis chosen to a target χ_rel in per cent
    instead (``nr_rncf_to_tolerance``, the run itself the training manoeuvre; ``vms`` and ``mds``
    are then not used, and ``spin_state`` governs the spinning-state check of each basis tried).
    ``reference`` (an NR-RNCF run): ``True`` compares it with the full model converged
    (``RunRecord.compare_converged``: the full run at a tenth and a hundredth of the tolerances,
    the reduced model again at the tighter, and the error split into its time-integration and
    basis parts); a full ``ForcedRun`` of the same body and output times is compared as it is."""
    from ..reduction import Basis, ToTolerance, nr_rncf, nr_rncf_to_tolerance

    if formulation not in FORMULATIONS:
        raise ValueError(f"formulation must be one of {FORMULATIONS}, got {formulation!r}")
    if formulation == "rncf" and reference is not False and reference is not None:
        raise ValueError("reference compares an NR-RNCF run with the full model; formulation 'rncf' is the full model")
    _validate.boolean("estimate_integration", estimate_integration)
    stops = run_step_ts(ts, estimate_samples, estimate_method, estimate_integration)  # checks them before anything runs
    pos = np.flatnonzero(np.asarray(full.body.is_position))
    red = None
    if formulation == "rncf":
        model = full
    else:
        # The step error on the position vectors' coordinates (what χ_rel measures): mapping it to
        # all of a large body's coordinates every step costs more than the reduced step itself.
        rows = (3 * pos[:, None] + np.arange(3)).reshape(-1)
        basis = Basis(n_modes=n_modes, vms=vms, mds=mds, max_dofs=None, spin_state=spin_state)
        red = (nr_rncf(full, jnp.asarray(ts), basis, error_rows=rows, modes=modes) if tol is None else
               nr_rncf_to_tolerance(full, jnp.asarray(ts), ToTolerance(tol=tol, samples=estimate_samples), basis,
                                    solver=GeneralizedAlpha(rho_inf), controller=AdaptiveStepSize(rtol, atol),
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

    own = red is not None and red.search is None and estimate  # the estimate reads the run's own step ends
    sol, compile_s, run_s = simulate_timed(model, GeneralizedAlpha(rho_inf), AdaptiveStepSize(rtol, atol),
                                           jnp.asarray(ts), observe=observe, progress=progress, max_steps=max_steps,
                                           step_ts=stops if own else None)
    w = positions(sol)
    if red is not None:
        P, V = (np.asarray(y) for y in jax.device_get(sol.ys))
    where = {int(p): i for i, p in enumerate(pos)}
    run = cls(formulation=formulation, dofs=int(np.sum(np.asarray(full.free_mask()))) if red is None else red.dofs,
              ts=np.asarray(ts), point=w[:, [where[int(p)] for p in np.atleast_1d(point_vectors)]].mean(axis=1),
              positions=w, steps=int(sol.num_steps), rejected=int(sol.num_rejected),
              newton_iters=int(sol.num_newton), compile_s=compile_s, run_s=run_s, **fields)
    if red is not None:
        run.vms, run.mds, run.reduction = red.selection.vms, red.selection.pairs, red
        run.offline_s = red.offline_s["total"]  # nr_rncf's own timing of its stages
        if red.search is not None:
            # The search ran the chosen basis over these output times with these settings: its
            # estimate is this run's, and a second one would cost a sparse factorisation a sample.
            run.estimate = red.search.estimate
        elif own:
            run.estimate = estimate_own_run(full, model, ts, P, V, samples=estimate_samples, method=estimate_method,
                                            integration=estimate_integration, rho_inf=rho_inf, rtol=rtol,
                                            atol=atol, max_steps=max_steps, norm_rows=rows)
    if reference is False or reference is None:
        return run
    if reference is not True:
        return run.compare(reference)

    def full_at(k):
        return run_forced(full, "rncf", ts, point_vectors, rho_inf=rho_inf, rtol=rtol / k, atol=atol / k,
                          progress=progress, max_steps=max_steps, cls=cls, **fields)

    def repeat_at(k):
        return positions(simulate(model, GeneralizedAlpha(rho_inf), AdaptiveStepSize(rtol / k, atol / k),
                                  jnp.asarray(ts), observe=observe, max_steps=max_steps))

    return run.compare_converged(full_at, repeat_at, rtol=rtol)


__all__ = ["FORMULATIONS", "ForcedRun", "run_forced"]
