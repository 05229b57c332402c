"""Full-order equations of one body whose reference frame follows a prescribed motion
(``motion.AbstractMotion``: rotation A(t), angular velocity ω(t) and acceleration ω̇(t) in the
reference frame, and the acceleration r̈₀ of its origin).

- ``RotatingFrameModel`` (RNCF, Eqs. 8 and 41): coordinates in the reference frame attached to
  the clamped root, ``M_αβ [q̈_β + 2ω̃ q̇_β + (ω̇̃ + ω̃ω̃) q_β] + F^α(q) = Q_α``, where Q includes
  the uniform load ``ϱ_α Aᵀ(g − r̈₀)`` of gravity and of the frame's translation. For a spin
  θ(t) about a fixed axis e, ω = θ̇ e. The reference conditions (the root's position and
  cross-section vectors) are eliminated as fixed coordinates. Optional Rayleigh damping adds
  ``D q̇`` (``damping.RayleighDamping``).
- ``InertialFrameModel`` (ANCF: docs/theory.md, §3 Equations of motion of one body): the same body
  with A = I; the root's clamped vectors are driven by the motion,
  ``q_root(t) = A(t) q̂_root (+ r₀(t) for positions)``.

The mass products ``M q̈`` use the assembled scalar M_αβ for bodies up to
``DENSE_MASS_MAX_VECTORS`` nodal vectors and element-wise products above (no n × n matrix).
"""

import abc

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._types import Array, Bool, Float, Int, Scalar
from .._validate import is_concrete
from ..bodies.body import DENSE_MASS_MAX_VECTORS, Body
from ..linalg import AbstractLinearSolver, linear_solver
from ..motion import AbstractMotion, skew
from .base import AbstractModel
from .damping import RayleighDamping


class Harmonic(eqx.Module):
    """The time history ``sin(2π f t + phase)`` of a load (``Loads(point_history=...)``)."""

    frequency: Float[Array, ""]  # [Hz]
    phase: Float[Array, ""]  # [rad]

    def __init__(self, frequency, phase=0.0):
        self.frequency = jnp.asarray(frequency, dtype=float)
        self.phase = jnp.asarray(phase, dtype=float)

    def __call__(self, t: Scalar) -> Float[Array, ""]:
        return jnp.sin(2.0 * jnp.pi * self.frequency * t + self.phase)


class Loads(eqx.Module):
    """External loads. ``gravity`` is an acceleration in the inertial frame; point forces act
    on nodal vectors (e.g. the tip's position vector) and are given in the reference frame,
    constant, or ``point_forces × point_history(t)`` with a scalar history such as ``Harmonic``."""

    gravity: Float[Array, " 3"]
    point_vectors: Int[Array, " k"]
    point_forces: Float[Array, "k 3"]
    point_history: eqx.Module | None

    def __init__(self, gravity=None, point_vectors=(), point_forces=None, point_history=None):
        self.gravity = jnp.zeros(3) if gravity is None else jnp.asarray(gravity, dtype=float).reshape(3)
        self.point_vectors = jnp.asarray(point_vectors, dtype=int).reshape(-1)
        k = self.point_vectors.shape[0]
        pf = jnp.zeros((k, 3)) if point_forces is None else jnp.asarray(point_forces, dtype=float)
        if pf.shape != (k, 3):
            raise ValueError(f"point_forces must have shape ({k}, 3) to match point_vectors, got {pf.shape}")
        self.point_forces = pf
        if point_history is not None and not callable(point_history):
            raise ValueError(f"point_history must be a function of time (e.g. Harmonic), got {point_history!r}")
        self.point_history = point_history

    def point_scale(self, t: Scalar) -> Float[Array, ""]:
        """The point forces' factor at time t (1 without a history)."""
        return jnp.ones(()) if self.point_history is None else self.point_history(t)

    def generalized(self, body: Body, A_T_g: Float[Array, " 3"], t: Scalar = 0.0) -> Float[Array, "n 3"]:
        """Q_α = ∫ S_α f dV in the reference frame at time t, for gravity ``Aᵀg`` there (Eq. 12)."""
        Q = body.varrho()[:, None] * A_T_g[None, :]
        if self.point_history is None:  # the constant-load path as it was (same operations)
            return Q.at[self.point_vectors].add(self.point_forces)
        return Q.at[self.point_vectors].add(self.point_forces * self.point_scale(t))


