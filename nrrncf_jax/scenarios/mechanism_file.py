"""Mechanisms of the user's own: what a model file returns (``MechanismSetup``), how it is found
(``load_setup``: a Python file, or a bundled example of ``nrrncf_jax.examples`` by name) and how
it runs (``run_setup``: the run's sensors at the output times and its statistics, a
``MechanismRun``).

A model file defines ``mechanism(**params) -> MechanismSetup``: the system (a
``multibody.Mechanism`` or any constrained system), its named sensors (``multibody.sensors``),
optionally the initial state ``y0 = (z0, v0)`` and the default end time. ``nrrncf run FILE
--param KEY=VALUE`` passes the parameters as keyword arguments (numbers parsed as numbers).
"""

import dataclasses
import importlib
import importlib.util
import inspect
import pathlib

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import _validate
from ..integrate import (
    AbstractSolver,
    AbstractStepSizeController,
    AdaptiveStepSize,
    ConstantStepSize,
    GeneralizedAlphaIndex3,
    Newton,
    simulate_timed,
)
from ..integrate.step_size import STEP_CONTROLS, adaptive_step_size, step_control_name, tightened
from ..models.constrained import AbstractConstrainedModel
from ..multibody.sensors import Observer, observe
from ..post.metrics import chi_rel_of_changes
from ..post.outline import mechanism_outline
from ..reduction.run_error import TIGHTEN, ErrorEstimator, estimate_times
from .run_record import chosen_step_settings, estimate_fields, estimate_mechanism_run, step_tolerances_to

_POINTS = "__points__"  # the recorded nodes' key among the observed outputs
_STATE = "__state__"  # the recorded coordinates' and velocities' key, for the error estimate


@dataclasses.dataclass
class MechanismSetup:
    """``system`` (constrained), ``sensors`` ({name: sensor}), the initial state ``y0`` (None:
    the system's reference at rest), ``t_end`` [s] (the default end time), ``rtol`` (the default
    step tolerance), ``rho_inf`` (the default generalized-α ρ∞), ``compare`` (the sensors whose
    χ_rel a reference run reports: positions and deflections; None: all) and ``info`` (anything
    the example reports: its parameters, an offline time), ``error_on`` (the sensors on which the
    step error is measured, ``multibody.Mechanism.observed_error``; empty: every nodal vector) and
    ``step_control`` (the adaptive controller's name, ``integrate.STEP_CONTROLS``). ``solver()`` and
    ``controller()`` build the integrator's objects from these defaults (what ``run_setup`` runs
    unless given others), with any of them overridden."""

    system: AbstractConstrainedModel
    sensors: dict
    y0: tuple | None = None
    t_end: float = 1.0
    rtol: float = 1e-6
    rho_inf: float = 0.9
    compare: tuple | None = None
    info: dict = dataclasses.field(default_factory=dict)
    error_on: tuple = ()
    step_control: str = "plain"

    def __post_init__(self):
        if not isinstance(self.system, AbstractConstrainedModel):
            raise ValueError(f"a model's system must be a constrained system (multibody.Mechanism), got "
                             f"{type(self.system).__name__}")
        if not isinstance(self.sensors, dict) or not self.sensors:
            raise ValueError("a model needs its sensors: a dict {name: sensor} (multibody.sensors)")
        self.error_on = _error_names(self.error_on, self.sensors)
        if self.step_control not in STEP_CONTROLS:
            raise ValueError(f"step_control must be one of {tuple(STEP_CONTROLS)}, got {self.step_control!r}")

    def solver(self, rho_inf: float | None = None) -> GeneralizedAlphaIndex3:
        """The model's integrator, ``GeneralizedAlphaIndex3`` at its ρ∞ (or ``rho_inf``): what
        ``run_setup`` runs without a ``solver``."""
        rho_inf = self.rho_inf if rho_inf is None else float(rho_inf)
        if not 0.0 <= rho_inf <= 1.0:
            raise ValueError(f"rho_inf must lie in [0, 1], got {rho_inf:g}")
        return GeneralizedAlphaIndex3(rho_inf)

    def controller(self, rtol: float | None = None, dt: float | None = None,
                   step_control: str | None = None) -> AbstractStepSizeController:
        """The model's step control, what ``run_setup`` runs without a ``controller``: error
        control at its ``rtol`` (or ``rtol``; atol = rtol/10 of the nodal vectors' metres) by its
        ``step_control`` (or ``step_control``, ``integrate.STEP_CONTROLS``), or fixed steps of
        ``dt`` (``ConstantStepSize``; rtol then scales Newton's test only), as the peers run
        quasi-static mechanisms."""
        rtol = self.rtol if rtol is None else float(rtol)
        if not 0 < rtol < 1:
            raise ValueError(f"rtol must lie in (0, 1), got {rtol:g}")
        if dt is not None:
            if step_control is not None:
                raise ValueError("fixed steps (dt) have no step control: pass dt or step_control, not both")
            if not float(dt) > 0:
                raise ValueError(f"dt must be > 0, got {dt}")
            return ConstantStepSize(float(dt), rtol=rtol, atol=rtol / 10)
        return adaptive_step_size(rtol, rtol / 10, self.step_control if step_control is None else step_control)


