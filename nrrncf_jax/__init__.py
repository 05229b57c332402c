"""nrrncf_jax: JAX-accelerated, differentiable flexible multibody dynamics with the NR-RNCF
nonlinear order reduction (Yuan, Ren et al., Mech. Mach. Theory 185, 2023).

The library never changes global JAX configuration: switch float64 on yourself (JAX's x64
option, as the README's example does) before building models. Only the ``nrrncf`` command
line switches it on, in its own entry point.
"""

from .body import Body as Body
from .body import beam_body as beam_body
from .compilation_cache import compilation_cache as compilation_cache
from .control import OptimalSpinup as OptimalSpinup
from .control import optimal_spinup as optimal_spinup
from .control import tip_response as tip_response
from .damping import RayleighDamping as RayleighDamping
from .families import SpinupFamily as SpinupFamily
from .families import offline_family as offline_family
from .identify import Measurement as Measurement
from .identify import identify as identify
from .identify import misfit as misfit
from .integrate import (
    GeneralizedAlpha as GeneralizedAlpha,
)
from .integrate import (
    SimulationError as SimulationError,
)
from .integrate import (
    Solution as Solution,
)
from .integrate import (
    simulate as simulate,
)
from .integrate import (
    simulate_batch as simulate_batch,
)
from .integrate.simulate import simulate_timed as simulate_timed
from .integrate.static import static_equilibrium as static_equilibrium
from .material import Material as Material
from .mesh import (
    BeamReference as BeamReference,
)
from .mesh import (
    arc_reference as arc_reference,
)
from .mesh import (
    centerline_reference as centerline_reference,
)
from .mesh import (
    straight_reference as straight_reference,
)
from .metrics import chi_rel as chi_rel
from .models import (
    AbstractModel as AbstractModel,
)
from .models import (
    InertialFrameModel as InertialFrameModel,
)
from .models import (
    LinearModel as LinearModel,
)
from .models import (
    Loads as Loads,
)
from .models import ReducedRotatingModel as ReducedRotatingModel
from .models import (
    RotatingFrameModel as RotatingFrameModel,
)
from .models import reduce_rotating_model as reduce_rotating_model
from .motion import SpinUp as SpinUp
from .motion import Stationary as Stationary
from .motion import SteadySpin as SteadySpin
from .nr_rncf import Reduction as Reduction
from .nr_rncf import nr_rncf as nr_rncf
from .observe import tip_index as tip_index
from .profiles import FourierSpinUp as FourierSpinUp
from .reduction import ModalDerivatives as ModalDerivatives
from .reduction import VibrationModes as VibrationModes
from .reduction import deflate as deflate
from .reduction import modal_derivatives as modal_derivatives
from .reduction import vibration_modes as vibration_modes
from .scenarios import BEAMS as BEAMS
from .scenarios import beam_preset as beam_preset
from .scenarios import run_spinup as run_spinup
from .section import TubeSection as TubeSection
from .sweep import SweepGrid as SweepGrid
from .sweep import SweepResult as SweepResult
from .sweep import spinup_sweep as spinup_sweep
from .sweep import sweep_grid as sweep_grid
from .sweep import sweep_reduction as sweep_reduction

__version__ = "0.1.0"