class _FullOrderModel(AbstractModel):
    body: Body
    motion: AbstractMotion
    loads: Loads
    clamped: Int[Array, " c"]  # nodal vectors fixed in the reference frame
    M: Float[Array, "n n"] | None  # scalar M_αβ, assembled once; None for large bodies (see mass_times)
    damping: RayleighDamping | None
    D_e: tuple | None  # per group, (element blocks of D = αM + βK̂, their DOFs); None: undamped

    solver: AbstractLinearSolver  # the iteration matrix's linear solver, resolved once at construction

    def __init__(self, body: Body, motion: AbstractMotion, *, loads: Loads | None = None, clamped=None,
                 damping: RayleighDamping | None = None, solver="auto"):
        if not isinstance(motion, AbstractMotion):
            raise ValueError(f"motion must be a motion.AbstractMotion (e.g. SpinUp, Stationary), got "
                             f"{type(motion).__name__}")
        self.body = body
        self.solver = _linear_solver(body, solver)
        self.motion = motion
        self.loads = Loads() if loads is None else loads
        # Default reference conditions: the root node's position and cross-section vectors
        # (r, r_y, r_z): the root section is clamped to the hub.
        if clamped is None and not body.chain:
            raise ValueError("clamped (the nodal vectors fixed in the reference frame) must be given for a body "
                             "that is not a beam chain: without reference conditions its stiffness is singular")
        self.clamped = jnp.asarray([0, 2, 4] if clamped is None else clamped, dtype=int)
        if is_concrete(self.clamped):
            c = np.asarray(self.clamped)
            if c.ndim != 1 or c.size == 0 or c.min() < 0 or c.max() >= body.n_vectors:
                raise ValueError(f"clamped must list nodal vectors of the body (0..{body.n_vectors - 1}), got "
                                 f"{c.tolist()}")
        self.M = body.mass_matrix() if body.n_vectors <= DENSE_MASS_MAX_VECTORS else None
        if damping is not None and not isinstance(damping, RayleighDamping):
            raise ValueError(f"damping must be a RayleighDamping or None, got {type(damping).__name__}")
        self.damping = damping
        if damping is None:
            self.D_e = None
        else:
            # Per element group: D_e = α M_e ⊗ I3 + β K̂_e, with its DOFs.
            self.D_e = tuple(
                (damping.alpha * _kron_eye3(M_e) + damping.beta * K_hat, dofs)
                for (K_hat, dofs), (M_e, _) in zip(body.tangent_parts(body.q_hat), body.mass_parts())
            )

    @property
    def n_dof(self) -> int:
        return self.body.n_dof

    def free_mask(self) -> Bool[Array, " n"]:
        if is_concrete(self.clamped):
            # Outside a trace (the offline stage, input checks): NumPy, since the jnp scatter
            # compiles a dozen small kernels op by op on every cold start.
            fixed = np.zeros((self.body.n_vectors, 3), bool)
            fixed[np.asarray(self.clamped)] = True
            return jnp.asarray(~fixed.reshape(-1), dtype=bool)
        fixed = jnp.zeros((self.body.n_vectors, 3), bool).at[self.clamped].set(True)
        return ~fixed.reshape(-1)

    def with_motion(self, motion: AbstractMotion) -> "_FullOrderModel":
        """This model under another prescribed motion."""
        if not isinstance(motion, AbstractMotion):
            raise ValueError(f"motion must be a motion.AbstractMotion, got {type(motion).__name__}")
        return eqx.tree_at(lambda m: m.motion, self, motion)

    def rotation(self, t: Scalar) -> Float[Array, "3 3"]:
        return self.motion.rotation(t)

    def mass_times(self, X: Float[Array, "n ..."]) -> Float[Array, "n ..."]:
        """Σ_β M_αβ X_β: the assembled M for small bodies, element by element for large ones."""
        return self.body.mass_product(X) if self.M is None else self.M @ X

    @abc.abstractmethod
    def displacements(self, t: Scalar, q: Float[Array, " n"]) -> Float[Array, "nv 3"]:
        """Nodal displacements ``w = q − q̂`` in the rotating reference frame (docs/theory.md, §9
        Accuracy measures and checks)."""

    def damping_force(self, v: Float[Array, " n"]) -> Float[Array, " n"]:
        """D v with D = αM + βK̂, assembled from the element blocks (zero when undamped)."""
        Dv = jnp.zeros_like(v)
        for D_e, dofs in self.D_e or ():
            Dv = Dv.at[dofs].add(jnp.einsum("eab,eb->ea", D_e, v[dofs]))
        return Dv

    def _factor(self, t, q, v, c_M, c_C, c_K, frame_C, frame_K):
        """Iteration matrix from element blocks, group by group:
        c_M M + c_C (M⊗frame_C + D) + c_K (K + M⊗frame_K)."""
        body = self.body
        frame = c_M * jnp.eye(3) + c_C * frame_C + c_K * frame_K
        parts = []
        for k, ((Kt, dofs), (M_e, _)) in enumerate(zip(body.tangent_parts(q.reshape(-1, 3)), body.mass_parts())):
            G = c_K * Kt + _kron_eye3(M_e, frame)
            if self.D_e is not None:
                G = G + c_C * self.D_e[k][0]
            parts.append((G, dofs))
        return self.solver.factor(parts, self.free_mask())


