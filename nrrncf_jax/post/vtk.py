"""VTK output of frames (beams and bars) and plates for ParaView, through meshio.

A frame's mesh is its position vectors as points and its members as polylines of line cells
(each member's consecutive nodes) plus one line per bar; a plate's is its vertices and triangles.
Displacement fields go along as point data (ParaView's "Warp By Vector" shows the deformed
shape); a time series also gets a ``.pvd`` collection that ParaView opens as one animated set.
A moving chain of beams (``write_polyline_series``) is written with its current positions.
"""

import os

import numpy as np

from ..bodies.frame import Frame


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


def write_plate_vtk(folder: str, plate, fields: dict[str, np.ndarray], times=None) -> list[str]:
    """One ``.vtu`` file per field in ``folder`` (made if missing) for a ``plate_mesh.PlateBody``:
    the vertices and triangles with ``fields[name]`` (a displacement of every nodal vector, n × 3)
    at the vertices. With ``times`` (one per field) also ``series.pvd``, the time series. Returns
    the paths of the ``.vtu`` files."""
    import meshio

    points = np.asarray(plate.body.q_hat)[plate.layout.vertex_vectors[:, 0]]
    os.makedirs(folder, exist_ok=True)
    paths = []
    for name, u in fields.items():
        u = np.asarray(u, dtype=float).reshape(plate.body.n_vectors, 3)
        path = os.path.join(folder, f"{name}.vtu")
        meshio.write_points_cells(path, points, [("triangle", np.asarray(plate.triangles, dtype=np.int64))],
                                  point_data={"displacement": u[plate.layout.vertex_vectors[:, 0]]})
        paths.append(path)
    if times is not None:
        write_pvd(os.path.join(folder, "series.pvd"), paths, times)
    return paths


def write_polyline_series(folder: str, points, lines, times, name: str = "t") -> list[str]:
    """A moving set of polylines (a chain of beams) as a time series in ``folder`` (made if
    missing): ``points[k]`` (nt × p × 3) are the points' current positions at ``times[k]``, ``lines``
    (l × 2) the line cells; one ``.vtu`` file per time plus ``series.pvd``, each point with its
    displacement from the first time. Returns the paths of the ``.vtu`` files."""
    import meshio

    points = np.asarray(points, dtype=float)
    times = np.asarray(times, dtype=float).reshape(-1)
    if points.ndim != 3 or points.shape[2] != 3 or len(points) != len(times):
        raise ValueError(f"points must be (nt, p, 3) with one time per frame, got {points.shape} and {len(times)} "
                         "times")
    os.makedirs(folder, exist_ok=True)
    paths = []
    for k, (x, t) in enumerate(zip(points, times)):
        path = os.path.join(folder, f"{name}_{k:05d}.vtu")
        meshio.write_points_cells(path, x, [("line", np.asarray(lines, dtype=np.int64))],
                                  point_data={"displacement": x - points[0]})
        paths.append(path)
    write_pvd(os.path.join(folder, "series.pvd"), paths, times)
    return paths


def write_pvd(path: str, files, times) -> None:
    """A ParaView collection (``.pvd``) of ``files`` at ``times``. Written by hand: meshio has no
    PVD writer (its XDMF time series would need h5py), and the format is three XML tags."""
    times = np.asarray(times, dtype=float).reshape(-1)
    if len(times) != len(files):
        raise ValueError(f"one time per file: {len(files)} files, {len(times)} times")
    folder = os.path.dirname(os.path.abspath(path))
    rows = "\n".join(f'    <DataSet timestep="{t:.9g}" part="0" file="{os.path.relpath(os.path.abspath(f), folder)}"/>'
                     for t, f in zip(times, files))
    with open(path, "w") as fh:
        fh.write('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
                 f"{rows}\n  </Collection>\n</VTKFile>\n")


__all__ = ["frame_mesh", "write_frame_vtk", "write_plate_vtk", "write_pvd"]
