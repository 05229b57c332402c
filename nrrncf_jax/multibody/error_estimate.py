"""A-posteriori error estimate of a reduced mechanism's run (NR-RNCF bodies in floating frames,
joints, drivers, force elements), from the run alone: ``reduction.error_estimate``'s
static correction carried over to a jointed system, and the linearised error equation integrated
along the run, which sees what the static one cannot.

The full model is the same mechanism with each NR-RNCF body replaced by its full-order RNCF
counterpart (``full_counterpart``: the same element body, frame and reference conditions, every
coordinate those conditions leave free, the elements' own elastic force). At an output time the
reduced state (z, ż) is completed by its consistent accelerations and multipliers (z̈, λ) from
the reduced DAE (``consistent_accelerations``) and lifted body by body,

    z_f = (R, e, Ψ̄ p),   ż_f = (Ṙ, ė, Ψ̄ ṗ),   z̈_f = (R̈, ë, Ψ̄ p̈),

Ψ̄ the reduced basis's rows on the full body's free coordinates (the frame coordinates R, e and
the rigid bodies are shared). The full model's residual r = R(z_f, ż_f, z̈_f) + C_zᵀλ is
evaluated there; on each flexible body's deformation coordinates it is what the basis cannot
represent (the reduced equations make its projection on the basis vanish).

``method="static"``: at sampled output times, the displacement correction that would cancel r,
quasi-statically with the body's frame and the joints' reactions held, one solve a body,
K_b e_b = −r_b (K_b the full body's deformation block with the inertia terms' derivatives,
``Mechanism.tangent_blocks``): the correction of a cantilever held by its frame. Cheap (a few
small solves a sample), but blind to error in the mechanism's own motion: a reduced body slightly
too stiff or too soft moves its joints and the frames beyond them a little differently, and that
difference is carried and amplified over the run (the phase of a swinging chain), while the
residual at any one instant is of the size of the deformation error only.

K_b is not the body's elastic stiffness: its inertia terms (the frame's rotation and angular
acceleration acting on the deformation) soften it, and on a soft body swinging fast they carry
it through singular (K_b's eigenvalues cross zero, and it is indefinite for a while). There the
quasi-static premise fails (the body's response to the residual is not static), and a plain
solve K_b⁻¹r amplifies it without bound: which samples land near a crossing is chance, so such
an estimate could change several-fold between two tolerances of one run. The correction is
therefore solved in the Tikhonov sense, e_b = −Σ_i v_i σ_i/(σ_i² + μ²) u_iᵀ r_b over K_b's
singular triplets, with μ = σ_min(K_e)/2 (``COMPLIANCE_CAP``), K_e the body's elastic block in
the reference state: no direction is then more compliant than the elastic body's most compliant
one, 1/σ_min(K_e) (σ/(σ² + μ²) ≤ 1/(2μ)). A direction as stiff as that loses a fifth of its
correction; a stiffer one, less than (μ/σ)². The estimate is a smooth function of the run's states.

``method="dynamic"``: the full equations linearised about the lifted run, for the error
e = z − z_f of every coordinate (frames included) and the multipliers' error μ,

    R_z̈ ë + R_ż ė + R_z e + C_zᵀμ = −r(t),    C_z e = −C(z_f),    e(0) = ė(0) = 0,

integrated over the output times by Newmark's rule; δx = ∂x/∂z e on the position vectors. It
carries the error through the mechanism's motion, drift included, and tracks the measured error
output by output where the linearisation holds. Where the linearised equations are unstable
(again a soft beam in compression, which buckles, where the nonlinear motion stays bounded) its
solution grows without bound: the first output where |δx| exceeds ``RELIABLE_PERCENT`` of the
largest displacement so far ends its validity (``ErrorEstimate.valid_until``; χ_rel is then over
the outputs before it, and the estimate says it is not reliable;
``reduction.error_estimate.valid_outputs``). It costs a factorisation of
the full model's constrained iteration matrix an output, as much as a few steps of the full
run: output intervals of the order of the motion's time scale, not of the integrator's steps.

Either way the estimate of χ_rel is 100 √(Σ_t |δx(t)|²) / √(Σ_t |w(t)|²) over the flexible
bodies' position vectors, w(t) their displacement from the run's first output: the norm of
``scenarios.pendulum.PendulumRun.compare``."""

