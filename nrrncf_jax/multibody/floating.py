"""Free-floating reference frames with reduced deformation: NR-RNCF for jointed systems
(THEORY §3, Eqs. 4-6; paper Sec. 4.4).

Each body b has a reference frame, origin R_b and orientation A(e_b) from Euler parameters e_b,
and its deformation in that frame reduced to a basis, w_b = Ψ_b p_b (vibration modes and modal
derivatives, zero on the body's reference conditions). Its nodal vectors in the inertial frame:

    position vectors   x_α = R + A (q̂_α + w_α),      gradient vectors   x_α = A (q̂_α + w_α),

x_b = f_b(z_b) with z_b = (R_b, e_b, p_b) (3 + 4 + k coordinates). The joints (``joints``) act on
x = f(z) as in the full system. With M_b constant in the inertial nodal vectors, Lagrange's
equations of the map are

    J_bᵀ (M_b ẍ_b − Q_b) + ∂U_b/∂z_b + C_zᵀ λ = 0,    ẍ_b = J_b z̈_b + J̇_b ż_b,    J_b = ∂f_b/∂z_b,

and the strain energy U_b depends on p_b alone (it is invariant under the frame's motion): its
gradient is the reduced cubic force f + K p + L p p + N p p p of Eq. 24 (``reduction.tensors``).
These are Eqs. 4-6 (translation, rotation, deformation) written in one piece.

Choices, and why:

- **Euler parameters** for the orientation, with |e_b|² = 1 as one more constraint per body: no
  singular orientation (a rotation vector is singular at |ψ| = 2π, Euler angles at gimbal lock),
  the equations stay polynomial-like, and the index-3 solver already carries constraints. A is
  the rotation of e/|e| (normalised), so a scaling of e moves nothing: M_z is singular along e and
  the normalisation constraint's row (2eᵀ) removes exactly that direction, so
  ``[[M_z, C_zᵀ], [C_z, 0]]`` is regular.
- **Inertia through automatic differentiation** of the map f (its Jacobian: 7 + k directional
  derivatives; the quadratic-velocity terms J̇ż: one second directional derivative), rather than
  the paper's precomputed inertia invariants: exact, with no invariant tensors to get wrong, and
  its cost grows only linearly with the full body's size (products with the constant M_b). The
  elastic force, the costly part at full order, is the reduced cubic one.
- The iteration matrix is dense (z has a few tens of coordinates): the mass matrix J ᵀM J and
  the reduced elastic stiffness K + 2Lp + 3Npp; the inertia terms' derivatives through J and the
  joints' Hessian are left to Newton's iterations (``iteration_matrix``).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._types import Array, Bool, Float, Scalar
from ..body import Body
from ..linalg import DenseLU
from ..models.base import AbstractModel
from ..reduction.tensors import ElasticTensors
from .joints import AbstractJoint
from .system import AugmentedFactor


def rotation(e: Float[Array, " 4"]) -> Float[Array, "3 3"]:
    """The rotation matrix of the Euler parameters e = (e0, e1, e2, e3), normalised first:
    A = (e0² − ēᵀē) I + 2 ē ēᵀ + 2 e0 ẽ, divided by |e|²."""
    e0, eb = e[0], e[1:]
    skew = jnp.array([[0.0, -eb[2], eb[1]], [eb[2], 0.0, -eb[0]], [-eb[1], eb[0], 0.0]])
    A = (e0**2 - eb @ eb) * jnp.eye(3) + 2.0 * jnp.outer(eb, eb) + 2.0 * e0 * skew
    return A / (e @ e)


def euler_parameters(A) -> np.ndarray:
    """Euler parameters (e0 ≥ 0) of a proper rotation matrix (host-side, for initial states)."""
    A = np.asarray(A, dtype=float)
    if A.shape != (3, 3) or not np.allclose(A.T @ A, np.eye(3), atol=1e-10) or np.linalg.det(A) < 0:
        raise ValueError("the frame's orientation must be a proper 3 × 3 rotation matrix")
    w, V = np.linalg.eigh(np.array([  # the largest eigenvector of Bar-Itzhack's symmetric matrix
        [A[0, 0] + A[1, 1] + A[2, 2], A[2, 1] - A[1, 2], A[0, 2] - A[2, 0], A[1, 0] - A[0, 1]],
        [A[2, 1] - A[1, 2], A[0, 0] - A[1, 1] - A[2, 2], A[0, 1] + A[1, 0], A[0, 2] + A[2, 0]],
        [A[0, 2] - A[2, 0], A[0, 1] + A[1, 0], A[1, 1] - A[0, 0] - A[2, 2], A[1, 2] + A[2, 1]],
        [A[1, 0] - A[0, 1], A[0, 2] + A[2, 0], A[1, 2] + A[2, 1], A[2, 2] - A[0, 0] - A[1, 1]]]) / 3.0)
    e = V[:, -1]
    return e if e[0] >= 0 else -e


class FloatingBody(eqx.Module):
    """A body in a floating frame, deformation reduced: ``body`` in its own frame (its ``q_hat``
    the stress-free state in frame coordinates), the deformation basis ``basis`` (n_dof × k,
    zero on the reference conditions), its ``tensors`` (``reduction.elastic_tensors(body,
    body.q_hat, basis)``), and the frame's initial origin ``R0`` and orientation ``A0``."""

    body: Body
    basis: Float[Array, "ndof k"]
    tensors: ElasticTensors
    R0: Float[Array, " 3"]
    e0: Float[Array, " 4"]
    is_position: Bool[Array, " nv"]

    def __init__(self, body: Body, basis, tensors: ElasticTensors, R0=(0.0, 0.0, 0.0), A0=None):
        basis = jnp.asarray(basis)
        if basis.ndim != 2 or basis.shape[0] != body.n_dof:
            raise ValueError(f"basis must be (n_dof, k) = ({body.n_dof}, k), got {basis.shape}")
        if tensors.K.shape != (basis.shape[1], basis.shape[1]):
            raise ValueError(f"tensors are for {tensors.K.shape[0]} coordinates, the basis has {basis.shape[1]}")
        self.body, self.basis, self.tensors = body, basis, tensors
        self.R0 = jnp.asarray(R0, dtype=float).reshape(3)
        self.e0 = jnp.asarray(euler_parameters(np.eye(3) if A0 is None else A0))
        self.is_position = jnp.asarray(body.is_position, dtype=bool)

    @property
    def k(self) -> int:
        return int(self.basis.shape[1])

    @property
    def n_z(self) -> int:
        return 7 + self.k

    def nodal_vectors(self, z: Float[Array, " nz"]) -> Float[Array, "nv 3"]:
        """x = f(z): the nodal vectors in the inertial frame."""
        R, e, p = z[:3], z[3:7], z[7:]
        local = self.body.q_hat + (self.basis @ p).reshape(-1, 3)
        return local @ rotation(e).T + jnp.where(self.is_position[:, None], R[None, :], 0.0)

    def initial(self) -> Float[Array, " nz"]:
        return jnp.concatenate([self.R0, self.e0, jnp.zeros(self.k)])


