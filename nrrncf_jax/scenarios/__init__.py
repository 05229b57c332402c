"""The paper's examples as presets.

- ``beams``: the beam presets. ``paper``: the paper's 8 m aluminium tube (Table 1; E = 70 GPa,
  ρ = 2700 kg/m³, ν = 0.3, outer radius 20 mm, inner 5.724 mm); ``classic``: the spin-up beam of
  Simo & Vu-Quoc and Kane, Ryan & Banerjee (EA, EI and ρA given, as a 40/20 mm tube); and the
  paper's three curved beams (Sec. 4.2: arcs of the same length, radius 32/π m). The spin is about
  +z, so the tip moves toward +y: ``curved-upwind`` curves toward −y, ``curved-downwind`` toward
  +y, ``curved-out-of-plane`` toward +z.
- ``spinup``: the spin-up of Eq. 43 with the full models (``run_spinup``: RNCF or ANCF) or NR-RNCF
  against a reference (``run_nr_rncf_spinup``); the default mesh for a speed follows the paper's
  Table 2 (``PAPER_ELEMENTS``); ``sweep_reduction`` builds a sweep's shared basis.
- ``identification``: the identification demonstration (a synthetic record from the full damped
  RNCF model, fitted through the reduced one).
- ``membrane``: the rotating membrane of Sec. 4.3 (the paper's Table 6 is lost: a 1 m aluminium
  disk clamped at its centre, of the thickness that puts the modes in the paper's order, with
  mode 19 its first in-plane mode and modes 3 and 8 axisymmetric), its in-plane spin-up and its
  bending-torsion case (the spin-up with the hub oscillating along Z), full RNCF (sparse SuperLU)
  against NR-RNCF with the paper's bases, found by mode shape.
- ``truss``: the beamlike truss of Sec. 4.5 (its Table 10 is lost in the paper's text: a
  substitute geometry of the same kind, beams rigidly joined and pin-ended bars in one body), its
  modes and mode types, the equivalent-beam closed forms, and the resonant tip excitation, full RNCF against NR-RNCF.
- ``pendulum``: the three-beam pendulum of Sec. 4.4: full order as ANCF bodies (``build_pendulum``)
  or as the paper's full RNCF (``build_rncf_pendulum``), NR-RNCF in floating frames
  (``build_reduced_pendulum``, its basis a ``PendulumBasis``: modes and modal derivatives, the
  joints' static modes, or the extended Craig-Bampton basis; ``mmi_per_body`` picks each beam's MDs
  by MMI), and
  ``release_sweep`` for a batch of release angles in one compiled loop.
- ``forced_run``: a large body's full or NR-RNCF run and its χ_rel against a full one, shared by
  the truss and the membrane.

The runners (``run_spinup``, ``run_nr_rncf_spinup``, ``run_membrane``, ``run_truss``, ``run_forced``,
``run_pendulum``, ``run_chain``) take their options as objects, as ``integrate.simulate`` and
``reduction.nr_rncf`` do: the basis a ``reduction.Basis`` (the pendulum's a ``PendulumBasis``), the
time integration a ``solver`` (``integrate.GeneralizedAlpha``; ``GeneralizedAlphaIndex3`` for the
jointed pendulum) and a step-size ``controller`` (``integrate.AdaptiveStepSize``, plain or PI), the
a-posteriori error estimate a ``reduction.ErrorEstimator`` (None: none), and a basis chosen to a
tolerance ``tol`` (per cent, or a ``reduction.ToTolerance``). Their defaults are each scenario's own.

Each example has its ``nrrncf`` subcommand, its notebook and its benchmark; the measured figures
are on the documentation's Benchmark results page, summed up in the README's results table.
"""

from .beams import BEAMS as BEAMS
from .beams import BeamPreset as BeamPreset
from .beams import beam_preset as beam_preset
from .run_record import RunRecord as RunRecord
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