import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from .._types import Array, Float
from ..reduction.error_estimate import (
    NEWMARK_BETA,
    NEWMARK_GAMMA,
    ErrorEstimate,
    estimate_indices,
    integrate_error_equation,
    valid_outputs,
)
from .floating import FloatingBody, rigid_motions_left, rotation
from .full_order_frame import full_floating_body
from .mechanism import Mechanism
from .sensors import observe


def _reduced(body) -> bool:
    return isinstance(body, FloatingBody) and body.k > 0 and not body.tensors.full_order


def full_counterpart(system: Mechanism) -> Mechanism:
    """The full-order mechanism of a reduced one: each NR-RNCF ``FloatingBody`` replaced by the
    full-order RNCF body of the same element body, frame origin and orientation, with every
    nodal coordinate its reference conditions leave free (``FloatingBody.free``;
    ``full_floating_body``); every other body, the joints, gravity and the force elements as
    they are. A planar body's ``free`` (``reduce(plane_normal=...)``) holds the coordinates odd
    under the plane's mirror, which the full planar motion leaves at zero too. A mean-axis body's
    ``free`` leaves rigid motions free: its counterpart holds them by the mean-axis conditions
    (``full_floating_body(mean_axis=True)``), constraints that its reduced basis meets already."""
    if not isinstance(system, Mechanism):
        raise ValueError(f"system must be a Mechanism (FloatingFrameSystem), got {type(system).__name__}")
    if not any(_reduced(b) for b in system.bodies):
        raise ValueError("the system has no NR-RNCF body (a FloatingBody with a reduced basis) to estimate")
    if any(_reduced(b) and b.free is None for b in system.bodies):
        raise ValueError("an NR-RNCF body does not record its free coordinates (its reference conditions): build it "
                         "with multibody.reduce, or pass free= to FloatingBody")
    bodies = [full_floating_body(b.body, np.asarray(b.free), R0=b.R0, A0=np.asarray(rotation(b.e0)),
                                 mean_axis=bool(rigid_motions_left(b.body, np.asarray(b.free)).shape[1]))
              if _reduced(b) else b for b in system.bodies]
    return type(system)(bodies, system.joints, gravity=system.gravity, forces=system.forces)


def _lift_maps(full: Mechanism, reduced: Mechanism) -> list:
    """For each body, the matrix Ψ̄ (full body's deformation coordinates × reduced ones) that lifts
    p, or None where the two bodies are the same kind of body (z copied). Checks that the
    systems correspond (``ValueError``)."""
    if len(full.bodies) != len(reduced.bodies) or full.n_joint_equations != reduced.n_joint_equations:
        raise ValueError("full and reduced must be the same mechanism (bodies, joints), the full one with full-order "
                         "bodies: build it with full_counterpart(reduced)")
    maps = []
    for k, (bf, br) in enumerate(zip(full.bodies, reduced.bodies)):
        if not _reduced(br):
            if full.body_sizes()[k] != reduced.body_sizes()[k]:
                raise ValueError(f"body {k}: the full and reduced systems' bodies differ")
            maps.append(None)
            continue
        if not (isinstance(bf, FloatingBody) and bf.tensors.full_order) or \
                bf.body.n_dof != br.body.n_dof or not np.allclose(np.asarray(bf.body.q_hat), np.asarray(br.body.q_hat)):
            raise ValueError(f"body {k}: the full system's body must be the full-order RNCF body of the reduced one's "
                             "element body (full_counterpart)")
        sel, Psi = np.asarray(bf.basis), np.asarray(br.basis)
        P = sel.T @ Psi
        if np.abs(sel @ P - Psi).max() > 1e-9 * max(np.abs(Psi).max(), 1.0):
            raise ValueError(f"body {k}: the reduced basis moves coordinates the full body holds")
        maps.append(jnp.asarray(P))
    return maps


def _lift(maps, reduced: Mechanism, y):
    """A reduced mechanism's stacked coordinates (or velocities, accelerations) in the full one's."""
    parts = [yb if P is None else jnp.concatenate([yb[:7], P @ yb[7:]]) for P, yb in zip(maps, reduced.split(y))]
    return jnp.concatenate(parts)