def _linear_solver(body: Body, solver) -> AbstractLinearSolver:
    """The iteration matrix's linear solver for this body (``linalg.linear_solver``: ``"auto"``
    takes block-tridiagonal for a beam chain, dense for small bodies, sparse for large ones, with
    its pattern), decided once from the body's static connectivity."""
    dofs = [g.dofs() for g in body.groups]
    shapes = [(np.broadcast_to(0.0, (d.shape[0], d.shape[1], d.shape[1])), d) for d in dofs]
    block = 3 * body.vectors_per_node if body.chain else None
    return linear_solver(solver, shapes, body.n_dof, chain_block=block)


def _kron_eye3(M_e: Float[Array, "n_el ne ne"], B: Float[Array, "3 3"] | None = None) -> Float[Array, "n_el nd nd"]:
    """Element blocks of ``M_e ⊗ B`` (B = I3 by default) as flat ``(n_el, 3n_e, 3n_e)`` matrices."""
    n_el, ne = M_e.shape[:2]
    B = jnp.eye(3) if B is None else B
    return jnp.einsum("eab,ij->eaibj", M_e, B).reshape(n_el, 3 * ne, 3 * ne)


class RotatingFrameModel(_FullOrderModel):
    """Full RNCF body in the frame rotating with the clamped root (Eq. 41)."""

    def initial_state(self, t0):
        q0 = self.body.q_hat.reshape(-1)
        return q0, jnp.zeros_like(q0)

    def constrain(self, t, q, v, a):
        free = self.free_mask()
        q = jnp.where(free, q, self.body.q_hat.reshape(-1))
        return q, jnp.where(free, v, 0.0), jnp.where(free, a, 0.0)

    def residual(self, t, q, v, a):
        Q, V, Acc = (x.reshape(-1, 3) for x in (q, v, a))
        # a_α = q̈_α + 2ω×q̇_α + ω̇×q_α + ω×(ω×q_α)   (Eq. 8)
        coriolis, euler, centrifugal = self.motion.frame_terms(t, Q, V)
        rel = Acc + coriolis + euler + centrifugal
        # Gravity and the frame's translation act as one uniform acceleration, g − r̈₀ (Eq. 12).
        A_T_g = self.rotation(t).T @ (self.loads.gravity - self.motion.origin_acceleration(t))
        r = self.mass_times(rel) + self.body.elastic_force(Q) - self.loads.generalized(self.body, A_T_g, t)
        r = r.reshape(-1) + self.damping_force(v)
        return jnp.where(self.free_mask(), r, 0.0)

    def factor_iteration_matrix(self, t, q, v, c_M, c_C, c_K):
        W, Wd, WW = self.motion.frame_matrices(t)
        return self._factor(t, q, v, c_M, c_C, c_K, 2.0 * W, Wd + WW)

    def displacements(self, t, q):
        return q.reshape(-1, 3) - self.body.q_hat


