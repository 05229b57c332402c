"""VTK output of frames (beams and bars) for ParaView, through meshio.

The mesh is the frame's position vectors as points and its members as polylines of line cells
(each member's consecutive nodes) plus one line per bar; displacement fields go along as point
data (ParaView's "Warp By Vector" shows the deformed shape).
"""

import os

import numpy as np

from .frame import Frame


def frame_mesh(frame: Frame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(points, lines, position_vectors)``: reference positions (p × 3), line cells (l × 2, point
    indices) and the nodal-vector index of each point."""
    body = frame.body
    pos = np.flatnonzero(np.asarray(body.is_position))
    where = {int(v): i for i, v in enumerate(pos)}
    lines = [(where[int(a)], where[int(b)]) for p in frame.member_positions for a, b in zip(p[:-1], p[1:])]
    if frame.n_bars:
        bars = np.asarray(body.groups[-1].elements)
        lines += [(where[int(a)], where[int(b)]) for a, b in bars]
    return np.asarray(body.q_hat)[pos], np.asarray(lines, dtype=np.int64), pos


def write_frame_vtk(folder: str, frame: Frame, fields: dict[str, np.ndarray]) -> list[str]:
    """One ``.vtu`` file per field in ``folder`` (made if missing): ``fields[name]`` is a
    displacement of every nodal vector (n × 3, e.g. a mode shape reshaped, or w = q − q̂); only
    the position vectors' rows are written. Returns the paths."""
    import meshio

    points, lines, pos = frame_mesh(frame)
    os.makedirs(folder, exist_ok=True)
    paths = []
    for name, u in fields.items():
        u = np.asarray(u, dtype=float).reshape(frame.body.n_vectors, 3)
        path = os.path.join(folder, f"{name}.vtu")
        meshio.write_points_cells(path, points, [("line", lines)], point_data={"displacement": u[pos]})
        paths.append(path)
    return paths


__all__ = ["frame_mesh", "write_frame_vtk"]
