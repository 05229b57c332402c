"""Prescribed motions of a body's reference frame (docs/theory.md, §3 Equations of motion of one
body): ``prescribed`` holds the motion interface (``AbstractMotion``: rotation A(t), ω(t), ω̇(t) and
the origin's acceleration) and its cases (the spin-up of Eq. 43, steady spin, a stationary frame, a
hub translation, compositions); ``profiles`` the trainable spin-up profile used for control.

A motion gives the frame's rotation A(t), its angular velocity ω(t) and acceleration ω̇(t) as
3-vectors, and its origin's acceleration: the spin-up of Eq. 43 about any fixed axis (``SpinUp``),
a steady spin (``SteadySpin``), a hub translation (``HarmonicTranslation``, as in the membrane's
bending-torsion case) and any composition of them (``ComposedMotion``, e.g. a spin about a
precessing axis). The RNCF model (``models.RotatingFrameModel``), the ANCF model with its root
driven (``models.InertialFrameModel``) and the reduced model agree under such a motion to round-off
(``tests/test_motion.py``). ``profiles.FourierSpinUp`` adds to Eq. 43's θ̈ a Fourier correction that
vanishes at 0 and Ts and keeps the end speed, the control variable of ``studies.control``
(``notebooks/04_optimal_spinup.ipynb``); ``profiles.SpinSchedule`` moves a spin rate between
plateaus by half-cosine ramps (the validation set's rotating shaft)."""

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
from .profiles import HalfCosine as HalfCosine
from .profiles import RestToRest as RestToRest
from .profiles import SpinSchedule as SpinSchedule
