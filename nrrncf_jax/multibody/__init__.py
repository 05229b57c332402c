"""Multibody systems: bodies joined by joints (index-3 DAE; docs/theory.md, §7 Jointed bodies;
docs/multibody-theory.md).

- ``section_frame``: a node's orientation as joints see it, the orthonormal triad of its two
  section vectors (never a beam's slope r_x, through which a moment does not converge with the
  mesh); ``Directions`` fixed in it.
- ``joints``: ``Spherical``, ``Revolute`` (on section frames), ``Fixed`` (nodal vectors
  prescribed); ``weld``: ``Weld``; ``prismatic``: ``Prismatic``; ``cylindrical``: ``Cylindrical``;
  ``universal``: ``Universal``; ``eccentric_ball``: ``EccentricBall``;
  ``drivers``: ``AngleDriver``, ``DistanceDriver``, an angle or a slider's travel prescribed in
  time (their multipliers the driving torque or force).
- ``markers``: the joints in physical terms, ``hinge``, ``ball``, ``clamp``, ``slider``,
  ``cylindrical``, ``universal``, ``angle_driver`` on ``Marker``s (a body and a point of its reference
  configuration) with axes in any direction, which a system resolves into joints.
- ``forces``: force elements, ``SpringDamper`` and ``Actuator`` on a measure (``Distance``,
  ``HingeAngle``, ``Travel``), or on markers: ``spring``, ``torsion_spring``, ``motor``,
  ``actuator`` (its law a function of time, its own measure and rate, parameters and, with
  ``inputs``, kinematic sensors anywhere in the mechanism: state feedback).
- ``mechanism``: ``Mechanism``, bodies of any kind (``kinds``: ``FloatingBody``, a ``RigidBody``
  in its frame, an ANCF ``Body`` in the inertial frame as ``InertialBody``, ``PointMass``) in one
  system, run with ``integrate.GeneralizedAlphaIndex3``.
- ``system``: ``MultibodySystem``, a ``Mechanism`` of inertial-frame (ANCF) bodies only, each
  held by a joint; ``placed`` moves a body into place.
- ``floating``: ``FloatingBody``, a body in a free-floating frame (Euler parameters) with
  reduced deformation: NR-RNCF for jointed systems; ``FloatingFrameSystem`` is a ``Mechanism``
  of these only. ``Mechanism`` is the one constrained-system implementation; the two are checks
  on its input.
- ``full_order_frame``: ``full_floating_body``, a floating-frame body with every free nodal
  coordinate kept and the elements' own elastic force: the full-order RNCF.
- ``modal_interaction``: ``select_modal_derivatives(system, ts)``, each reduced body's modal
  derivatives chosen by maximum modal interaction in the mechanism's own motion (bodies reduced
  with ``reduce(..., mds="mmi")``; the paper's Fig. 16).
- ``error_estimate``: how good a reduced mechanism's run is, from the run alone
  (``estimate_mechanism_error`` against ``full_counterpart(system)``: each reduced body's static
  correction in its frame), and where that stops working (the drift of a long multibody motion).
- ``basis_to_tolerance``: ``mechanism_to_tolerance(build, order, ts, target)``, the reduced bodies'
  bases grown along a ranked list of candidates until the error estimate of a training run meets
  a target χ_rel (``scenarios.pendulum.pendulum_to_tolerance`` for the paper's pendulum).

A ``MultibodySystem`` is an index-3 DAE: the joints' multipliers are in the integrator's state
(``integrate.GeneralizedAlphaIndex3``, generalized-α in the Arnold-Brüls form, scaled), and its
constrained iteration matrix is factored body by body with the joints' Schur complement
(``linalg``). A joint refers to nodal vectors of its bodies; the system refuses, before anything
is traced, a joint that names a missing vector, an initial state that violates a joint, or
redundant equations. A stiff hinged beam swings with the exact elliptic-integral period, and with
ρ∞ = 1 the energy drifts only by the integration error (``tests/test_multibody.py``). A system
turns as a whole with ``system.turned(axis, angle)`` (its frames or nodal vectors and its joints'
fixed data; traceable in the angle), which ``scenarios.pendulum.release_sweep`` vmaps over release
angles.

A ``FloatingFrameSystem`` holds each body in its own frame (its origin and Euler parameters, |e| = 1
a constraint), its deformation reduced to its vibration modes and modal derivatives, optionally
with its joint's static modes or as the extended Craig-Bampton basis
(``reduction.craig_bampton``). The equations come from Lagrange's, with the map to the inertial
nodal vectors, its Jacobian and the quadratic-velocity terms in closed form; a free spinning body
keeps its momenta and energy, and a stiff one has the exact pendulum period
(``tests/test_floating.py``). The index-3 step projects the floating frames' velocities onto the
constraints' tangent space after each step, without which their accelerations oscillate from step
to step and stall the step size. ``full_floating_body`` is the paper's full-order RNCF reference:
each beam in the frame of its left end's centre-line tangent, every other nodal coordinate kept,
the elements' own elastic force; it is the ANCF model in other coordinates (its residual is Jᵀ of
the ANCF one), and the two agree to their integration error. Its iteration matrix carries the
inertia terms' derivatives with respect to the deformation in closed form, without which modified
Newton contracts slowly. The three-beam pendulum of the paper, all three ways:
``scenarios.pendulum``, ``notebooks/07_pendulum.ipynb``.
"""

from .cylindrical import Cylindrical as Cylindrical
from .drivers import AngleDriver as AngleDriver
from .drivers import DistanceDriver as DistanceDriver
from .eccentric_ball import EccentricBall as EccentricBall
from .floating import FloatingBody as FloatingBody
from .forces import Actuator as Actuator
from .forces import SpringDamper as SpringDamper
from .forces import actuator as actuator
from .forces import motor as motor
from .forces import spring as spring
from .forces import torsion_spring as torsion_spring
from .full_order_frame import NodalElasticForce as NodalElasticForce
from .full_order_frame import full_floating_body as full_floating_body
from .joints import GROUND as GROUND
from .joints import AbstractJoint as AbstractJoint
from .joints import Fixed as Fixed
from .joints import Revolute as Revolute
from .joints import Spherical as Spherical
from .kinds import AbstractBodyKind as AbstractBodyKind
from .markers import Marker as Marker
from .markers import angle_driver as angle_driver
from .markers import ball as ball
from .markers import clamp as clamp
from .markers import cylindrical as cylindrical
from .markers import hinge as hinge
from .markers import slider as slider
from .markers import universal as universal
from .mechanism import FloatingFrameSystem as FloatingFrameSystem
from .mechanism import Mechanism as Mechanism
from .point_mass import PointMass as PointMass
from .prismatic import Prismatic as Prismatic
from .rigid import rigid_floating_body as rigid_floating_body
from .section_frame import Directions as Directions
from .system import MultibodySystem as MultibodySystem
from .system import placed as placed
from .universal import Universal as Universal
from .weld import Weld as Weld
