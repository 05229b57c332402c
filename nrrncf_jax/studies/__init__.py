"""Studies: what is done *with* the simulator, outside its core (bodies, elements, models,
reduction, integrator), which never imports this package.

- ``families``: parameterised reduced models, ``params -> model`` (fixed basis, or through the
  offline stage), the models that identification differentiates.
- ``identification``: measurements, the misfit, ``identify`` (Adam, then L-BFGS).
- ``control``: the spin-up profile with the least residual vibration (``optimal_spinup``).
- ``sweep``: batched, vmapped and device-sharded sweeps over (ωs, Ts, E).
- ``distributed``: the sweeps on several processes and hosts (``jax.distributed``, a local
  launcher, shards and their merge).
- ``optimize``: the one L-BFGS / line-search driver shared by identification and control.

The public names are exported here and by the package (``nrrncf_jax.identify``, ``nrrncf_jax.spinup_sweep``,
...).

Identification fits Young's modulus, a damping ratio and the spin-up (ωs, Ts) to a measured
response, by optax Adam then L-BFGS on log-parameters, with reverse-mode gradients through the
checkpointed integrator; either with the basis held fixed (``SpinupFamily``: κ is linear in E) or
through the whole offline stage (``offline_family``: modes, modal derivatives, deflation, tensors,
with a degeneracy-safe derivative of ``eigh``, and a warning and the fixed-basis fallback when a
selected mode has a repeated eigenvalue). The demonstration: ``nrrncf identify --demo``,
``scenarios.identification``, ``notebooks/02_identification.ipynb``.

A sweep is one compiled, vmapped run over a (ωs, Ts, E) grid on one shared basis, built at the
grid's hardest case, split across devices with ``shard_map`` (no cross-device communication per
step); ``integrate.simulate_batch`` runs any batch of models the same way, each member with its
own adaptive steps, and with fewer lanes than members the rest queue for the lane of a member
that ends (``notebooks/03_sweep.ipynb``).

Control: the spin-up to a given ωs within Ts that leaves the least residual vibration, by gradient
descent over the Fourier correction of ``motion.FourierSpinUp`` through the reduced simulation,
checked on the full RNCF model (``notebooks/04_optimal_spinup.ipynb``).
"""

from .control import OptimalSpinup as OptimalSpinup
from .control import optimal_spinup as optimal_spinup
from .control import tip_response as tip_response
from .families import SpinupFamily as SpinupFamily
from .families import offline_family as offline_family
from .identification import Measurement as Measurement
from .identification import identify as identify
from .identification import misfit as misfit
from .optimize import AdamLbfgs as AdamLbfgs
from .sweep import SweepGrid as SweepGrid
from .sweep import SweepResult as SweepResult
from .sweep import spinup_sweep as spinup_sweep
from .sweep import sweep_grid as sweep_grid
