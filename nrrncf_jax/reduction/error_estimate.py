"""A-posteriori error estimate of an NR-RNCF run, from the run alone (ERROR_CONTROL.md): the
static-correction estimate of χ_rel (Eq. 40).

At sampled output times the reduced state is lifted to the full RNCF coordinates,

    q = q° + Ψ p,    q̇ = Ψ ṗ,    q̈ = Ψ p̈    (p̈ from the reduced equations at (p, ṗ)),

and the full model's residual r = M q̈ + g(t, q, q̇) is evaluated there (its free rows). The full
solution makes r vanish; the Galerkin reduced one makes Ψᵀ r vanish, so r is what the basis
cannot represent. The displacement error e that would cancel it, to first order and with the
inertia of the correction left out (the missing coordinates are the stiff ones, whose response
to a slowly varying residual is quasi-static), is

    K_T(t, q) e = −r,      K_T = ∂r/∂q (the full tangent with the rotation's terms),

one factorisation and solve of the full model's iteration matrix with c_M = c_C = 0 per sampled
time. The estimate of χ_rel is 100 √(Σ_t |e(t)|²) / √(Σ_t |w(t)|²) over the sampled times, w = q − q̂
the reduced run's displacements: the same norm as the measured χ_rel, whose reference is the
full run.

Why this estimator: it needs nothing but the full model's residual and tangent, which the
offline stage has; it costs a few sparse factorisations, not a full run; and where the basis
captures the motion (χ_rel below a few per cent) it is first-order accurate, so its effectivity
(estimate / measured) is near 1. Where it stops working: when the basis misses a large part of the
motion (χ_rel of tens of per cent, e.g. a basis of vibration modes only under large deflection) the
correction is no longer small, the linearisation about the reduced state fails, and the estimate
says only that the error is large (``reliable`` is False above ``RELIABLE_PERCENT``). The states
must lie on the reduced equations: p̈ comes from them, so a state interpolated between a run's
steps, whose stiff
coordinates (the modal derivatives) sit off their balance by the interpolation's error, gives an
acceleration far above the motion's and a residual that measures the interpolation, not the basis
(it can lie orders of magnitude above the basis error). ``reduction.run_error`` therefore takes its
states at the ends of steps (``integrate.states_at``), and the scenarios' estimates go through it.
The
quasi-static model is blind to error that accumulates over the run: it *under*estimates where a
small basis lets error grow (a slightly wrong frequency drifting in phase), possibly by a large
factor while the estimate stays below ``RELIABLE_PERCENT`` and so is not flagged.
``basis_to_tolerance`` asks for half its tolerance for that reason.

``method="dynamic"`` integrates the linearised error equation M ë + R_q̇ ė + R_q e = −r(t)
along all the output times instead (``integrate_error_equation``, shared with
``multibody.error_estimate``), which carries error from one output to the next. Where its
linearisation holds it follows the measured error output by output; where it grows faster than
the motion can make it, it stops being valid (``valid_outputs``, ``ErrorEstimate.valid_until``).
It costs a factorisation of the full iteration matrix per output, not per sample.
"""

import dataclasses
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from .._types import Array, Float

RELIABLE_PERCENT = 20.0
"""Above this estimate (χ_rel in per cent) the linearised correction is not small next to the
displacement and the estimate is an order of magnitude, not a figure."""

METHODS = ("static", "dynamic")

NEWMARK_GAMMA, NEWMARK_BETA = 0.6, 0.3025
"""The error equation's Newmark parameters: γ = 0.6, β = (γ + 1/2)²/4, unconditionally stable
with a little numerical damping of the components at the output interval's frequency and above.
With the trapezoidal rule (γ = 1/2, none) the pendulum's error at 0.01 s outputs spiked where
the stiff components rang; the slow part the estimate is for is barely touched (first order in
γ − 1/2 times the output interval over its period)."""

