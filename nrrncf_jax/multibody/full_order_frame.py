"""Full-order floating-frame bodies: RNCF of a jointed system without reduction (docs/theory.md, §3
Equations of motion of one body; the paper's full RNCF reference in Sec. 4.4).

A ``FloatingBody`` whose deformation basis is the identity on every nodal coordinate that its
reference conditions leave free (Ψ = I[:, free], so p is those coordinates of the nodal vectors
in the frame), and whose elastic force is the elements' own, ``NodalElasticForce``: Ψᵀ F(q̂ + Ψp)
and its tangent Ψᵀ K(q) Ψ, assembled element by element. With Ψ a selection both are gathers:
no projection is formed. The frame, joints, inertia and the index-3 integration are those of
``floating``; only the elastic force differs from NR-RNCF's reduced cubic one (Eq. 24), which is
its projection on a reduced basis (for constant κ the cubic form is exact, so the two agree on
any basis: ``tests/test_floating.py``).

Cost, and why it is dense: z_b has 7 + (n_dof − held) coordinates (196 on the pendulum's
10-element beams) and its iteration-matrix block couples the frame's seven with all of them
through the mass matrix, so each body's block is factored dense (one LU of 196 × 196 a body a
step). The ANCF ``MultibodySystem`` keeps its bodies' banded structure instead; this model is
the paper's full-order RNCF, the reference NR-RNCF reduces.
"""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float, Int
from ..bodies.body import Body
from .floating import FloatingBody


class NodalElasticForce(eqx.Module):
    """The body's elastic force on its ``free`` nodal coordinates (indices into its n_dof),
    through its elements (Eqs. 9-11): ``force(p) = F(q̂ + Ψp)[free]`` and its Jacobian
    ``K(q̂ + Ψp)[free, free]``, Ψ = I[:, free]. The same interface as
    ``reduction.ElasticTensors``, so a ``FloatingBody`` takes either."""

    full_order: ClassVar[bool] = True
    """The elements' own force on every free nodal coordinate (full-order RNCF)."""

    body: Body
    free: Int[Array, " k"]

    def __init__(self, body: Body, free):
        free = np.asarray(free)
        if free.dtype == bool:
            if free.shape != (body.n_dof,):
                raise ValueError(f"free must be a mask of the body's {body.n_dof} coordinates, got {free.shape}")
            free = np.flatnonzero(free)
        if free.ndim != 1 or free.size == 0 or free.min() < 0 or free.max() >= body.n_dof or \
                np.unique(free).size != free.size:
            raise ValueError(f"free must be distinct coordinate indices in [0, {body.n_dof})")
        self.body, self.free = body, jnp.asarray(free, dtype=int)

    @property
    def n_coordinates(self) -> int:
        return int(self.free.shape[0])

    def _q(self, p):
        return (self.body.q_hat.reshape(-1).at[self.free].add(p)).reshape(-1, 3)

    def force(self, p: Float[Array, " k"]) -> Float[Array, " k"]:
        return self.body.elastic_force(self._q(p)).reshape(-1)[self.free]

    def energy(self, p: Float[Array, " k"]) -> Float[Array, ""]:
        """The elements' strain energy at q̂ + Ψp (zero at the stress-free q̂)."""
        return self.body.strain_energy(self._q(p))

    def force_and_jacobian(self, p: Float[Array, " k"]):
        q = self._q(p)
        K = self.body.stiffness_matrix(q)
        return self.body.elastic_force(q).reshape(-1)[self.free], K[self.free[:, None], self.free[None, :]]


def full_floating_body(body: Body, free, R0=(0.0, 0.0, 0.0), A0=None, mean_axis: bool = False) -> FloatingBody:
    """``body`` in a floating frame at ``R0``, ``A0`` with every coordinate of the ``free`` mask
    (n_dof booleans: False on the reference conditions, which hold the frame) a deformation
    coordinate: the full-order RNCF body. ``mean_axis``: the frame held by the mean-axis
    conditions instead, where ``free`` leaves rigid motions free (``reduce(conditions=
    "mean-axis")``): the body adds the linear constraints G p = 0 (the deformation's momenta
    relative to the frame, ``FloatingBody.own_equations``), one a rigid motion left, so that its
    frame and its deformation do not share them; its motion is the same as under any other
    reference conditions, and it is the full-order counterpart of a mean-axis reduced body."""
    force = NodalElasticForce(body, np.asarray(free, dtype=bool))  # checks the mask
    return FloatingBody(body, np.eye(body.n_dof)[:, np.asarray(force.free)], force, R0=R0, A0=A0,
                        free=np.asarray(free, dtype=bool), mean_axis=mean_axis)


__all__ = ["NodalElasticForce", "full_floating_body"]
