"""Studies: what is done *with* the simulator, outside its core (bodies, elements, models,
reduction, integrator), which never imports this package.

- ``families``: parameterised reduced models, ``params -> model`` (fixed basis, or through the
  offline stage), the models that identification differentiates.
- ``identification``: measurements, the misfit, ``identify`` (Adam, then L-BFGS).
- ``control``: the spin-up profile with the least residual vibration (``optimal_spinup``).
- ``sweep``: batched, vmapped and device-sharded sweeps over (ωs, Ts, E).
- ``optimize``: the one L-BFGS / line-search driver shared by identification and control.

The public names are exported here and by the package (``nrrncf_jax.identify``, ``nrrncf_jax.spinup_sweep``,
...).
"""

from .control import OptimalSpinup as OptimalSpinup
from .control import optimal_spinup as optimal_spinup
from .control import tip_response as tip_response
from .families import SpinupFamily as SpinupFamily
from .families import offline_family as offline_family
from .identification import Measurement as Measurement
from .identification import identify as identify
from .identification import misfit as misfit
from .sweep import SweepGrid as SweepGrid
from .sweep import SweepResult as SweepResult
from .sweep import spinup_sweep as spinup_sweep
from .sweep import sweep_grid as sweep_grid
