"""``nrrncf modes``: natural frequencies, and the MMI matrix (Eq. 39) of a spin-up.

Mode indices are 0-based (mode 0 is the lowest), in the table and the JSON alike, as in the
Python API (``Selection.vms``, ``Selection.pairs``).
"""

import json

from .. import _validate
from . import _common


def _mmi(args) -> dict:
    """The MMI matrix (Eq. 39) of the spin-up at ``args.omega`` and the automatic selection."""
    import jax.numpy as jnp
    import numpy as np

    from ..post.plotting import mmi_quarter
    from ..reduction import Basis, nr_rncf
    from ..scenarios.spinup import build_spinup_model, output_times

    ts = output_times(args.t_end, args.dt_out)
    full = build_spinup_model("rncf", args.beam, args.omega, args.ts, args.elements)
    red = nr_rncf(full, jnp.asarray(ts), Basis(n_modes=args.count))
    sel = red.selection
    if args.plot:
        from ..post.plotting import plot_mmi

        plot_mmi(args.plot, sel.W, sel, red.omega,
                 title=f"MMI, {args.beam} beam, {args.elements} el., $\\omega_s$ = {args.omega:g} rad/s")
    return {"omega_s": args.omega, "T_s": args.ts, "t_end": args.t_end,
            "W_quarter": np.round(mmi_quarter(sel.W), 6).tolist(),
            "selected_vms": list(sel.vms), "selected_mds": [list(p) for p in sel.pairs],
            "dofs": red.dofs, "spin_vectors": red.n_spin, "basis": red.describe(),
            "offline_s": round(red.offline_s["total"], 3)}


def _print_mmi(d: dict) -> None:
    import numpy as np

    Wq = np.asarray(d["W_quarter"])
    k = Wq.shape[0]
    print(f"\nMMI matrix (Eq. 39) of the spin-up, omega_s = {d['omega_s']:g} rad/s, T_s = {d['T_s']:g} s, "
          f"t = 0..{d['t_end']:g} s: (W_ij / max W)^(1/4), upper triangle, modes 0-based")
    print("  i\\j " + "".join(f"{j:>6d}" for j in range(k)))
    for i in range(k):
        print(f"  {i:4d}" + " " * 6 * i + "".join(f"{Wq[i, j]:6.2f}" for j in range(i, k)))
    print(f"  selected VMs (auto): {d['selected_vms']}")
    print("  selected MDs (auto): " + (" ".join(f"θ{i},{j}" for i, j in d["selected_mds"]) or "none"))
    print(f"  reduced basis: {d['basis']}  (offline {d['offline_s']:.2f} s)")


def _modes(args) -> int:
    import numpy as np

    from ..models import RotatingFrameModel
    from ..motion import Stationary
    from ..reduction import vibration_modes
    from ..scenarios import beam_preset

    preset = beam_preset(args.beam)
    body = preset.body(args.elements)
    model = RotatingFrameModel(body, Stationary())
    modes = vibration_modes(body, model.free_mask(), args.count)
    omega = np.asarray(modes.omega)
    mmi = _mmi(args) if args.mmi else None
    if args.json:
        d = {"beam": args.beam, "elements": args.elements, "omega_rad_s": omega.tolist(),
             "frequency_hz": (omega / (2 * np.pi)).tolist()}
        if mmi is not None:
            d["mmi"] = mmi
        print(json.dumps(d))
    else:
        print(f"{args.beam} beam, {args.elements} elements, clamped at the hub "
              f"(Euler-Bernoulli first bending: {preset.first_frequency_eb:.4f} rad/s)" if preset.curve is None
              else f"{args.beam} beam, {args.elements} elements, clamped at the hub")
        print("  mode   omega [rad/s]   f [Hz]")
        for i, w in enumerate(omega):
            print(f"  {i:4d}  {w:14.5f}  {w / (2 * np.pi):9.4f}")
        if mmi is not None:
            _print_mmi(mmi)
            if args.plot:
                print(f"  MMI plot -> {args.plot}")
    return 0


def _check(args) -> None:
    """Every argument, before anything runs (no JAX)."""
    _common.at_least("--elements", args.elements, 1)
    _common.at_least("--count", args.count, 1)
    if (args.omega is not None or args.plot) and not args.mmi:
        raise ValueError("--omega and --plot go with --mmi")
    if args.mmi:
        if args.omega is None:
            raise ValueError("--mmi needs --omega (the steady spin rate of the spin-up)")
        _validate.positive("--omega (steady spin rate)", args.omega)
        _validate.positive("--ts (spin-up time T_s)", args.ts)
        _common.output_times(args.t_end, args.dt_out)
        _common.output_path("--plot", args.plot)


def register(sub) -> None:
    m = sub.add_parser("modes", help="natural frequencies of a beam clamped at the hub",
                       description="Natural frequencies of a beam clamped at the hub, and with --mmi the "
                                   "maximum-modal-interaction matrix (Eq. 39) of a spin-up and the basis it selects. "
                                   f"{_common.MODE_INDICES}.",
                       formatter_class=_common.HelpFormatter)
    m.add_argument("--beam", choices=_common.BEAM_NAMES, default="paper", help="beam preset")
    m.add_argument("--elements", type=int, default=8, help="beam elements")
    m.add_argument("--count", type=int, default=10, help="modes to compute (with --mmi: the candidate modes)")
    m.add_argument("--mmi", action="store_true",
                   help="also the maximum-modal-interaction matrix (Eq. 39) of a spin-up and the automatic selection")
    m.add_argument("--omega", type=float, default=None, help="--mmi: steady spin rate omega_s [rad/s]")
    m.add_argument("--ts", type=float, default=15.0, help="--mmi: spin-up time T_s [s] (default 15)")
    m.add_argument("--t-end", type=float, default=30.0, help="--mmi: end time [s] (default 30)")
    m.add_argument("--dt-out", type=float, default=0.01, help="--mmi: sampling interval of W [s] (default 0.01)")
    m.add_argument("--plot", help="--mmi: write the MMI bar plot (PNG) here")
    m.add_argument("--json", action="store_true",
                   help="print one JSON object (frequencies; with --mmi the MMI matrix and the 0-based selection)")
    m.set_defaults(func=_modes, check=_check)