BLOWUP_FACTOR = 10.0
"""The error equation's solution is taken to have left its linearisation's validity where it
grows by more than this factor within 1/ω_max, ω_max the frames' largest angular speed over the
run: an exponential rate above ln(10) ω_max ≈ 2.3 ω_max. A reduced run's own error grows with
the motion, at rates below ω_max; an unstable linearisation (a soft beam in compression, which
buckles) grows faster, as fast as its buckling modes."""


def integrate_error_equation(ts, states, linearised, measure, n: int, m: int = 0, refinements: int = 1,
                             batch: int = 1):
    """The linearised error equation of a reduced run integrated along it from e = ė = 0 by
    Newmark's rule (``NEWMARK_GAMMA``, ``NEWMARK_BETA``) over the output times ``ts``: the
    ``measure`` of the error at each output, the first (zero error) included.

    ``states``: a pytree of per-output arrays (leading axis len(ts)). ``linearised(t, h, state)``
    gives ``(defect, factor, lifted)`` at an output: ``defect(e, ė, ë, μ)``, the residual of the
    linear equations there (n rows for e, m for a constraint's multipliers μ, scaled as the
    factor's), ``factor.solve`` with their Newmark iteration matrix for (ë, μ), and ``lifted``,
    what ``measure(lifted, e)`` needs. Each step solves ``refinements`` times on the exact
    defect: once where the factor is the equations' exact Jacobian, more where it leaves terms
    out. Shared by the single-body (``estimate_error``) and the mechanism
    (``multibody.error_estimate``) estimates.

    ``batch`` > 1: the factors of ``batch`` consecutive steps are made together (a ``vmap``), each
    window of steps then integrated one step after another with them; the factors depend on the
    run's states only, not on the error. For factorisations of many small operations
    (``FACTOR_BATCH`` says where that pays and where batched LAPACK calls must be avoided)."""
    g, b = NEWMARK_GAMMA, NEWMARK_BETA

    def step(carry, args, factor=None):
        e, ed, x = carry
        t0, t, state = args
        h = t - t0
        defect, own, lifted = linearised(t, h, state)  # ``own`` unused (compiled away) when given one
        factor = own if factor is None else factor
        e_p, ed_p = e + h * ed + (0.5 - b) * h**2 * x[:n], ed + (1.0 - g) * h * x[:n]

        def refine(_, x):
            a = x[:n]
            return x - factor.solve(defect(e_p + b * h**2 * a, ed_p + g * h * a, a, x[n:]))

        x = lax.fori_loop(0, refinements, refine, x)
        e1, ed1 = e_p + b * h**2 * x[:n], ed_p + g * h * x[:n]
        return (e1, ed1, x), measure(lifted, e1)

    # ë(0) = 0 rather than its consistent value (one factorisation less to compile): the first
    # step's predictor misses (1/2 − β) h² ë(0), second order in the output interval
    zero = jnp.zeros(n, ts.dtype)
    carry0 = (zero, zero, jnp.zeros(n + m, ts.dtype))
    steps = (ts[:-1], ts[1:], jax.tree.map(lambda s: s[1:], states))
    if batch <= 1:
        _, out = lax.scan(step, carry0, steps)
    else:
        count = ts.shape[0] - 1
        windows, size = _batches(count, batch)
        windowed = jax.tree.map(lambda x: _padded(x, windows, size), steps)

        def window(carry, args):
            t0, t, state = args
            factors = jax.vmap(lambda t0, t, state: linearised(t, t - t0, state)[1])(t0, t, state)
            return lax.scan(lambda c, a: step(c, a[:3], a[3]), carry, (t0, t, state, factors))

        _, out = lax.scan(window, carry0, windowed)
        out = jax.tree.map(lambda o: o.reshape(windows * size, *o.shape[2:])[:count], out)
    return jax.tree.map(lambda o: jnp.concatenate([jnp.zeros_like(o[:1]), o]), out)


START_FRACTION = 1e-2
"""``valid_outputs`` tests the error against ``RELIABLE_PERCENT`` of the largest displacement so
far, but never of less than this fraction of the run's largest."""


