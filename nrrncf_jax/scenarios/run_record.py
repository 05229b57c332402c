"""The record of one time-integration run that the scenarios share, and its comparison with a
reference run.

``compare`` fills in the global relative error (Eq. 40; docs/theory.md, §9 Accuracy measures and checks),
``χ_rel = sqrt(Σ_t |w(t) − w̄(t)|²) / sqrt(Σ_t |w(t)|²) × 100 %`` of the run's displacement series
``w̄`` against the reference's ``w`` on the same output times (``post.metrics.chi_rel``), and the
speed-up, the reference's run time over this run's. Each scenario's record (``PendulumRun``,
``ForcedRun``, ``SpinupResult``) adds its own series and fields and says which displacements
χ_rel covers (``displacement_series``).
"""

import abc
import dataclasses
from collections.abc import Callable
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import _validate
from ..integrate import AdaptiveStepSize, GeneralizedAlpha, with_tolerances
from ..post.metrics import chi_rel, chi_rel_of_changes
from ..reduction.basis_choice import Basis
from ..reduction.basis_to_tolerance import ToTolerance
from ..reduction.run_error import ErrorEstimator


def estimate_fields(e, **after_times) -> dict:
    """A run's error estimate (a ``reduction.ErrorEstimate``) as the summary's fields, in their
    order: the estimated total χ_rel (the basis part, plus the run's own time-integration part
    where it was estimated: their sum bounds the norm of the summed errors), the basis part alone,
    whether it is in its reliable range, its samples and run time, then ``after_times`` (a
    scenario's own, e.g. the effectivity), where the dynamic estimate stopped being valid, the
    integration part, each reduced body's estimate on its deformation and, for a mechanism's
    sensors, each one's total and parts (``_sensor_fields``)."""
    total = e.chi_rel_percent + (e.integration_percent or 0.0)
    return {"chi_rel_estimate_percent": total, "basis_error_estimate_percent": e.chi_rel_percent,
            "estimate_reliable": e.reliable, "estimate_samples": int(len(e.ts)), "estimate_run_s": e.run_s,
            **after_times,
            **({} if e.valid_until is None else {"estimate_valid_until_s": e.valid_until}),
            **({} if e.integration_percent is None else {"integration_error_estimate_percent": e.integration_percent}),
            **({} if not e.body_chi_percent else
               {f"chi_rel_estimate_body_{b}_percent": c for b, c in e.body_chi_percent.items()}),
            **_sensor_fields(e)}


def _sensor_fields(e) -> dict:
    """A mechanism's estimate on each sensor: the total (the basis part, plus the integration
    part where it was estimated) as ``chi_rel_estimate_percent_<name>``, what ``nrrncf run
    --reference full`` measures as ``chi_rel_percent_<name>``, and the parts."""
    basis, integration = e.sensor_chi_percent or {}, e.sensor_integration_percent or {}
    names = list(dict.fromkeys([*basis, *integration]))
    return ({f"chi_rel_estimate_percent_{k}": basis.get(k, 0.0) + integration.get(k, 0.0) for k in names}
            | {f"basis_error_estimate_percent_{k}": c for k, c in basis.items()}
            | {f"integration_error_estimate_percent_{k}": c for k, c in integration.items()})