def _positions(system: Mechanism, z, flexible) -> Float[Array, " n"]:
    """The flexible bodies' nodal vectors in the inertial frame, stacked, zero but on the
    position vectors."""
    xs = system.nodal_vectors(z)
    return jnp.concatenate([(system.bodies[b].is_position[:, None] * xs[b]).reshape(-1) for b in flexible])


def _body_norms(system: Mechanism, x, flexible) -> Float[Array, " b"]:
    """|x_b| of each flexible body's part of a stacked ``_positions`` vector."""
    sizes = [3 * system.bodies[b].n_vectors for b in flexible]
    ends = np.cumsum(sizes)
    return jnp.stack([jnp.linalg.norm(x[e - n:e]) for n, e in zip(sizes, ends)])


def _deformations(reduced: Mechanism, z, flexible) -> Float[Array, " b"]:
    """|Ψ p| of each flexible body on its position vectors: its deformation, the same in its
    frame and in space (a rotation does not change a norm), without the frame's rigid motion."""
    parts = reduced.split(z)
    out = []
    for b in flexible:
        body = reduced.bodies[b]
        w = body.is_position[:, None] * (body.basis @ parts[b][7:]).reshape(-1, 3)
        out.append(jnp.linalg.norm(w))
    return jnp.stack(out)


def _lift_multipliers(full: Mechanism, reduced: Mechanism, lam):
    """The reduced mechanism's multipliers in the full one's layout (the joints', then each
    body's own equations'): zero on the equations only the full bodies have (a full-order
    mean-axis body's conditions, which the reduced basis meets by construction)."""
    if full.n_constraints == reduced.n_constraints:
        return lam
    m = reduced.n_joint_equations
    parts, at = [lam[:m]], m
    for bf, br in zip(full.bodies, reduced.bodies):
        parts.append(lam[at:at + br.n_own_equations])
        parts.append(jnp.zeros(bf.n_own_equations - br.n_own_equations, lam.dtype))
        at += br.n_own_equations
    return jnp.concatenate(parts)


def _lifted_state(maps, full: Mechanism, reduced: Mechanism, t, z, v):
    """(z_f, ż_f, z̈_f, λ): the reduced state completed by its consistent accelerations and
    multipliers, lifted to the full mechanism's coordinates."""
    a, lam = reduced.consistent_accelerations(t, z, v)
    zf, vf, af = (_lift(maps, reduced, y) for y in (z, v, a))
    return zf, vf, af, _lift_multipliers(full, reduced, lam)


def _sensor_errors(observer, t, zf, vf, e) -> dict:
    """The sensors' first-order errors ∂s/∂z e at the lifted state (each sensor of ``observer``,
    ``sensors.observe`` on the full mechanism; None: none)."""
    if observer is None:
        return {}
    return jax.jvp(lambda y: observer(t, y, vf), (zf,), (e,))[1]


COMPLIANCE_CAP = 0.5
"""μ of the static correction's Tikhonov solve, in units of σ_min(K_e) (module docstring): the
largest compliance the correction applies, 1/(2μ), is then the elastic body's largest."""


def _tikhonov_solve(K, r, mu):
    """x = (KᵀK + μ²I)⁻¹Kᵀr = Σ_i v_i σ_i/(σ_i² + μ²) u_iᵀ r: K⁻¹r where K is well above μ, bounded
    where it is near singular. By the augmented system [[μI, K], [Kᵀ, −μI]] [y; x] = [r; 0], whose
    eigenvalues are ±√(σ_i² + μ²): its condition is at most K's, where the normal equations' would
    be K's squared; one LU of twice the size costs a third of K's SVD."""
    n = K.shape[0]
    eye = jnp.eye(n, dtype=K.dtype)
    A = jnp.block([[mu * eye, K], [K.T, -mu * eye]])
    return jnp.linalg.solve(A, jnp.concatenate([r, jnp.zeros_like(r)]))[n:]


