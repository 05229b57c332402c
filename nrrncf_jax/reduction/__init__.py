"""Model order reduction (docs/theory.md, §4 Reduction to §7 Jointed bodies): vibration modes, modal
derivatives, maximum modal interaction, SVD deflation, the extended Craig-Bampton basis of jointed
bodies, the spinning-state enrichment and the reduced tensors (``reduction.pipeline.nr_rncf`` chains
them; ``reduction.basis.modal_basis`` assembles and deflates the basis of modes, modal derivatives
and extra columns).

``nr_rncf(full, ts, Basis(...))`` is the paper's Fig. 2 (``basis_choice.Basis``: which columns it
keeps): mass-normalised vibration modes (``modes``), static
modal derivatives (``modal_derivatives``: the closed form of Eq. 35, checked against automatic
differentiation), the modes and pairs chosen by maximum modal interaction (``selection``, Eq. 39)
from a linear simulation of the same manoeuvre, SVD deflation (``deflation``, Algorithm 1), and
the reduced cubic elastic force f + Kp + Lpp + Nppp (Eq. 24) built element by element by compiled
einsum kernels (``tensors``). The reduced model (``reduced_model.ReducedRotatingModel``) is an
``equinox.Module`` integrated by the same generalized-α loop as the full one; it vmaps and
differentiates (e.g. with respect to Young's modulus with the basis held fixed,
``studies.families``). The offline stage's cost is mostly compilation (the persistent cache,
``integrate.compilation_cache``, saves most of it).

Beyond the paper, the spinning-state enrichment (``spin_state``, on by default as a check): at the
manoeuvre's top spin rate the spinning equilibrium and its modes are computed; when the rest
basis's Rayleigh-Ritz estimate misses the dominant spinning frequency by more than
``SpinState.tol``, the first spinning mode and modal derivatives of spinning-mode pairs join the
basis within the same DOF budget. ``nr_rncf(full, ts, Basis(spin_state=False))`` (``nrrncf spinup
--spin-state off``) gives the paper's basis alone.

Round tubes' bending modes come in equal-frequency pairs, and the eigensolver returns any mix of
the two planes: ``align_degenerate_modes`` turns each pair to the load, and ``excited_modes`` with
``plane_loads`` picks the modes a planar motion excites (``elements.beam.mirror_even`` gives them
exactly). Close but distinct frequencies (a curved beam's out-of-plane and in-plane first modes)
are resolved by the eigensolver only to round-off, which would let an unloaded mode's MMI weight
depend on the CPU: ``purify_close_modes`` takes that round-off out. ``craig_bampton`` is the
extended Craig-Bampton basis of a jointed body (paper Eqs. 44-46: the joint's coordinates kept as
boundary coordinates with their static constraint modes, fixed-interface modes and their modal
derivatives), used by ``multibody.floating``; ``static_modes`` the attachment modes of chosen
coordinates, the same span kept as plain basis vectors. Mode indices are 0-based everywhere
(``Reduction.selection.vms``, ``.pairs``), as in the command line's output.

How good a reduced run is, without the full run: ``error_estimate`` (the static-correction
estimate of χ_rel from the run alone), made on a run of one's own by ``run_error``: run the
reduced model with ``step_ts=estimate_times(ts)`` (its steps then end on the samples), then
``estimate_run_error(full, reduced, ts, P, V)`` with its coordinates and velocities at ``ts``
(``ErrorEstimator``: how the scenario runners make it, static or dynamic, with or without the
run's time-integration part);
and ``basis_to_tolerance`` (``nr_rncf_to_tolerance(full, ts, P)``: the
basis grown along the MMI ranking until that estimate over a training run is at most P per cent);
for jointed systems of reduced bodies, ``multibody.error_estimate``."""

from .basis import ModalBasis as ModalBasis
from .basis import modal_basis as modal_basis
from .basis_choice import Basis as Basis
from .basis_choice import SpinState as SpinState
from .basis_to_tolerance import BasisSearch as BasisSearch
from .basis_to_tolerance import ToTolerance as ToTolerance
from .basis_to_tolerance import greedy_order as greedy_order
from .basis_to_tolerance import nr_rncf_to_tolerance as nr_rncf_to_tolerance
from .craig_bampton import CraigBampton as CraigBampton
from .craig_bampton import attachment_modes as attachment_modes
from .craig_bampton import craig_bampton as craig_bampton
from .craig_bampton import static_modes as static_modes
from .deflation import deflate as deflate
from .error_estimate import ErrorEstimate as ErrorEstimate
from .error_estimate import estimate_error as estimate_error
from .modal_derivatives import ModalDerivatives as ModalDerivatives
from .modal_derivatives import modal_derivatives as modal_derivatives
from .modes import VibrationModes as VibrationModes
from .modes import vibration_modes as vibration_modes
from .pipeline import Reduction as Reduction
from .pipeline import nr_rncf as nr_rncf
from .reduced_model import ReducedRotatingModel as ReducedRotatingModel
from .reduced_model import reduce_rotating_model as reduce_rotating_model
from .run_error import ErrorEstimator as ErrorEstimator
from .run_error import estimate_run_error as estimate_run_error
from .run_error import estimate_times as estimate_times
from .selection import Selection as Selection
from .selection import align_degenerate_modes as align_degenerate_modes
from .selection import excited_modes as excited_modes
from .selection import mmi_matrix as mmi_matrix
from .selection import plane_loads as plane_loads
from .selection import purify_close_modes as purify_close_modes
from .selection import select as select
from .spin_state import SpinCheck as SpinCheck
from .spin_state import match_modes as match_modes
from .spin_state import ritz_frequencies as ritz_frequencies
from .spin_state import spinning_equilibrium as spinning_equilibrium
from .spin_state import spinning_modes as spinning_modes
from .tensors import ElasticTensors as ElasticTensors
from .tensors import RotationInertia as RotationInertia
from .tensors import elastic_tensors as elastic_tensors
from .tensors import rotation_inertia as rotation_inertia
