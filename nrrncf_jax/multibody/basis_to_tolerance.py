"""A reduced mechanism's bases chosen to a tolerance: the mechanism counterpart of
``reduction.basis_to_tolerance``.

The caller gives an ordered list of candidates (``order``: whatever its builder understands,
for example vibration modes, modal-derivative pairs and a joint's static modes, ranked by modal
interaction) and ``build(prefix)``, the reduced mechanism whose bodies hold the candidates of a
prefix of that order. Each prefix tried is a *trial*: the mechanism is built, run over the
training manoeuvre (output times ``ts`` from ``y0``, index-3 generalized-α at tightened
tolerances, as ``reduction.run_error`` explains: the estimate is then of the basis, not of a loose
run's integration error) and its error estimated from the run alone
(``multibody.error_estimate``, by default ``method="dynamic"``, the linearised error equation of
the whole mechanism, which sees the drift of the mechanism's motion that a body's quasi-static
correction cannot). A trial passes when its estimate is at most ``tol / safety`` and the
estimate held over the whole training window (``ErrorEstimate.reliable``). The shortest passing
prefix is found by growth and bisection (``reduction.basis_to_tolerance.shortest_passing``).

Where it stops working: a mechanism's basis error grows with time (the drift of the motion),
and the error equation holds only as long as its linearisation does (a soft chain compressed
past its buckling load makes it grow without bound: ``error_estimate``). A training window
short enough for the estimate to hold is therefore shorter than the run the basis is for, and
its χ_rel reads lower than that run's: ``safety`` is the margin for it.
"""

import dataclasses
import time
from collections.abc import Callable, Sequence

import jax.numpy as jnp
import numpy as np

from .. import _validate
from ..integrate import AdaptiveStepSize, GeneralizedAlphaIndex3, Newton, simulate, tightened
from ..reduction.basis_to_tolerance import ToTolerance, candidate_name, shortest_passing
from ..reduction.error_estimate import ErrorEstimate
from ..reduction.run_error import estimate_times
from .error_estimate import estimate_mechanism_error, full_counterpart
from .mechanism import Mechanism


@dataclasses.dataclass(frozen=True)
class MechanismTrial:
    """One basis tried: the prefix length ``columns`` of the order and its candidates
    (``items``), the mechanism's DOFs, its training run's estimate (χ_rel in per cent; the last
    output time at which the error equation held, ``valid_until``, None where it held
    throughout; ``reliable``), the run's accepted steps and the trial's wall time [s] (building,
    compilations, run and estimate)."""

    columns: int
    items: tuple
    dofs: int
    chi_rel_estimate_percent: float
    valid_until: float | None
    reliable: bool
    steps: int
    seconds: float


@dataclasses.dataclass
class MechanismSearch:
    """How a mechanism's bases were chosen to ``tol`` (per cent χ_rel over the training window;
    a basis passes with a reliable estimate of at most ``tol / safety``): whether the tolerance
    was ``met``, every ``MechanismTrial`` in the order made, the ``chosen`` one with its
    ``system`` and ``estimate``, and the candidates' ``order``."""

    tol: float
    safety: float
    met: bool
    trials: list[MechanismTrial]
    chosen: MechanismTrial
    order: list
    system: Mechanism
    estimate: ErrorEstimate

    def summary(self) -> dict:
        """The JSON-ready record: the target, whether it was met, and each basis tried."""
        return {"tol_percent": self.tol, "tol_met": self.met,
                "basis_chosen": [candidate_name(i) for i in self.chosen.items],
                "basis_trials": [{"columns": t.columns, "dofs": t.dofs,
                                  "chi_rel_estimate_percent": t.chi_rel_estimate_percent,
                                  "valid_until_s": t.valid_until, "seconds": t.seconds} for t in self.trials]}

    def describe(self) -> str:
        """What was chosen and why: the tolerance, the verdict and every trial."""
        c = self.chosen
        names = ", ".join(map(candidate_name, c.items))
        head = (f"bases to tol = {self.tol:g} % (a reliable estimate <= {self.tol / self.safety:g} %): {c.dofs} DOFs "
                f"(the first {c.columns} of {len(self.order)} ranked candidates: {names}), "
                f"estimate {c.chi_rel_estimate_percent:.4g} %")
        if not self.met:
            head += "; NOT MET: no basis tried passes (the largest is kept)"
        rows = [f"  {t.columns:4d} candidates → {t.dofs:3d} DOFs: estimate {t.chi_rel_estimate_percent:10.4g} %"
                f"{'' if t.valid_until is None else f' (valid until {t.valid_until:.3g} s)'}"
                f"{'' if t.reliable else ' not reliable'}, {t.steps} steps, {t.seconds:.1f} s"
                for t in sorted(self.trials, key=lambda t: t.columns)]
        return "\n".join([head, "  trials, by prefix length:"] + rows)


