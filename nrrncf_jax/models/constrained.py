"""Constrained systems: bodies joined by joints, the index-3 DAE (docs/theory.md, §7 Jointed
bodies; docs/multibody-theory.md, §Index-3 constraints)

    M(x) a + g(t, x, v) + C_xᵀ λ = 0,      C(x) = 0,

with x the bodies' coordinates stacked body by body, C the joints' equations (and any equations
a body kind brings, such as the Euler parameters' |e|² = 1) and λ their multipliers, the joints'
reactions. ``integrate.GeneralizedAlphaIndex3`` runs any ``AbstractConstrainedModel`` and carries
λ in its state.

What differs between body kinds (inertial-frame ANCF bodies, whose coordinates are their nodal
vectors; bodies in floating frames with reduced deformation) is the map from a body's coordinates
to its nodal vectors, its mass matrix and its forces: the body kinds supply those, and
``multibody.Mechanism`` (of which ``MultibodySystem`` and ``FloatingFrameSystem`` are checked
special cases) assembles them. What every
system shares is written here once: the coordinates' layout, the checks of the joints before
anything is traced, the consistent initial accelerations and multipliers, the reactions at any
state, the constraints' acceleration terms and the energy.
"""

import abc
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._types import Array, Bool, Float, Scalar
from .._validate import is_concrete
from ..linalg import DenseLU
from .base import AbstractModel