@dataclasses.dataclass(kw_only=True)
class RunRecord(abc.ABC):
    """One run: its ``formulation`` (e.g. ``"rncf"``, ``"nr-rncf"``), coordinates ``dofs``, output
    times ``ts``, the integrator's accepted and rejected ``steps``/``rejected`` and Newton
    iterations ``newton_iters``, the compile and run times [s] (measured apart), the adaptive
    controller's name ``step_control`` (``integrate.STEP_CONTROLS``); after ``compare``
    the reference's DOFs and run time, χ_rel [%] and the speed-up; for a reduced run, where it
    was made, the error estimate from the run alone (``reduction.error_estimate``,
    ``multibody.error_estimate``). Keyword-only: each scenario's record adds fields of its own."""

    formulation: str
    dofs: int
    ts: np.ndarray
    steps: int
    rejected: int
    newton_iters: int
    compile_s: float
    run_s: float
    reference_dofs: int | None = None
    reference_run_s: float | None = None
    chi_rel_percent: float | None = None
    speedup: float | None = None  # reference_run_s / run_s
    estimate: object = None  # an NR-RNCF run's a-posteriori ``ErrorEstimate`` (None: not made)
    step_control: str = "plain"  # the adaptive controller (integrate.STEP_CONTROLS)
    reference: "RunRecord | None" = dataclasses.field(default=None, repr=False)  # the run compared against
    error_split: dict | None = None  # against a converged reference: the error's parts (``compare_converged``)
    step_tolerances: tuple | None = None  # (rtol, atol[, dt_max]) chosen to a tolerance (``step_tolerances_to``)

    REFERENCE: ClassVar[str] = "a run of the same model and output times"
    """What ``compare`` accepts as the reference, for its error message."""

    @abc.abstractmethod
    def displacement_series(self) -> np.ndarray | None:
        """The displacements χ_rel is computed on, (nt, ...) at the output times ``ts`` (None when
        the run did not keep them): each scenario's record says which."""

    def compare(self, reference: "RunRecord") -> "RunRecord":
        """Fill in χ_rel (Eq. 40) of ``displacement_series`` against ``reference``'s, the
        reference's DOFs and run time, and the speed-up ``reference.run_s / run_s``; returns
        ``self``. Raises ``ValueError`` unless the reference kept the same series on the same
        output times."""
        w_ref, w = reference.displacement_series(), self.displacement_series()
        if (w_ref is None or w is None or w_ref.shape != w.shape or np.shape(reference.ts) != np.shape(self.ts)
                or not np.allclose(reference.ts, self.ts)):
            raise ValueError(f"the reference must be {self.REFERENCE}")
        self.reference_dofs, self.reference_run_s = reference.dofs, reference.run_s
        self.chi_rel_percent = float(chi_rel(w_ref, w))
        self.speedup = reference.run_s / self.run_s
        self.reference = reference
        return self

    def compare_converged(self, full_at: Callable[[float], "RunRecord"],
                          repeat_at: Callable[[float], np.ndarray] | None = None, *,
                          rtol: float) -> "RunRecord":
        """Compare against a converged full run, and split the error into its parts.

        ``full_at(k)`` runs the full model at the run's tolerances divided by ``k``; it runs at
        ``k = REFERENCE_TIGHTENING`` and at its square. The tighter run is the reference, and the
        distance of the two bounds the looser one's own error (``reference_error_percent``: with a
        convergent integrator the tighter run is the closer, so the error of the reference is
        well below it). χ_rel is then this run's *total* error, time integration and basis
        together. ``repeat_at(k)`` (a reduced run) repeats this run's model at the tighter
        tolerances and returns its ``displacement_series``: this run against it is the run's own
        time-integration error (``integration_error_percent``), it against the reference the
        basis error (``basis_error_percent``). The speed-up is against the looser full run, the
        one a user would run for a comparable accuracy. ``rtol``: the run's own, for the record
        (``reference_rtol`` is the reference's). Returns ``self``."""
        loose, ref = full_at(REFERENCE_TIGHTENING), full_at(REFERENCE_TIGHTENING**2)
        self.compare(ref)
        self.reference_run_s, self.speedup = loose.run_s, loose.run_s / self.run_s
        w_ref, w = ref.displacement_series(), self.displacement_series()
        split = {"reference_rtol": rtol / REFERENCE_TIGHTENING**2,
                 "reference_error_percent": float(chi_rel(w_ref, loose.displacement_series()))}
        if repeat_at is not None:
            w_t = np.asarray(repeat_at(REFERENCE_TIGHTENING**2))
            split |= {"integration_error_percent": float(chi_rel(w_t, w)),
                      "basis_error_percent": float(chi_rel(w_ref, w_t))}
        self.error_split = split
        return self

    def statistics(self, newton_key: str = "newton_iters") -> dict:
        """The integrator's record for ``--json``: ``steps, rejected``, the Newton iterations
        (under ``newton_key``), ``compile_s`` (to the millisecond), ``run_s`` (to 0.1 ms), and
        ``step_control`` where it is not the default plain controller (so that a default run's
        record keeps its fields)."""
        out = {"steps": self.steps, "rejected": self.rejected, newton_key: self.newton_iters,
               "compile_s": round(self.compile_s, 3), "run_s": round(self.run_s, 4)}
        return out if self.step_control == "plain" else out | {"step_control": self.step_control}

    def step_tolerance_fields(self) -> dict:
        """Where the step settings were chosen to a target (``step_tolerances_to``): ``step_rtol,
        step_atol``, ``step_dt_max`` where the steps were limited to the output interval; else
        nothing."""
        if self.step_tolerances is None:
            return {}
        rtol, atol, *dt_max = self.step_tolerances
        return {"step_rtol": rtol, "step_atol": atol} | ({"step_dt_max": dt_max[0]} if dt_max else {})

    def comparison(self) -> dict:
        """After ``compare``: ``reference_dofs, reference_run_s`` (to the millisecond),
        ``chi_rel_percent, speedup`` for ``--json``, and ``reference_converged``: after
        ``compare_converged`` true, with the error's parts (``error_split``); after a plain
        ``compare`` false: the reference ran as it was given, so χ_rel is the distance of two runs,
        each with its own time-integration error, not necessarily the run's error against a
        converged solution. Before either, nothing."""
        if self.chi_rel_percent is None:
            return {}
        return {"reference_dofs": self.reference_dofs, "reference_run_s": round(self.reference_run_s, 3),
                "chi_rel_percent": self.chi_rel_percent, "speedup": self.speedup,
                "reference_converged": self.error_split is not None, **(self.error_split or {})}

    def estimate_summary(self) -> dict:
        """The error estimate's fields (empty without one): the estimated total χ_rel (the basis
        part, plus the run's own time-integration part where it was estimated) and the basis part
        alone, whether it is in its reliable range, its samples and run time, after ``compare`` the
        effectivity (total estimate / measured), and the basis search's record where the basis was
        chosen to a tolerance."""
        e = self.estimate
        if e is None:
            return {}
        total = estimate_fields(e)["chi_rel_estimate_percent"]
        eff = None if not self.chi_rel_percent else total / self.chi_rel_percent
        search = getattr(getattr(self, "reduction", None), "search", None)
        return estimate_fields(e, effectivity=eff) | ({} if search is None else search.summary())


