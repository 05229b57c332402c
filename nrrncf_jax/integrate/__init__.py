"""Time integration: ``simulate(model, solver, controller, ts)``.

- solvers (``base.AbstractSolver``): ``GeneralizedAlpha`` (docs/theory.md, §8 Time integration; Arnold-Brüls form) for
  models with prescribed coordinates, ``GeneralizedAlphaIndex3`` for constrained systems (joints,
  Lagrange multipliers in the state);
- step-size controllers (``step_size``): ``AdaptiveStepSize`` (error control; plain or PI,
  ``adaptive_step_size`` by name, ``step_control_name`` the name back), ``ConstantStepSize``;
  ``with_tolerances``, a controller at other tolerances (a run repeated tighter), and ``tightened``,
  one whose integration error is a given factor smaller (tolerances, or a fixed step);
- ``Newton``: each step's implicit solve (modified or full Newton, ``newton``; ``reuse=True`` keeps
  the iteration matrix across steps, ``base.IterationMatrix``);
- ``simulate``, ``simulate_batch`` (a batch of models in one loop, each with its own steps;
  ``batch_lanes``, how many advance together by default),
  ``simulate_timed`` (compile and run timed apart); ``Solution`` and ``SimulationResult``;
  ``states_at`` (states at given times, each the end of a step, not an interpolated output);
  ``kernel_options`` (XLA's options for programs of small kernels, for a user's own ``jax.jit``);
- ``static_equilibrium``: load-stepped static solutions; ``constrained_equilibrium``: a
  mechanism's static state and joint reactions, ``stability`` its stiffness there and
  ``vibration_frequencies`` its natural frequencies about it;
  ``compilation_cache``: JAX's persistent compilation cache as a context manager.

The whole simulation is one jit-compiled loop. Each step solves for the new acceleration by Newton
(full Newton stops on the error its last update leaves, estimated from the observed contraction;
a Newton failure or a non-finite state retries a shorter step), a Zienkiewicz-Xie local error
estimate drives the step size, and dense output gives the requested output times (``step_ts``:
times on which steps must end, where an output is then a step's end state). The loop works
under ``jax.vmap`` and is differentiable with ``jax.grad``: reverse mode runs a checkpointed loop
with implicit differentiation of each step's Newton solve, so its memory grows with the number of
checkpoints, not of steps. A run that stops early (a non-finite state, Newton failing at the
smallest step, the step limit) raises ``SimulationError`` naming the time reached.
"""

from .base import AbstractSolver as AbstractSolver
from .base import GeneralizedAlphaState as GeneralizedAlphaState
from .base import IterationMatrix as IterationMatrix
from .base import Newton as Newton
from .base import NewtonOptions as NewtonOptions
from .cache import compilation_cache as compilation_cache
from .generalized_alpha import AbstractGeneralizedAlpha as AbstractGeneralizedAlpha
from .generalized_alpha import GeneralizedAlpha as GeneralizedAlpha
from .index3 import GeneralizedAlphaIndex3 as GeneralizedAlphaIndex3
from .newton import NewtonResult as NewtonResult
from .newton import NewtonSolution as NewtonSolution
from .results import SimulationError as SimulationError
from .results import SimulationResult as SimulationResult
from .simulate import CPU_BATCH_LANES as CPU_BATCH_LANES
from .simulate import SMALL_KERNEL_OPTIONS as SMALL_KERNEL_OPTIONS
from .simulate import Solution as Solution
from .simulate import batch_lanes as batch_lanes
from .simulate import kernel_options as kernel_options
from .simulate import simulate as simulate
from .simulate import simulate_batch as simulate_batch
from .simulate import simulate_timed as simulate_timed
from .simulate import states_at as states_at
from .static import Equilibrium as Equilibrium
from .static import constrained_equilibrium as constrained_equilibrium
from .static import stability as stability
from .static import static_equilibrium as static_equilibrium
from .static import vibration_frequencies as vibration_frequencies
from .step_size import STEP_CONTROLS as STEP_CONTROLS
from .step_size import AbstractStepSizeController as AbstractStepSizeController
from .step_size import AdaptiveStepSize as AdaptiveStepSize
from .step_size import ConstantStepSize as ConstantStepSize
from .step_size import adaptive_step_size as adaptive_step_size
from .step_size import step_control_name as step_control_name
from .step_size import tightened as tightened
from .step_size import with_tolerances as with_tolerances