class FloatingFrameSystem(AbstractModel):
    """Floating-frame bodies (``FloatingBody``) joined by ``joints`` (acting on the bodies'
    inertial nodal vectors, as in ``MultibodySystem``), under ``gravity``. Coordinates z: each
    body's (R, e, p), stacked. Constraints: the joints' equations, then |e_b|² − 1 per body.
    See the module docstring for the equations. Runs with ``integrate.GeneralizedAlphaIndex3``."""

    bodies: tuple[FloatingBody, ...]
    joints: tuple[AbstractJoint, ...]
    gravity: Float[Array, " 3"]
    masses: tuple  # each body's M_b (n_dof × n_dof, ⊗ I3 applied)
    offsets: tuple[int, ...] = eqx.field(static=True)

    preferred_newton = "modified"

    def __init__(self, bodies, joints, gravity=(0.0, 0.0, 0.0)):
        self.bodies = tuple(bodies)
        self.joints = tuple(joints)
        if not self.bodies or not all(isinstance(b, FloatingBody) for b in self.bodies):
            raise ValueError("bodies must be a non-empty sequence of FloatingBody")
        if not all(isinstance(j, AbstractJoint) for j in self.joints):
            raise ValueError("joints must be multibody joints (Spherical, Revolute, Fixed, ...)")
        self.gravity = jnp.asarray(gravity, dtype=float).reshape(3)
        self.masses = tuple(jnp.asarray(np.kron(np.asarray(b.body.mass_matrix()), np.eye(3))) for b in self.bodies)
        sizes = [b.n_z for b in self.bodies]
        self.offsets = tuple(int(o) for o in np.concatenate([[0], np.cumsum(sizes)[:-1]]))
        self._check()

    def _check(self) -> None:
        nb = len(self.bodies)
        for k, joint in enumerate(self.joints):
            for b, v in joint.references():
                if not 0 <= b < nb or not 0 <= v < self.bodies[b].body.n_vectors:
                    raise ValueError(f"joint {k} ({type(joint).__name__}) refers to nodal vector {v} of body {b}, "
                                     "which does not exist")
        z0 = self.reference()
        C0 = np.asarray(jax.jit(lambda z: self.constraints(z))(z0))
        if np.abs(C0).max(initial=0.0) > 1e-9 * max(1.0, float(np.abs(z0).max())):
            raise ValueError(f"the initial state violates joint equations (largest {np.abs(C0).max():.3g}): place "
                             "the frames so that their joints fit")
        B = np.asarray(jax.jit(lambda z: self.constraint_jacobian(z))(z0))
        s = np.linalg.svd(B, compute_uv=False)
        if int(np.sum(s > 1e-10 * s.max())) < B.shape[0]:
            raise ValueError(f"the joints' {B.shape[0] - nb} equations are redundant: remove the duplicated "
                             "constraints, or the iteration matrix is singular")

    # --- coordinates ------------------------------------------------------------------------------
    @property
    def n_dof(self) -> int:
        return sum(b.n_z for b in self.bodies)

    @property
    def n_constraints(self) -> int:
        return sum(j.n_equations for j in self.joints) + len(self.bodies)

    def split(self, z: Float[Array, " n"]) -> tuple[Float[Array, " nz"], ...]:
        return tuple(z[o:o + b.n_z] for b, o in zip(self.bodies, self.offsets))

    def nodal_vectors(self, z: Float[Array, " n"]) -> tuple[Float[Array, "nv 3"], ...]:
        """Every body's nodal vectors in the inertial frame (the full system's ``split``)."""
        return tuple(b.nodal_vectors(zb) for b, zb in zip(self.bodies, self.split(z)))

    def reference(self) -> Float[Array, " n"]:
        return jnp.concatenate([b.initial() for b in self.bodies])

    def free_mask(self) -> Bool[Array, " n"]:
        return jnp.ones(self.n_dof, bool)

    def initial_state(self, t0: Scalar):
        z0 = self.reference()
        return z0, jnp.zeros_like(z0)

    def constrain(self, t, q, v, a):
        return q, v, a

    def error_space(self, z, e):
        """The step error in the inertial nodal vectors (J e), so that a tolerance means what it
        means for the full system."""
        x, dx = jax.jvp(lambda y: jnp.concatenate([v.reshape(-1) for v in self.nodal_vectors(y)]), (z,), (e,))
        return x, dx, jnp.ones(x.shape[0], bool)

    # --- the equations ----------------------------------------------------------------------------
    def constraints(self, z: Float[Array, " n"]) -> Float[Array, " m"]:
        xs = self.nodal_vectors(z)
        joints = [j(xs) for j in self.joints]
        norms = [jnp.atleast_1d(zb[3:7] @ zb[3:7] - 1.0) for zb in self.split(z)]
        return jnp.concatenate(joints + norms)

    def constraint_jacobian(self, z):
        return jax.jacfwd(self.constraints)(z)

    def constraint_acceleration(self, z, v) -> Float[Array, " m"]:
        """(C_z v)_z v: the part of C̈ that does not hold the accelerations."""
        def rate(y):
            return jax.jvp(self.constraints, (y,), (v,))[1]

        return jax.jvp(rate, (z,), (v,))[1]

    def _kinematics(self, z, v):
        """Per body: the Jacobian J_b = ∂x_b/∂z_b (n_b × (7 + k)) and J̇_b ż_b (the second
        directional derivative of f_b along ż_b)."""
        out = []
        for b, zb, vb in zip(self.bodies, self.split(z), self.split(v)):
            def flat(y, b=b):
                return b.nodal_vectors(y).reshape(-1)

            J = jax.jacfwd(flat)(zb)
            Jdv = jax.jvp(lambda y, flat=flat, vb=vb: jax.jvp(flat, (y,), (vb,))[1], (zb,), (vb,))[1]
            out.append((J, Jdv))
        return out

    def residual(self, t: Scalar, z, v, a) -> Float[Array, " n"]:
        """J ᵀ(M ẍ − Q) + ∂U/∂z, ẍ = J z̈ + J̇ ż, without the joints' forces (the stepper adds
        C_zᵀ λ)."""
        parts = []
        for b, M, (J, Jdv), ab, zb in zip(self.bodies, self.masses, self._kinematics(z, v), self.split(a),
                                          self.split(z)):
            Q = (b.body.varrho()[:, None] * self.gravity[None, :]).reshape(-1)
            parts.append((J.T @ (M @ (J @ ab + Jdv) - Q)).at[7:].add(b.tensors.force(zb[7:])))
        return jnp.concatenate(parts)

    def mass_matrix(self, z) -> Float[Array, "n n"]:
        """M_z = blockdiag(J_bᵀ M_b J_b): singular along each body's e (see the module docstring)."""
        return jax.scipy.linalg.block_diag(*[J.T @ M @ J for M, (J, _) in
                                             zip(self.masses, self._kinematics(z, jnp.zeros_like(z)))])

    def iteration_matrix(self, t, z, v, c_M, c_C, c_K):
        """``c_M M_z + c_K ∂F/∂z``: the mass matrix and the reduced elastic stiffness. The
        derivatives of the inertia terms through J (centrifugal, gyroscopic, the load's change of
        direction) are left out: they are of order c_K ω² M and c_C ω M against M, small at the
        steps the motion needs, and Newton's iterations absorb them (a modified Newton on this
        matrix converges linearly, at that rate, to the same solution)."""
        blocks = []
        for b, M, (J, _), zb in zip(self.bodies, self.masses, self._kinematics(z, jnp.zeros_like(z)), self.split(z)):
            _, K = b.tensors.force_and_jacobian(zb[7:])
            blocks.append((c_M * (J.T @ M @ J)).at[7:, 7:].add(c_K * K))
        return jax.scipy.linalg.block_diag(*blocks)

    def factor_iteration_matrix(self, t, z, v, c_M, c_C, c_K):
        return DenseLU.factor(self.iteration_matrix(t, z, v, c_M, c_C, c_K))

    def factor_augmented(self, t, z, v, lam, c_C, c_K) -> AugmentedFactor:
        """``[[S, C_zᵀ], [C_z, 0]]`` factored densely, S the ``iteration_matrix`` (the joints'
        Hessian c_K H_λ left out as well: of the order of the reactions times c_K)."""
        S = self.iteration_matrix(t, z, v, 1.0, c_C, c_K)
        B = self.constraint_jacobian(z)
        m = B.shape[0]
        return AugmentedFactor(dense=DenseLU.factor(jnp.block([[S, B.T], [B, jnp.zeros((m, m), S.dtype)]])))

    def consistent_accelerations(self, t: Scalar, z, v):
        """``(a, λ)`` with the equations of motion and C̈ = 0 at (z, v)."""
        B = self.constraint_jacobian(z)
        n, m = self.n_dof, B.shape[0]
        A = jnp.block([[self.mass_matrix(z), B.T], [B, jnp.zeros((m, m), z.dtype)]])
        rhs = jnp.concatenate([-self.residual(t, z, v, jnp.zeros_like(z)), -self.constraint_acceleration(z, v)])
        sol = DenseLU.factor(A).solve(rhs)
        return sol[:n], sol[n:]

    def kinetic_energy(self, z, v) -> Float[Array, ""]:
        """½ Σ_b ẋ_bᵀ M_b ẋ_b, ẋ_b = J_b ż_b."""
        total = 0.0
        for b, M, zb, vb in zip(self.bodies, self.masses, self.split(z), self.split(v)):
            xv = jax.jvp(b.nodal_vectors, (zb,), (vb,))[1].reshape(-1)
            total = total + 0.5 * xv @ (M @ xv)
        return total

    def energy(self, z, v) -> Float[Array, ""]:
        """Kinetic + strain + gravity potential energy (conserved without damping)."""
        total = self.kinetic_energy(z, v)
        for b, zb, x in zip(self.bodies, self.split(z), self.nodal_vectors(z)):
            local = b.body.q_hat + (b.basis @ zb[7:]).reshape(-1, 3)
            total = total + b.body.strain_energy(local) - jnp.sum(b.body.varrho()[:, None] * x * self.gravity[None, :])
        return total


__all__ = ["FloatingBody", "FloatingFrameSystem", "euler_parameters", "rotation"]
