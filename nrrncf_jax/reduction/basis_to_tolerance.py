"""An NR-RNCF basis chosen to a tolerance: grown along the maximum-modal-interaction
ranking until the a-posteriori error estimate of a training run is below the target χ_rel
divided by a safety factor (``nr_rncf_to_tolerance``'s ``safety``: the estimate can fall short of
the true error by up to about 3x on small bases).

The candidates are the vibration modes the MMI simulation finds active (amplitude at least
``vm_tol`` of the largest; unlike ``nr_rncf``'s ``'auto'`` choice, no spin-rate band: the order
itself puts weakly excited modes late) and the modal derivatives of their pairs. The *greedy
order* ranks them by modal interaction (Eq. 39): at each place the candidate of largest weight among those
available, a VM i weighing W_ii and an MD θ_ij weighing W_ij, an MD being available once both of
its modes are in. (By Cauchy-Schwarz W_ij ≤ √(W_ii W_jj), so each MD comes after the first of its
modes; a spinning beam's first mode with itself, its foreshortening, typically comes second.)
Weights within ``TIE`` of each other, relative to the largest, count as tied and keep the candidates' index
order: a ranking decided by round-off would make the chosen basis depend on the CPU.

A basis is a prefix of that order, SVD-deflated (Algorithm 1). Each prefix tried is a *trial*:
its reduced model is built, run over the training manoeuvre (the full model's own load case on
the output times ``ts``) and its error estimated from the run alone
(``reduction.error_estimate``). The shortest prefix whose estimate is at most ``tol / safety`` is
searched by growth (prefix lengths 2, 3, 5, 8, 12, ... : ×1.5) and then bisection between the last
failing and the first passing length, which assumes that the estimate falls along the order;
every trial is recorded, so where it does not the record shows it. A trial compiles its own
reduced model (the reduced size is a shape), which is most of its cost.

A prefix carries candidates that the ones after it made redundant: the MMI weight ranks a column
by how strongly the training motion excites it, not by what it adds to the columns before it.
So the passing prefix is then *pruned* (``prune``, on by default): backward elimination, each
candidate from the lowest ranked up dropped where the basis without it still passes and has no
more DOFs, a VM kept while an MD of its pairs is. Most of their sizes were compiled by the
search before them, so they cost about their runs and estimates. The result passes the same
test as the prefix; it is not the smallest passing subset, which would need a search over
subsets.

The training runs end their steps on the estimate's samples (``reduction.run_error``: an output
interpolated between steps would make the estimate read the interpolation, not the basis), at
tightened tolerances. Where it stops working: the
estimate's own limits (``reduction.error_estimate``). Where no prefix passes, the result says
the tolerance was not met, with the largest basis tried.

The spinning-state enrichment of ``nr_rncf`` is not part of the order: each basis tried is
checked as ``nr_rncf`` checks its own, and enriched with the spinning-state columns where the
check fails (a fast spin whose stiffened first mode the rest basis misses). The quasi-static
estimate cannot see the drift such a frequency error causes over a run: unenriched, a fast
spin-up's search can pass a basis on an estimate far below its true error.
"""

import dataclasses
import functools
import math
import time

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import _validate
from ..integrate import AdaptiveStepSize, GeneralizedAlpha
from ..models.full_order import RotatingFrameModel
from .basis import modal_basis
from .basis_choice import Basis
from .error_estimate import ErrorEstimate, estimate_error
from .modal_derivatives import modal_derivatives
from .pipeline import Reduction, _reduce, _spin_enrichment, modal_interaction, spin_checked
from .run_error import TIGHTEN, sampled_states
from .selection import Selection, select
from .spin_state import spinning_modes

TIE = 1e-9
"""Interaction weights closer than this, relative to the largest, rank by candidate index."""


