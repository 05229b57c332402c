"""Time integration: adaptive generalized-α for second-order models."""

from .generalized_alpha import GeneralizedAlpha as GeneralizedAlpha
from .simulate import (
    RESULTS as RESULTS,
    SimulationError as SimulationError,
    Solution as Solution,
    simulate as simulate,
)