class AbstractConstrainedModel(AbstractModel):
    """Bodies joined by joints under gravity (see the module docstring).

    A joint (``multibody.joints``) is a function of the bodies' nodal vectors in the inertial
    frame with ``n_equations``, ``references()`` (the (body, nodal vector) pairs it reads) and
    ``bodies()``. A concrete system supplies its bodies' coordinate counts (``body_sizes``), their
    nodal vectors (``nodal_vectors``, ``vector_counts``), the stress-free initial state
    (``reference``), the mass matrix, the residual without the joints' forces, the constraints
    with their Jacobian, and the factored constrained iteration matrix (``factor_augmented``).
    """

    bodies: eqx.AbstractVar[tuple]
    joints: eqx.AbstractVar[tuple]
    gravity: eqx.AbstractVar[Float[Array, " 3"]]

    project_velocities: ClassVar[bool] = False
    """Whether the index-3 step projects v onto C_x v = 0 after each step (``integrate.index3``):
    for systems whose velocities leave the constraint's tangent space by O(h) (floating frames)."""

    # --- what a concrete system supplies -----------------------------------------------------------
    @property
    @abc.abstractmethod
    def formulation(self) -> str:
        """What the bodies are, for records and tables: ``"ancf"`` (inertial-frame nodal vectors),
        ``"rncf"`` (floating frames, full-order deformation), ``"nr-rncf"`` (floating frames,
        reduced deformation)."""

    @abc.abstractmethod
    def body_sizes(self) -> tuple[int, ...]:
        """Each body's number of coordinates, in the order of x."""

    @abc.abstractmethod
    def vector_counts(self) -> tuple[int, ...]:
        """Each body's number of nodal vectors (what joints refer to)."""

    @abc.abstractmethod
    def nodal_vectors(self, x: Float[Array, " n"]) -> tuple[Float[Array, "nv 3"], ...]:
        """Every body's nodal vectors in the inertial frame, where the joints act."""

    @abc.abstractmethod
    def reference(self) -> Float[Array, " n"]:
        """The stacked stress-free initial state."""

    @abc.abstractmethod
    def mass_matrix(self, x: Float[Array, " n"]) -> Float[Array, "n n"]:
        """M(x), all coordinates (dense; for the consistent accelerations and checks)."""

    @abc.abstractmethod
    def constraints(self, x: Float[Array, " n"], t: Scalar = 0.0) -> Float[Array, " m"]:
        """C(x, t): the joints' equations, joint by joint, then any equations of the bodies (t is
        read by drivers only)."""

    @abc.abstractmethod
    def constraint_jacobian(self, x: Float[Array, " n"], t: Scalar = 0.0) -> Float[Array, "m n"]:
        """C_x = ∂C/∂x (dense)."""

    @abc.abstractmethod
    def factor_augmented(self, t: Scalar, x, v, lam, c_C, c_K, a=None):
        """The step's constrained iteration matrix ``[[S, C_xᵀ], [C_x, 0]]`` factored
        (``linalg.schur.AugmentedFactor``), S = c_M ∂r/∂a + c_C ∂r/∂v + c_K ∂r/∂x with c_M = 1."""

    @abc.abstractmethod
    def kinetic_energy(self, x, v) -> Float[Array, ""]:
        """½ ẋᵀ M ẋ in the inertial nodal vectors."""

    @abc.abstractmethod
    def potential_energy(self, x) -> Float[Array, ""]:
        """Strain energy plus the gravity potential."""

    # --- shared ------------------------------------------------------------------------------------
    @property
    def n_dof(self) -> int:
        return sum(self.body_sizes())

    @property
    def n_joint_equations(self) -> int:
        return sum(j.n_equations for j in self.joints)

    @property
    def n_constraints(self) -> int:
        """Rows of C: the joints' equations and the bodies' own."""
        return self.n_joint_equations + self.n_body_equations

    @property
    @abc.abstractmethod
    def n_body_equations(self) -> int:
        """Equations the bodies add to C after the joints' (e.g. one |e|² = 1 a floating frame)."""

    @property
    def offsets(self) -> tuple[int, ...]:
        """The first coordinate of each body in x."""
        return tuple(int(o) for o in np.concatenate([[0], np.cumsum(self.body_sizes())[:-1]]))

    def split(self, x: Float[Array, " n"]) -> tuple[Float[Array, " nb"], ...]:
        """Each body's part of the stacked x."""
        return tuple(x[o:o + n] for o, n in zip(self.offsets, self.body_sizes()))

    def free_mask(self) -> Bool[Array, " n"]:
        return jnp.ones(self.n_dof, bool)

    def initial_state(self, t0: Scalar):
        x0 = self.reference()
        return x0, jnp.zeros_like(x0)

    def constrain(self, t, q, v, a):
        return q, v, a

    def joint_equations(self, xs: tuple[Float[Array, "nv 3"], ...], t: Scalar = 0.0) -> Float[Array, " mj"]:
        """The joints' equations on the bodies' nodal vectors ``xs`` at time ``t``, joint by joint."""
        if not self.joints:
            return jnp.zeros((0,), jnp.result_type(*xs))
        return jnp.concatenate([j(xs, t) for j in self.joints])

    @property
    def rheonomic(self) -> bool:
        """Whether a joint prescribes a motion in time (a driver): C depends on t."""
        return any(j.rheonomic for j in self.joints)

    def constraint_force(self, q: Float[Array, " n"], lam: Float[Array, " m"], t: Scalar = 0.0) -> Float[Array, " n"]:
        """C_xᵀ λ, by one reverse-mode product: C_x is not formed, as Newton needs this product
        every iteration and the matrix once a step."""
        return jax.vjp(lambda y: self.constraints(y, t), q)[1](lam)[0]

    def dae_residual(self, t: Scalar, x, v, a, lam) -> tuple[Float[Array, " n"], Float[Array, " m"]]:
        """``(r(x, v, a) + C_xᵀ λ, C(x))``: what the index-3 step's Newton iteration evaluates
        (``integrate.index3``). A system may compute both from one evaluation of its nodal
        vectors (``multibody.Mechanism``)."""
        return self.residual(t, x, v, a) + self.constraint_force(x, lam, t), self.constraints(x, t)

    def constraint_rate(self, x, t: Scalar) -> Float[Array, " m"]:
        """C_t = ∂C/∂t (zero without drivers): velocities on the constraint satisfy C_x v = −C_t."""
        if not self.rheonomic:
            return jnp.zeros(self.n_constraints, x.dtype)
        return jax.jvp(lambda s: self.constraints(x, s), (jnp.asarray(t, x.dtype),), (jnp.ones((), x.dtype),))[1]

    def constraint_jacobian_and_rate(self, x, t: Scalar) -> tuple[Float[Array, "m n"], Float[Array, " m"]]:
        """``(C_x, C_t)``: the velocity equations' matrix and rate together (a system may compute
        both from one derivative: ``multibody.Mechanism``)."""
        return self.constraint_jacobian(x, t), self.constraint_rate(x, t)

    def constraint_acceleration(self, x, v, t: Scalar = 0.0) -> Float[Array, " m"]:
        """The part of C̈ = C_x a + (C_x v)_x v + 2 C_xt v + C_tt that does not hold a: the second
        derivative of C along the path (x + s v, t + s) (the t terms only with drivers)."""
        if not self.rheonomic:
            def rate(y):
                return jax.jvp(lambda z: self.constraints(z, t), (y,), (v,))[1]

            return jax.jvp(rate, (x,), (v,))[1]
        one = jnp.ones((), x.dtype)

        def path_rate(y, s):
            return jax.jvp(self.constraints, (y, s), (v, one))[1]

        return jax.jvp(path_rate, (x, jnp.asarray(t, x.dtype)), (v, one))[1]

    def constraint_jacobian_and_acceleration(self, x, v, t: Scalar = 0.0) -> tuple[Float[Array, "m n"],
                                                                                     Float[Array, " m"]]:
        """``(C_x, constraint_acceleration)``: what the consistent accelerations read of the
        constraints (a system may compute both from one evaluation: ``multibody.Mechanism``)."""
        return self.constraint_jacobian(x, t), self.constraint_acceleration(x, v, t)

    def consistent_accelerations(self, t: Scalar, x, v) -> tuple[Float[Array, " n"], Float[Array, " m"]]:
        """``(a, λ)`` that satisfy the equations of motion and C̈ = 0 at (x, v):

            [M   C_xᵀ] [a]   [−(g(t, x, v))  ]
            [C_x  0  ] [λ] = [−(C_x v)_x v   ]

        one dense solve (a system's own factorisation is for the iteration matrix)."""
        B, gamma = self.constraint_jacobian_and_acceleration(x, v, t)
        n, m = self.n_dof, B.shape[0]
        A = jnp.block([[self.mass_matrix(x), B.T], [B, jnp.zeros((m, m), x.dtype)]])
        rhs = jnp.concatenate([-self.residual(t, x, v, jnp.zeros_like(x)), -gamma])
        z = DenseLU.factor(A).solve(rhs)
        return z[:n], z[n:]

    def reactions(self, t: Scalar, x, v) -> Float[Array, " m"]:
        """λ at (x, v): the multipliers of the DAE's solution through that state (``joints`` gives
        their sign). They are functions of the state, so this is what an output at any time
        should report; the integrator's own λ carries an O(h) transient."""
        return self.consistent_accelerations(t, x, v)[1]

    def joint_slices(self) -> list[slice]:
        """Where each joint's equations (and multipliers) sit in C and λ."""
        out, k = [], 0
        for j in self.joints:
            out.append(slice(k, k + j.n_equations))
            k += j.n_equations
        return out

    def energy(self, x, v) -> Float[Array, ""]:
        """Kinetic + strain + gravity potential energy (conserved without damping)."""
        return self.kinetic_energy(x, v) + self.potential_energy(x)

    def check_joints(self, require_held: bool = False) -> None:
        """The checks of a system before anything is traced (``ValueError``): every joint refers to
        bodies and nodal vectors that exist; with ``require_held``, every body is held by a joint;
        and, when the system's arrays are concrete, the initial state satisfies the constraints
        and their Jacobian has full rank (redundant joint equations make the iteration matrix
        singular)."""
        nb, counts = len(self.bodies), self.vector_counts()
        held = set()
        for k, joint in enumerate(self.joints):
            for b, v in joint.references():
                if not 0 <= b < nb:
                    raise ValueError(f"joint {k} ({type(joint).__name__}) refers to body {b}; the system has bodies "
                                     f"0..{nb - 1}")
                if not 0 <= v < counts[b]:
                    raise ValueError(f"joint {k} ({type(joint).__name__}) refers to nodal vector {v} of body {b}, "
                                     f"which has vectors 0..{counts[b] - 1}")
            held |= joint.bodies()
        loose = sorted(set(range(nb)) - held)
        if require_held and loose:
            raise ValueError(f"bodies {loose} are held by no joint: each body of a system needs a joint (a body "
                             "on its own is a single-body model)")
        if self.n_constraints == 0 or not all(is_concrete(x) for x in jax.tree_util.tree_leaves(self)):
            return  # built inside a trace: the value checks run where the system is built concretely
        x0 = self.reference()
        # one compiled function, not dozens of small kernels compiled op by op on a cold start
        C0, B = (np.asarray(y) for y in jax.jit(lambda x: (self.constraints(x), self.constraint_jacobian(x)))(x0))
        scale = max(1.0, float(np.abs(x0).max()))
        bad = np.flatnonzero(np.abs(C0) > 1e-9 * scale)
        if bad.size:
            raise ValueError(f"the initial state violates joint equations {bad[:10].tolist()} (largest "
                             f"{np.abs(C0).max():.3g}): place the bodies so that their joints fit")
        s = np.linalg.svd(B, compute_uv=False)
        rank = int(np.sum(s > 1e-10 * s.max()))
        if rank < B.shape[0]:
            raise ValueError(f"the joints' {self.n_joint_equations} equations are redundant (rank {rank} of "
                             f"{B.shape[0]} constraints): remove the duplicated constraints, or the iteration "
                             "matrix is singular")


__all__ = ["AbstractConstrainedModel"]