def _elastic_floors(full: Mechanism, flexible) -> tuple:
    """μ = ``COMPLIANCE_CAP`` σ_min(K_e) of each flexible body, K_e its deformation block in the
    mechanism's reference state at rest (no inertia terms, no reactions)."""
    z = full.reference()
    blocks = full.tangent_blocks(0.0, z, jnp.zeros_like(z), jnp.zeros_like(z), jnp.zeros(full.n_constraints, z.dtype))
    return tuple(COMPLIANCE_CAP * jnp.linalg.svd(blocks[b][7:, 7:], compute_uv=False)[-1] for b in flexible)


@eqx.filter_jit
def _mechanism_corrections(full, reduced, maps, ts, zs, vs, flexible, observer=None):
    """|e_b| over each flexible body's position vectors at each sample, (samples, bodies), and
    the ``observer``'s sensors' errors under the corrections (``_sensor_errors``; the frames
    held, as the corrections hold them) (``lax.map``: one sample after another, as
    ``reduction.error_estimate`` does, for the same reason). Each correction by
    ``_tikhonov_solve`` (module docstring)."""
    floors = _elastic_floors(full, flexible)

    def one(args):
        t, z, v = args
        zf, vf, af, lam = _lifted_state(maps, full, reduced, t, z, v)
        r = full.split(full.residual(t, zf, vf, af) + full.constraint_force(zf, lam, t))
        blocks = full.tangent_blocks(t, zf, vf, af, lam)
        norms, parts = [], [jnp.zeros_like(y) for y in full.split(zf)]
        for b, mu in zip(flexible, floors):
            body = full.bodies[b]
            e = -_tikhonov_solve(blocks[b][7:, 7:], r[b][7:], mu)
            parts[b] = jnp.concatenate([jnp.zeros(7, e.dtype), e])
            dq = (body.basis @ e).reshape(-1, 3)
            norms.append(jnp.sqrt(jnp.sum(body.is_position[:, None] * dq**2)))
        return jnp.stack(norms), _sensor_errors(observer, t, zf, vf, jnp.concatenate(parts))
    return lax.map(one, (ts, zs, vs))


REFINEMENTS = 3
"""Corrections a step of the error equation solves with its iteration matrix, each on the exact
defect (the matrix leaves out the joints' Hessian and the frames' inertia derivatives, as the
integrator's does): the linear step's equations to far below the estimate's own accuracy."""


@eqx.filter_jit
def _error_equation(full, reduced, maps, ts, zs, vs, flexible, observer=None):
    """The linearised error equation integrated along the run (``method="dynamic"``): |δx(t)| of
    the flexible bodies' position vectors at each output time.

    The full equations R(z, ż, z̈) + C_zᵀλ = 0, C(z) = 0, linearised about the lifted run
    (z_f, ż_f, z̈_f, λ) for the error e = z − z_f and the multipliers' error μ:

        R_z̈ ë + R_ż ė + R_z e + C_zᵀ μ = −r(t),    C_z e = −C(z_f),

    r the lifted residual (the static estimate's), integrated from e = ė = 0 over the output
    times (``reduction.error_estimate.integrate_error_equation``); each step's linear equations
    solved by the full model's constrained iteration matrix (``factor_augmented``) with
    ``REFINEMENTS`` corrections on the exact defect (its products R_z e, ... by forward-mode
    derivatives). δx = ∂x/∂z e, its norm over each flexible body's position vectors, and the
    ``observer``'s sensors' errors ∂s/∂z e (``_sensor_errors``)."""
    g, b = NEWMARK_GAMMA, NEWMARK_BETA
    n, m = full.n_dof, full.n_constraints

    def linearised(t, h, state):
        zf, vf, af, lam = _lifted_state(maps, full, reduced, t, *state)

        def F(dz, dv, da, mu):
            return (full.residual(t, zf + dz, vf + dv, af + da) + full.constraint_force(zf + dz, lam, t)
                    + full.constraint_force(zf, mu, t))

        zero_n, zero_m = jnp.zeros(n, zf.dtype), jnp.zeros(m, zf.dtype)
        c_f = full.constraints(zf, t)

        def defect(e, ed, edd, mu):
            r, lin = jax.jvp(F, (zero_n, zero_n, zero_n, zero_m), (e, ed, edd, mu))
            c = c_f + jax.jvp(lambda y: full.constraints(y, t), (zf,), (e,))[1]
            return jnp.concatenate([r + lin, c / (b * h**2)])

        return defect, full.factor_augmented(t, zf, vf, lam, g * h, b * h**2, a=af), (zf, vf, t)

    def position_error(lifted, e):
        zf, vf, t = lifted
        norms = _body_norms(full, jax.jvp(lambda y: _positions(full, y, flexible), (zf,), (e,))[1], flexible)
        return norms, _sensor_errors(observer, t, zf, vf, e)

    return integrate_error_equation(ts, (zs, vs), linearised, position_error, n, m, REFINEMENTS)


