"""Maximum modal interaction in a mechanism (paper Eq. 39, its Fig. 16 for the pendulum): the
modal derivatives of each reduced body chosen from that body's own motion in its system.

A body alone cannot choose them: which pairs of its vibration modes interact depends on how the
mechanism moves it (the pendulum's three beams rank their pairs differently). So the mechanism is
run first with its bodies' vibration modes (``reduce(..., mds="mmi")``: the VMs and no modal
derivatives), each body's modal amplitudes are recovered from its reduced coordinates,
η(t) = Φ⁺ Ψ p(t), and W_ij = ∫ |η_i η_j| dt ranks its pairs (``reduction.mmi_matrix``,
``reduction.select``). Each body's basis is then rebuilt from its modes and its ``n_mds`` pairs
of largest W, deflated by SVD, with its tensors (``reduction.modal_basis``,
``reduction.elastic_tensors``). The first run need not be accurate, only rank the pairs: a loose
tolerance serves."""

import numpy as np

from ..reduction import mmi_matrix, select
from ..reduction.selection import Selection
from .floating import FloatingBody, rotation
from .mechanism import Mechanism
from .reduce import modal_body


def modal_interaction(system: Mechanism, ts, zs, n_mds: int) -> list[Selection | None]:
    """Each body's ``reduction.Selection`` from the mechanism's motion ``zs`` (n_out × n_dof) at
    ``ts``: its W over its vibration modes and its ``n_mds`` pairs (i ≤ j) of largest W_ij; None
    for a body without recorded vibration modes (rigid, full-order, Craig-Bampton)."""
    zs = np.asarray(zs, float)
    if zs.ndim != 2 or zs.shape != (len(ts), system.n_dof):
        raise ValueError(f"zs must be (len(ts), n_dof) = ({len(ts)}, {system.n_dof}), got {zs.shape}")
    out = []
    for body, zb in zip(system.bodies, system.split(zs.T)):
        if not isinstance(body, FloatingBody) or body.modes is None:
            out.append(None)
            continue
        phi = np.asarray(body.modes)
        to_vms = np.linalg.lstsq(phi, np.asarray(body.basis), rcond=None)[0]  # η = Φ⁺ Ψ p
        eta = np.asarray(zb[7:]).T @ to_vms.T
        n_vms = phi.shape[1]
        out.append(select(mmi_matrix(np.asarray(ts, float), eta), n_vms=list(range(n_vms)),
                          n_mds=min(n_mds, n_vms * (n_vms + 1) // 2)))
    return out


def select_modal_derivatives(system: Mechanism, ts, n_mds: int = 8, rtol: float = 1e-3, rho_inf: float = 0.9,
                             y0=None, deflation_tol: float = 1e-6) -> tuple[Mechanism, list[Selection | None]]:
    """The mechanism with each reduced body's basis enriched by the modal derivatives of its
    ``n_mds`` most interacting pairs (module docstring), from a run of ``system`` as it is over
    the output times ``ts`` at ``rtol`` (index-3 generalized-α, ρ∞ ``rho_inf``) from ``y0``
    (z, ż) (default: its reference at rest), and each body's
    ``Selection`` (None for bodies it leaves as they are). Raises ``ValueError`` when no body
    records its vibration modes (build them with ``reduce(..., mds="mmi")``)."""
    from ..integrate import AdaptiveStepSize, GeneralizedAlphaIndex3, simulate

    if not isinstance(system, Mechanism):
        raise ValueError(f"system must be a Mechanism, got {type(system).__name__}")
    if not any(isinstance(b, FloatingBody) and b.modes is not None for b in system.bodies):
        raise ValueError("no body records its vibration modes: reduce the flexible bodies with "
                         "multibody.reduce(..., mds='mmi')")
    if not (isinstance(n_mds, int) and n_mds >= 1):
        raise ValueError(f"n_mds must be a positive integer, got {n_mds!r}")
    ts = np.asarray(ts, float)
    sol = simulate(system, GeneralizedAlphaIndex3(rho_inf), AdaptiveStepSize(rtol, rtol / 10), ts,
                   observe=lambda t, z, v: z, y0=y0)
    selections = modal_interaction(system, ts, np.asarray(sol.ys), n_mds)
    bodies = [b if s is None else modal_body(b.body, np.asarray(b.free), np.asarray(b.modes), s.pairs, b.R0,
                                             np.asarray(rotation(b.e0)), deflation_tol,
                                             note=b.note.replace("MDs to be chosen by modal interaction",
                                                                 f"{len(s.pairs)} MDs chosen by modal interaction"))
              for b, s in zip(system.bodies, selections)]
    return type(system)(bodies, system.joints, gravity=system.gravity, forces=system.forces), selections


__all__ = ["modal_interaction", "select_modal_derivatives"]