def greedy_order(W, candidates) -> list[tuple[int, int] | int]:
    """The greedy order of the VMs ``candidates`` (mode indices) and the MDs of their pairs by
    the MMI matrix ``W`` (module docstring): a list of mode indices (VMs) and ``(i, j)`` pairs
    (MDs, i ≤ j). Deterministic: weights are compared on a grid of ``TIE`` × the largest, ties
    broken by kind (a VM before an MD) and then by index."""
    W = np.asarray(W, dtype=float)
    cand = sorted(int(i) for i in candidates)
    if not cand:
        raise ValueError("greedy_order needs at least one candidate mode")
    scale = max(float(np.max(np.abs(W[np.ix_(cand, cand)]))), np.finfo(float).tiny)

    def key(item):
        w = W[item, item] if isinstance(item, int) else W[item]
        grid = round(float(w) / (scale * TIE))
        return (-grid, 0, item, 0) if isinstance(item, int) else (-grid, 1, *item)

    order, chosen = [], []
    available = list(cand)  # VMs not yet taken and MDs whose modes are both in
    while available:
        best = min(available, key=key)
        available.remove(best)
        order.append(best)
        if isinstance(best, int):
            chosen.append(best)
            available += [(min(best, j), max(best, j)) for j in chosen]
    return order


def _pruned(evaluate, items, chosen, limit):
    """Backward elimination from the passing prefix ``items`` (its ``Trial`` ``chosen``): each
    candidate after the first, from the lowest ranked up, is dropped where the basis without it
    (``evaluate(items, dropped)``, a ``Trial``) still has an estimate at most ``limit`` and
    no more DOFs (the spinning-state check can enrich a smaller set). A VM is kept while an MD of
    its pairs is. The last candidate is not tried first: without it, the prefix is the shorter one
    the search found failing. Returns the key (``_trial_key``) of the last basis kept."""
    kept = list(items)
    for c in reversed(items[1:-1]):
        if isinstance(c, int) and any(not isinstance(x, int) and c in x for x in kept):
            continue
        rest = [x for x in kept if x != c]
        t = evaluate(rest, (*chosen.dropped, c))
        if t.chi_rel_estimate_percent <= limit and t.dofs <= chosen.dofs:
            kept, chosen = rest, t
    return _trial_key(chosen.columns, chosen.dropped)


def _trial_key(columns: int, dropped: tuple):
    """A trial's key in the search's records: a prefix by its length, a pruning trial by what it
    dropped."""
    return ("pruned", *dropped) if dropped else columns


def shortest_passing(trial, length: int, start: int = 1) -> int | None:
    """The shortest prefix length n ≤ ``length`` with ``trial(n)`` true, searched by growth
    (``start``, then ×1.5, at least one more each time) and bisection between the last length
    that failed and the first that passed; None when even ``length`` fails. Assumes that a
    longer prefix passes once a shorter one does (the estimate falls along the order); where it
    does not, the search still returns a passing length, not necessarily the shortest."""
    failed, passed, n = 0, None, min(max(1, int(start)), length)
    while passed is None:  # grow by half until a prefix passes or the candidates run out
        if trial(n):
            passed = n
        elif n == length:
            break
        else:
            failed, n = n, min(length, max(n + 1, math.ceil(1.5 * n)))
    while passed is not None and passed - failed > 1:  # bisect between the last failure and the pass
        mid = (failed + passed) // 2
        if trial(mid):
            passed = mid
        else:
            failed = mid
    return passed


@dataclasses.dataclass(frozen=True)
class Trial:
    """One basis tried: the prefix length ``columns`` of the greedy order, its DOFs after
    deflation, its VMs and MD pairs, the estimate of its training run (χ_rel in per cent, and
    whether that is in the estimate's reliable range), the run's accepted steps, the trial's
    wall time [s] (its reduction, compilations, run and estimate), and whether the spinning-state
    check added its columns (``spin_enriched``; the DOFs count them). A pruning trial's ``dropped``
    lists the candidates removed from the passing prefix, the one it tried last; ``columns`` is
    then the number of candidates it kept."""

    columns: int
    dofs: int
    vms: tuple[int, ...]
    pairs: tuple[tuple[int, int], ...]
    chi_rel_estimate_percent: float
    reliable: bool
    steps: int
    seconds: float
    spin_enriched: bool = False
    dropped: tuple = ()