REFERENCE_TIGHTENING = 10.0
"""A converged reference (``RunRecord.compare_converged``: the ``--reference`` of ``nrrncf spinup``,
``membrane``, ``truss`` and ``nrrncf run``): the full model runs at the run's tolerances over this
and over its square; the tighter run is the reference, their distance bounds the looser one's own
error."""


STEP_TOLERANCE_ROUNDS = 4
"""``step_tolerances_to``: the most estimates made to bring a run's own time-integration error to
its share of the target."""


MARGIN = 0.5
"""``step_tolerances_to``'s aim below its target, as a factor of the tolerance: a run's
integration error is no smooth function of its tolerance (the step sequence changes with it) and
can differ by a good part of itself between nearby tolerances, so the rule aims at about 0.6 of
the target's share."""


def chosen_step_settings(controller: AdaptiveStepSize) -> tuple:
    """A controller's ``(rtol, atol)``, and its ``dt_max`` where it is finite: the record's
    ``step_tolerances`` (``step_tolerances_to``)."""
    dt_max = float(controller.dt_max)
    return (float(controller.rtol), float(controller.atol)) + ((dt_max,) if np.isfinite(dt_max) else ())


def _with_dt_max(controller: AdaptiveStepSize, dt_max: float) -> AdaptiveStepSize:
    """``controller`` with its steps limited to ``dt_max``, its other settings kept."""
    return eqx.tree_at(lambda c: c.dt_max, controller, jnp.asarray(dt_max, jnp.result_type(float)))


