"""The spin-up manoeuvre (paper Section 4.1, Eq. 43): build, run, and report one case."""

import csv
import dataclasses
import json
from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from .. import _validate
from ..integrate import AdaptiveStepSize, GeneralizedAlpha, step_control_name, with_tolerances
from ..integrate.simulate import simulate, simulate_timed
from ..models import InertialFrameModel, RotatingFrameModel
from ..motion import SpinUp
from ..reduction.basis_choice import Basis
from ..reduction.basis_to_tolerance import ToTolerance, nr_rncf_to_tolerance
from ..reduction.pipeline import nr_rncf
from ..reduction.run_error import TIGHTEN, ErrorEstimator, observe_state
from ..studies.sweep import SweepGrid
from .beams import BeamPreset, beam_preset
from .run_record import (
    REFERENCE_TIGHTENING,
    RunRecord,
    chosen_step_settings,
    reduction_targets,
    run_integrator,
    step_tolerances_to,
)

PAPER_ELEMENTS = {4.0: 6, 10.0: 10, 20.0: 16, 40.0: 24}
"""Elements per steady spin rate in the paper's Table 2."""

FORMULATIONS = ("rncf", "ancf")
"""Full-order formulations; ``run_nr_rncf_spinup`` runs the reduced ``'nr-rncf'``."""


def default_elements(omega_s: float) -> int:
    """The paper's mesh for the nearest of its speeds at or above ``omega_s`` (Table 2)."""
    for w, n in sorted(PAPER_ELEMENTS.items()):
        if omega_s <= w:
            return n
    return max(PAPER_ELEMENTS.values())


def build_spinup_model(formulation: str, beam: BeamPreset | str, omega_s: float, T_s: float = 15.0,
                       elements: int | None = None):
    """The full-order RNCF (``'rncf'``) or ANCF (``'ancf'``) model of a beam spun up about +z."""
    if formulation not in FORMULATIONS:
        raise ValueError(f"formulation must be one of {FORMULATIONS}, got {formulation!r}")
    preset = beam_preset(beam) if isinstance(beam, str) else beam
    _validate.positive("omega (steady spin rate)", omega_s)
    _validate.positive("ts (spin-up time T_s)", T_s)
    n_el = default_elements(float(omega_s)) if elements is None else _validate.positive_int("elements", elements)
    body = preset.body(n_el)
    cls = RotatingFrameModel if formulation == "rncf" else InertialFrameModel
    return cls(body, SpinUp(omega_s, T_s))


