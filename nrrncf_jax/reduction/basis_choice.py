"""What an NR-RNCF basis keeps, as objects: ``Basis`` (the candidate vibration modes, the
maximum-modal-interaction choice among them and its limits, how the modal derivatives are
computed and deflated) and ``SpinState`` (the spinning-state enrichment, beyond the paper).

``nr_rncf`` builds the basis a ``Basis`` describes; ``nr_rncf_to_tolerance`` grows one along the
MMI ranking from the same candidates and uses only their part of it (``n_modes``, ``vm_tol``,
``max_dofs``, ``md_method``, ``deflation_tol``, ``spin_state``). Both are frozen dataclasses:
``dataclasses.replace(basis, vms=3)`` is a variant, and a scenario runner builds one from its
command-line options. The choice itself is docs/theory.md, §6 Selecting the basis (Eq. 39).
"""

import dataclasses
from collections.abc import Sequence

from .. import _validate


@dataclasses.dataclass(frozen=True, kw_only=True)
class SpinState:
    """The spinning-state enrichment (``reduction.spin_state``). At the largest spin rate of the
    manoeuvre the spinning equilibrium and its modes are computed, and the rest basis's
    Rayleigh-Ritz estimate of the frequency of the spinning mode that continues the dominant VM
    (largest W_ii) is compared with the exact one.

    ``check``: ``"auto"`` enriches a basis with modal derivatives where that estimate is off by
    more than ``tol`` (relative), under a steady spin about a fixed axis; ``True`` always enriches;
    ``False`` never checks (the paper's bases). The enrichment is ``vms`` spinning modes and the
    modal derivatives (at rest) of ``mds`` spinning-mode pairs, both ranked by the MMI weight of the
    rest modes they continue; the rest MDs give way so that the total stays within ``max_dofs``."""

    check: bool | str = "auto"
    vms: int = 1
    mds: int = 4
    tol: float = 2e-3

    def __post_init__(self):
        if not any(self.check is v for v in (True, False)) and self.check != "auto":
            raise ValueError(f"spin_state must be 'auto', True or False, got {self.check!r}")
        for name in ("vms", "mds"):
            n = getattr(self, name)
            if isinstance(n, bool) or not isinstance(n, int) or n < 0:
                raise ValueError(f"SpinState.{name} must be an integer >= 0, got {n!r}")
        _validate.positive("SpinState.tol", self.tol)


@dataclasses.dataclass(frozen=True, kw_only=True)
class Basis:
    """The columns NR-RNCF keeps (docs/theory.md, §6 Selecting the basis).

    ``n_modes`` candidate vibration modes enter the linear MMI simulation; ``vms`` and ``mds``
    choose among them (``selection.select``): ``"auto"``, a count, or explicit 0-based indices
    (``vms``) and index pairs (``mds``). With ``vms="auto"`` the modes kept lie below ``band``
    times the manoeuvre's largest spin rate, or are strongly loaded (amplitude at least ``vm_tol``
    of the largest); with ``mds="auto"`` the MDs of largest weight (at least ``md_tol`` of the
    largest, at most ``max_mds``) are added while VMs + MDs ≤ ``max_dofs`` (None: no cap).
    ``md_method``: ``"closed_form"`` or ``"autodiff"`` (``modal_derivatives``); ``deflation_tol``: the SVD
    deflation's relative threshold ϑ (Algorithm 1). ``spin_state``: a ``SpinState``, or its
    ``check`` alone (``"auto"``, True, False)."""

    n_modes: int = 24
    vms: int | str | Sequence[int] = "auto"
    mds: int | str | Sequence[tuple[int, int]] = "auto"
    max_dofs: int | None = 25
    band: float = 6.0
    vm_tol: float = 1e-6
    md_tol: float = 0.01
    max_mds: int | None = None
    md_method: str = "closed_form"
    deflation_tol: float = 1e-6
    spin_state: SpinState = SpinState()

    def __post_init__(self):
        if not isinstance(self.spin_state, SpinState):
            object.__setattr__(self, "spin_state", SpinState(check=self.spin_state))
        _validate.positive_int("n_modes", self.n_modes)
        if self.max_dofs is not None:
            _validate.positive_int("max_dofs", self.max_dofs)
        for name in ("vm_tol", "md_tol", "deflation_tol"):
            _validate.positive(name, getattr(self, name))
        _validate.non_negative("band", self.band)


__all__ = ["Basis", "SpinState"]