def with_step_settings(controller: AdaptiveStepSize, settings: tuple) -> AdaptiveStepSize:
    """``controller`` with the settings ``chosen_step_settings`` recorded: (rtol, atol) and, where
    recorded, dt_max; its step control kept."""
    rtol, atol, *dt_max = settings
    controller = with_tolerances(controller, rtol, atol)
    return _with_dt_max(controller, dt_max[0]) if dt_max else controller


def step_tolerances_to(tol: float, controller: AdaptiveStepSize, estimate: Callable, rerun: Callable,
                       dt_out: float, judged: Callable | None = None) -> tuple:
    """The step settings of a reduced run chosen to a target χ_rel of ``tol`` per cent, beside a
    basis chosen to it (``tol=P`` of the scenarios): ``(estimate, controller)``, the estimate of
    the last run and the controller it ran with.

    The basis is chosen to an estimated error of at most ``tol`` / 2; the run's own
    time-integration error gets the other half, so that the total, basis and time integration,
    meets ``tol``. ``estimate(controller)`` estimates the run made last (at ``controller``) with
    its integration part (an ``ErrorEstimator`` with ``integration``: the run against its
    repetition at tightened tolerances); while that part exceeds ``tol`` / 2, ``rerun(controller)``
    runs the model again, either

    - at tighter tolerances: rtol and atol shrink together, by the rule that a run's global error
      goes as its tolerance to the power 2/3, aiming below the target by ``MARGIN`` in the
      tolerance (at most a hundredfold and at least twofold a round); or,
    - where the last tightening lowered the integration part by less than half (in its logarithm)
      of what that rule predicts, with steps no longer than the output interval ``dt_out``
      (``dt_max``): the part is then the outputs' interpolation between steps far longer than
      their interval (cubic Hermite, whose error the step's error estimate does not see), which no
      tolerance reaches.

    At most ``STEP_TOLERANCE_ROUNDS`` estimates; the last is kept whether or not it meets the
    target (its figures say so: ``integration_percent`` against ``tol`` / 2). ``judged(estimate)``:
    the integration part judged (default its ``integration_percent``, on the reduced bodies'
    positions; a mechanism's model file judges its sensors')."""
    previous, predicted = None, None  # the part before the last tightening, and the ratio the rule predicted
    for attempt in range(STEP_TOLERANCE_ROUNDS):
        est = estimate(controller)
        part = est.integration_percent if judged is None else judged(est)
        if part <= 0.5 * tol or attempt == STEP_TOLERANCE_ROUNDS - 1:
            return est, controller
        if predicted is not None and part > previous * np.sqrt(predicted) and float(controller.dt_max) > dt_out:
            controller = _with_dt_max(controller, dt_out)
            predicted = None
        else:
            shrink = float(np.clip(MARGIN * (0.5 * tol / part) ** 1.5, 1e-2, 0.5))
            controller = with_tolerances(controller, float(controller.rtol) * shrink, float(controller.atol) * shrink)
            predicted = shrink ** (2.0 / 3.0)
        previous = part
        rerun(controller)
    raise AssertionError("unreachable")


def run_integrator(solver, controller: AdaptiveStepSize | None, rtol: float = 1e-4, atol: float = 1e-6, *,
                   solver_type: type = GeneralizedAlpha) -> tuple:
    """A scenario run's ``(solver, controller)``, each a default where None: ``solver_type(0.9)``
    and the plain ``AdaptiveStepSize(rtol, atol)`` at the scenario's own tolerances (built here, at
    the call, so that they take the float precision JAX is set to then). Checked before anything
    runs: the solver a ``solver_type`` (``GeneralizedAlpha``: the large bodies' scenarios have no
    joints; ``GeneralizedAlphaIndex3`` for a jointed chain), the controller an
    ``AdaptiveStepSize`` with rtol < 1 (a converged reference, an estimate's repetition and a
    basis search rerun the model at its tolerances tightened, which a constant step would not
    follow)."""
    solver = solver_type(0.9) if solver is None else solver
    controller = AdaptiveStepSize(rtol, atol) if controller is None else controller
    if not isinstance(solver, solver_type):
        raise ValueError(f"solver must be an integrate.{solver_type.__name__}, got {type(solver).__name__}")
    if not isinstance(controller, AdaptiveStepSize):
        raise ValueError(f"controller must be an integrate.AdaptiveStepSize (error-controlled steps), got "
                         f"{type(controller).__name__}")
    _validate.tolerances(float(controller.rtol), float(controller.atol))
    return solver, controller


