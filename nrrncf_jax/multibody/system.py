"""A multibody system of flexible bodies in the inertial frame (ANCF: docs/theory.md, §3 Equations
of motion of one body, with A = I, r = 0) joined by joints (``multibody.joints``), under gravity:
the index-3 DAE

    M a + F(x) − Q + C_x(x)ᵀ λ = 0,    C(x) = 0,

with x the bodies' nodal vectors stacked (body by body), M the block-diagonal mass matrix
``M_αβ ⊗ I3`` of each body, F their elastic forces (Eqs. 9-11), Q the gravity load ``ϱ_α g``,
C the joints' equations and λ their multipliers (the reactions, see ``joints``). It runs with
``integrate.GeneralizedAlphaIndex3``, which carries λ in its state.

Why inertial-frame bodies: every body's motion lives in its nodal vectors, so the system is one
vector space (no rotation parameters), its mass matrix is constant, and any joint is a quadratic
polynomial in the nodal vectors. It is the full-order reference of a jointed system.

``MultibodySystem`` is a ``mechanism.Mechanism`` whose bodies are all ANCF bodies
(``inertial.InertialBody``): the one constrained-system implementation, which factors each beam
chain's block by its block-tridiagonal solver and the joints by their Schur complement. This
class only checks its input (element bodies, each held by a joint); ``nodal_vectors(x)`` is the
state as one (n_vectors, 3) array a body.
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float, Scalar
from ..bodies.body import Body
from .inertial import InertialBody
from .mechanism import Mechanism


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


class MultibodySystem(Mechanism):
    """Bodies (``Body``, placed in space: their ``q_hat`` is the initial, stress-free state), joints
    (on nodal vectors or on markers) and ``gravity`` (an acceleration, 3-vector): a ``Mechanism``
    of ANCF bodies (see the module docstring). Its ``bodies`` are the mechanism's
    ``InertialBody``s; ``bodies[k].body`` is the element body.

    Raises ``ValueError`` before anything is traced for: a joint that refers to a body or nodal
    vector that does not exist, a body that no joint holds, joint equations that the initial
    state does not satisfy, and redundant joint equations (a rank-deficient C_x, which would make
    the iteration matrix singular)."""

    require_held = True

    def __init__(self, bodies, joints, gravity=(0.0, 0.0, 0.0)):
        bodies = tuple(bodies)  # element bodies, or the InertialBody that a system made of one
        if not bodies or not all(isinstance(b, (Body, InertialBody)) for b in bodies):
            raise ValueError("bodies must be a non-empty sequence of Body")
        super().__init__(bodies, joints, gravity)

    def displacements(self, t: Scalar, x: Float[Array, " n"]) -> Float[Array, "nv 3"]:
        """All nodal vectors' displacements from the initial state, stacked body by body."""
        return (x - self.reference()).reshape(-1, 3)

    @property
    def M(self) -> Float[Array, "n n"]:
        """The constant block-diagonal mass matrix (dense, all coordinates)."""
        return self.mass_matrix(self.reference())


__all__ = ["MultibodySystem", "placed"]