@dataclasses.dataclass
class BasisSearch:
    """How a basis was chosen to ``tol`` (per cent χ_rel; a basis passes with an estimate at most
    ``tol / safety``): whether the tolerance was ``met``, every ``Trial`` in the order it was
    made, the ``chosen`` one, the greedy ``order`` and the chosen trial's ``estimate`` (its
    ``ErrorEstimate``)."""

    tol: float
    safety: float
    met: bool
    trials: list[Trial]
    chosen: Trial
    order: list
    estimate: ErrorEstimate

    def summary(self) -> dict:
        """The JSON-ready record: the target, whether it was met, and each basis tried."""
        return {"tol_percent": self.tol, "tol_met": self.met,
                "basis_trials": [{"columns": t.columns, "dofs": t.dofs,
                                  "chi_rel_estimate_percent": t.chi_rel_estimate_percent, "seconds": t.seconds,
                                  "dropped": [candidate_name(c) for c in t.dropped]}
                                 for t in self.trials]}

    def trials_line(self, digits: int = 3) -> str:
        """Every trial on one line, in the order made: a prefix as ``n→DOFs: estimate`` (n its
        length), a pruning trial as ``−candidate→DOFs: estimate`` (the candidate it dropped)."""
        return ", ".join((f"{t.columns}" if not t.dropped else f"−{candidate_name(t.dropped[-1])}")
                         + f"→{t.dofs}: {t.chi_rel_estimate_percent:.{digits}g}" for t in self.trials)

    def describe(self) -> str:
        """What was chosen and why: the tolerance, the verdict and every trial."""
        c = self.chosen
        which = (f"the first {c.columns} of {len(self.order)} ranked candidates" if not c.dropped else
                 f"the first {c.columns + len(c.dropped)} of {len(self.order)} ranked candidates without "
                 + ", ".join(candidate_name(d) for d in c.dropped))
        head = (f"basis to tol = {self.tol:g} % (estimate <= {self.tol / self.safety:g} %): {c.dofs} DOFs "
                f"({len(c.vms)} VMs + {len(c.pairs)} MDs, {which}), estimate "
                f"{c.chi_rel_estimate_percent:.4g} %")
        if not self.met:
            head += (f"; NOT MET: no basis tried has an estimate at or below {self.tol / self.safety:g} % (the largest "
                     "is kept; "
                     "see reduction.error_estimate for where the estimate raises false alarms)")

        def label(t):
            return (f"prefix of {t.columns:3d}" if not t.dropped else
                    f"{t.columns:3d}, without {candidate_name(t.dropped[-1])}")
        rows = [f"  {label(t)} → {t.dofs:3d} DOFs{' (spin-enriched)' if t.spin_enriched else ''}: "
                f"estimate {t.chi_rel_estimate_percent:10.4g} %"
                f"{'' if t.reliable else ' (above the reliable range)'}, {t.steps} steps, {t.seconds:.1f} s"
                for t in self.trials]
        return "\n".join([head, "  trials, in the order made (columns → DOFs):"] + rows)


def candidate_name(candidate) -> str:
    """A candidate as the paper writes it, with 0-based mode indices as everywhere: VM i as φi,
    the MD of modes i, j as θi,j, anything else (a named block of columns) as its text."""
    if isinstance(candidate, tuple):
        return f"θ{candidate[0]},{candidate[1]}"
    return f"φ{candidate}" if isinstance(candidate, (int, np.integer)) else str(candidate)


