"""Figures of the paper's spin-up examples (matplotlib, Agg backend; imported only when plotting).

- ``plot_tip``: tip displacement in the rotating frame against time, several runs overlaid
  (paper Figs. 6 and 9: full RNCF against NR-RNCF).
- ``plot_mmi``: the maximum-modal-interaction matrix as upper-triangle 3-D bars,
  ``(W_ij / max W)^(1/4)``, the selected modal derivatives highlighted (paper Figs. 5 and 8).
- ``plot_point_history``, ``plot_truss_tip``, ``plot_membrane_rim``: an observed point of a large
  body against time, several runs overlaid (paper Figs. 12, 14 and 24).
- ``plot_plate_shapes``, ``plot_truss_modes``: mode shapes and modal derivatives (Figs. 11, 13).
- ``plot_pendulum``, ``animate_pendulum``: a chain of beams' shapes and tips (Figs. 17 and 18), and
  a GIF of its motion.
"""

from typing import TYPE_CHECKING, Protocol

import numpy as np

if TYPE_CHECKING:
    from ..reduction.selection import Selection


class TipRecord(Protocol):
    """What ``plot_tip`` draws: the tip displacement (rotating frame) at the output times, and the
    formulation and DOF count for the legend (an optional ``chi_rel_percent`` too). The spin-up
    scenario's ``SpinupResult`` is one; the core does not import scenarios."""

    formulation: str
    dofs: int
    ts: np.ndarray  # (nt,)
    tip: np.ndarray  # (nt, 3)

_STYLES = ["-", "--", ":", "-."]
_SELECTED = "#800020"  # burgundy, as in the paper's bar plots
_OTHER = "#9db4c8"


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _finish(fig, path: str | None, dpi: int):
    """Lay the figure out; return it when ``path`` is None (a notebook shows it), else write the
    PNG, close the figure and return None."""
    fig.tight_layout()
    if path is None:
        return fig
    fig.savefig(path, dpi=dpi)
    _pyplot().close(fig)
    return None


def _label(r: TipRecord) -> str:
    label = f"{r.formulation.upper()} ({r.dofs} DOF)"
    if getattr(r, "chi_rel_percent", None) is not None:
        label += f", $\\chi_{{rel}}$ = {r.chi_rel_percent:.2f} %"
    return label


def plot_tip(path: str, *results: TipRecord, labels: list[str] | None = None, title: str | None = None,
             dpi: int = 120) -> None:
    """Tip displacement (rotating frame) of each result against t: u_y (transverse) and u_x
    (axial) panels, and u_z when any run moves out of the plane. The first result names the
    case in the title; line styles follow the order (solid, dashed, dotted, dash-dotted).
    ``labels`` overrides the legend entries (default: formulation, DOFs and χ_rel)."""
    if not results:
        raise ValueError("plot_tip needs at least one result")
    if labels is not None and len(labels) != len(results):
        raise ValueError(f"plot_tip got {len(results)} results but {len(labels)} labels")
    plt = _pyplot()
    scale = max(float(np.abs(r.tip).max()) for r in results) or 1.0
    # Round-off of a planar run (~1e-6 of the deflection) does not count as out-of-plane motion.
    out_of_plane = any(float(np.abs(r.tip[:, 2]).max()) > 1e-3 * scale for r in results)
    panels = [(1, "tip $u_y$ (transverse) [m]"), (0, "tip $u_x$ (axial) [m]")]
    if out_of_plane:
        panels.append((2, "tip $u_z$ (out of plane) [m]"))
    fig, axes = plt.subplots(len(panels), 1, figsize=(7, 2.2 + 1.9 * len(panels)), sharex=True)
    for k, r in enumerate(results):
        style = _STYLES[k % len(_STYLES)]
        for ax, (c, _) in zip(axes, panels):
            ax.plot(r.ts, r.tip[:, c], style, label=_label(r) if labels is None else labels[k])
    for ax, (_, ylabel) in zip(axes, panels):
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        ax.legend(fontsize="small")
    axes[-1].set_xlabel("t [s]")
    r0 = results[0]
    axes[0].set_title(title or f"{r0.beam} beam spin-up, $\\omega_s$ = {r0.omega_s:g} rad/s, $T_s$ = {r0.T_s:g} s")
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def mmi_quarter(W) -> np.ndarray:
    """``(W / max W)^(1/4)``: the normalised MMI matrix as the paper's bar plots show it."""
    W = np.asarray(W, dtype=float)
    m = W.max()
    return (W / m) ** 0.25 if m > 0 else np.zeros_like(W)


