"""The identification demonstration: recover E and a damping ratio from a noisy
tip-deflection record of the classic beam's spin-up, with the NR-RNCF reduced model.

1. The *measurement*: the full RNCF model of the classic beam (true E, Rayleigh damping with
   ratio ζ = 2 % in its first two in-plane bending modes) spun up to ωs = 10 rad/s in Ts = 15 s;
   the in-plane tip deflection sampled every ``dt_out`` over 0-``t_end`` s, plus Gaussian noise of
   ``noise`` × its standard deviation.
2. The *model*: the NR-RNCF reduction of the same beam built at the starting guess (E and ζ
   both ``start`` × the truth), basis held fixed (``SpinupFamily``).
3. ``identify``: Adam, then L-BFGS, on log-parameters.
"""

import dataclasses
import json
import time

import jax.numpy as jnp
import numpy as np

from .. import _validate
from .._progress import note
from ..integrate import AdaptiveStepSize, GeneralizedAlpha
from ..integrate.simulate import simulate
from ..models.damping import RayleighDamping
from ..models.full_order import RotatingFrameModel
from ..models.observe import tip_observer
from ..motion import SpinUp
from ..reduction.basis_choice import Basis
from ..reduction.pipeline import nr_rncf
from ..studies.families import SpinupFamily
from ..studies.identification import (
    AdamLbfgs,
    IdentificationResult,
    Measurement,
    Observation,
    identify,
    tip_deflection,
)
from .beams import beam_preset
from .spinup import output_times


@dataclasses.dataclass
class IdentificationDemo:
    """The demonstration's data and outcome; ``summary()`` gives the CLI's JSON keys."""

    ts: np.ndarray
    clean: np.ndarray  # full-model tip deflection (no noise)
    measured: np.ndarray  # with noise
    initial_fit: np.ndarray  # reduced model at the starting guess
    final_fit: np.ndarray  # reduced model at the identified parameters
    E_true: float
    zeta_true: float
    result: IdentificationResult
    reduced_dofs: int
    measurement_s: float
    offline_s: float

    def summary(self) -> dict:
        p = self.result.params
        return {
            "E_true": self.E_true, "E_initial": self.result.initial["E"], "E_identified": p["E"],
            "E_rel_err": p["E"] / self.E_true - 1.0,
            "zeta_true": self.zeta_true, "zeta_initial": self.result.initial["zeta"], "zeta_identified": p["zeta"],
            "zeta_rel_err": p["zeta"] / self.zeta_true - 1.0,
            "iterations": self.result.iterations, "adam_iterations": self.result.adam_iterations,
            "lbfgs_iterations": self.result.lbfgs_iterations, "loss_evaluations": self.result.loss_evaluations,
            "final_loss": float(self.result.loss_history[-1]), "reduced_dofs": self.reduced_dofs,
            "samples": int(self.ts.size), "wall_s": round(self.result.wall_s, 3),
            "compile_s": round(self.result.compile_s, 3), "measurement_s": round(self.measurement_s, 3),
            "offline_s": round(self.offline_s, 3),
        }

    def json(self) -> str:
        return json.dumps(self.summary())

    def plot(self, path: str | None = None, dpi: int = 120):
        """Measured, initial and identified tip deflection, and the loss history."""
        import matplotlib

        if path is not None:
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 3.8), gridspec_kw={"width_ratios": [2.2, 1]})
        ax.plot(self.ts, self.measured, ".", ms=2, color="0.5", label="measured (full RNCF + noise)")
        ax.plot(self.ts, self.initial_fit, "--", lw=1, label="reduced, start")
        ax.plot(self.ts, self.final_fit, lw=1.2, label="reduced, identified")
        ax.set(xlabel="t [s]", ylabel="tip $u_y$ [m]", title="classic beam spin-up, $\\omega_s$ = 10 rad/s")
        ax.legend(fontsize=8)
        bx.semilogy(np.arange(1, len(self.result.loss_history) + 1), self.result.loss_history, "o-", ms=3)
        bx.axvline(self.result.adam_iterations + 0.5, color="0.7", lw=0.8)
        bx.set(xlabel="iteration (Adam | L-BFGS)", ylabel="relative misfit", title="convergence")
        fig.tight_layout()
        if path is not None:
            fig.savefig(path, dpi=dpi)
            plt.close(fig)
        return fig