class InertialFrameModel(_FullOrderModel):
    """Full ANCF body in the inertial frame; the clamped root vectors follow the rotation.

    Undamped only: Rayleigh damping acts on the velocity relative to the rotating frame, which
    the inertial coordinates do not separate from the rigid spin (use ``RotatingFrameModel``).
    """

    def __init__(self, body: Body, motion: AbstractMotion, *, loads: Loads | None = None, clamped=None,
                 damping: RayleighDamping | None = None, solver="auto"):
        if damping is not None:
            raise ValueError("InertialFrameModel (ANCF) is undamped: Rayleigh damping acts on the velocity "
                             "relative to the rotating frame; use RotatingFrameModel (RNCF)")
        super().__init__(body, motion, loads=loads, clamped=clamped, solver=solver)

    def _rigid_motion(self, t, q_hat):
        """Nodal vectors ``q_hat`` carried rigidly by the frame: ``(A q̂ (+ r₀), Ȧ q̂ (+ ṙ₀), Ä q̂ (+ r̈₀))``
        as rows, the origin terms on position vectors only; Ȧ = (Aω)~ A and
        Ä = ((Aω̇)~ + (Aω)~(Aω)~) A."""
        A = self.rotation(t)
        W = skew(A @ self.motion.angular_velocity(t))  # ω in the inertial frame
        Wd = skew(A @ self.motion.angular_acceleration(t))
        return q_hat @ A.T, W, Wd + W @ W

    def _root_motion(self, t):
        root, W, W2 = self._rigid_motion(t, self.body.q_hat[self.clamped])
        vel = root @ W.T
        acc = root @ W2.T
        pos = self.body.is_position[self.clamped][:, None]
        r0, v0 = self.motion.origin(t)
        a0 = self.motion.origin_acceleration(t)
        return (jnp.where(pos, root + r0, root), jnp.where(pos, vel + v0, vel), jnp.where(pos, acc + a0, acc))

    def initial_state(self, t0):
        q0, W, _ = self._rigid_motion(t0, self.body.q_hat)
        v0 = q0 @ W.T
        pos = self.body.is_position[:, None]
        r0, rd0 = self.motion.origin(t0)
        q0, v0 = jnp.where(pos, q0 + r0, q0), jnp.where(pos, v0 + rd0, v0)
        return q0.reshape(-1), v0.reshape(-1)

    def constrain(self, t, q, v, a):
        root, vel, acc = self._root_motion(t)
        put = lambda x, val: x.reshape(-1, 3).at[self.clamped].set(val).reshape(-1)  # noqa: E731
        return put(q, root), put(v, vel), put(a, acc)

    def residual(self, t, q, v, a):
        Q, Acc = q.reshape(-1, 3), a.reshape(-1, 3)
        A = self.rotation(t)
        # Point forces are given in the rotating frame: rotate them with A; gravity is inertial.
        P = jnp.zeros_like(Q).at[self.loads.point_vectors].add(self.loads.point_forces @ A.T)
        if self.loads.point_history is not None:
            P = P * self.loads.point_scale(t)
        ext = self.body.varrho()[:, None] * self.loads.gravity[None, :] + P
        r = self.mass_times(Acc) + self.body.elastic_force(Q) - ext
        return jnp.where(self.free_mask(), r.reshape(-1), 0.0)

    def factor_iteration_matrix(self, t, q, v, c_M, c_C, c_K):
        z = jnp.zeros((3, 3))
        return self._factor(t, q, v, c_M, c_C, c_K, z, z)

    def displacements(self, t, q):
        Q = q.reshape(-1, 3)
        Q = jnp.where(self.body.is_position[:, None], Q - self.motion.origin(t)[0], Q)
        return Q @ self.rotation(t) - self.body.q_hat