def _frames_speed(reduced: Mechanism, vs) -> float:
    """The floating frames' largest angular speed over the run, |ω| = 2|ė| (0 without frames)."""
    parts = zip(reduced.bodies, reduced.split(np.asarray(vs).T))  # each body's (n_b, n_out)
    frames = [vb[3:7] for b, vb in parts if isinstance(b, FloatingBody)]
    return max((2.0 * float(np.linalg.norm(f, axis=0).max()) for f in frames), default=0.0)


def estimate_mechanism_error(full: Mechanism, reduced: Mechanism, ts, zs, vs, samples: int = 16,
                             method: str = "static", sensors: dict | None = None) -> ErrorEstimate:
    """The error estimate (module docstring) of the reduced mechanism's run whose coordinates
    ``zs`` and velocities ``vs`` (each (n_out, n_dof)) were recorded at the output times ``ts``,
    against ``full`` (``full_counterpart(reduced)``): ``method="static"`` at ``samples`` of the
    output times, ``"dynamic"`` (the integrated error equation) over all of them, its validity
    in ``valid_until``. χ_rel over the flexible bodies' position vectors, their displacement from
    the first output; and each reduced body's on its deformation (``body_chi_percent``: its
    position vectors' error over its deformation Ψp, without the frame's rigid motion, which in a
    mechanism can be far larger than the deformation and would make a basis that misses the
    deformation read as accurate). ``sensors`` ({name: sensor}, ``multibody.sensors``, of the
    reduced mechanism, whose markers the full one shares): each one's estimated error, its first
    order change ∂s/∂z e under the state's estimated error e, evaluated on the full mechanism,
    as χ_rel of the sensor's change from its value at the first output (``sensor_chi_percent``;
    the static estimate holds the frames, so a sensor on a rigid body reads none of the basis's
    error there, which the dynamic one carries through the joints). Compile and run timed apart
    (``compile_s``, ``run_s``)."""
    ts, zs, vs = np.asarray(ts, float), np.asarray(zs, float), np.asarray(vs, float)
    if zs.ndim != 2 or zs.shape != vs.shape or zs.shape[0] != ts.shape[0] or zs.shape[1] != reduced.n_dof:
        raise ValueError(f"zs and vs must be (len(ts), {reduced.n_dof}) = ({ts.shape[0]}, {reduced.n_dof}), got "
                         f"{zs.shape} and {vs.shape}")
    idx = estimate_indices(ts.shape[0], samples, method)
    maps = _lift_maps(full, reduced)
    if method == "static" and any(getattr(b, "mean_axis_rows", None) is not None for b in full.bodies):
        raise ValueError(
            "the static estimate corrects each body's deformation with its frame held, where a joint holds it; "
            "a mean-axis body's frame sits at its centre of mass and no joint holds it, so the static correction "
            "misses the error in where the body lies between its joints (it reads several times low): estimate a "
            "mechanism with mean-axis bodies by method='dynamic' (the linearised error equation of the whole "
            "mechanism)")
    flexible = tuple(b for b, P in enumerate(maps) if P is not None)
    observer = observe(full, dict(sensors)) if sensors else None  # the markers resolved on the full bodies
    args = (full, reduced, maps, jnp.asarray(ts[idx]), jnp.asarray(zs[idx]), jnp.asarray(vs[idx]), flexible,
            observer)
    fn = _mechanism_corrections if method == "static" else _error_equation
    t0 = time.perf_counter()
    compiled = fn.lower(*args).compile()
    t1 = time.perf_counter()
    e_bodies, ds = jax.block_until_ready(compiled(*args))  # (samples, flexible bodies), {sensor: (samples, ...)}
    e_bodies = np.asarray(e_bodies)
    t2 = time.perf_counter()
    e = np.sqrt(np.sum(e_bodies**2, axis=1))
    x0 = _positions(reduced, jnp.asarray(zs[0]), flexible)
    w = np.asarray(jax.vmap(lambda z: jnp.linalg.norm(_positions(reduced, z, flexible) - x0))(jnp.asarray(zs[idx])))
    valid_until, upto = None, idx.size
    if method == "dynamic":
        upto = valid_outputs(ts, e, w, _frames_speed(reduced, vs))
        if upto < idx.size:
            valid_until = float(ts[upto - 1])

    def chi_of(err, ref):
        den = float(np.sqrt(np.sum(ref[:upto] ** 2)))
        return 100.0 * float(np.sqrt(np.sum(err[:upto] ** 2))) / den if den > 0 else 0.0

    d = np.asarray(jax.vmap(lambda z: _deformations(reduced, z, flexible))(jnp.asarray(zs[idx])))
    bodies = {b: chi_of(e_bodies[:, i], d[:, i]) for i, b in enumerate(flexible)}
    per_sensor = None
    if sensors:
        on_run = observe(reduced, dict(sensors))
        values = jax.vmap(on_run)(jnp.asarray(ts[idx]), jnp.asarray(zs[idx]), jnp.asarray(vs[idx]))
        first = on_run(ts[0], jnp.asarray(zs[0]), jnp.asarray(vs[0]))
        per_sensor = {}
        for name in sensors:
            err = np.asarray(ds[name]).reshape(idx.size, -1)
            change = (np.asarray(values[name]) - np.asarray(first[name])).reshape(idx.size, -1)
            per_sensor[name] = chi_of(np.linalg.norm(err, axis=1), np.linalg.norm(change, axis=1))
    return ErrorEstimate(ts=ts[idx], error_norm=e, displacement_norm=w, chi_rel_percent=chi_of(e, w),
                         output_error=np.zeros((idx.size, 0)), compile_s=t1 - t0, run_s=t2 - t1,
                         valid_until=valid_until, body_chi_percent=bodies, sensor_chi_percent=per_sensor)



