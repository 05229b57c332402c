"""Time integration: adaptive generalized-α for second-order models, and its index-3 form for
constrained (multibody) models."""

from .cache import compilation_cache as compilation_cache
from .generalized_alpha import GeneralizedAlpha as GeneralizedAlpha
from .index3 import GeneralizedAlphaIndex3 as GeneralizedAlphaIndex3
from .newton import NewtonResult as NewtonResult
from .newton import NewtonSolution as NewtonSolution
from .newton import newton as newton
from .simulate import (
    RESULTS as RESULTS,
)
from .simulate import (
    SimulationError as SimulationError,
)
from .simulate import (
    Solution as Solution,
)
from .simulate import (
    simulate as simulate,
)
from .simulate import (
    simulate_batch as simulate_batch,
)
from .simulate import simulate_timed as simulate_timed
from .state import AbstractStepper as AbstractStepper
from .state import GeneralizedAlphaState as GeneralizedAlphaState
from .state import NewtonOptions as NewtonOptions
from .static import static_equilibrium as static_equilibrium