def valid_outputs(ts, e, w, omega: float) -> int:
    """How many outputs, from the first, an integrated error equation's solution (``e``: |δx| at
    each output; ``w``: the displacement's norm there) is valid for: up to the first output where
    it exceeds ``RELIABLE_PERCENT`` of the largest displacement so far (the linearisation is then
    no longer small), or, where it first grows by more than ``BLOWUP_FACTOR`` within 1/ω_max
    (``omega``, the largest angular speed of the run's frames), up to where that growth began.
    Growth is that of the error relative to the largest displacement so far, against its largest
    value over the 1/ω_max before (its envelope there): at the start of the run both grow from zero
    together, and the error alone grows infinitely fast; and an error that oscillates (a phase error
    of a ringing beam) passes near zero and grows back tenfold within a period without growing at
    all. Against the largest value over the whole run instead, a blow-up that follows an early
    peak is seen late, after it has spoilt the estimate. In the test against ``RELIABLE_PERCENT``
    the largest displacement so far counts as at least ``START_FRACTION`` of the run's largest: at
    the start of a run from rest (a spin-up) both the displacement and its error are far below the
    motion's scale, and below the run's absolute tolerance, and their ratio is not the
    linearisation's size."""
    e, w = np.asarray(e), np.asarray(w)
    w_max = np.maximum.accumulate(w)
    broken = e > RELIABLE_PERCENT / 100.0 * np.maximum(w_max, START_FRACTION * w.max(initial=0.0))
    broken[0] = False
    first = int(np.argmax(broken)) if broken.any() else e.size
    if omega > 0:
        k = max(1, int(np.ceil(1.0 / (omega * (ts[-1] - ts[0]) / max(ts.size - 1, 1)))))
        relative = e / np.where(w_max > 0, w_max, np.inf)
        for i in range(k + 1, first):
            before = relative[max(0, i - 2 * k):i - k + 1].max()  # its envelope over the 1/ω before
            if relative[i] > BLOWUP_FACTOR * max(before, 1e-6):
                return i - k + 1
    return first


@dataclasses.dataclass
class ErrorEstimate:
    """The static-correction estimate of a reduced run (module docstring): the sampled output
    times ``ts``, the estimated error |e(t)| and the displacement |w(t)| there (2-norms over the
    coordinates ``norm_rows`` of ``estimate_error``, all of them by default), ``chi_rel_percent``
    (the estimate of χ_rel), the estimated error of a quantity of interest at each sample,
    ``output_error`` (the correction's rows ``output`` of ``estimate_error``, e.g. the tip's
    displacement; shape (samples, rows), empty without one), and the estimate's compile and run
    times [s]. ``valid_until``: for an error equation integrated along the run
    (``multibody.error_estimate``, ``method="dynamic"``), the last output time at which its
    linearisation held (None: throughout); χ_rel is then over the outputs up to it.
    ``integration_percent``: the run's own time-integration error as χ_rel in per cent, where
    the estimate was made on a repetition of the run at tightened tolerances
    (``reduction.run_error``; None otherwise). ``body_chi_percent``: for a mechanism, each
    reduced body's estimated χ_rel relative to its own deformation ({body index: per cent};
    ``multibody.error_estimate``; None otherwise). ``sensor_integration_percent``: for a mechanism's
    run with its sensors, each compared sensor's time-integration error, χ_rel of its change from
    its initial value against the tightened repetition's ({name: per cent};
    ``scenarios.mechanism_file.run_setup``; None otherwise); ``sensor_chi_percent``: each one's
    basis error (``multibody.error_estimate.estimate_mechanism_error``'s ``sensors``)."""

    ts: np.ndarray
    error_norm: np.ndarray
    displacement_norm: np.ndarray
    chi_rel_percent: float
    output_error: np.ndarray
    compile_s: float
    run_s: float
    valid_until: float | None = None  # where an integrated error equation stopped being valid (None: throughout)
    integration_percent: float | None = None  # the run's own time-integration error (reduction.run_error)
    body_chi_percent: dict | None = None  # a mechanism's: {body: estimated χ_rel on its deformation}
    sensor_integration_percent: dict | None = None  # a mechanism's: {sensor: its integration error's χ_rel}
    sensor_chi_percent: dict | None = None  # a mechanism's: {sensor: its estimated basis error's χ_rel}

    @property
    def reliable(self) -> bool:
        """Whether the estimate is in the range where it is first-order accurate (and, for an
        integrated error equation, valid over the whole run)."""
        throughout = self.valid_until is None or self.valid_until >= self.ts[-1]
        return bool(self.chi_rel_percent <= RELIABLE_PERCENT and throughout)


