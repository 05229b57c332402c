"""Multibody systems: bodies joined by joints (index-3 DAE, THEORY §7).

- ``joints``: ``Spherical``, ``Revolute``, ``Fixed`` (to another body or to the ground).
- ``system``: ``MultibodySystem`` of inertial-frame (ANCF) bodies under gravity, run with
  ``integrate.GeneralizedAlphaIndex3``; ``placed`` moves a body into place.
- ``floating``: ``FloatingFrameSystem`` of bodies in free-floating frames (Euler parameters)
  with reduced deformation (``FloatingBody``): NR-RNCF for jointed systems.
"""

from .floating import FloatingBody as FloatingBody
from .floating import FloatingFrameSystem as FloatingFrameSystem
from .joints import GROUND as GROUND
from .joints import AbstractJoint as AbstractJoint
from .joints import Fixed as Fixed
from .joints import Revolute as Revolute
from .joints import Spherical as Spherical
from .system import MultibodySystem as MultibodySystem
from .system import placed as placed
