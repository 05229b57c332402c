"""An ANCF body in the inertial frame as a mechanism's body: its coordinates are its nodal vectors
(z = x, J = I), its mass matrix M ⊗ I₃ constant, its forces the elements' own (docs/theory.md, §3
Equations of motion of one body, with A = I, r = 0; ``system.MultibodySystem`` is a mechanism of
these alone).
In a ``mechanism.Mechanism`` it sits beside floating-frame, rigid and point-mass bodies. Its
iteration block M + c_K K(q) is factored by the body's own linear solver (``linalg.linear_solver``,
``"auto"``, from its static connectivity): block-tridiagonal for a beam chain, where a dense LU
of a few hundred coordinates a body would cost more than the rest of the step, dense for small
or unstructured bodies."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float
from ..bodies.body import Body, stiffened
from ..linalg import AbstractLinearSolver, Dense, linear_solver
from .kinds import AbstractBodyKind
from .markers import BodyGeometry


class InertialBody(AbstractBodyKind):
    """``body`` (placed in space: its ``q_hat`` the stress-free, initial state) with its nodal
    vectors as coordinates."""

    body: Body
    mass: Float[Array, "nv nv"]  # M on the nodal vectors (the same for each component)
    weights: Float[Array, " nv"]  # ϱ
    solver: AbstractLinearSolver  # its block's linear solver, resolved once

    kind = "ancf"

    def __init__(self, body: Body):
        if not isinstance(body, Body):
            raise ValueError(f"expected a bodies.Body, got {type(body).__name__}")
        self.body = body
        self.mass = jnp.asarray(body.mass_matrix())
        self.weights = jnp.asarray(body.varrho())
        parts = [(np.broadcast_to(0.0, (d.shape[0], d.shape[1], d.shape[1])), d)
                 for d in (g.dofs() for g in body.groups)]
        self.solver = linear_solver("auto", parts, body.n_dof,
                                    chain_block=3 * body.vectors_per_node if body.chain else None)

    def stiffened(self, s) -> "InertialBody":
        """κ times s (``bodies.body.stiffened``): the elastic force is linear in it."""
        return eqx.tree_at(lambda b: b.body, self, stiffened(self.body, s))

    @property
    def n_z(self) -> int:
        return self.body.n_dof

    @property
    def n_vectors(self) -> int:
        return self.body.n_vectors

    def initial(self):
        return self.body.q_hat.reshape(-1)

    def geometry(self) -> BodyGeometry:
        return BodyGeometry(np.asarray(self.body.q_hat), np.asarray(self.body.is_position), self.body.vectors_per_node,
                            self.body.section_slots)

    def nodal_vectors(self, z):
        return z.reshape(-1, 3)

    def tangent(self, z, dz):
        return dz.reshape(-1, 3)

    def jacobian(self, z, rows):
        rows = np.asarray(rows, dtype=int)
        return jnp.eye(self.n_z, dtype=z.dtype)[(3 * rows[:, None] + np.arange(3)[None, :])]

    def generalized(self, z, F):
        return F.reshape(-1)

    def residual(self, z, v, a, gravity):
        """M a + F(q) − ϱ g."""
        q = z.reshape(-1, 3)
        return (self.mass @ a.reshape(-1, 3) + self.body.elastic_force(q)
                - self.weights[:, None] * gravity[None, :]).reshape(-1)

    def mass_matrix(self, z):
        return jnp.kron(self.mass, jnp.eye(3, dtype=self.mass.dtype))

    def block(self, z, c_M, c_K, gravity, state=None, c_C=0.0):
        """c_M M + c_K K(q) (the residual has no velocity terms)."""
        return c_M * self.mass_matrix(z) + c_K * self.body.stiffness_matrix(z.reshape(-1, 3))

    @property
    def structured(self) -> bool:
        return not isinstance(self.solver, Dense)

    def factor(self, z, c_M, c_K, gravity, state=None, c_C=0.0):
        """c_M M + c_K K(q) factored by the body's solver, element by element (module docstring)."""
        if not self.structured:
            return super().factor(z, c_M, c_K, gravity, state, c_C)
        parts = [(c_K * Kt + c_M * jnp.einsum("eab,ij->eaibj", M_e, jnp.eye(3)).reshape(Kt.shape), dofs)
                 for (Kt, dofs), (M_e, _) in zip(self.body.tangent_parts(z.reshape(-1, 3)), self.body.mass_parts())]
        return self.solver.factor(parts, jnp.ones(self.n_z, bool))

    def kinetic_energy(self, z, v):
        xv = v.reshape(-1, 3)
        return 0.5 * jnp.sum(xv * (self.mass @ xv))

    def potential_energy(self, z, gravity):
        q = z.reshape(-1, 3)
        return self.body.strain_energy(q) - jnp.sum(self.weights[:, None] * q * gravity[None, :])

    def turned(self, e, A) -> "InertialBody":
        return eqx.tree_at(lambda b: b.body.q_hat, self, self.body.q_hat @ A.T)

    def rigid_velocity(self, z, velocity, omega):
        """Position vectors: velocity + ω × x; gradient vectors: ω × x."""
        x = z.reshape(-1, 3)
        pos = jnp.asarray(np.asarray(self.body.is_position, dtype=float))
        w = jnp.asarray(omega, dtype=float).reshape(3)
        return (pos[:, None] * jnp.asarray(velocity, dtype=float).reshape(3)[None] + jnp.cross(w[None], x)).reshape(-1)


__all__ = ["InertialBody"]