def flexible_bodies(system: Mechanism) -> tuple[int, ...]:
    """The indices of ``system``'s reduced (NR-RNCF) bodies: those whose error the estimate measures."""
    return tuple(b for b, body in enumerate(system.bodies) if _reduced(body))


def integration_error_percent(system: Mechanism, zs, zs_tight) -> float:
    """The time-integration error of a reduced mechanism's run whose coordinates ``zs`` were
    recorded at its output times, against a repetition at tightened tolerances (``zs_tight``, the
    same times): χ_rel in per cent over the flexible bodies' position vectors and every output,
    the norm of ``estimate_mechanism_error``'s χ_rel (the displacement from the first output of the
    repetition), so that the two parts of a run's error add on one norm (the triangle inequality).
    The repetition's own error is about ``reduction.run_error.TIGHTEN`` times smaller than the
    run's, which this then measures."""
    zs, zs_tight = np.asarray(zs, float), np.asarray(zs_tight, float)
    if zs.shape != zs_tight.shape or zs.ndim != 2 or zs.shape[1] != system.n_dof:
        raise ValueError(f"zs and zs_tight must both be (outputs, {system.n_dof}), got {zs.shape} and "
                         f"{zs_tight.shape}")
    flexible = flexible_bodies(system)
    if not flexible:
        raise ValueError("the system has no reduced (NR-RNCF) body whose error this would measure")
    x = jax.vmap(lambda z: _positions(system, z, flexible))
    run, rep = np.asarray(x(jnp.asarray(zs))), np.asarray(x(jnp.asarray(zs_tight)))
    den = float(np.linalg.norm(rep - rep[:1]))
    return 100.0 * float(np.linalg.norm(run - rep)) / den if den > 0 else 0.0


__all__ = ["estimate_mechanism_error", "flexible_bodies", "full_counterpart", "integration_error_percent"]