def _error_names(error_on, sensors: dict) -> tuple:
    """``error_on`` as a tuple of sensor names: a sequence of names, a comma-separated string, or
    ``"nodes"``/empty for every nodal vector."""
    if isinstance(error_on, str):
        error_on = () if error_on.strip() in ("", "nodes") else tuple(n.strip() for n in error_on.split(","))
    names = tuple(str(n) for n in error_on)
    unknown = [n for n in names if n not in sensors]
    if unknown:
        raise ValueError(f"error_on names sensors {unknown} that the model does not have (its sensors: "
                         f"{', '.join(sensors)}; 'nodes' for every nodal vector)")
    return names


@dataclasses.dataclass
class MechanismRun:
    """The sensors' histories ``series`` ({name: (n_out, ...) array}) at ``ts``, and the run's
    ``dofs``, ``steps``, ``rejected``, ``newton_iters``, ``compile_s`` and ``run_s``, each body described
    (``bodies``) and the integrator settings it ran with (``settings``: rtol, atol, ρ∞, the sensors of the
    step error or ``"nodes"``, the controller or the fixed step)."""

    ts: np.ndarray
    series: dict
    dofs: int
    steps: int
    rejected: int
    newton_iters: int
    compile_s: float
    run_s: float
    formulation: str
    points: np.ndarray | None = None  # the bodies' nodes at ts (nt × p × 3), with ``positions=True``
    lines: np.ndarray | None = None  # their edges (l × 2, ``post.outline``)
    bodies: tuple[str, ...] = ()  # each body described (``Mechanism.describe``): its kind and basis
    settings: dict = dataclasses.field(default_factory=dict)  # the run's integrator settings, as chosen
    estimate: object = None  # the run's error estimate (``run_setup``'s ``estimator``): a reduction.ErrorEstimate

    def table(self) -> tuple[list[str], np.ndarray]:
        """CSV columns ``t`` and each sensor (a vector sensor as ``name_0, name_1, ...``)."""
        names, cols = ["t"], [self.ts]
        for name, y in self.series.items():
            y = np.asarray(y).reshape(len(self.ts), -1)
            if y.shape[1] == 1:
                names.append(name)
                cols.append(y[:, 0])
            else:
                names += [f"{name}_{i}" for i in range(y.shape[1])]
                cols += list(y.T)
        return names, np.stack(cols, axis=1)

    def summary(self) -> dict:
        """The run's statistics, bodies and settings, and its error estimate's fields where it has one
        (``run_record.estimate_fields``), with ``estimate_dominant_part`` where both parts were
        estimated (``dominant_part``)."""
        out = {"formulation": self.formulation, "dofs": self.dofs, "steps": self.steps, "rejected": self.rejected,
               "newton_iters": self.newton_iters, "compile_s": self.compile_s, "run_s": self.run_s,
               "bodies": list(self.bodies), **self.settings}
        if self.estimate is None:
            return out
        dominant = dominant_part(self.estimate)
        return out | estimate_fields(self.estimate) | ({} if dominant is None else {"estimate_dominant_part": dominant})


