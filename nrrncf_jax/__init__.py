"""nrrncf_jax: JAX-accelerated, differentiable flexible multibody dynamics with the NR-RNCF
nonlinear order reduction (Yuan, Ren et al., Mech. Mach. Theory 185, 2023).

The library never changes global JAX configuration: switch on float64 yourself,
``jax.config.update("jax_enable_x64", True)``, before building models.
"""

from .body import Body as Body, beam_body as beam_body
from .integrate import (
    GeneralizedAlpha as GeneralizedAlpha,
    SimulationError as SimulationError,
    Solution as Solution,
    simulate as simulate,
)
from .integrate.simulate import simulate_timed as simulate_timed
from .integrate.static import static_equilibrium as static_equilibrium
from .material import Material as Material
from .mesh import (
    BeamReference as BeamReference,
    arc_reference as arc_reference,
    centerline_reference as centerline_reference,
    straight_reference as straight_reference,
)
from .metrics import chi_rel as chi_rel
from .models import (
    AbstractModel as AbstractModel,
    InertialFrameModel as InertialFrameModel,
    LinearModel as LinearModel,
    Loads as Loads,
    RotatingFrameModel as RotatingFrameModel,
)
from .motion import SpinUp as SpinUp, Stationary as Stationary
from .reduction import VibrationModes as VibrationModes, vibration_modes as vibration_modes
from .scenarios import BEAMS as BEAMS, beam_preset as beam_preset, run_spinup as run_spinup
from .section import TubeSection as TubeSection

__version__ = "0.1.0"