@dataclasses.dataclass(kw_only=True)
class SpinupResult(RunRecord):
    """One spin-up run (``RunRecord``): tip motion in the rotating frame, integrator statistics
    and timings.

    For ``formulation='nr-rncf'`` (``run_nr_rncf_spinup``) the NR-RNCF fields are set too: the
    basis (``vms``, ``mds``: kept vibration modes and modal-derivative pairs, 0-based indices
    into the candidate modes, in ``summary()``, ``table()`` and ``json()`` too), the offline time,
    and, when the full RNCF ran as ``reference`` (``compare``), χ_rel (Eq. 40, all nodal
    displacements) and the run-time ratio full/reduced.
    """

    beam: str
    omega_s: float
    T_s: float
    elements: int
    theta: np.ndarray
    tip: np.ndarray  # (nt, 3): ux (axial), uy (in-plane transverse), uz, in the rotating frame
    displacements: np.ndarray | None = None  # (nt, n_vectors, 3), w = q − q̂ in the rotating frame
    # NR-RNCF only
    vms: tuple[int, ...] | None = None
    mds: tuple[tuple[int, int], ...] | None = None
    offline_s: dict | None = None  # per offline stage, with 'total'
    spin: object = None  # the ``SpinCheck`` of the spinning-state enrichment (None: not checked)
    reduction: object = dataclasses.field(default=None, repr=False)  # the ``Reduction`` (W, omega, model)
    basis_search: object = None  # the ``reduction.basis_to_tolerance.BasisSearch`` (None: no tol given)

    REFERENCE: ClassVar[str] = ("a full RNCF SpinupResult of the same beam mesh and output times, run with "
                                "save_displacements=True")

    @property
    def reduced(self) -> bool:
        return self.vms is not None

    def displacement_series(self) -> np.ndarray | None:
        """All nodal displacements q − q̂ in the rotating frame (None unless kept)."""
        return self.displacements

    def summary(self) -> dict:
        s = {
            "formulation": self.formulation, "beam": self.beam, "omega_s": self.omega_s, "T_s": self.T_s,
            "t_end": float(self.ts[-1]), "elements": self.elements, "dofs": self.dofs, **self.statistics(),
            "tip_ux_min": float(self.tip[:, 0].min()),
            "tip_uy_min": float(self.tip[:, 1].min()), "tip_uy_max": float(self.tip[:, 1].max()),
            "tip_uz_absmax": float(np.abs(self.tip[:, 2]).max()),
        }
        if self.reduced:
            ref = self.reference
            s.update({
                "vms": len(self.vms), "mds": len(self.mds),
                "selected_vms": list(self.vms),  # 0-based mode indices, as everywhere (``nrrncf modes`` too)
                "selected_mds": [list(p) for p in self.mds],
                "offline_s": round(self.offline_s["total"], 3),
                "basis": None if self.reduction is None else self.reduction.describe(),
                "spin_enriched": bool(self.spin is not None and self.spin.enriched),
                "spin_check": None if self.spin is None else {
                    "omega": self.spin.omega, "mode": self.spin.mode, "omega_spin": self.spin.omega_spin,
                    "omega_ritz": self.spin.omega_ritz, "rel_err": self.spin.rel_err, "enriched": self.spin.enriched,
                    "spin_vms": list(self.spin.vms), "spin_mds": [list(p) for p in self.spin.pairs]},
                "chi_rel_percent": self.chi_rel_percent, "speedup": self.speedup, **(self.error_split or {}),
                **self.step_tolerance_fields(),
                **self.estimate_summary(), **self._tolerance_summary(),
                "reference": None if ref is None else {"formulation": ref.formulation, "dofs": ref.dofs,
                                                       **ref.statistics()},
            })
        return s

    def estimate_summary(self) -> dict:
        """``RunRecord.estimate_summary`` and the tip's estimated error (the largest over the
        samples), with a reference also the tip's error measured at the same samples."""
        e = self.estimate
        if e is None:
            return {}
        out = {**super().estimate_summary(), "estimate_compile_s": e.compile_s,
               "tip_error_estimate_m": float(np.linalg.norm(e.output_error, axis=1).max())}
        if self.reference is not None:  # the tip's error measured at the same samples
            at = np.searchsorted(self.ts, e.ts)
            out["tip_error_m"] = float(np.linalg.norm(self.tip[at] - self.reference.tip[at], axis=1).max())
        return out

    def _tolerance_summary(self) -> dict:
        """The basis search's fields (empty without ``tol``): ``BasisSearch.summary``."""
        return {} if self.basis_search is None else self.basis_search.summary()

    def table(self) -> str:
        s = self.summary()
        rows = [("formulation", s["formulation"].upper()), ("beam", s["beam"]),
                ("omega_s [rad/s] / T_s [s]", f"{s['omega_s']:g} / {s['T_s']:g}"),
                ("time span [s]", f"0 - {s['t_end']:g}"), ("elements / DOFs", f"{s['elements']} / {s['dofs']}")]
        if self.reduced:
            rows += [("VMs / MDs (0-based modes)", f"{s['vms']} / {s['mds']}  (VMs {s['selected_vms']}; MDs "
                      + (" ".join(f"θ{i},{j}" for i, j in s["selected_mds"]) or "none") + ")"),
                     ("offline [s]", f"{s['offline_s']:.2f}")]
            if self.reduction is not None:
                rows.insert(-1, ("reduced coordinates", self.reduction.describe()))
            if self.basis_search is not None:
                b = self.basis_search
                rows.insert(-1, ("basis to tol [%]", f"{b.tol:g}: {'met' if b.met else 'NOT MET (largest kept)'}; "
                                 f"tried (prefix length or −dropped→DOFs: estimate %) {b.trials_line()}"))
            if self.step_tolerances is not None:
                f = self.step_tolerance_fields()
                rows.insert(-1, ("step tolerances (to tol)", f"rtol {f['step_rtol']:.3g}, atol {f['step_atol']:.3g}"
                                 + (f", steps <= {f['step_dt_max']:g} s" if "step_dt_max" in f else "")
                                 + ": the run's own integration error estimate at most tol / 2"))
            c = s["spin_check"]
            if c is not None:
                added = (f"added spinning mode(s) {c['spin_vms']} and MDs "
                         + " ".join(f"θ*{i},{j}" for i, j in c["spin_mds"])) if c["enriched"] else "not enriched"
                rows.append(("spinning-state check", f"ω = {c['omega']:g} rad/s: mode {c['mode']} at "
                             f"{c['omega_spin']:.4f} rad/s, rest basis {c['omega_ritz']:.4f} "
                             f"({100 * c['rel_err']:+.3f} %); {added}"))
        if self.estimate is not None:
            note = "" if s["estimate_reliable"] else "  (above its reliable range: an order of magnitude, not a figure)"
            rows.append(("chi_rel estimate [%] (no full run)", f"{s['chi_rel_estimate_percent']:.4f}  "
                         f"({s['estimate_samples']} samples, {s['estimate_run_s']:.3f} s){note}"))
            if "integration_error_estimate_percent" in s:
                rows.append(("  basis error estimate [%]", f"{s['basis_error_estimate_percent']:.4f}"))
                rows.append(("  integration error estimate [%]", f"{s['integration_error_estimate_percent']:.4f}  "
                             f"(this run against its repetition at rtol/{TIGHTEN:g}, at the samples)"))
            rows.append(("tip error estimate, basis [m]", f"{s['tip_error_estimate_m']:.2e}"
                         + ("" if "tip_error_m" not in s else f"  (measured {s['tip_error_m']:.2e})")))
        rows += [("steps accepted / rejected", f"{s['steps']} / {s['rejected']}"),
                 ("Newton iterations", f"{s['newton_iters']}"), ("compile [s]", f"{s['compile_s']:.2f}"),
                 ("run [s]", f"{s['run_s']:.3f}"),
                 ("tip uy min / max [m]", f"{s['tip_uy_min']:.5f} / {s['tip_uy_max']:.5f}"),
                 ("tip ux min [m]", f"{s['tip_ux_min']:.5f}")]
        if self.reference is not None:
            r = self.reference
            name = f"reference {r.formulation.upper()}"
            rows += [(f"{name}: DOFs / steps", f"{r.dofs} / {r.steps} ({r.rejected} rejected)"),
                     (f"{name}: compile / run [s]", f"{r.compile_s:.2f} / {r.run_s:.3f}"),
                     ("chi_rel (Eq. 40, all q - q^) [%]", f"{self.chi_rel_percent:.4f}"
                      + ("" if s.get("effectivity") is None else f"  (estimate / measured {s['effectivity']:.2f})"))]
            if self.error_split is not None:
                e = self.error_split
                rows += [("  its parts [%]", f"time integration {e['integration_error_percent']:.4f}, basis "
                          f"{e['basis_error_percent']:.4f} (the model again at the reference's tolerance)"),
                         ("  reference's own error [%]", f"<= {e['reference_error_percent']:.4f} (full RNCF at rtol "
                          f"{e['reference_rtol']:g} against {REFERENCE_TIGHTENING:g}x looser)")]
            rows += [("speed-up (run time full / reduced)", f"{self.speedup:.2f}x"
                      + ("" if self.error_split is None else
                         f"  (full at rtol {self.error_split['reference_rtol'] * REFERENCE_TIGHTENING:g})"))]
        w = max(len(r[0]) for r in rows)
        return "\n".join(f"  {a:<{w}}  {b}" for a, b in rows)

    def json(self) -> str:
        return json.dumps(self.summary())

    def to_csv(self, path: str) -> None:
        with open(path, "w", newline="") as f:
            wr = csv.writer(f)
            wr.writerow(["t", "theta", "ux", "uy", "uz"])
            for t, th, u in zip(self.ts, self.theta, self.tip):
                wr.writerow([f"{t:.6g}", f"{th:.10g}", f"{u[0]:.10g}", f"{u[1]:.10g}", f"{u[2]:.10g}"])

    def plot(self, path: str, others: list["SpinupResult"] = (), dpi: int = 120) -> None:
        """Tip displacement against time (``plotting.plot_tip``); with a ``reference``, the full
        run (solid) and this reduced one (dashed) together, as in the paper's Figs. 6 and 9."""
        from ..post.plotting import plot_tip

        first = [self.reference, self] if self.reference is not None else [self]
        plot_tip(path, *first, *others, dpi=dpi)


