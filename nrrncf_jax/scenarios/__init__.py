"""The paper's examples as presets."""

from .beams import BEAMS as BEAMS, BeamPreset as BeamPreset, beam_preset as beam_preset
from .spinup import (
    PAPER_ELEMENTS as PAPER_ELEMENTS,
    SpinupResult as SpinupResult,
    build_spinup_model as build_spinup_model,
    run_spinup as run_spinup,
)
