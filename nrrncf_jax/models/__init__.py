"""Equations of motion: residuals and iteration matrices that the integrator solves."""

from .base import AbstractModel as AbstractModel
from .linear import LinearModel as LinearModel
from .full_order import (
    InertialFrameModel as InertialFrameModel,
    Loads as Loads,
    RotatingFrameModel as RotatingFrameModel,
)
