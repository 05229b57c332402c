"""Control design through the differentiable simulator: the spin-up profile with the least
residual tip vibration.

The profile is a ``FourierSpinUp`` (Eq. 43 plus a zero-mean Fourier correction of θ̈, so
θ̇(Ts) = ωs for any coefficients). The objective is the mean square of the in-plane tip
deflection uy (rotating frame) over the output times in [Ts, t_end], after the manoeuvre, when
a straight beam at constant spin and without load oscillates about uy ≈ 0. It is minimised by
Adam, then L-BFGS (``optimize.lbfgs``), on gradients taken through the whole simulation
(``simulate(adjoint='reverse')``, a checkpointed loop; or forward mode, one tangent per
coefficient). The amplitude reported is max |uy| over the same times.
"""

import dataclasses
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optax

from .. import _validate
from .._types import Array, Float
from ..integrate import AbstractSolver, AbstractStepSizeController, AdaptiveStepSize, GeneralizedAlpha
from ..integrate.simulate import simulate
from ..models.observe import TipObserver, tip_observer
from ..motion import SpinUp
from ..motion.profiles import FourierSpinUp
from .optimize import AdamLbfgs, lbfgs


def tip_response(model, motion, ts, *, solver: AbstractSolver | None = None,
                 controller: AbstractStepSizeController | None = None, tip: int | None = None,
                 observer: TipObserver | None = None, **simulate_kwargs) -> Float[Array, "nt 3"]:
    """Tip displacement (rotating frame: ux axial, uy in-plane, uz) at ``ts`` of ``model`` driven
    by ``motion`` (a ``motion.AbstractMotion``), run with ``solver`` (default
    ``GeneralizedAlpha(0.9)``) and ``controller`` (default ``AdaptiveStepSize()``); the other
    keywords go to ``simulate``."""
    obs = tip_observer(model, tip) if observer is None else observer
    solver = GeneralizedAlpha(0.9) if solver is None else solver
    controller = AdaptiveStepSize() if controller is None else controller
    return simulate(model.with_motion(motion), solver, controller, ts, observe=obs, **simulate_kwargs).ys


def residual_mean_square(ts, uy, T_s) -> Float[Array, ""]:
    """Mean of uy² over the output times t ≥ Ts: the smooth objective."""
    after = jnp.asarray(ts) >= T_s
    return jnp.sum(jnp.where(after, uy**2, 0.0)) / jnp.maximum(jnp.sum(after), 1)


def residual_amplitude(ts, uy, T_s) -> float:
    """max |uy| over the output times t ≥ Ts: the residual vibration amplitude reported."""
    after = np.asarray(ts) >= T_s
    return float(np.max(np.abs(np.asarray(uy)[after]))) if after.any() else 0.0


@dataclasses.dataclass
class OptimalSpinup:
    """Result of ``optimal_spinup``: the optimised profile against Eq. 43 on the model optimised.

    Residuals are of the in-plane tip deflection uy over the output times t ≥ Ts: ``amplitude``
    is max |uy|, ``rms`` the root mean square. ``loss_history`` holds the objective (mean square
    normalised by Eq. 43's, plus the smoothness penalty) at every iterate; the profile returned is
    the iterate of least loss.
    """

    profile: FourierSpinUp
    baseline: SpinUp
    ts: np.ndarray
    tip_baseline: np.ndarray  # (nt, 3)
    tip_optimal: np.ndarray  # (nt, 3)
    amplitude_baseline: float
    amplitude_optimal: float
    rms_baseline: float
    rms_optimal: float
    loss_history: np.ndarray
    iterations: int  # Adam + L-BFGS iterations
    evaluations: int  # simulations with gradient (line-search trials included)
    best_iteration: int
    compile_s: float
    wall_s: float  # optimisation loop, compilation excluded
    peak_acc_baseline: float  # max |θ̈| over [0, Ts] [rad/s²]
    peak_acc_optimal: float

    @property
    def reduction_factor(self) -> float:
        """Eq. 43's residual amplitude over the optimised one."""
        return self.amplitude_baseline / max(self.amplitude_optimal, 1e-300)

    def table(self) -> str:
        rows = [("profile", "Eq. 43", f"optimised ({self.profile.n_terms} terms)"),
                ("residual max |uy| [m]", f"{self.amplitude_baseline:.3e}", f"{self.amplitude_optimal:.3e}"),
                ("residual RMS uy [m]", f"{self.rms_baseline:.3e}", f"{self.rms_optimal:.3e}"),
                ("max |θ̈| [rad/s²]", f"{self.peak_acc_baseline:.3f}", f"{self.peak_acc_optimal:.3f}")]
        w = [max(len(r[i]) for r in rows) for i in range(3)]
        lines = [f"  {a:<{w[0]}}  {b:>{w[1]}}  {c:>{w[2]}}" for a, b, c in rows]
        lines.append(f"  iterations {self.iterations} (best {self.best_iteration}), compile {self.compile_s:.1f} s, "
                     f"optimisation {self.wall_s:.1f} s; amplitude reduced {self.reduction_factor:.1f}x")
        return "\n".join(lines)