def lift(reduced, t, p: Float[Array, " k"], v: Float[Array, " k"]):
    """``(q, q̇, q̈)`` in the full RNCF coordinates of the reduced state (p, ṗ), with p̈ solved
    from the reduced equations (linear in p̈: Ī p̈ = −r(t, p, ṗ, 0))."""
    zero = jnp.zeros_like(p)
    r0 = reduced.residual(t, p, v, zero)
    inertia = jax.jacfwd(lambda a: reduced.residual(t, p, v, a))(zero)
    a = -jnp.linalg.solve(inertia, r0)
    return reduced.q_eq.reshape(-1) + reduced.Psi @ p, reduced.Psi @ v, reduced.Psi @ a


def static_correction(full, reduced, t, p: Float[Array, " k"], v: Float[Array, " k"]):
    """The displacement correction e = −K_T⁻¹ r of the lifted state (free coordinates; zero on
    the prescribed ones)."""
    return _correction(full, t, *lift(reduced, t, p, v))


def _correction(full, t, q, qd, qdd):
    """e = −K_T⁻¹ r(t, q, q̇, q̈) of a full state (free coordinates; zero on the prescribed ones)."""
    r = full.residual(t, q, qd, qdd)
    e = -full.factor_iteration_matrix(t, q, qd, 0.0, 0.0, 1.0).solve(r)
    return jnp.where(full.free_mask(), e, 0.0)


@eqx.filter_jit
def _lifted(reduced, ts, ps, vs, norm_rows):
    """The sampled reduced states lifted to full coordinates, and |w| = |q − q̂| on ``norm_rows``."""
    q, qd, qdd = jax.vmap(lambda t, p, v: lift(reduced, t, p, v))(ts, ps, vs)
    w = jax.vmap(lambda p: reduced.coordinates(p).reshape(-1)[norm_rows] - reduced.q_hat.reshape(-1)[norm_rows])(ps)
    return q, qd, qdd, jnp.linalg.norm(w, axis=1)


FACTOR_BATCH = 8
"""How many factorisations of the full tangent are made together where the full model's linear
solver batches them well (``linalg.AbstractLinearSolver.batches_factors``: block-tridiagonal, a
beam chain): the static estimate's samples (a ``vmap`` within each batch, the batches one after
another) and the error equation's outputs (``integrate_error_equation``'s windows). A
factorisation is then the element tangents, their assembly and a block LU (a scan over the nodes
of small LAPACK factorisations): many small operations, whose fixed cost a batch shares. Batches of
a few share it; one batch of all the samples at once can be slower on a fine mesh. The batches are
equal (``_batches``, padded with copies of the last item), so that one program serves them.

Other solvers (``batches_factors`` false) factor one at a time. A dense tangent's LU is one large
LAPACK call, which a batch does not make cheaper, and jaxlib's batched LAPACK LU on the CPU can
hang: the 876-DOF test membrane's static corrections in one batch of 8 hung on 2 cores (a batched
LU of eight such matrices on its own did not; ``linalg.dense.solve_once`` avoids the batched call
for the reduced models). The block LU's node blocks (12 × 12 on the paper's beams) are batched
as in the batched runs of beams (``simulate_batch``). The sparse solver's host callbacks run one
after another under ``vmap`` anyway."""


