"""Equations of motion: residuals and iteration matrices that the integrator solves."""

from .base import AbstractModel as AbstractModel
from .full_order import (
    Harmonic as Harmonic,
)
from .full_order import (
    InertialFrameModel as InertialFrameModel,
)
from .full_order import (
    Loads as Loads,
)
from .full_order import (
    RotatingFrameModel as RotatingFrameModel,
)
from .linear import LinearModel as LinearModel
from .reduced import ReducedRotatingModel as ReducedRotatingModel
from .reduced import reduce_rotating_model as reduce_rotating_model
