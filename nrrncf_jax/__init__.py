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
import sys
import types

__version__ = "0.1.0"

_EXPORTS = {
    "body": ("Body", "beam_body"),
    "compilation_cache": ("compilation_cache",),
    "damping": ("RayleighDamping",),
    "integrate": ("GeneralizedAlpha", "SimulationError", "Solution", "simulate", "simulate_batch"),
    "integrate.simulate": ("simulate_timed",),
    "integrate.static": ("static_equilibrium",),
    "material": ("Material",),
    "mesh": ("BeamReference", "arc_reference", "centerline_reference", "straight_reference"),
    "metrics": ("chi_rel",),
    "frame": ("Frame", "frame_body"),
    "models": ("AbstractModel", "Harmonic", "InertialFrameModel", "LinearModel", "Loads", "ReducedRotatingModel",
               "RotatingFrameModel", "reduce_rotating_model"),
    "motion": ("AbstractMotion", "AbstractAxisMotion", "ComposedMotion", "HarmonicTranslation", "SpinUp",
               "Stationary", "SteadySpin"),
    "nr_rncf": ("Reduction", "nr_rncf"),
    "observe": ("tip_index",),
    "profiles": ("FourierSpinUp",),
    "reduction": ("ModalDerivatives", "VibrationModes", "deflate", "modal_derivatives", "vibration_modes"),
    "scenarios": ("BEAMS", "beam_preset", "run_spinup"),
    "scenarios.truss": ("TrussSpec", "build_truss"),
    "section": ("TubeSection",),
    "studies.control": ("OptimalSpinup", "optimal_spinup", "tip_response"),
    "studies.families": ("SpinupFamily", "offline_family"),
    "studies.identification": ("Measurement", "identify", "misfit"),
    "studies.sweep": ("SweepGrid", "SweepResult", "spinup_sweep", "sweep_grid", "sweep_reduction"),
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


class _Package(types.ModuleType):
    """This package's module type: a submodule that shares its name with a function exported here
    (``nr_rncf``, ``compilation_cache``) does not replace the function as the package's attribute
    when it is imported (the import system sets each submodule on its package), so
    ``nrrncf_jax.nr_rncf`` is the function, as it was when the package imported everything at once;
    the submodule stays in ``sys.modules``."""

    def __setattr__(self, name, value):
        if isinstance(value, types.ModuleType) and name in _WHERE and value.__name__ == f"{__name__}.{name}":
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