def sensor_totals(e) -> dict:
    """A mechanism's estimate's total on each sensor: its basis part plus its integration part
    where that was estimated ({name: per cent}; empty without sensors)."""
    basis, integration = e.sensor_chi_percent or {}, e.sensor_integration_percent or {}
    return {k: basis.get(k, 0.0) + integration.get(k, 0.0) for k in [*basis, *integration]}


def dominant_part(e) -> str | None:
    """Which part of the estimated error dominates, in words, where both the basis part and the
    time-integration part were estimated (None otherwise): on the compared sensor whose estimated
    total is largest (on the reduced bodies' positions without sensors), ``"basis (0.91 % of
    2.62 % on w_mid)"`` or ``"time integration (...)"``, so that a user knows whether a larger
    basis or a tighter tolerance is what would lower it."""
    if e.integration_percent is None:
        return None
    basis, integration = e.sensor_chi_percent or {}, e.sensor_integration_percent or {}
    totals = sensor_totals(e)
    if totals:
        name = max(totals, key=totals.get)
        b, i, where = basis.get(name, 0.0), integration.get(name, 0.0), f" on {name}"
    else:
        b, i, where = e.chi_rel_percent, e.integration_percent, " on the reduced bodies' positions"
    part, value = ("basis", b) if b >= i else ("time integration", i)
    return f"{part} ({value:.3g} % of {b + i:.3g} %{where})"


def compare_sensors(setup: MechanismSetup, series: dict, other: dict) -> dict:
    """χ_rel (Eq. 40, %) of the sensors' histories ``series`` against ``other``'s ({name: array}
    at the same output times), each sensor's change from its initial value
    (``post.metrics.chi_rel_of_changes``): the model's ``compare`` (positions and deflections,
    say, not reactions, whose high-frequency content differs between models), every sensor
    without one; a sensor that does not change in ``other`` is left out."""
    return chi_rel_of_changes({name: series[name] for name in setup.compare or tuple(series)}, other)


