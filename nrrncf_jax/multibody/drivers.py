"""Drivers: joints that prescribe a relative motion as a function of time (a rheonomic
constraint, C(x, t) = 0; MULTIBODY.md).

- ``AngleDriver``: the angle of body b about a hinge's axis relative to body a (or the ground)
  follows φ(t) = θ(t) − θ(0), θ from a motion (``motion.SteadySpin``, ``SpinUp``, ``FourierSpinUp``
  or any module whose ``motion(t)[0]`` is the angle). With u_a, w_a = axis × u_a two of a's
  gradient vectors normal to the axis and u_b b's gradient vector along u_a in the reference:

      u_b · (cos φ w_a − sin φ u_a) = 0,

  one equation, which together with the hinge (``joints.Revolute``) fixes b's rotation. Its
  multiplier λ is the driving torque: the force −λ n on u_b (n = axis × u_b) is the moment
  u_b × (−λ n) = −λ |u_b| axis, so the torque the driver applies to b about the axis is −λ (exact
  for a rigid body's unit directors, to the section vectors' stretch on a flexible one).
- ``DistanceDriver``: the distance of b's point along a's axis vector d_a (or a fixed axis) from
  a's point follows s(t) − s(0) from its reference value:

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
from .joints import AbstractJoint, _vector


def _motion_value(motion, t):
    """The prescribed angle or distance: ``motion(t)[0]`` relative to t = 0."""
    return motion(t)[0] - motion(0.0)[0]


class AngleDriver(AbstractJoint):
    """b's rotation about a hinge's axis prescribed (see the module docstring). ``body_a=None``:
    relative to the fixed directions ``ground`` (2 × 3: u and w = axis × u)."""

    body_a: int | None = eqx.field(static=True)
    u_a: int | None = eqx.field(static=True)
    w_a: int | None = eqx.field(static=True)
    body_b: int = eqx.field(static=True)
    u_b: int = eqx.field(static=True)
    motion: eqx.Module
    ground: Float[Array, "2 3"]

    n_equations = 1
    rheonomic = True

    def __init__(self, body_a, u_a, w_a, body_b: int, u_b: int, motion, ground=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))):
        if not callable(motion):
            raise ValueError("a driver's motion must be callable: motion(t)[0] is the prescribed angle")
        if body_a is None:
            self.body_a, self.u_a, self.w_a = None, None, None
        else:
            self.body_a, self.u_a, self.w_a = int(body_a), int(u_a), int(w_a)
        self.body_b, self.u_b = int(body_b), int(u_b)
        self.motion = motion
        self.ground = jnp.asarray(ground, dtype=float).reshape(2, 3)

    def references(self):
        refs = [(self.body_b, self.u_b)]
        return refs + ([] if self.body_a is None else [(self.body_a, self.u_a), (self.body_a, self.w_a)])

    def turned(self, A):
        return eqx.tree_at(lambda j: j.ground, self, self.ground @ A.T)

    def angle(self, t):
        """φ(t) = θ(t) − θ(0), the prescribed angle from the reference configuration."""
        return _motion_value(self.motion, t)

    def effort(self, lam: Float[Array, " 1"]) -> Float[Array, ""]:
        """The driving torque on body b about the axis from the driver's multiplier: −λ."""
        return -lam[0]

    def __call__(self, xs, t=0.0):
        if self.body_a is None:
            u_a, w_a = self.ground[0], self.ground[1]
        else:
            u_a, w_a = _vector(xs, self.body_a, self.u_a), _vector(xs, self.body_a, self.w_a)
        phi = self.angle(t)
        return (_vector(xs, self.body_b, self.u_b) @ (jnp.cos(phi) * w_a - jnp.sin(phi) * u_a))[None]


class DistanceDriver(AbstractJoint):
    """b's point's distance along a's axis prescribed (see the module docstring). ``body_a=None``:
    along the fixed ``axis`` from the fixed ``point``."""

    body_a: int | None = eqx.field(static=True)
    position_a: int | None = eqx.field(static=True)
    axis_a: int | None = eqx.field(static=True)
    body_b: int = eqx.field(static=True)
    position_b: int = eqx.field(static=True)
    motion: eqx.Module
    s_ref: Float[Array, ""]
    point: Float[Array, " 3"]
    axis: Float[Array, " 3"]

    n_equations = 1
    rheonomic = True

    def __init__(self, body_a, position_a, axis_a, body_b: int, position_b: int, motion, s_ref=0.0,
                 point=(0.0, 0.0, 0.0), axis=(1.0, 0.0, 0.0)):
        if not callable(motion):
            raise ValueError("a driver's motion must be callable: motion(t)[0] is the prescribed distance")
        if body_a is None:
            self.body_a, self.position_a, self.axis_a = None, None, None
        else:
            self.body_a, self.position_a, self.axis_a = int(body_a), int(position_a), int(axis_a)
        self.body_b, self.position_b = int(body_b), int(position_b)
        self.motion = motion
        self.s_ref = jnp.asarray(s_ref, dtype=float)
        self.point = jnp.asarray(point, dtype=float).reshape(3)
        self.axis = jnp.asarray(axis, dtype=float).reshape(3)

    def references(self):
        refs = [(self.body_b, self.position_b)]
        return refs + ([] if self.body_a is None else [(self.body_a, self.position_a), (self.body_a, self.axis_a)])

    def turned(self, A):
        return eqx.tree_at(lambda j: (j.point, j.axis), self, (A @ self.point, A @ self.axis))

    def effort(self, lam: Float[Array, " 1"]) -> Float[Array, ""]:
        """The driving force on body b along the axis from the driver's multiplier: −λ."""
        return -lam[0]

    def __call__(self, xs, t=0.0):
        if self.body_a is None:
            r_a, d = self.point, self.axis
        else:
            r_a, d = _vector(xs, self.body_a, self.position_a), _vector(xs, self.body_a, self.axis_a)
        s = (_vector(xs, self.body_b, self.position_b) - r_a) @ d
        return (s - self.s_ref - _motion_value(self.motion, t))[None]


__all__ = ["AngleDriver", "DistanceDriver"]