def check_reduction(basis, estimator) -> None:
    """A reduced run's ``basis`` (a ``reduction.Basis``) and ``estimator`` (a
    ``reduction.ErrorEstimator`` or None), checked before anything runs."""
    if not isinstance(basis, Basis):
        raise ValueError(f"basis must be a reduction.Basis, got {type(basis).__name__}")
    if estimator is not None and not isinstance(estimator, ErrorEstimator):
        raise ValueError(f"estimator must be a reduction.ErrorEstimator or None, got {type(estimator).__name__}")


def reduction_targets(basis, estimator, tol, ts) -> tuple:
    """``(tol, step_ts)`` of a reduced run, after ``check_reduction``: ``tol`` as a
    ``reduction.ToTolerance`` (a number takes the estimator's samples; None stays None), and the
    output times the run must end a step on for its estimate (``ErrorEstimator.step_ts``; None
    without an estimator), checked before anything runs."""
    check_reduction(basis, estimator)
    if tol is not None and not isinstance(tol, ToTolerance):
        tol = ToTolerance(tol=tol) if estimator is None else ToTolerance(tol=tol, samples=estimator.samples)
    return tol, None if estimator is None else estimator.step_ts(ts)



def estimate_mechanism_run(full, reduced, estimator, ts, states, *, sensors=None, outputs=None, repetition=None):
    """The error estimate (a ``reduction.ErrorEstimate``) of a reduced mechanism's run from
    reduced runs alone, as the scenario runners make it (``mechanism_file.run_setup``,
    ``pendulum.run_chain``): ``multibody.error_estimate.estimate_mechanism_error`` (the
    ``estimator``'s method and samples, on ``sensors`` too) at the run's states ``(zs, vs)`` at
    ``ts``, or at a repetition's where there is one. ``repetition``: ``(its outputs, (zs, vs),
    compile_s, run_s)``, the run made again ending its steps on the estimate's times (at the
    tolerances divided by ``reduction.run_error.TIGHTEN`` where the ``estimator`` asks for the
    ``integration`` part); with ``integration`` the run's distance to it is that part, on the
    reduced bodies' positions (``multibody.error_estimate.integration_error_percent``) and on
    each of the run's ``outputs`` ({name: history}, ``post.metrics.chi_rel_of_changes``). Its
    compile and run times are added to the estimate's."""
    from ..multibody.error_estimate import estimate_mechanism_error, integration_error_percent

    zs, vs = states
    integration = per_output = None
    compile_s = run_s = 0.0
    if repetition is not None:
        rep_outputs, (rep_zs, rep_vs), compile_s, run_s = repetition
        if estimator.integration:
            integration = integration_error_percent(reduced, zs, rep_zs)
            per_output = chi_rel_of_changes(dict(outputs or {}), rep_outputs)
        zs, vs = rep_zs, rep_vs
    est = estimate_mechanism_error(full, reduced, ts, zs, vs, samples=estimator.samples, method=estimator.method,
                                   sensors=sensors)
    return dataclasses.replace(est, integration_percent=integration, sensor_integration_percent=per_output,
                               compile_s=est.compile_s + compile_s, run_s=est.run_s + run_s)

__all__ = ["REFERENCE_TIGHTENING", "RunRecord", "check_reduction", "estimate_fields", "estimate_mechanism_run",
           "reduction_targets", "run_integrator"]