def identification_demo(*, elements: int = 6, omega_s: float = 10.0, T_s: float = 15.0, t_end: float = 30.0,
                        dt_out: float = 0.05, zeta: float = 0.02, noise: float = 0.01, start: float = 1.3,
                        vms: int = 3, seed: int = 0, optimizer: AdamLbfgs = AdamLbfgs(adam_steps=15, lbfgs_steps=30),
                        progress: bool = False) -> IdentificationDemo:
    """Run the demonstration (see the module docstring); defaults are the issue's case.
    ``optimizer``: ``identify``'s (15 Adam steps, then up to 30 of L-BFGS). ``progress=True``
    prints each stage and each iteration on stderr."""
    for name, value in (("omega_s", omega_s), ("T_s", T_s), ("zeta", zeta), ("start", start)):
        _validate.positive(name, value)
    _validate.non_negative("noise", noise)
    _validate.positive_int("elements", elements)
    preset = beam_preset("classic")
    ts = output_times(t_end, dt_out)
    E_true = preset.E

    # The reduced model at the starting guess.
    E0 = start * E_true
    note(progress, f"reduced model at the starting guess E = {E0:.4g} Pa: modes, MMI, modal derivatives, tensors ...")
    t0 = time.perf_counter()
    red = nr_rncf(RotatingFrameModel(preset.with_(E=E0).body(elements), SpinUp(omega_s, T_s)), jnp.asarray(ts),
                  Basis(n_modes=4 * vms, vms=vms, max_dofs=None))
    family = SpinupFamily.from_reduction(red, E0)
    offline_s = time.perf_counter() - t0

    # The measurement: full RNCF at the true E with ζ in the same two modes of the true beam.
    note(progress, f"offline stage {offline_s:.1f} s; the measurement: full RNCF model ({elements} elements) at the "
                   f"true E and zeta, 0-{float(ts[-1]):g} s ...")
    t0 = time.perf_counter()
    w_ref = np.asarray(family.omega_ref) * np.sqrt(E_true / E0)
    body = preset.body(elements)
    truth = RotatingFrameModel(body, SpinUp(omega_s, T_s), damping=RayleighDamping.from_ratio(zeta, *w_ref))
    clean = np.asarray(simulate(truth, GeneralizedAlpha(0.9), AdaptiveStepSize(1e-6, 1e-9), jnp.asarray(ts),
                                observe=tip_observer(truth), progress=progress).ys)[:, 1]
    measurement_s = time.perf_counter() - t0
    note(progress, f"measurement {measurement_s:.1f} s")
    rng = np.random.default_rng(seed)
    measured = clean + noise * np.std(clean) * rng.standard_normal(clean.shape)

    initial = {"E": E0, "zeta": start * zeta}
    result = identify(family, Measurement(ts, measured), initial, optimizer=optimizer, progress=progress)

    def response(params):
        m = family(params)
        return np.asarray(simulate(m, GeneralizedAlpha(0.9), AdaptiveStepSize(1e-6, 1e-9), jnp.asarray(ts),
                                   observe=Observation(m, tip_deflection(m))).ys)

    note(progress, "the reduced model's response at the start and at the identified parameters ...")
    return IdentificationDemo(
        ts=ts, clean=clean, measured=measured, initial_fit=response(initial), final_fit=response(result.params),
        E_true=float(E_true), zeta_true=float(zeta), result=result, reduced_dofs=red.dofs,
        measurement_s=measurement_s, offline_s=offline_s,
    )
