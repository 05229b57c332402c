"""Multibody systems: bodies joined by joints (index-3 DAE, THEORY §7).

- ``joints``: ``Spherical``, ``Revolute``, ``Fixed`` (to another body or to the ground).
- ``system``: ``MultibodySystem`` of inertial-frame (ANCF) bodies under gravity, run with
  ``integrate.GeneralizedAlphaIndex3``; ``placed`` moves a body into place.
"""

from .joints import GROUND as GROUND
from .joints import AbstractJoint as AbstractJoint
from .joints import Fixed as Fixed
from .joints import Revolute as Revolute
from .joints import Spherical as Spherical
from .system import MultibodySystem as MultibodySystem
from .system import placed as placed
