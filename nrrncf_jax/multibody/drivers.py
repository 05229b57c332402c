"""Drivers: joints that prescribe a relative motion as a function of time (a rheonomic
constraint, C(x, t) = 0; docs/multibody-theory.md, §Joints: driven joints).

- ``AngleDriver``: the angle of body b about a hinge's axis relative to body a (or the ground)
  follows φ(t) = θ(t) − θ(0), θ from a motion (``motion.SteadySpin``, ``SpinUp``, ``FourierSpinUp``
  or any module whose ``motion(t)[0]`` is the angle). With u_a, w_a = axis × u_a two directions
  normal to the axis fixed in a's section frame and u_b the one fixed in b's that is u_a in the
  reference (``measures.HingeAngle``, ``section_frame``):

      u_b · (cos φ w_a − sin φ u_a) = 0,

  one equation, which together with the hinge (``joints.Revolute``) fixes b's rotation. Its
  multiplier λ is the driving torque: a rotation δθ of b's section changes the equation by
  δθ·(u_b × c) = δθ·axis (c = cos φ w_a − sin φ u_a), so the torque the driver applies to b
  about the axis is −λ, exactly: the directions are unit vectors of orthonormal section frames,
  and the torque acts on the cross-section, not through a beam's slope.
- ``DistanceDriver``: the distance of b's point along an axis d_a fixed in a's section frame (or
  a fixed axis) from a's point follows s(t) − s(0) from its reference value:

      (r_b − r_a) · d_a − s_ref − (s(t) − s(0)) = 0;

  with a prismatic joint (``prismatic.Prismatic``) it fixes the slider. The force the driver
  applies to b along the axis is −λ (for |d_a| = 1).

The system hands the time to every joint (``AbstractJoint.__call__(xs, t)``); the constraint's
time derivatives (C_t for the velocities, C_tt and C_xt for the accelerations) are taken by
automatic differentiation in ``models.constrained``.
"""

import equinox as eqx
import jax.numpy as jnp

from .._types import Array, Float
from .joints import AbstractJoint
from .measures import HingeAngle, Travel
from .section_frame import dot


def _motion_value(motion, t):
    """The prescribed angle or distance: ``motion(t)[0]`` relative to t = 0."""
    return motion(t)[0] - motion(0.0)[0]


class AngleDriver(AbstractJoint):
    """b's rotation about a hinge's axis prescribed (see the module docstring), on the directions
    of a ``measures.HingeAngle``."""

    hinge: HingeAngle
    motion: eqx.Module

    n_equations = 1
    rheonomic = True

    def __init__(self, hinge: HingeAngle, motion):
        if not callable(motion):
            raise ValueError("a driver's motion must be callable: motion(t)[0] is the prescribed angle")
        self.hinge = hinge
        self.motion = motion

    def references(self):
        return self.hinge.references()

    def turned(self, A):
        return eqx.tree_at(lambda j: j.hinge, self, self.hinge.turned(A))

    def angle(self, t):
        """φ(t) = θ(t) − θ(0), the prescribed angle from the reference configuration."""
        return _motion_value(self.motion, t)

    def effort(self, lam: Float[Array, " 1"]) -> Float[Array, ""]:
        """The driving torque on body b about the axis from the driver's multiplier: −λ."""
        return -lam[0]

    def __call__(self, xs, t=0.0):
        u_a, w_a, u_b = self.hinge.directions(xs)
        phi = self.angle(t)
        return dot(u_b, jnp.cos(phi) * w_a - jnp.sin(phi) * u_a)[None]


class DistanceDriver(AbstractJoint):
    """b's point's distance along a's axis prescribed (see the module docstring), a
    ``measures.Travel`` held to its reference value ``s_ref`` plus the motion."""

    travel: Travel
    motion: eqx.Module
    s_ref: Float[Array, ""]

    n_equations = 1
    rheonomic = True

    def __init__(self, travel: Travel, motion, s_ref=0.0):
        if not callable(motion):
            raise ValueError("a driver's motion must be callable: motion(t)[0] is the prescribed distance")
        self.travel = travel
        self.motion = motion
        self.s_ref = jnp.asarray(s_ref, dtype=float)

    def references(self):
        return self.travel.references()

    def turned(self, A):
        return eqx.tree_at(lambda j: j.travel, self, self.travel.turned(A))

    def effort(self, lam: Float[Array, " 1"]) -> Float[Array, ""]:
        """The driving force on body b along the axis from the driver's multiplier: −λ."""
        return -lam[0]

    def __call__(self, xs, t=0.0):
        return (self.travel(xs) - self.s_ref - _motion_value(self.motion, t))[None]


__all__ = ["AngleDriver", "DistanceDriver"]
