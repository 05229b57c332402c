"""Prescribed motions of a body's reference frame (THEORY §3): ``prescribed`` holds the motion
interface (``AbstractMotion``: rotation A(t), ω(t), ω̇(t) and the origin's acceleration) and its
cases (the spin-up of Eq. 43, steady spin, a stationary frame, a hub translation, compositions);
``profiles`` the trainable spin-up profile used for control."""

from .prescribed import AbstractAxisMotion as AbstractAxisMotion
from .prescribed import AbstractMotion as AbstractMotion
from .prescribed import ComposedMotion as ComposedMotion
from .prescribed import HarmonicTranslation as HarmonicTranslation
from .prescribed import SpinUp as SpinUp
from .prescribed import Stationary as Stationary
from .prescribed import SteadySpin as SteadySpin
from .prescribed import rotation_about as rotation_about
from .prescribed import skew as skew
from .prescribed import spin_up_angle as spin_up_angle
from .prescribed import unit_axis as unit_axis
from .profiles import FourierSpinUp as FourierSpinUp
