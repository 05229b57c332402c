"""The paper's examples as presets."""

from .beams import BEAMS as BEAMS
from .beams import BeamPreset as BeamPreset
from .beams import beam_preset as beam_preset
from .spinup import (
    PAPER_ELEMENTS as PAPER_ELEMENTS,
)
from .spinup import (
    SpinupResult as SpinupResult,
)
from .spinup import (
    build_spinup_model as build_spinup_model,
)
from .spinup import (
    run_nr_rncf_spinup as run_nr_rncf_spinup,
)
from .spinup import (
    run_spinup as run_spinup,
)
from .spinup import sweep_reduction as sweep_reduction