@dataclasses.dataclass(frozen=True, kw_only=True)
class ToTolerance:
    """A basis chosen to a target error (module docstring): ``tol``, the target χ_rel in per cent;
    a basis passes when the estimate of its training run is at most ``tol / safety``; ``samples``:
    the estimate's sampled outputs; ``start``: the first prefix length tried; ``prune``: drop what
    the passing prefix does not need; ``tighten``: the training runs go at the run's tolerances
    divided by this (``reduction.run_error``)."""

    tol: float
    safety: float = 2.0
    samples: int = 16
    start: int = 2
    prune: bool = True
    tighten: float = TIGHTEN

    def __post_init__(self):
        _validate.positive("tol (a target χ_rel in per cent)", self.tol)
        _validate.positive("safety", self.safety)
        _validate.boolean("prune", self.prune)
        _validate.positive_int("samples", self.samples)
        _validate.positive_int("start", self.start)
        _validate.positive("tighten", self.tighten)


def nr_rncf_to_tolerance(full: RotatingFrameModel, ts, target: "float | ToTolerance", basis: Basis | None = None, *,
                         solver: GeneralizedAlpha | None = None, controller: AdaptiveStepSize | None = None,
                         max_steps: int = 500_000, error_rows=None, norm_rows=None, output=(),
                         modes=None) -> Reduction:
    """The NR-RNCF reduced model of ``full`` with the smallest greedy basis whose training run
    over the output times ``ts`` has an error estimate of at most ``tol / safety`` per cent χ_rel
    (module docstring). ``target``: a ``ToTolerance``, or its ``tol`` alone.

    ``basis`` (a ``Basis``; default ``Basis(max_dofs=None)``): its ``n_modes``, ``vm_tol``,
    ``md_method``, ``deflation_tol`` and ``spin_state`` as ``nr_rncf`` uses them (each basis
    tried is checked, and enriched, as ``nr_rncf`` checks its own), its ``max_dofs`` the most
    columns tried (None: every candidate); its ``vms``, ``mds``, ``band``, ``md_tol`` and
    ``max_mds`` are not used, the search chooses instead. ``solver``, ``controller`` and
    ``max_steps``: the integrator of the run the basis is for (default ``GeneralizedAlpha(0.9)``,
    ``AdaptiveStepSize(1e-4, 1e-6)``), whose training runs go at the controller's tolerances
    divided by ``target.tighten``. ``error_rows``: see ``reduce_rotating_model``; ``norm_rows``,
    ``output``: the estimate's (``estimate_error``); ``modes``: see ``nr_rncf``. Returns the
    ``Reduction`` of the chosen basis, with ``search`` (a ``BasisSearch``) holding every trial;
    ``search.met`` is False (and the largest basis tried is kept) when no basis reaches the
    tolerance."""
    if not isinstance(full, RotatingFrameModel):
        raise ValueError("nr_rncf_to_tolerance reduces a RotatingFrameModel (RNCF); got " + type(full).__name__)
    target = target if isinstance(target, ToTolerance) else ToTolerance(tol=target)
    basis = Basis(max_dofs=None) if basis is None else basis
    if not isinstance(basis, Basis):
        raise ValueError(f"basis must be a reduction.Basis, got {type(basis).__name__}")
    solver = GeneralizedAlpha(0.9) if solver is None else solver
    controller = AdaptiveStepSize(1e-4, 1e-6) if controller is None else controller
    # The training runs' controller: the run's, at tightened tolerances.
    training = eqx.tree_at(lambda c: (c.rtol, c.atol), controller,
                           (controller.rtol / target.tighten, controller.atol / target.tighten))
    tol, safety, spin_state = target.tol, target.safety, basis.spin_state
    n_modes, max_dofs, md_method, deflation_tol = basis.n_modes, basis.max_dofs, basis.md_method, basis.deflation_tol
    ts = np.asarray(ts, dtype=float)
    body, free = full.body, full.free_mask()
    modes, W, spin, offline = modal_interaction(full, ts, n_modes, modes)
    candidates = select(W, "auto", 0, vm_tol=basis.vm_tol).vms
    order = greedy_order(W, candidates)
    length = len(order) if max_dofs is None else min(len(order), int(max_dofs))

    t0 = time.perf_counter()
    all_pairs = [c for c in order[:length] if not isinstance(c, int)]
    theta = (np.asarray(modal_derivatives(body, free, modes.phi, all_pairs, method=md_method).theta)
             if all_pairs else None)
    offline["modal_derivatives"] = time.perf_counter() - t0
    phi = np.asarray(modes.phi)
    runs, trials = {}, {}
    spinning = functools.cache(lambda: spinning_modes(full, spin, n_modes))  # at the first basis checked

    def enriched(basis, vms, pairs, cols):
        """The basis with the spinning-state columns where ``nr_rncf``'s check fails."""
        if not spin_checked(full, spin_state.check, spin, bool(pairs)):
            return basis, False
        sel = Selection(W=jnp.asarray(W), vms=vms, pairs=pairs)
        _, extra, _ = _spin_enrichment(full, modes, sel, basis.Psi, spin, n_modes, spin_state, None, None, md_method,
                                       spinning=spinning())
        if extra is None:
            return basis, False
        return modal_basis(body, free, phi, pairs, vms=vms, extra=[extra], theta=theta[:, cols],
                           deflation_tol=deflation_tol), True

    def evaluate(items, dropped=()):
        """Build, run and estimate the basis of the candidates ``items``, recorded under its
        ``_trial_key``."""
        key = _trial_key(len(items), dropped)
        t1 = time.perf_counter()
        vms = tuple(c for c in items if isinstance(c, int))
        cols = [k for k, c in enumerate(all_pairs) if c in items]
        pairs = tuple(all_pairs[k] for k in cols)
        basis = modal_basis(body, free, phi, pairs, vms=vms, theta=theta[:, cols] if cols else None,
                            deflation_tol=deflation_tol)
        basis, spun = enriched(basis, vms, pairs, cols)
        model = _reduce(full, basis.Psi, force="auto")
        if error_rows is not None:
            model = model.with_error_rows(error_rows)
        # At the ends of steps, not at interpolated outputs (reduction.run_error says why).
        idx, P, V, _, _, steps = sampled_states(model, ts, target.samples, solver, training, max_steps)
        est = estimate_error(full, model, ts[idx], P, V, samples=idx.size, output=output, norm_rows=norm_rows)
        runs[key] = (model, est)
        trials[key] = Trial(columns=len(items), dofs=model.n_dof, vms=vms, pairs=pairs,
                            chi_rel_estimate_percent=est.chi_rel_percent, reliable=est.reliable,
                            steps=steps, seconds=time.perf_counter() - t1, spin_enriched=spun, dropped=dropped)
        return trials[key]

    def trial(n):
        return evaluate(order[:n]).chi_rel_estimate_percent <= tol / safety

    t0 = time.perf_counter()
    passed = shortest_passing(trial, length, target.start)
    offline["greedy"] = time.perf_counter() - t0
    chosen = passed if passed is not None else length
    if target.prune and passed is not None:
        t0 = time.perf_counter()
        chosen = _pruned(evaluate, order[:passed], trials[passed], tol / safety)
        offline["prune"] = time.perf_counter() - t0
    model, est = runs[chosen]
    pick = trials[chosen]
    offline["total"] = sum(v for k, v in offline.items() if k != "total")
    search = BasisSearch(tol=float(tol), safety=float(safety), met=passed is not None,
                         trials=list(trials.values()), chosen=pick, order=order, estimate=est)
    return Reduction(model=model, omega=np.asarray(modes.omega), n_vms=len(pick.vms), n_mds=len(pick.pairs),
                     selection=Selection(W=jnp.asarray(W), vms=pick.vms, pairs=pick.pairs), offline_s=offline,
                     search=search, phi=np.asarray(modes.phi))


__all__ = ["TIE", "BasisSearch", "ToTolerance", "Trial", "candidate_name", "greedy_order", "nr_rncf_to_tolerance",
           "shortest_passing"]
