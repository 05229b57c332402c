"""VTK output of frames (beams and bars) and plates for ParaView, through meshio.

A frame's mesh is its position vectors as points and its members as polylines of line cells
(each member's consecutive nodes) plus one line per bar; a plate's is its vertices and triangles.
Displacement fields go along as point data (ParaView's "Warp By Vector" shows the deformed
shape); a time series also gets a ``.pvd`` collection that ParaView opens as one animated set.
A moving chain of beams (``write_polyline_series``) is written with its current positions.
Stresses go along as cell data: ``stress_fields`` gives the section resultants of a configuration
per line cell of a frame or per triangle of a plate (``post.stress``), which both writers take as
``cell_data``.
"""

import os

import jax
import jax.numpy as jnp
import numpy as np

from ..bodies.body import Body
from ..bodies.frame import Frame
from ..bodies.plate_mesh import PlateBody
from ..elements.bar import Bar
from ..elements.beam import C1Beam
from . import stress


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


def write_frame_vtk(folder: str, frame: Frame, fields: dict[str, np.ndarray],
                    cell_data: dict[str, dict[str, np.ndarray]] | None = None) -> list[str]:
    """One ``.vtu`` file per field in ``folder`` (made if missing): ``fields[name]`` is a
    displacement of every nodal vector (n × 3, e.g. a mode shape reshaped, or w = q − q̂); only
    the position vectors' rows are written. ``cell_data[name]`` (optional, for any of the fields):
    arrays with one value a line cell of ``frame_mesh`` that go into that field's file, e.g.
    ``stress_fields(frame, q̂ + u)``. Returns the paths."""
    import meshio

    points, lines, pos = frame_mesh(frame)
    os.makedirs(folder, exist_ok=True)
    paths = []
    for name, u in fields.items():
        u = np.asarray(u, dtype=float).reshape(frame.body.n_vectors, 3)
        path = os.path.join(folder, f"{name}.vtu")
        meshio.write_points_cells(path, points, [("line", lines)], point_data={"displacement": u[pos]},
                                  cell_data=_cell_data(cell_data, name, len(lines)))
        paths.append(path)
    return paths


def write_plate_vtk(folder: str, plate, fields: dict[str, np.ndarray], times=None,
                    cell_data: dict[str, dict[str, np.ndarray]] | None = None) -> list[str]:
    """One ``.vtu`` file per field in ``folder`` (made if missing) for a ``plate_mesh.PlateBody``:
    the vertices and triangles with ``fields[name]`` (a displacement of every nodal vector, n × 3)
    at the vertices. With ``times`` (one per field) also ``series.pvd``, the time series.
    ``cell_data[name]`` (optional, for any of the fields): arrays with one value a triangle that go
    into that field's file, e.g. ``stress_fields(plate, q̂ + u)``. Returns the paths of the
    ``.vtu`` files."""
    import meshio

    points = np.asarray(plate.body.q_hat)[plate.layout.vertex_vectors[:, 0]]
    os.makedirs(folder, exist_ok=True)
    paths = []
    for name, u in fields.items():
        u = np.asarray(u, dtype=float).reshape(plate.body.n_vectors, 3)
        path = os.path.join(folder, f"{name}.vtu")
        meshio.write_points_cells(path, points, [("triangle", np.asarray(plate.triangles, dtype=np.int64))],
                                  point_data={"displacement": u[plate.layout.vertex_vectors[:, 0]]},
                                  cell_data=_cell_data(cell_data, name, len(plate.triangles)))
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


def _cell_data(cell_data, name: str, n_cells: int):
    """meshio's ``cell_data`` (one block) for the file of field ``name``, after checking that every
    array has one value a cell."""
    fields = {} if cell_data is None else cell_data.get(name, {})
    out = {}
    for key, values in fields.items():
        values = np.asarray(values, dtype=float)
        if values.shape[:1] != (n_cells,):
            raise ValueError(f"cell field {key!r} of {name!r} needs one value a cell ({n_cells}), got shape "
                             f"{values.shape}")
        out[key] = [values]
    return out or None


def stress_fields(obj, q, lengths=None) -> dict[str, np.ndarray]:
    """The stress resultants of the configuration ``q`` (nodal vectors, n × 3 or flat) as cell
    fields, one array a name with one value a cell, for the writers' ``cell_data``:

    - a ``Frame``: ``stress.BEAM_RESULTANTS`` (N, V2, V3, T, M2, M3) per line cell of ``frame_mesh``,
      each element's of its beam group at its midpoint in its own section axes; a bar's cell has its axial
      force N (``stress.bar_strain_stress``) and zeros for the rest;
    - a ``PlateBody``: ``stress.PLATE_RESULTANTS`` per triangle at its centroid (the body's x, y);
    - a chain beam ``Body`` (``bodies.beam_body``): ``BEAM_RESULTANTS`` per element at its midpoint,
      the cells of the polyline through its nodes (``write_polyline_series``); ``lengths`` as in
      ``stress.beam_element_resultants``.
    """
    if isinstance(obj, PlateBody):
        values = np.asarray(stress.plate_resultants(obj.body, jnp.asarray(q, dtype=float)))
        return dict(zip(stress.PLATE_RESULTANTS, values.T))
    if isinstance(obj, Frame):
        body = obj.body
        q = jnp.asarray(q, dtype=float).reshape(body.n_vectors, 3)
        _, lines, pos = frame_mesh(obj)
        line_of = {(int(pos[a]), int(pos[b])): i for i, (a, b) in enumerate(lines)}
        values = np.zeros((len(lines), len(stress.BEAM_RESULTANTS)))
        for g in body.groups:
            el = np.asarray(g.elements)
            if isinstance(g.element, C1Beam):
                first, last = g.element.position_slots[0], (g.element.nodes - 1) * g.element.vectors_per_node
                rows = _beam_midpoints(body, q, lengths)
            elif isinstance(g.element, Bar):
                first, last = 0, 1
                _, S11 = _bar_stresses(g.element, body.q_hat[g.elements], q[g.elements])
                rows = np.zeros((len(el), len(stress.BEAM_RESULTANTS)))
                rows[:, 0] = np.asarray(g.element.area * S11)
            else:
                continue  # joint cells and links: no cells of the mesh
            cells = [line_of[(int(a), int(b))] for a, b in zip(el[:, first], el[:, last])]
            values[cells] = np.asarray(rows)
        return dict(zip(stress.BEAM_RESULTANTS, values.T))
    if isinstance(obj, Body):
        values = np.asarray(_beam_midpoints(obj, jnp.asarray(q, dtype=float), lengths))
        return dict(zip(stress.BEAM_RESULTANTS, values.T))
    raise ValueError(f"stress_fields takes a Frame, a PlateBody or a chain beam Body, got {type(obj).__name__}")


def _beam_midpoints(body, q, lengths):
    return stress.beam_element_resultants(body, q, 0.5, lengths)


_bar_stresses = jax.jit(jax.vmap(stress.bar_strain_stress, in_axes=(None, 0, 0)))


__all__ = ["frame_mesh", "stress_fields", "write_frame_vtk", "write_plate_vtk", "write_pvd"]