output_times = _validate.output_times  # the scenarios' and the CLI's name for it


def run_spinup(formulation: str = "rncf", beam: str | BeamPreset = "paper", omega_s: float = 4.0,
               T_s: float = 15.0, t_end: float = 30.0, elements: int | None = None, dt_out: float = 0.01, *,
               solver: GeneralizedAlpha | None = None, controller: AdaptiveStepSize | None = None,
               save_displacements: bool = False, progress: bool = False, max_steps: int = 500_000) -> SpinupResult:
    """Run the spin-up of Eq. 43 with the full-order ``formulation`` and report tip motion in the
    rotating frame, step counts, and compile/run times (measured apart). The run goes with
    ``solver`` (default ``GeneralizedAlpha(0.9)``) and ``controller`` (default
    ``AdaptiveStepSize(1e-4, 1e-6)``, the plain controller; ``integrate.adaptive_step_size(rtol,
    atol, "pi")`` is Gustafsson's PI controller), as ``run_nr_rncf_spinup``'s.
    ``save_displacements``: keep every nodal displacement (``SpinupResult.displacements``), as a
    reference for χ_rel."""
    ts = _validate.output_times(t_end, dt_out)
    solver, controller = run_integrator(solver, controller)
    return _run_full(formulation, beam, omega_s, T_s, ts, elements, solver, controller, save_displacements, progress,
                     max_steps)


