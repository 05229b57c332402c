"""Model order reduction (THEORY §4-7): vibration modes, modal derivatives, maximum modal
interaction, SVD deflation, the extended Craig-Bampton basis of jointed bodies, the
spinning-state enrichment and the reduced tensors (``reduction.pipeline.nr_rncf`` chains them)."""

from .craig_bampton import CraigBampton as CraigBampton
from .craig_bampton import craig_bampton as craig_bampton
from .deflation import deflate as deflate
from .modal_derivatives import ModalDerivatives as ModalDerivatives
from .modal_derivatives import modal_derivatives as modal_derivatives
from .modes import VibrationModes as VibrationModes
from .modes import vibration_modes as vibration_modes
from .pipeline import Reduction as Reduction
from .pipeline import nr_rncf as nr_rncf
from .reduced_model import ReducedRotatingModel as ReducedRotatingModel
from .reduced_model import reduce_rotating_model as reduce_rotating_model
from .selection import Selection as Selection
from .selection import align_degenerate_modes as align_degenerate_modes
from .selection import excited_modes as excited_modes
from .selection import mmi_matrix as mmi_matrix
from .selection import plane_loads as plane_loads
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