def peak_acceleration(motion, T_s, n: int = 2001) -> float:
    """max |θ̈| over [0, Ts] on n points."""
    return float(jnp.max(jnp.abs(motion(jnp.linspace(0.0, T_s, n))[2])))


OPTIMIZER = AdamLbfgs(adam_steps=20, adam_lr=0.005, lbfgs_steps=10, gtol=0.0, ftol=None)
"""``optimal_spinup``'s optimiser: 20 Adam steps from a learning rate of 0.005, then up to 10
L-BFGS iterations, which stop only when no step lowers the loss."""


def optimal_spinup(model, omega_s: float, T_s: float, t_end: float, n_terms: int = 4, *,
                   optimizer: AdamLbfgs = OPTIMIZER, tip: int | None = None, dt_out: float = 0.05,
                   smoothness: float = 0.0, init: FourierSpinUp | None = None,
                   grad: str = "reverse", controller: AbstractStepSizeController | None = None,
                   max_steps: int = 20_000, verbose: bool = False) -> OptimalSpinup:
    """Find the spin-up to ``omega_s`` within ``T_s`` with the least residual tip vibration.

    ``model`` is a rotating-frame model (typically the NR-RNCF ``Reduction.model``; its own
    motion is replaced), ``tip`` the nodal vector observed (see ``tip_observer``). The profile is
    a ``FourierSpinUp`` with ``n_terms`` sine and ``n_terms`` cosine-pair coefficients, starting
    from Eq. 43 (or ``init``). Every iteration simulates 0..``t_end`` with outputs every
    ``dt_out`` and takes the gradient of

        J(x) = mean_{t ≥ Ts} uy(t)² / (the same for Eq. 43) + smoothness · mean_{[0,Ts]}(θ̈ − θ̈_Eq.43)² / (ωs/Ts)²

    with respect to x = coefficients / (ωs/Ts). The second term (off by default) penalises the
    departure from Eq. 43, should the optimum need large accelerations. ``optimizer`` (an
    ``optimize.AdamLbfgs``, default ``OPTIMIZER``): its ``adam_steps`` Adam iterations (the
    learning rate ``adam_lr`` cosine-decayed to 5 % over them) are followed by up to its
    ``lbfgs_steps`` L-BFGS iterations (``optimize.lbfgs``: optax's direction, Armijo
    backtracking, a trial point whose simulation fails shortening the step, its ``gtol`` and
    ``ftol``) from the best Adam iterate: the residual vibration is
    nearly linear in θ̈, so J is nearly quadratic in x, where quasi-Newton converges fast.
    ``grad='reverse'`` differentiates the checkpointed loop (``simulate(adjoint='reverse')``;
    memory grows with ``max_steps``), ``'forward'`` pushes 2·n_terms tangents (constant memory,
    but slower than reverse mode at the default 8 coefficients). ``controller`` (default
    ``AdaptiveStepSize(1e-5, 1e-8)``; a ``ConstantStepSize`` makes the loss a smooth function of
    the coefficients) and ``max_steps`` go to ``simulate``; adaptive step sizes are held fixed
    under differentiation. One
    value-and-gradient function is compiled and reused for every evaluation. Returns an
    ``OptimalSpinup`` with the iterate of least loss.
    """
    _validate.positive("omega_s (steady spin rate)", omega_s)
    _validate.positive("T_s (spin-up time)", T_s)
    _validate.positive("t_end", t_end)
    _validate.positive("dt_out", dt_out)
    if not isinstance(optimizer, AdamLbfgs):
        raise ValueError(f"optimizer must be an optimize.AdamLbfgs, got {type(optimizer).__name__}")
    _validate.non_negative("smoothness", smoothness)
    n_terms = _validate.positive_int("n_terms", n_terms)
    steps, lbfgs_steps = optimizer.adam_steps, optimizer.lbfgs_steps
    if t_end <= T_s:
        raise ValueError(f"t_end must be after the manoeuvre ends (T_s = {T_s}), got t_end = {t_end}")
    if grad not in ("reverse", "forward"):
        raise ValueError(f"grad must be 'reverse' or 'forward', got {grad!r}")
    ts_np = np.arange(0.0, t_end + 0.5 * dt_out, dt_out)
    ts_np = ts_np[ts_np <= t_end + 1e-12]
    if np.sum(ts_np >= T_s) < 2:
        raise ValueError("dt_out leaves fewer than two output times after T_s")
    if init is not None and (not isinstance(init, FourierSpinUp) or init.n_terms != n_terms):
        raise ValueError(f"init must be a FourierSpinUp with n_terms={n_terms}")
    ts = jnp.asarray(ts_np)
    profile0 = FourierSpinUp(omega_s, T_s, n_terms=n_terms)
    obs = tip_observer(model, tip)
    controller = AdaptiveStepSize(1e-5, 1e-8) if controller is None else controller
    if not isinstance(controller, AbstractStepSizeController):
        raise ValueError(f"controller must be an integrate step-size controller (AdaptiveStepSize, "
                         f"ConstantStepSize), got {type(controller).__name__}")
    sim = dict(controller=controller, max_steps=max_steps)
    scale = float(omega_s) / float(T_s)
    adjoint = "reverse" if grad == "reverse" else "forward"
    # The model travels as an argument (not as constants baked into the compiled program).
    dynamic, static = eqx.partition((model, obs, profile0), eqx.is_array)

    def objective(x, J0, dynamic):
        model, obs, prof = eqx.combine(dynamic, static)
        prof = eqx.tree_at(lambda p: p.coeffs, prof, scale * x)
        tip_u = tip_response(model, prof, ts, observer=obs, adjoint=adjoint, **sim)
        J = residual_mean_square(ts, tip_u[:, 1], T_s) / J0
        return J + smoothness * prof.correction_mean_square() / scale**2, tip_u

    if grad == "reverse":
        value_and_grad = jax.value_and_grad(objective, has_aux=True)
    else:
        def value_and_grad(x, J0, dynamic):
            g, out = jax.jacfwd(lambda y: (lambda r: (r[0], r))(objective(y, J0, dynamic)), has_aux=True)(x)
            return out, g

    x0 = jnp.zeros((2, n_terms))
    t0 = time.perf_counter()
    value_and_grad = jax.jit(value_and_grad).lower(x0, 1.0, dynamic).compile()
    compile_s = time.perf_counter() - t0

    # Eq. 43 is the profile with zero coefficients.
    t0 = time.perf_counter()
    (J0, tip0), g0 = value_and_grad(x0, 1.0, dynamic)
    J0 = float(J0)
    if not (np.isfinite(J0) and J0 > 0.0):
        raise ValueError(f"Eq. 43 leaves no measurable residual vibration on this model (mean square {J0})")
    history, best = [], dict(loss=np.inf, x=x0, tip=None, iteration=0)
    evaluations = 0

    def evaluate(x):
        nonlocal evaluations
        evaluations += 1
        (val, tip_u), g = value_and_grad(x, J0, dynamic)
        val = float(val)
        if not np.isfinite(val) or not bool(jnp.all(jnp.isfinite(g))):
            raise FloatingPointError(f"non-finite loss or gradient after {len(history)} iterations: loss = {val}")
        return val, g, tip_u

    def record(x, val, g, tip_u, phase):
        history.append(val)
        if val < best["loss"]:
            best.update(loss=val, x=x, tip=tip_u, iteration=len(history) - 1)
        if verbose:
            print(f"  {phase} {len(history) - 1:4d}  loss {val:.6e}  |grad| {float(jnp.linalg.norm(g)):.3e}",
                  flush=True)

    if init is None:  # J(0) = 1; the penalty's gradient vanishes there
        x, val, g, tip_u = x0, 1.0, g0 / J0, tip0
        evaluations += 1
    else:
        x = jnp.asarray(init.coeffs) / scale
        val, g, tip_u = evaluate(x)
    record(x, val, g, tip_u, "start")
    opt = optax.adam(optax.cosine_decay_schedule(optimizer.adam_lr, max(steps, 1), alpha=0.05))
    state = opt.init(x)
    for _ in range(steps):
        upd, state = opt.update(g, state, x)
        x = optax.apply_updates(x, upd)
        val, g, tip_u = evaluate(x)
        record(x, val, g, tip_u, "adam ")
    if lbfgs_steps:  # from the best Adam iterate, reusing the one compiled function (optimize.lbfgs)
        x = best["x"]
        val, g, _ = evaluate(x) if steps else (val, g, None)
        lbfgs(evaluate, x, val, g, max_iterations=lbfgs_steps, gtol=optimizer.gtol, ftol=optimizer.ftol,
              max_tries=_MAX_HALVINGS, on_step=lambda i, x, val, g, tip_u: record(x, val, g, tip_u, "lbfgs"))
    wall_s = time.perf_counter() - t0

    profile = FourierSpinUp(omega_s, T_s, scale * best["x"])
    baseline = SpinUp(omega_s, T_s)
    tip0, tip1 = np.asarray(tip0), np.asarray(best["tip"])
    return OptimalSpinup(
        profile=profile, baseline=baseline, ts=ts_np, tip_baseline=tip0, tip_optimal=tip1,
        amplitude_baseline=residual_amplitude(ts_np, tip0[:, 1], T_s),
        amplitude_optimal=residual_amplitude(ts_np, tip1[:, 1], T_s),
        rms_baseline=float(np.sqrt(J0)), rms_optimal=float(np.sqrt(residual_mean_square(ts_np, tip1[:, 1], T_s))),
        loss_history=np.asarray(history), iterations=len(history) - 1, evaluations=evaluations,
        best_iteration=best["iteration"], compile_s=compile_s, wall_s=wall_s,
        peak_acc_baseline=peak_acceleration(baseline, T_s), peak_acc_optimal=peak_acceleration(profile, T_s),
    )


_MAX_HALVINGS = 12  # line-search trials per L-BFGS iteration (each a simulation)


def _non_negative_int(name, value) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ValueError(f"{name} must be an integer >= 0, got {value!r}")
    return int(value)