def _batches(count: int, most: int) -> tuple[int, int]:
    """``(batches, size)`` for ``count`` items: as few batches of at most ``most`` as cover them,
    all of one size, with as little padding as that allows."""
    batches = -(-count // most)
    return batches, -(-count // batches)


def _batch_for(full) -> int:
    """How many of ``full``'s factorisations to make together: ``FACTOR_BATCH`` where its linear
    solver batches them well (``linalg.AbstractLinearSolver.batches_factors``), one otherwise."""
    return FACTOR_BATCH if getattr(getattr(full, "solver", None), "batches_factors", False) else 1


def _padded(x, batches: int, size: int):
    """``x`` (count, ...) as (batches, size, ...), padded with copies of its last item."""
    x = jnp.concatenate([x, jnp.repeat(x[-1:], batches * size - x.shape[0], axis=0)])
    return x.reshape(batches, size, *x.shape[1:])


@eqx.filter_jit
def _corrections(full, ts, q, qd, qdd, norm_rows, rows):
    """|e| on ``norm_rows`` and e[rows] at each sample, in batches (``FACTOR_BATCH``). Apart from
    the lift, so that it is compiled once per full model and sample count, whatever the reduced
    model (``basis_to_tolerance`` tries many reduced sizes against one full model)."""
    batches, size = _batches(ts.shape[0], _batch_for(full))

    def one(t, q, qd, qdd):
        e = _correction(full, t, q, qd, qdd)
        return jnp.linalg.norm(e[norm_rows]), e[rows]

    norms, out = lax.map(lambda x: jax.vmap(one)(*x), tuple(_padded(x, batches, size) for x in (ts, q, qd, qdd)))
    return norms.reshape(-1)[:ts.shape[0]], out.reshape(batches * size, *out.shape[2:])[:ts.shape[0]]


@eqx.filter_jit
def _error_equation(full, ts, q, qd, qdd, norm_rows, rows):
    """``method="dynamic"`` (module docstring): the linearised error equation

        M ë + R_q̇ ė + R_q e = −r(t),    r = R(t, q, q̇, q̈) of the lifted run,

    integrated along the output times (``integrate_error_equation``); |e| on ``norm_rows`` and
    e[rows] at each output. The Newmark iteration matrix is the full model's own
    (``factor_iteration_matrix`` with c_M = 1, c_C = γh, c_K = βh²), the residual's exact
    Jacobian (the elastic tangent and the frame's terms), so one solve a step is exact."""
    g, b = NEWMARK_GAMMA, NEWMARK_BETA
    free = full.free_mask()

    def linearised(t, h, state):
        q, qd, qdd = state
        zero = jnp.zeros_like(q)

        def defect(e, ed, edd, mu):
            r, lin = jax.jvp(lambda x, y, z: full.residual(t, q + x, qd + y, qdd + z), (zero, zero, zero), (e, ed, edd))
            return r + lin

        return defect, full.factor_iteration_matrix(t, q, qd, 1.0, g * h, b * h**2), None

    def measure(_, e):
        e = jnp.where(free, e, 0.0)
        return jnp.linalg.norm(e[norm_rows]), e[rows]

    return integrate_error_equation(ts, (q, qd, qdd), linearised, measure, full.n_dof, batch=_batch_for(full))


def sample_indices(n_out: int, samples: int) -> np.ndarray:
    """``samples`` output indices spread evenly over ``n_out`` outputs, the first and last
    included (all of them when there are fewer)."""
    if samples < 2:
        raise ValueError(f"samples must be at least 2, got {samples}")
    return np.unique(np.round(np.linspace(0, n_out - 1, min(samples, n_out))).astype(int))


def estimate_indices(n_out: int, samples: int, method: str) -> np.ndarray:
    """The outputs (of ``n_out``) at which the estimate of ``method`` evaluates a run:
    ``samples`` of them (``sample_indices``) for ``"static"``, every one for ``"dynamic"``; an
    unknown method is a ``ValueError``."""
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    return sample_indices(n_out, int(samples)) if method == "static" else np.arange(n_out)


def estimate_error(full, reduced, ts, ps, vs, samples: int = 16, output=(), norm_rows=None,
                   method: str = "static") -> ErrorEstimate:
    """The error estimate (module docstring) of the reduced run whose coordinates ``ps`` and
    velocities ``vs`` (each (n_out, k)) were recorded at the output times ``ts``, against the
    full RNCF model ``full`` it was reduced from: ``method="static"``, the static correction at
    ``samples`` of the output times; ``"dynamic"``, the error equation integrated over all of
    them, its validity in ``valid_until`` (``valid_outputs``, with the motion's largest angular
    speed).
    ``output``: indices of full coordinates whose error is wanted on its own (a quantity of
    interest: the tip node's position, say), in ``output_error``. ``norm_rows``: the full
    coordinates the χ_rel norm runs over, as in the measured χ_rel it estimates (default all of
    them; the membrane's and truss's χ_rel take their position vectors only). Compiled once per
    model structure; compile and run timed apart."""
    ts, ps, vs = np.asarray(ts, float), np.asarray(ps, float), np.asarray(vs, float)
    if ps.ndim != 2 or ps.shape != vs.shape or ps.shape[0] != ts.shape[0] or ps.shape[1] != reduced.n_dof:
        raise ValueError(f"ps and vs must be (len(ts), {reduced.n_dof}) = ({ts.shape[0]}, {reduced.n_dof}), got "
                         f"{ps.shape} and {vs.shape}")
    if reduced.Psi.shape[0] != full.n_dof:
        raise ValueError(f"the reduced model's basis has {reduced.Psi.shape[0]} rows; the full model has "
                         f"{full.n_dof} coordinates: pass the full model it was reduced from")
    rows = np.asarray(output, dtype=int).reshape(-1)
    if rows.size and (rows.min() < 0 or rows.max() >= full.n_dof):
        raise ValueError(f"output must index the full model's {full.n_dof} coordinates, got {rows.tolist()}")
    norm_rows = np.arange(full.n_dof) if norm_rows is None else np.asarray(norm_rows, dtype=int).reshape(-1)
    if norm_rows.size == 0 or norm_rows.min() < 0 or norm_rows.max() >= full.n_dof:
        raise ValueError(f"norm_rows must index the full model's {full.n_dof} coordinates")
    idx = estimate_indices(ts.shape[0], samples, method)
    norm_rows = jnp.asarray(norm_rows)
    t_s = jnp.asarray(ts[idx])
    lifted = (reduced, t_s, jnp.asarray(ps[idx]), jnp.asarray(vs[idx]), norm_rows)
    t0 = time.perf_counter()
    lift_c = _lifted.lower(*lifted).compile()
    t1 = time.perf_counter()
    q, qd, qdd, w = jax.block_until_ready(lift_c(*lifted))
    t2 = time.perf_counter()
    args = (full, t_s, q, qd, qdd, norm_rows, jnp.asarray(rows))
    correct = (_corrections if method == "static" else _error_equation).lower(*args).compile()
    t3 = time.perf_counter()
    e, out = jax.block_until_ready(correct(*args))
    t4 = time.perf_counter()
    e, w = np.asarray(e), np.asarray(w)
    valid_until, upto = None, idx.size
    if method == "dynamic":
        omega = float(np.linalg.norm(np.asarray(jax.vmap(full.motion.angular_velocity)(t_s)), axis=1).max())
        upto = valid_outputs(ts, e, w, omega)
        if upto < idx.size:
            valid_until = float(ts[upto - 1])
    den = float(np.sqrt(np.sum(w[:upto] ** 2)))
    chi = 100.0 * float(np.sqrt(np.sum(e[:upto] ** 2))) / den if den > 0 else 0.0
    return ErrorEstimate(ts=ts[idx], error_norm=e, displacement_norm=w, chi_rel_percent=chi,
                         output_error=np.asarray(out), compile_s=(t1 - t0) + (t3 - t2), run_s=(t2 - t1) + (t4 - t3),
                         valid_until=valid_until)


__all__ = ["METHODS", "RELIABLE_PERCENT", "ErrorEstimate", "estimate_error", "estimate_indices",
           "integrate_error_equation", "lift",
           "sample_indices", "static_correction", "valid_outputs"]