def _run_full(formulation, beam, omega_s, T_s, ts, elements, solver, controller, save_displacements, progress,
              max_steps) -> SpinupResult:
    """``run_spinup`` on the output times ``ts`` with a ``solver`` and ``controller`` (the
    converged reference of ``run_nr_rncf_spinup`` runs the reduced run's, tightened)."""
    model = build_spinup_model(formulation, beam, omega_s, T_s, elements)
    body = model.body
    tip = body.n_vectors - body.vectors_per_node

    def observe(t, q, v):
        w = model.displacements(t, q)
        out = {"tip": w[tip], "theta": model.motion(t)[0]}
        if save_displacements:
            out["w"] = w
        return out

    sol, compile_s, run_s = simulate_timed(model, solver, controller, jnp.asarray(ts), observe=observe,
                                           progress=progress, max_steps=max_steps)
    ys = jax.tree_util.tree_map(np.asarray, sol.ys)
    name = beam if isinstance(beam, str) else beam.name
    return SpinupResult(
        formulation=formulation, beam=name, omega_s=float(omega_s), T_s=float(T_s), elements=body.n_elements,
        dofs=int(np.sum(np.asarray(model.free_mask()))), ts=ts, theta=ys["theta"], tip=ys["tip"],
        steps=int(sol.num_steps), rejected=int(sol.num_rejected), newton_iters=int(sol.num_newton),
        compile_s=compile_s, run_s=run_s, displacements=ys.get("w"), step_control=step_control_name(controller),
    )


