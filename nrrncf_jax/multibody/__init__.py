"""Multibody systems: bodies joined by joints (index-3 DAE, THEORY §7).

- ``joints``: ``Spherical``, ``Revolute``, ``Fixed`` (to another body or to the ground).
- ``system``: ``MultibodySystem`` of inertial-frame (ANCF) bodies under gravity, run with
  ``integrate.GeneralizedAlphaIndex3``; ``placed`` moves a body into place.
- ``floating``: ``FloatingFrameSystem`` of bodies in free-floating frames (Euler parameters)
  with reduced deformation (``FloatingBody``): NR-RNCF for jointed systems.
- ``full_order_frame``: ``full_floating_body``, a floating-frame body with every free nodal
  coordinate kept and the elements' own elastic force: the full-order RNCF.
"""

from .floating import FloatingBody as FloatingBody
from .floating import FloatingFrameSystem as FloatingFrameSystem
from .full_order_frame import NodalElasticForce as NodalElasticForce
from .full_order_frame import full_floating_body as full_floating_body
from .joints import GROUND as GROUND
from .joints import AbstractJoint as AbstractJoint
from .joints import Fixed as Fixed
from .joints import Revolute as Revolute
from .joints import Spherical as Spherical
from .system import MultibodySystem as MultibodySystem
from .system import placed as placed