def plot_mmi(path: str, W, selection: "Selection", omega=None, n_first: int = 8, title: str | None = None,
             dpi: int = 120) -> None:
    """Bar plot of the MMI matrix (Eq. 39): the upper triangle of ``(W_ij / max W)^(1/4)`` as
    3-D bars, the selected modal derivatives θ_ij in burgundy, the rest pale; selected VMs are
    starred on the axes.

    Shown are the first ``n_first`` candidate modes and every selected VM beyond them (e.g. an
    axial mode far up the spectrum), labelled by mode index (0-based, as everywhere); ``omega``
    (rad/s), if given, is listed in the title for the modes shown."""
    plt = _pyplot()
    from matplotlib.patches import Patch

    Wq = mmi_quarter(W)
    k = Wq.shape[0]
    vms = set(selection.vms)
    pairs = {(min(i, j), max(i, j)) for i, j in selection.pairs}
    shown = sorted(set(range(min(int(n_first), k))) | vms)
    n = len(shown)
    fig = plt.figure(figsize=(6.4, 5.4))
    ax = fig.add_subplot(projection="3d")
    xs, ys, hs, cs = [], [], [], []
    for a, i in enumerate(shown):
        for b in range(a, n):
            j = shown[b]
            xs.append(a)
            ys.append(b)
            hs.append(Wq[i, j])
            cs.append(_SELECTED if (i, j) in pairs else _OTHER)
    ax.bar3d(np.array(xs) + 0.15, np.array(ys) + 0.15, np.zeros(len(xs)), 0.7, 0.7, np.array(hs), color=cs,
             shade=True, edgecolor="k", linewidth=0.2)
    ticks = [f"{i}{'*' if i in vms else ''}" for i in shown]  # 0-based mode indices, as everywhere
    for set_ticks, set_labels in ((ax.set_xticks, ax.set_xticklabels), (ax.set_yticks, ax.set_yticklabels)):
        set_ticks(np.arange(n) + 0.5)
        set_labels(ticks, fontsize=7)
    ax.set_xlabel("VM i")
    ax.set_ylabel("VM j")
    ax.set_zlabel("$(W_{ij}/\\max W)^{1/4}$")
    ax.set_zlim(0, 1)
    ax.view_init(elev=28, azim=-60)
    n_md = len(pairs)
    n_md_shown = sum(1 for i, j in pairs if i in shown and j in shown)
    ax.legend(handles=[Patch(color=_SELECTED, label=f"selected MDs ({n_md})"),
                       Patch(color=_OTHER, label="not selected")], loc="upper left", fontsize="small")
    sub = f"modes shown: {n} of {k} candidates; * = selected VM"
    if n_md_shown < n_md:
        sub += f" ({n_md - n_md_shown} selected MDs off the plot)"
    if omega is not None:
        om = [f"{i}: {np.asarray(omega)[i]:.3g}" for i in shown]
        sub += "\nω [rad/s]  " + "\n".join(", ".join(om[r:r + 8]) for r in range(0, len(om), 8))
    ax.set_title((title + "\n" if title else "") + sub, fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def plot_point_history(path: str, runs, components=(1, 2), names=("y", "z"), what: str = "free end",
                       dpi: int = 120) -> None:
    """An observed point's displacement components against time, several runs overlaid; each run
    (``scenarios.forced_run.ForcedRun``) has ``formulation``, ``dofs``, ``ts`` and ``point``
    (nt × 3)."""
    plt = _pyplot()
    fig, axes = plt.subplots(len(components), 1, figsize=(7, 2.5 * len(components)), sharex=True)
    axes = np.atleast_1d(axes)
    for k, run in enumerate(runs):
        for ax, c in zip(axes, components):
            ax.plot(run.ts, run.point[:, c], _STYLES[k % len(_STYLES)], label=_label(run))
    for ax, name in zip(axes, names):
        ax.set_ylabel(f"{what} {name} [m]")
    axes[-1].set_xlabel("t [s]")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def plot_truss_tip(path: str, runs, dpi: int = 120) -> None:
    """The free end's midpoint y and z displacements against time, several runs overlaid (the
    paper's Fig. 24)."""
    plot_point_history(path, runs, (1, 2), ("y", "z"), "free end", dpi)


def plot_membrane_rim(path: str, runs, dpi: int = 120) -> None:
    """The rim point's deflections in the reference frame against time, radial X, tangential Y and
    axial Z, several runs overlaid (the paper's Figs. 12 and 14)."""
    plot_point_history(path, runs, (0, 1, 2), ("X (radial)", "Y (tangential)", "Z (axial)"), "rim", dpi)


def plot_plate_shapes(path: str | None, plate, shapes: dict, dpi: int = 120):
    """Shapes of a plate (``plate_mesh.PlateBody``) side by side, the paper's Figs. 11 and 13:
    ``shapes[title]`` a displacement of every nodal vector (a mode, a modal derivative, w = q − q̂).
    A mostly out-of-plane shape is drawn as its deflection w (colour); an in-plane one as the
    deformed mesh, scaled to a tenth of the plate's size, coloured by |u|. Returns the figure when
    ``path`` is None (a notebook shows it), else writes the PNG."""
    plt = _pyplot()
    from matplotlib.tri import Triangulation

    V, T = plate.vertices, plate.triangles
    rows = plate.layout.vertex_vectors[:, 0]
    size = float(np.ptp(V, axis=0).max())
    fig, axes = plt.subplots(1, len(shapes), figsize=(3.4 * len(shapes), 3.4), squeeze=False)
    for ax, (title, u) in zip(axes[0], shapes.items()):
        u = np.asarray(u, dtype=float).reshape(plate.body.n_vectors, 3)[rows]
        if np.sum(u[:, 2] ** 2) >= np.sum(u[:, :2] ** 2):
            ax.tripcolor(Triangulation(V[:, 0], V[:, 1], T), u[:, 2], shading="gouraud", cmap="RdBu_r")
        else:
            scale = 0.1 * size / max(float(np.abs(u[:, :2]).max()), 1e-300)
            X = V + scale * u[:, :2]
            ax.triplot(Triangulation(V[:, 0], V[:, 1], T), color="0.8", lw=0.3)
            ax.tripcolor(Triangulation(X[:, 0], X[:, 1], T), np.linalg.norm(u[:, :2], axis=1), shading="gouraud",
                         cmap="viridis", alpha=0.9)
        ax.set_title(title, fontsize=9)
        ax.set_aspect("equal")
        ax.set_axis_off()
    return _finish(fig, path, dpi)


def plot_truss_modes(path: str, truss, phi: np.ndarray, frequencies, types, count: int = 6, dpi: int = 120) -> None:
    """The first ``count`` mode shapes of a truss (``scenarios.truss.Truss``): the section-mean
    transverse displacement of each station along the axis, y and z, with frequency and type."""
    plt = _pyplot()
    pos = truss.station_positions()
    x = np.asarray(truss.body.q_hat)[pos[:, 0], 0]
    P = np.asarray(phi).reshape(truss.body.n_vectors, 3, -1)
    count = min(count, P.shape[-1])
    fig, axes = plt.subplots(count, 1, figsize=(7, 1.6 * count), sharex=True)
    for i, ax in enumerate(np.atleast_1d(axes)):
        u = P[pos, :, i].mean(axis=1)
        ax.plot(x, u[:, 1], "-", label="y")
        ax.plot(x, u[:, 2], "--", label="z")
        ax.set_ylabel(f"{i}: {frequencies[i]:.3f} Hz\n{types[i]}", fontsize=8)
    np.atleast_1d(axes)[0].legend(fontsize=8)
    np.atleast_1d(axes)[-1].set_xlabel("x [m]")
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def plot_pendulum(path: str | None, runs, times=(0.0, 0.5, 1.0, 1.5, 2.0), dpi: int = 120):
    """A jointed chain of beams (``scenarios.pendulum.PendulumRun``: ``ts``, ``nodes`` (nt, beams,
    nodes, 3), ``tip_displacements``, ``transverse_deflections``), several runs overlaid: (a) the
    shapes at ``times`` (those within the run; the paper's Fig. 17), (b) each beam's right-end
    displacement x and y, (c) each right end's transverse deflection in the frame of its beam's
    left end (Fig. 18). Returns the figure when ``path`` is None, else writes the PNG."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, run in enumerate(runs):
        style = _STYLES[k % len(_STYLES)]
        label = f"{run.formulation.upper()} ({run.dofs} DOF)"
        for j, t in enumerate(t for t in times if run.ts[0] - 1e-12 <= t <= run.ts[-1] + 1e-12):
            i = int(np.argmin(np.abs(run.ts - t)))
            chain = run.nodes[i, :, :, :2].reshape(-1, 2)
            axes[0].plot(chain[:, 0], chain[:, 1], style, color=colours[j % len(colours)],
                         label=f"t = {run.ts[i]:.2f} s" if k == 0 else None)
        u, w = run.tip_displacements, run.transverse_deflections
        for b in range(u.shape[1]):
            c = colours[b % len(colours)]
            axes[1].plot(run.ts, u[:, b, 0], style, color=c, lw=1.0, label=f"{label}" if b == 0 else None)
            axes[1].plot(run.ts, u[:, b, 1], style, color=c, lw=2.0, label=f"tip {b + 1}" if k == 0 else None)
            axes[2].plot(run.ts, w[:, b], style, color=c, label=f"{label}, beam {b + 1}")
    axes[0].set_aspect("equal")
    axes[0].set_xlabel("x [m]")
    axes[0].set_ylabel("y [m]")
    axes[0].set_title("shapes (Fig. 17)", fontsize=9)
    axes[1].set_xlabel("t [s]")
    axes[1].set_ylabel("right-end displacement [m] (thin x, thick y)")
    axes[2].set_xlabel("t [s]")
    axes[2].set_ylabel("transverse deflection in the left end's frame [m]")
    for ax in axes:
        ax.legend(fontsize=7)
    return _finish(fig, path, dpi)


def animate_pendulum(path: str, run, fps: int = 25, dpi: int = 80) -> int:
    """An animated GIF of a chain of beams (``PendulumRun``) in its plane (``animate_lines``).
    Returns the number of frames."""
    nt, beams, nodes, _ = run.nodes.shape
    lines = np.asarray([(b * nodes + i, b * nodes + i + 1) for b in range(beams) for i in range(nodes - 1)])
    return animate_lines(path, run.ts, run.nodes.reshape(nt, beams * nodes, 3), lines,
                         f"{run.formulation.upper()}, " + "t = {t:.2f} s", fps=fps, dpi=dpi, origin=True)


def animate_lines(path: str, ts, points, lines, title: str = "t = {t:.3f} s", fps: int = 25, dpi: int = 80,
                  plane: tuple[int, int] = (0, 1), origin: bool = False) -> int:
    """An animated GIF of moving points (nt × p × 3) joined by ``lines`` (l × 2), projected on
    the ``plane`` of two axes (x, y by default), at ``fps`` frames a second, in real time or, for
    a run too short to make 50 frames so, in slow motion (output times picked to match; Pillow,
    which matplotlib ships with). ``title`` is formatted with
    ``t``; ``origin`` marks the origin. Returns the number of frames."""
    plt = _pyplot()
    from matplotlib.animation import FuncAnimation, PillowWriter
    from matplotlib.collections import LineCollection

    ts, points, lines = np.asarray(ts), np.asarray(points), np.asarray(lines, dtype=int).reshape(-1, 2)
    if points.ndim != 3 or points.shape[0] != len(ts) or points.shape[2] != 3:
        raise ValueError(f"points must be (nt, p, 3) with one time per frame, got {points.shape} and {len(ts)} times")
    # real time, or slow motion for a short run: at least 50 frames where the outputs have them
    real = (ts[-1] - ts[0]) * fps if len(ts) > 1 else 1.0
    every = max(1, int(len(ts) // max(real, min(len(ts), 50))))
    frames = list(range(0, len(ts), every))
    xy = points[..., list(plane)]
    lo, hi = xy.min(axis=(0, 1)), xy.max(axis=(0, 1))
    pad = 0.05 * float(max(hi - lo)) + 1e-12
    fig, ax = plt.subplots(figsize=(5, 5))
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    if origin:
        ax.plot([0.0], [0.0], "k^")
    segments = LineCollection([], lw=2)
    ax.add_collection(segments)
    dots = ax.plot([], [], "k.", ms=3)[0]
    label = ax.set_title("")

    def draw(i):
        segments.set_segments(xy[i][lines])
        dots.set_data(xy[i, :, 0], xy[i, :, 1])
        label.set_text(title.format(t=ts[i]))
        return segments, dots, label

    FuncAnimation(fig, draw, frames=frames, blit=False).save(path, writer=PillowWriter(fps=fps), dpi=dpi)
    plt.close(fig)
    return len(frames)
