"""Model order reduction: vibration modes (more to come: modal derivatives, selection, tensors)."""

from .modes import VibrationModes as VibrationModes, vibration_modes as vibration_modes
