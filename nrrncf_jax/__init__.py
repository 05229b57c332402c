"""nrrncf_jax: JAX-accelerated, differentiable flexible multibody dynamics with the NR-RNCF
nonlinear order reduction (Yuan, Ren et al., Mech. Mach. Theory 185, 2023).

The library never changes global JAX configuration: switch float64 on yourself (JAX's x64
option, as the README's example does) before building models. Only the ``nrrncf`` command
line switches it on, in its own entry point.

The names below are imported on first use (PEP 562), so that ``import nrrncf_jax`` (and the
``nrrncf`` command's ``--help`` and argument checks) does not start JAX; ``nrrncf_jax.simulate``
and ``from nrrncf_jax import simulate`` work as usual.
"""

import importlib
import importlib.util

__version__ = "0.1.0"

_EXPORTS = {
    "bodies": ("Body", "beam_body", "Frame", "frame_body", "BeamReference",
               "arc_reference", "centerline_reference", "straight_reference"),
    "elements": ("Material", "TubeSection"),
    "integrate": ("AdaptiveStepSize", "ConstantStepSize", "GeneralizedAlpha", "GeneralizedAlphaIndex3", "Newton",
                  "SimulationError", "SimulationResult", "Solution", "simulate", "simulate_batch", "simulate_timed",
                  "static_equilibrium", "compilation_cache"),
    "models": ("AbstractModel", "Harmonic", "InertialFrameModel", "LinearModel", "Loads", "RayleighDamping",
               "RotatingFrameModel", "tip_index"),
    "motion": ("AbstractMotion", "AbstractAxisMotion", "ComposedMotion", "FourierSpinUp", "HarmonicTranslation",
               "SpinUp", "Stationary", "SteadySpin"),
    "post": ("chi_rel",),
    "reduction": ("Basis", "ErrorEstimator", "ModalDerivatives", "ReducedRotatingModel", "Reduction", "SpinState",
                  "ToTolerance", "VibrationModes", "deflate", "modal_derivatives", "nr_rncf", "nr_rncf_to_tolerance",
                  "reduce_rotating_model", "vibration_modes"),
    "scenarios": ("BEAMS", "beam_preset", "run_spinup", "sweep_reduction"),
    "scenarios.truss": ("TrussSpec", "build_truss"),
    "studies": ("AdamLbfgs", "Measurement", "OptimalSpinup", "SpinupFamily", "SweepGrid", "SweepResult", "identify",
                "misfit", "offline_family", "optimal_spinup", "spinup_sweep", "sweep_grid", "tip_response"),
}
"""Public names by the submodule (relative to this package) that defines them."""

_WHERE = {name: module for module, names in _EXPORTS.items() for name in names}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    """Import a public name (or a submodule) on first use and keep it."""
    module = _WHERE.get(name)
    if module is not None:
        value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    elif importlib.util.find_spec(f"{__name__}.{name}") is not None:
        value = importlib.import_module(f"{__name__}.{name}")
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_WHERE))