def load_setup(source: str, params: dict | None = None) -> MechanismSetup:
    """The ``MechanismSetup`` of ``source``: a path to a Python file, or the name of a bundled
    example (``nrrncf_jax/examples/<name>.py``), its ``mechanism(**params)`` called. Raises
    ``ValueError`` for a missing file or example, a file without ``mechanism``, an unknown
    parameter, or a function that does not return a ``MechanismSetup``."""
    params = dict(params or {})
    path = pathlib.Path(source)
    if path.suffix == ".py":
        if not path.is_file():
            raise ValueError(f"model file {source!r} does not exist")
        spec = importlib.util.spec_from_file_location(f"nrrncf_model_{path.stem}", path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    else:
        try:
            module = importlib.import_module(f"nrrncf_jax.examples.{source}")
        except ModuleNotFoundError:
            raise ValueError(f"no model file or bundled example {source!r} (examples: {', '.join(examples())})") \
                from None
    fn = getattr(module, "mechanism", None)
    if not callable(fn):
        raise ValueError(f"{source!r} does not define mechanism(**params) returning a MechanismSetup")
    accepted = inspect.signature(fn).parameters
    unknown = [k for k in params if k not in accepted]
    if unknown and not any(p.kind == p.VAR_KEYWORD for p in accepted.values()):
        raise ValueError(f"{source!r}: unknown parameter(s) {unknown}; mechanism() takes {list(accepted)}")
    setup = fn(**params)
    if not isinstance(setup, MechanismSetup):
        raise ValueError(f"{source!r}: mechanism() returned {type(setup).__name__}, not a MechanismSetup")
    return setup


def examples() -> list[str]:
    """The bundled examples' names."""
    folder = pathlib.Path(__file__).parent.parent / "examples"
    return sorted(p.stem for p in folder.glob("*.py") if not p.stem.startswith("_"))


class _WithState(eqx.Module):
    """An observer's outputs and the state (z, ż) at each output, which the error estimate reads
    (``run_setup``'s ``estimator``)."""

    outputs: eqx.Module

    def __call__(self, t, z, v):
        return self.outputs(t, z, v) | {_STATE: (z, v)}


class _WithOutline(eqx.Module):
    """The sensors (``multibody.sensors.Observer``) and every body's nodes (``positions=True``) as
    one observer module, so that the system stays an argument of the compiled run."""

    sensors: Observer
    nodes: tuple[tuple[int, int], ...] = eqx.field(static=True)

    def __call__(self, t, z, v):
        xs = self.sensors.system.nodal_vectors(z)
        return self.sensors(t, z, v) | {_POINTS: jnp.stack([xs[b][i] for b, i in self.nodes])}


def run_setup(setup: MechanismSetup, t_end: float | None = None, n_out: int = 201, *,
              solver: AbstractSolver | None = None, controller: AbstractStepSizeController | None = None,
              newton: Newton | None = None, estimator: ErrorEstimator | None = None, error_on=None,
              positions: bool = False, progress: bool = False) -> MechanismRun:
    """Run ``setup`` to ``t_end`` (its default), the sensors at ``n_out`` equal output times;
    compile and run timed apart (ahead-of-time compilation, then a blocked run).

    The integrator's objects, as ``simulate`` takes them: ``solver`` (an index-3 solver; the
    model's by default, ``MechanismSetup.solver()``: ``GeneralizedAlphaIndex3`` at its ρ∞),
    ``controller`` (the model's by default, ``MechanismSetup.controller()``: error control at its
    rtol and step control; ``setup.controller(rtol=1e-3)``, ``setup.controller(dt=4e-3)`` for fixed
    steps, or any ``integrate`` controller) and ``newton`` (each step's ``Newton``; ``simulate``'s
    default otherwise). ``error_on``: the sensors whose values the step error is measured on
    (names, a comma-separated string, or ``"nodes"`` for every nodal vector; the setup's
    ``error_on`` by default, ``multibody.Mechanism.observed_error``). ``positions``: also record
    every body's nodes and their edges (``post.outline``: ``points``, ``lines``), for a VTK series
    or an animation. ``MechanismRun.settings`` says what ran: rtol, atol, ρ∞, the solver, the step
    control's name (``integrate.step_control_name``) and the fixed step where there is one.

    ``estimator`` (a ``reduction.ErrorEstimator``; a system with reduced bodies): the run's error
    from reduced runs alone, in ``MechanismRun.estimate`` (``run_record.estimate_fields`` in its
    summary). Its basis part: ``multibody.error_estimate.estimate_mechanism_error`` against the
    system's full-order counterpart, over the reduced bodies' position vectors, each one's on
    its deformation and each compared sensor's (the model's ``compare``; every sensor without
    one), at states that end the run's steps (``reduction.run_error``: the run itself
    stops on the static estimate's samples; the dynamic estimate, or ``integration``, repeats it).
    With ``integration``, the repetition is at the tolerances divided by ``TIGHTEN`` (fixed steps:
    the step divided by √``TIGHTEN``: ``integrate.tightened``), and the run's
    distance to it is its own time-integration error: on the same positions
    (``multibody.error_estimate.integration_error_percent``, so that the two parts add up to the
    total's estimate) and on each compared sensor (``compare_sensors``), what
    ``nrrncf run --reference full`` measures as ``integration_error_percent_<name>``."""
    if estimator is not None and not isinstance(estimator, ErrorEstimator):
        raise ValueError(f"estimator must be a reduction.ErrorEstimator (or None), got {type(estimator).__name__}")
    for name, value, kind in (("solver", solver, AbstractSolver), ("newton", newton, Newton),
                              ("controller", controller, AbstractStepSizeController)):
        if value is not None and not isinstance(value, kind):
            raise ValueError(f"{name} must be a {kind.__name__}, got {type(value).__name__}")
    t_end = setup.t_end if t_end is None else float(t_end)
    if not t_end > 0:
        raise ValueError(f"t_end must be > 0, got {t_end}")
    solver = setup.solver() if solver is None else solver
    controller = setup.controller() if controller is None else controller
    if isinstance(controller, ConstantStepSize) and not float(controller.dt) <= t_end:
        raise ValueError(f"the fixed step must lie in (0, t_end = {t_end:g}], got {float(controller.dt):g}")
    system = setup.system
    error_on = setup.error_on if error_on is None else _error_names(error_on, setup.sensors)
    if error_on or getattr(system, "error_sensors", ()):
        if not hasattr(system, "observed_error"):
            raise ValueError(f"error_on: a {type(system).__name__} measures its step error on its own coordinates")
        system = system.observed_error({k: setup.sensors[k] for k in error_on})
    awaiting = [b for b, body in enumerate(getattr(system, "bodies", ())) if getattr(body, "awaiting_mds", False)]
    if awaiting:  # it would run with its vibration modes alone, which the model did not ask for
        raise ValueError(f"bodies {awaiting} were reduced with mds='mmi' and their modal derivatives were never "
                         "chosen: call multibody.modal_interaction.select_modal_derivatives(system, ts) in the model "
                         "file (or reduce with mds='all', a list of pairs, or [] for vibration modes alone)")
    ts = np.linspace(0.0, t_end, int(n_out))
    full = None
    if estimator is not None:
        from ..multibody.error_estimate import full_counterpart

        full = full_counterpart(system)  # refuses a system without reduced bodies, before the run
    fn = observe(system, setup.sensors)
    lines = None
    if positions:
        nodes, lines = mechanism_outline(system)
        fn = _WithOutline(fn, tuple(nodes))
    if estimator is not None:
        fn = _WithState(fn)
    y0 = setup.y0 if setup.y0 is not None else (system.reference(), 0.0 * system.reference())
    rtol, atol = (getattr(controller, k, None) for k in ("rtol", "atol"))  # a controller of the user's may have none
    settings = {"rtol": None if rtol is None else float(rtol),
                "atol": None if atol is None else float(f"{float(atol):.12g}"),
                "rho_inf": float(solver.rho_inf) if hasattr(solver, "rho_inf") else None,
                "error_on": list(error_on) or "nodes", "solver": type(solver).__name__,
                "step_control": step_control_name(controller)}
    settings |= {"dt": float(controller.dt)} if isinstance(controller, ConstantStepSize) else {}

    # the system is an argument of the compiled program, not a constant in it (``simulate_timed``):
    # XLA does not fold its arrays, and a reduced mechanism compiles with ``simulate``'s small-kernel
    # options, which a program of the user's own ``jax.jit`` around ``simulate`` would not get; a
    # run that stops early raises ``integrate.SimulationError`` with the time and the reason
    step_ts = None if estimator is None else _run_step_ts(estimator, ts)
    sol, compile_s, run_s = simulate_timed(system, solver, controller, ts, observe=fn, y0=y0, progress=progress,
                                           newton=newton, step_ts=step_ts)
    series = {k: np.asarray(sol.ys[k]) for k in setup.sensors}  # in the setup's order (a dict pytree is sorted)
    run = MechanismRun(ts, series, system.n_dof, int(sol.num_steps), int(sol.num_rejected), int(sol.num_newton),
                       compile_s, run_s, system.formulation,
                       np.asarray(sol.ys[_POINTS]) if positions else None, lines,
                       tuple(system.describe()) if hasattr(system, "describe") else (), settings)
    if estimator is not None:
        states = tuple(np.asarray(y) for y in sol.ys[_STATE])
        run.estimate = _estimate(setup, system, full, estimator, run, states, solver, controller, newton, fn, y0)
    return run


def run_to_tolerance(setup: MechanismSetup, tol: float, estimator: ErrorEstimator | None = None,
                     **options) -> MechanismRun:
    """``run_setup(setup, **options)`` of a model with reduced bodies, its step settings chosen to a
    target χ_rel of ``tol`` per cent on the compared sensors (``nrrncf run --tol``): the run's own
    time-integration error on each compared sensor (the model's ``compare``; each reduced body's
    positions where no sensor changes), estimated by ``estimator`` with its ``integration``
    part, at most ``tol`` / 2, the adaptive controller's tolerances tightened (or its steps
    limited to the output interval) until it is (``run_record.step_tolerances_to``).

    ``controller``: where the tightening starts (the model's by default, ``setup.controller()``;
    ``setup.controller(rtol=1e-3)`` from a looser rtol). The basis is the model's own (its
    parameters), so the other half of the target is the basis's:
    its part is estimated and reported, not chosen. ``MechanismRun.settings`` gets ``step_rtol``,
    ``step_atol`` (``step_dt_max`` where the steps were limited), ``tol_percent`` and ``tol_met``:
    whether the estimated total on every compared sensor is at most ``tol`` (where it is not,
    because the basis part exceeds its half, only a larger basis, through the model's parameters,
    can meet it). ``estimator``: the dynamic ``ErrorEstimator`` by default (it carries the basis's
    error through the joints to every sensor, where the static one holds the frames). A fixed
    step (``ConstantStepSize``) is refused: its error is not controlled by tolerances."""
    _validate.positive("tol (target chi_rel in per cent)", tol)
    if estimator is not None and not isinstance(estimator, ErrorEstimator):
        raise ValueError(f"estimator must be a reduction.ErrorEstimator (or None), got {type(estimator).__name__}")
    estimator = ErrorEstimator(method="dynamic") if estimator is None else estimator
    estimator = dataclasses.replace(estimator, integration=True)
    controller = options.pop("controller", None)
    controller = setup.controller() if controller is None else controller
    if not isinstance(controller, AdaptiveStepSize):  # a fixed step has no tolerance to tighten
        raise ValueError(f"run_to_tolerance chooses error-controlled steps: it tightens an "
                         f"integrate.AdaptiveStepSize's tolerances, got {type(controller).__name__}")
    last = run_setup(setup, controller=controller, estimator=estimator, **options)

    def rerun(c):
        nonlocal last
        last = run_setup(setup, controller=c, estimator=estimator, **options)

    def judged(est) -> float:  # the largest compared sensor's integration part, else the positions'
        parts = est.sensor_integration_percent or {}
        return max(parts.values()) if parts else est.integration_percent

    est, controller = step_tolerances_to(float(tol), controller, lambda c: last.estimate, rerun,
                                         float(np.diff(last.ts).min()), judged=judged)
    rtol, atol, *dt_max = chosen_step_settings(controller)
    totals = sensor_totals(est)
    total = max(totals.values()) if totals else est.chi_rel_percent + est.integration_percent
    last.settings |= {"step_rtol": rtol, "step_atol": atol, **({"step_dt_max": dt_max[0]} if dt_max else {}),
                      "tol_percent": float(tol), "tol_met": bool(total <= tol)}
    return last


def _run_step_ts(estimator: ErrorEstimator, ts):
    """Where the estimated run ends steps: the static estimate's samples, also where the estimate
    repeats the run for its ``integration`` part (``ErrorEstimator.step_ts`` would leave the run's
    steps free there): the repetition then has the run's shapes and reuses its compiled program,
    which for a mechanism costs far more than either run. The dynamic estimate's repetition ends
    a step on every output, which the run does not (it would bound its steps by the outputs'
    interval)."""
    return estimate_times(ts, estimator.samples, estimator.method) if estimator.method == "static" else None


def _estimate(setup, system, full, estimator, run, states, solver, controller, newton, fn, y0):
    """``run_setup``'s error estimate of ``run`` (its docstring), ``states`` the run's (z, ż) at
    its output times: ``run_record.estimate_mechanism_run`` on the compared sensors,
    with a repetition that ends its steps on the estimate's times where the dynamic estimate or
    the ``integration`` part needs one."""
    ts, repetition = run.ts, None
    compared = setup.compare or tuple(setup.sensors)
    if estimator.integration or estimator.method == "dynamic":
        again = tightened(controller, TIGHTEN) if estimator.integration else controller
        rep, compile_s, run_s = simulate_timed(system, solver, again, ts, observe=fn, y0=y0, newton=newton,
                                               step_ts=estimate_times(ts, estimator.samples, estimator.method))
        rep_states = tuple(np.asarray(y) for y in rep.ys[_STATE])
        repetition = ({k: np.asarray(rep.ys[k]) for k in compared}, rep_states, compile_s, run_s)
    return estimate_mechanism_run(full, system, estimator, ts, states, sensors={k: setup.sensors[k] for k in compared},
                                  outputs={k: run.series[k] for k in compared}, repetition=repetition)

__all__ = ["MechanismRun", "MechanismSetup", "compare_sensors", "dominant_part", "examples", "load_setup",
           "run_setup", "run_to_tolerance", "sensor_totals"]