TRAINING_TIGHTEN = 10.0
"""The training runs' tolerances are the run's divided by this. The training runs end their steps
on the estimate's times (every output for the error equation; ``reduction.run_error`` says why),
so their estimates barely depend on it, and a tighter factor costs steps for nothing."""


def mechanism_to_tolerance(build: Callable[[list], Mechanism], order: Sequence, ts, target: "float | ToTolerance", *,
                           y0=None, solver: GeneralizedAlphaIndex3 | None = None,
                           controller: AdaptiveStepSize | None = None, newton: Newton | None = None,
                           method: str = "dynamic", max_steps: int = 500_000) -> MechanismSearch:
    """The reduced mechanism ``build(order[:n])`` of the shortest prefix whose training run over
    ``ts`` (from ``y0`` = (z, ż), default: the mechanism's reference at rest) has a reliable
    error estimate of at most ``tol / safety`` per cent χ_rel (module docstring). ``target``: a
    ``reduction.ToTolerance`` (its ``tol``, ``safety``, ``samples``, ``start``, the first prefix
    length tried, and ``tighten``; its ``prune`` is not used: a mechanism's candidates are groups
    the builder takes in order, searched by prefix), or its ``tol`` alone, the search then
    starting at one group, the training runs at a tenth of the run's tolerances
    (``TRAINING_TIGHTEN``). ``solver``, ``controller``, ``newton`` and ``max_steps``: the
    integrator of the run the basis is for (defaults built at the call, as
    ``scenarios.pendulum.run_chain``'s: an ``integrate.GeneralizedAlphaIndex3`` at ρ∞ = 0.9, the
    plain ``integrate.AdaptiveStepSize`` at rtol 1e-4, atol 1e-5, and ``integrate.Newton(1e-2)``,
    Newton stopping at 1 % of the step's tolerance); the training runs go at the controller's
    tolerances divided by ``tighten`` (``integrate.tightened``). ``method``:
    ``estimate_mechanism_error``'s. Returns the ``MechanismSearch`` with every trial; ``met`` is
    False (and the longest prefix kept) when none passes."""
    order = list(order)
    if not order:
        raise ValueError("mechanism_to_tolerance needs at least one candidate in order")
    if not isinstance(target, ToTolerance):
        target = ToTolerance(tol=target, start=1, tighten=TRAINING_TIGHTEN)
    tol, safety, samples, start = target.tol, target.safety, target.samples, target.start
    solver = GeneralizedAlphaIndex3(0.9) if solver is None else solver
    controller = AdaptiveStepSize(1e-4, 1e-5) if controller is None else controller
    newton = Newton(1e-2) if newton is None else newton
    for name, value, kind in (("solver", solver, GeneralizedAlphaIndex3), ("controller", controller, AdaptiveStepSize),
                              ("newton", newton, Newton)):
        if not isinstance(value, kind):
            raise ValueError(f"{name} must be an integrate.{kind.__name__}, got {type(value).__name__}")
    _validate.tolerances(float(controller.rtol), float(controller.atol))
    training = tightened(controller, target.tighten)
    ts = np.asarray(ts, dtype=float)
    if ts.ndim != 1 or ts.size < 3 or np.any(np.diff(ts) <= 0):
        raise ValueError("ts must be at least three increasing output times (the training manoeuvre)")
    runs, trials = {}, {}

    def trial(n):
        t0 = time.perf_counter()
        system = build(order[:n])
        if not isinstance(system, Mechanism):
            raise ValueError(f"build must return a reduced Mechanism, got {type(system).__name__}")
        sol = simulate(system, solver, training, jnp.asarray(ts), observe=lambda t, z, v: (z, v), y0=y0,
                       newton=newton, max_steps=max_steps, step_ts=estimate_times(ts, samples, method))
        zs, vs = (np.asarray(y) for y in sol.ys)
        est = estimate_mechanism_error(full_counterpart(system), system, ts, zs, vs, samples=samples, method=method)
        runs[n] = (system, est)
        trials[n] = MechanismTrial(columns=n, items=tuple(order[:n]), dofs=system.n_dof,
                                   chi_rel_estimate_percent=est.chi_rel_percent, valid_until=est.valid_until,
                                   reliable=est.reliable, steps=int(sol.num_steps), seconds=time.perf_counter() - t0)
        return est.reliable and est.chi_rel_percent <= tol / safety

    passed = shortest_passing(trial, len(order), start)
    chosen = passed if passed is not None else len(order)
    system, est = runs[chosen]
    return MechanismSearch(tol=float(tol), safety=float(safety), met=passed is not None, trials=list(trials.values()),
                           chosen=trials[chosen], order=order, system=system, estimate=est)


__all__ = ["MechanismSearch", "MechanismTrial", "mechanism_to_tolerance"]
