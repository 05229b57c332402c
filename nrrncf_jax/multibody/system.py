"""A multibody system: flexible bodies in the inertial frame (ANCF, THEORY §3 with A = I, r = 0)
joined by joints (``multibody.joints``), under gravity: the index-3 DAE

    M a + F(x) − Q + C_x(x)ᵀ λ = 0,    C(x) = 0,

with x the bodies' nodal vectors stacked (body by body), M the block-diagonal mass matrix
``M_αβ ⊗ I3`` of each body, F their elastic forces (Eqs. 9-11), Q the gravity load ``ϱ_α g``,
C the joints' equations and λ their multipliers (the reactions, see ``joints``). It runs with
``integrate.GeneralizedAlphaIndex3``, which carries λ in its state.

Why inertial-frame bodies: every body's motion lives in its nodal vectors, so the system is one
vector space (no rotation parameters), its mass matrix is constant, and any joint is a quadratic
polynomial in the nodal vectors. It is the full-order reference of a jointed system; bodies in
floating frames with reduced deformation (NR-RNCF) are ``multibody.floating``'s
``FloatingFrameSystem``.

The constrained iteration matrix is factored body by body with the joints' Schur complement
when the bodies are beam chains (``factor_augmented``), else dense.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import scipy.linalg

from .._types import Array, Float, Scalar
from .._validate import is_concrete
from ..bodies.body import Body
from ..linalg import AbstractLinearSolver, AugmentedFactor, DenseLU, dense_augmented, linear_solver, schur_factor
from ..models.constrained import AbstractConstrainedModel
from ..motion import rotation_about, unit_axis
from .joints import AbstractJoint
from .markers import BodyGeometry, JointSpec, resolve_joints


def placed(body: Body, rotation=None, translation=(0.0, 0.0, 0.0)) -> Body:
    """``body`` moved rigidly in space: every nodal vector rotated by ``rotation`` (3 × 3, proper),
    the position vectors then translated by ``translation``. Its stress-free state moves along
    (the element integrals depend on the reference through dot products of its gradients, which a
    rigid motion keeps): the way to put bodies built about the origin where the system needs them."""
    R = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
    if R.shape != (3, 3) or not np.allclose(R.T @ R, np.eye(3), atol=1e-12) or np.linalg.det(R) < 0:
        raise ValueError("rotation must be a proper 3 × 3 rotation matrix")
    p = np.asarray(translation, dtype=float).reshape(3)
    q = np.asarray(body.q_hat) @ R.T + np.where(np.asarray(body.is_position)[:, None], p[None, :], 0.0)
    return eqx.tree_at(lambda b: b.q_hat, body, jnp.asarray(q))


def _body_solver(body: Body) -> AbstractLinearSolver:
    """The linear solver of a body's block of the iteration matrix (``linalg.linear_solver``,
    ``"auto"``), from its static connectivity."""
    parts = [(np.broadcast_to(0.0, (d.shape[0], d.shape[1], d.shape[1])), d) for d in (g.dofs() for g in body.groups)]
    return linear_solver("auto", parts, body.n_dof, chain_block=3 * body.vectors_per_node if body.chain else None)


class MultibodySystem(AbstractConstrainedModel):
    """Bodies (``Body``, placed in space: their ``q_hat`` is the initial, stress-free state), joints
    and ``gravity`` (an acceleration, 3-vector). See the module docstring for the equations.

    Raises ``ValueError`` before anything is traced for: a joint that refers to a body or nodal
    vector that does not exist, a body that no joint holds, joint equations that the initial
    state does not satisfy, and redundant joint equations (a rank-deficient C_x, which would make
    the iteration matrix singular).
    """

    bodies: tuple[Body, ...]
    joints: tuple[AbstractJoint, ...]
    gravity: Float[Array, " 3"]
    M: Float[Array, "n n"]  # the block-diagonal mass matrix, all coordinates
    solver: str = eqx.field(static=True)  # "dense" or "bodies": how factor_augmented factors the constrained matrix
    body_solvers: tuple[AbstractLinearSolver, ...]  # each body's block's linear solver ("bodies"), resolved once

    preferred_newton = "full"

    def __init__(self, bodies, joints, gravity=(0.0, 0.0, 0.0), solver: str = "auto"):
        if solver not in ("auto", "dense", "bodies"):
            raise ValueError(f"solver must be 'auto', 'dense' or 'bodies', got {solver!r}")
        self.bodies = tuple(bodies)
        self.solver = ("bodies" if all(getattr(b, "chain", False) for b in self.bodies) else "dense") \
            if solver == "auto" else solver
        if not self.bodies or not all(isinstance(b, Body) for b in self.bodies):
            raise ValueError("bodies must be a non-empty sequence of Body")
        joints = tuple(joints)
        if any(isinstance(j, JointSpec) for j in joints):  # markers: on the bodies' reference nodal vectors
            joints = resolve_joints(joints, tuple(
                BodyGeometry(np.asarray(b.q_hat), np.asarray(b.is_position), b.vectors_per_node, b.section_slots)
                for b in self.bodies))
        self.joints = joints
        if not all(isinstance(j, AbstractJoint) for j in self.joints):
            raise ValueError("joints must be multibody joints (Spherical, Revolute, Fixed, ...) or joints on markers "
                             "(hinge, ball, clamp)")
        self.gravity = jnp.asarray(gravity, dtype=float).reshape(3)
        self.body_solvers = tuple(_body_solver(b) for b in self.bodies)
        masses = [b.mass_matrix() for b in self.bodies]  # scalar M_αβ; the body's is M_αβ ⊗ I3
        if all(is_concrete(x) for x in masses):  # NumPy outside a trace: no op-by-op compiles on a cold start
            self.M = jnp.asarray(scipy.linalg.block_diag(*(np.kron(np.asarray(x), np.eye(3)) for x in masses)))
        else:
            self.M = jax.scipy.linalg.block_diag(*(jnp.kron(x, jnp.eye(3)) for x in masses))
        self.check_joints(require_held=True)

    # --- coordinates ------------------------------------------------------------------------------
    def body_sizes(self) -> tuple[int, ...]:
        return tuple(b.n_dof for b in self.bodies)

    def vector_counts(self) -> tuple[int, ...]:
        return tuple(b.n_vectors for b in self.bodies)

    @property
    def n_body_equations(self) -> int:
        """Inertial-frame bodies add no equations of their own."""
        return 0

    @property
    def formulation(self) -> str:
        return "ancf"

    def split(self, x: Float[Array, " n"]) -> tuple[Float[Array, "nv 3"], ...]:
        """The bodies' nodal vectors (one (n_vectors, 3) array a body) from the stacked x."""
        return tuple(xb.reshape(-1, 3) for xb in super().split(x))

    def nodal_vectors(self, x: Float[Array, " n"]) -> tuple[Float[Array, "nv 3"], ...]:
        return self.split(x)

    def reference(self) -> Float[Array, " n"]:
        """The stacked stress-free (initial) state."""
        return jnp.concatenate([b.q_hat.reshape(-1) for b in self.bodies])

    def mass_matrix(self, x=None) -> Float[Array, "n n"]:
        """The block-diagonal M (constant in the inertial nodal vectors)."""
        return self.M

    def turned(self, axis, angle) -> "MultibodySystem":
        """The system turned as a whole by ``angle`` [rad] about ``axis`` through the origin: every
        body's nodal vectors (its stress-free, initial state, as ``placed``) and the joints' fixed
        data in space (``AbstractJoint.turned``); gravity stays. Traceable in ``angle`` (a batch
        of release angles: ``scenarios.pendulum.release_sweep``)."""
        A = rotation_about(unit_axis(axis), jnp.asarray(angle, dtype=float))
        bodies = tuple(eqx.tree_at(lambda b: b.q_hat, b, b.q_hat @ A.T) for b in self.bodies)
        return eqx.tree_at(lambda s: (s.bodies, s.joints), self, (bodies, tuple(j.turned(A) for j in self.joints)))

    def displacements(self, t: Scalar, x: Float[Array, " n"]) -> Float[Array, "nv 3"]:
        """All nodal vectors' displacements from the initial state, stacked body by body."""
        return (x - self.reference()).reshape(-1, 3)

    # --- the equations ----------------------------------------------------------------------------
    def constraints(self, x: Float[Array, " n"], t: Scalar = 0.0) -> Float[Array, " m"]:
        """C(x, t): the joints' equations, joint by joint."""
        return self.joint_equations(self.split(x), t) if self.joints else jnp.zeros((0,), x.dtype)

    def constraint_jacobian(self, x: Float[Array, " n"], t: Scalar = 0.0) -> Float[Array, "m n"]:
        """C_x = ∂C/∂x (dense)."""
        return jax.jacfwd(lambda y: self.constraints(y, t))(x)

    def constraint_hessian(self, x: Float[Array, " n"], lam: Float[Array, " m"], t: Scalar = 0.0
                           ) -> Float[Array, "n n"]:
        """∂(C_xᵀ λ)/∂x: the joints' contribution to the tangent stiffness (constant in x: the
        equations are quadratic)."""
        return jax.hessian(lambda y: jnp.dot(lam, self.constraints(y, t)))(x)

    def residual(self, t: Scalar, x, v, a) -> Float[Array, " n"]:
        """M a + F(x) − Q, without the joints' forces (the stepper adds C_xᵀ λ)."""
        xs = self.split(x)
        parts = [(b.elastic_force(q) - b.varrho()[:, None] * self.gravity[None, :]).reshape(-1)
                 for b, q in zip(self.bodies, xs)]
        return self.M @ a + jnp.concatenate(parts)

    def stiffness(self, x) -> Float[Array, "n n"]:
        """The block-diagonal tangent stiffness ∂F/∂x of the bodies."""
        n = self.n_dof
        K = jnp.zeros((n, n), x.dtype)
        for b, o, q in zip(self.bodies, self.offsets, self.split(x)):
            K = K.at[o:o + b.n_dof, o:o + b.n_dof].set(b.stiffness_matrix(q))
        return K

    def iteration_matrix(self, t, x, v, c_M, c_C, c_K) -> Float[Array, "n n"]:
        """c_M ∂r/∂a + c_C ∂r/∂v + c_K ∂r/∂x of ``residual`` (no velocity terms: c_C unused)."""
        return c_M * self.M + c_K * self.stiffness(x)

    def factor_iteration_matrix(self, t, x, v, c_M, c_C, c_K):
        return DenseLU.factor(self.iteration_matrix(t, x, v, c_M, c_C, c_K))

    def factor_augmented(self, t, x, v, lam, c_C, c_K, a=None) -> "AugmentedFactor":
        """The step's constrained iteration matrix ``[[S + c_K H_λ, C_xᵀ], [C_x, 0]]`` factored
        (``integrate.GeneralizedAlphaIndex3``), S = M + c_K K(x). ``solver="dense"``: one dense LU
        of the whole matrix, with the joints' Hessian H_λ = ∂(C_xᵀλ)/∂x. ``"bodies"`` (the default
        when every body is a beam chain): each body's S factored on its own (block-tridiagonal for
        chains) and the joints by the m × m Schur complement C_x S⁻¹ C_xᵀ: O(n) instead of
        O(n³). It leaves H_λ out, which couples the bodies at their joints: Newton then converges
        linearly, at a rate of about c_K |H_λ| / |M| (the reactions times h²β against the nodal
        masses: small), to the same solution. ``a`` (the step's acceleration) is not used: the
        inertial frame's mass matrix is constant."""
        B = self.constraint_jacobian(x, t)
        if self.solver == "dense":
            S = self.iteration_matrix(t, x, v, 1.0, c_C, c_K) + c_K * self.constraint_hessian(x, lam, t)
            return dense_augmented(S, B)
        factors = []
        for b, solver, q in zip(self.bodies, self.body_solvers, self.split(x)):
            parts = [(c_K * Kt + jnp.einsum("eab,ij->eaibj", M_e, jnp.eye(3)).reshape(Kt.shape), dofs)
                     for (Kt, dofs), (M_e, _) in zip(b.tangent_parts(q), b.mass_parts())]
            factors.append(solver.factor(parts, jnp.ones(b.n_dof, bool)))
        return schur_factor(factors, self.offsets, self.body_sizes(), B)

    def kinetic_energy(self, x, v) -> Float[Array, ""]:
        """½ vᵀ M v (M constant in the inertial nodal vectors)."""
        return 0.5 * v @ (self.M @ v)

    def potential_energy(self, x) -> Float[Array, ""]:
        """Strain energy plus the gravity potential −Σ ϱ_α x_α·g."""
        xs = self.split(x)
        U = sum(b.strain_energy(q) for b, q in zip(self.bodies, xs))
        return U - sum(jnp.sum(b.varrho()[:, None] * q * self.gravity[None, :]) for b, q in zip(self.bodies, xs))


__all__ = ["MultibodySystem", "placed"]