def run_nr_rncf_spinup(beam: str | BeamPreset = "paper", omega_s: float = 4.0, T_s: float = 15.0,
                       t_end: float = 30.0, elements: int | None = None, basis: Basis = Basis(),
                       dt_out: float = 0.01, *, solver: GeneralizedAlpha | None = None,
                       controller: AdaptiveStepSize | None = None,
                       estimator: ErrorEstimator | None = ErrorEstimator(), tol: float | ToTolerance | None = None,
                       reference: "bool | SpinupResult" = False, progress: bool = False,
                       max_steps: int = 500_000) -> SpinupResult:
    """The spin-up of Eq. 43 with the NR-RNCF reduced model (paper Section 4.1).

    The basis is built by ``nr_rncf`` as ``basis`` (a ``reduction.Basis``; default ``Basis()``:
    24 candidate modes, VMs and MDs chosen by MMI up to 25 DOFs, the spinning-state check on) says,
    with the MMI simulation over the output times. The run goes with ``solver`` (default
    ``GeneralizedAlpha(0.9)``) and ``controller`` (default ``AdaptiveStepSize(1e-4, 1e-6)``, the
    plain controller; ``integrate.adaptive_step_size(rtol, atol, "pi")`` is Gustafsson's PI
    controller), as do the reference run, the estimate's repetition and the basis search's
    training runs (at their own tolerances).
    Returns a ``SpinupResult`` with ``formulation='nr-rncf'``, the reduced DOFs, the basis and the offline time. With
    ``reference=True`` the full RNCF model runs too, converged: at a tenth and a hundredth of the
    run's tolerances (``REFERENCE_TIGHTENING``), the tighter run the reference and their distance
    a bound on the looser one's own error, and the reduced model again at the tighter tolerance.
    χ_rel (Eq. 40, over all nodal displacements q − q̂ and all output times) is then the run's
    total error against the converged reference, and ``error_split`` holds its parts: the
    time-integration error (the run against its tight repetition), the basis error (the tight
    repetition against the reference) and the reference's own error; the run-time ratio is the
    looser full run's over the reduced run's. Or pass an RNCF ``SpinupResult`` from
    ``run_spinup(..., save_displacements=True)`` on the same output times to compare against it
    as it is.

    ``estimator`` (a ``reduction.ErrorEstimator``; None: no estimate): the run's a-posteriori
    error estimate from reduced runs alone (``reduction.run_error``; with a reference also the
    effectivity, estimate / measured). Its ``method``: ``"static"`` (the quasi-static correction
    at ``samples`` output times: the run ends a step on each, and the basis's χ_rel is estimated
    at its own states there) or ``"dynamic"`` (the linearised error equation over every output,
    ``reduction.error_estimate``, on a repetition of the run ending a step on each); its
    ``integration``: also the run's own time-integration error, from a repetition at tightened
    tolerances (``TIGHTEN``), which costs more than the run.

    ``tol``: a target χ_rel in per cent (or a ``reduction.ToTolerance``; a number takes the
    estimator's samples). The basis is then the smallest prefix of the MMI ranking whose run has
    an estimate at or below ``tol`` / 2 (``reduction.nr_rncf_to_tolerance``, the run itself the
    training manoeuvre, the basis's ``max_dofs`` the largest basis tried; its ``vms`` and ``mds``
    are not used, its ``spin_state`` governs the check of each basis tried). ``basis_search``
    holds every basis tried. With an estimator the step tolerances are chosen to it as well:
    starting from the controller's, rtol and atol shrink together until the run's own
    time-integration error, estimated against its repetition at a tenth of them, is at most
    ``tol`` / 2 (``run_record.step_tolerances_to``; ``step_tolerances`` holds the chosen pair),
    so that the total error, basis and time integration, meets ``tol``.
    """

    ts = _validate.output_times(t_end, dt_out)
    solver, controller = run_integrator(solver, controller)
    tol, stops = reduction_targets(basis, estimator, tol, ts)
    rtol, atol = float(controller.rtol), float(controller.atol)
    full = build_spinup_model("rncf", beam, omega_s, T_s, elements)
    body = full.body
    tip_rows = 3 * (body.n_vectors - body.vectors_per_node) + np.arange(3)  # the tip node's position
    red = (nr_rncf(full, jnp.asarray(ts), basis) if tol is None else
           nr_rncf_to_tolerance(full, jnp.asarray(ts), tol, basis, solver=solver,
                                controller=controller, max_steps=max_steps, output=tip_rows))
    model = red.model
    own = estimator is not None and red.search is None
    sol, compile_s, run_s = simulate_timed(model, solver, controller, jnp.asarray(ts), observe=observe_state,
                                           progress=progress, max_steps=max_steps, step_ts=stops if own else None)
    # Observing (p, ṗ) alone keeps the loop's carry small; displacements are rebuilt afterwards.
    P, V = sol.ys
    chosen = None
    if tol is not None and estimator is not None:  # the step tolerances to tol too (``step_tolerances_to``)
        with_integration = dataclasses.replace(estimator, integration=True)

        def estimate(c):
            return with_integration.estimate(full, model, ts, P, V, solver, c, max_steps=max_steps, output=tip_rows)

        def rerun(c):
            nonlocal sol, run_s, P, V
            sol, _, run_s = simulate_timed(model, solver, c, jnp.asarray(ts), observe=observe_state,
                                           progress=progress, max_steps=max_steps)
            P, V = sol.ys

        chosen, controller = step_tolerances_to(tol.tol, controller, estimate, rerun, float(np.diff(ts).min()))
        rtol, atol = float(controller.rtol), float(controller.atol)
    w = np.asarray(jax.vmap(lambda p: model.displacements(0.0, p))(P))
    theta = np.asarray(jax.vmap(lambda t: full.motion(t)[0])(jnp.asarray(ts)))
    name = beam if isinstance(beam, str) else beam.name
    res = SpinupResult(
        formulation="nr-rncf", beam=name, omega_s=float(omega_s), T_s=float(T_s), elements=body.n_elements,
        dofs=red.dofs, ts=ts, theta=theta, tip=w[:, body.n_vectors - body.vectors_per_node],
        steps=int(sol.num_steps), rejected=int(sol.num_rejected), newton_iters=int(sol.num_newton),
        compile_s=compile_s, run_s=run_s, displacements=w, vms=red.selection.vms, mds=red.selection.pairs,
        step_control=step_control_name(controller),
        offline_s=dict(red.offline_s), reduction=red, spin=red.spin, basis_search=red.search,
        # With tol, the estimate made as the step tolerance was chosen (the basis's and the run's own
        # integration error); without, the run's own.
        estimate=chosen if chosen is not None else red.search.estimate if red.search is not None else
        estimator.estimate(full, model, ts, P, V, solver, controller, max_steps=max_steps, output=tip_rows)
        if own else None,
        step_tolerances=None if chosen is None else chosen_step_settings(controller),
    )
    if reference is False or reference is None:
        return res
    if reference is not True:
        return res.compare(reference)
    # A converged reference (``RunRecord.compare_converged``): the full model at a tenth and a
    # hundredth of the run's tolerances, and the reduced model again at the tighter one.
    def full_at(k):
        return _run_full("rncf", beam, omega_s, T_s, ts, body.n_elements, solver,
                         with_tolerances(controller, rtol / k, atol / k), True, progress, max_steps)

    def repeat_at(k):
        sol = simulate(model, solver, with_tolerances(controller, rtol / k, atol / k), jnp.asarray(ts),
                       observe=observe_state, max_steps=max_steps)
        return np.asarray(jax.vmap(lambda p: model.displacements(0.0, p))(sol.ys[0]))

    return res.compare_converged(full_at, repeat_at, rtol=rtol)



def sweep_reduction(beam, grid: SweepGrid, *, t_end: float, elements: int | None = None, dt_out: float = 0.01,
                    n_modes: int = 24, vms="auto", mds="auto", max_dofs: int | None = 25):
    """The NR-RNCF ``Reduction`` one sweep shares: ``nr_rncf`` of the full RNCF model of ``beam``
    at the grid's hardest case (highest ωs, shortest Ts; the beam's own E), with the MMI
    simulation over 0..``t_end``. ``elements`` defaults to the paper's mesh for that ωs."""
    if not isinstance(grid, SweepGrid):
        raise ValueError(f"grid must be a SweepGrid (see sweep_grid), got {type(grid).__name__}")
    ts = output_times(t_end, dt_out)
    full = build_spinup_model("rncf", beam, float(grid.omega_s.max()), float(grid.T_s.min()), elements)
    return nr_rncf(full, jnp.asarray(ts), Basis(n_modes=n_modes, vms=vms, mds=mds, max_dofs=max_dofs))
