"""Triangle meshes of flat plates read from files (gmsh ``.msh`` v2 and v4, ``.vtk``, ``.vtu`` and
every other format meshio reads), and the plate body built on them (``plate_mesh.plate_body``).

- ``read_triangle_mesh(path)``: ``(vertices (V, 2), triangles (F, 3))`` of the file's linear
  triangle cells, ready for ``plate_mesh.plate_body``;
- ``plate_body_from_file(path, element)``: the ``plate_mesh.PlateBody`` on that mesh.

What is taken from the file, and why:

- Cells: every ``"triangle"`` block (gmsh writes one per surface entity). Points and curves
  (``"vertex"``, ``"line"``, ... cells: gmsh's boundary and physical-group elements) are ignored.
  Any other cell of dimension two or more (quadrilaterals, quadratic triangles, polygons,
  tetrahedra) is an error rather than silently dropped, since the plate element
  (``elements.TrianglePlate``) is a 3-vertex triangle and a partly read mesh would be a
  different plate.
- The plane: the plate lies in the xy-plane of its body frame (``plate_mesh``), so 3-D points
  must lie in one plane z = const (to ``plane_tol`` relative to the mesh's in-plane size); the
  constant is dropped, i.e. the plate's mid-surface becomes the body frame's z = 0. A plate
  meshed in another plane must be rotated into the xy-plane before it is written.
- Vertices: those of the triangles, renumbered in their file order (a file may also hold points
  used only by curves, or by nothing, which would be nodal vectors without an element).
- Orientation: ``plate_mesh`` wants counter-clockwise triangles (positive area seen from +z);
  meshers write either sense, depending on the surface normal, so clockwise triangles are
  turned (two vertices swapped), which leaves the surface unchanged.

Then the mesh goes through ``plate_mesh.check_mesh``, the checks every plate mesh gets
(non-manifold or overlapping edges, ...). Every problem is a ``ValueError`` that names the file,
raised before any body is built.
"""

import contextlib
import io
import os
import pathlib

import numpy as np

from ..elements.plate import TrianglePlate
from .plate_mesh import PlateBody, check_mesh, plate_body


def read_triangle_mesh(path: str | os.PathLike, plane_tol: float = 1e-9, *,
                       file_format: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The plate mesh in the file at ``path`` (see the module): ``(vertices (V, 2) float,
    triangles (F, 3) int)``, counter-clockwise, every vertex used, checked by
    ``plate_mesh.check_mesh``.

    ``plane_tol``: how far 3-D points may stray from one plane z = const, relative to the mesh's
    largest in-plane extent. ``file_format``: meshio's name of the format (``"gmsh"``, ``"vtu"``,
    ...) for a file whose extension does not tell it; by default meshio picks it from the
    extension. Raises ``ValueError`` for a missing or unreadable file, a file without triangle
    cells or with other surface or volume cells, points off a plane z = const, and degenerate
    triangles or any other mesh fault that ``check_mesh`` finds.
    """
    if isinstance(plane_tol, bool) or not isinstance(plane_tol, (int, float, np.integer, np.floating)) \
            or not (np.isfinite(plane_tol) and plane_tol >= 0):
        raise ValueError(f"plane_tol must be a finite number >= 0, got {plane_tol!r}")
    path = pathlib.Path(path)
    if not path.is_file():
        raise ValueError(f"no mesh file at {path}" + (" (it is a directory)" if path.is_dir() else ""))
    mesh = _read(path, file_format)

    points = np.asarray(mesh.points, dtype=float)
    if points.ndim != 2 or points.shape[1] not in (2, 3):
        raise ValueError(f"the points of {path} must be 2-D or 3-D (shape (n_points, 2 or 3)), got {points.shape}")
    found = sorted({c.type for c in mesh.cells})
    other = sorted({c.type for c in mesh.cells if c.type != "triangle" and c.dim >= 2 and len(c)})
    if other:
        raise ValueError(f"{path} holds {', '.join(other)} cells: only linear 3-node triangle cells are supported "
                         "(a plate mesh of triangles; curves and points are ignored)")
    tri = [np.asarray(c.data) for c in mesh.cells if c.type == "triangle" and len(c)]
    if not tri:
        raise ValueError(f"{path} holds no triangle cells (found: {', '.join(found) or 'no cells'}); only "
                         "triangle meshes are supported")
    T = np.concatenate([d.reshape(-1, 3) for d in tri]).astype(np.int64)
    if T.min() < 0 or T.max() >= len(points):
        raise ValueError(f"the triangles of {path} refer to point {int(T.max())} (or a negative one); "
                         f"it has {len(points)}")

    # Keep the vertices of the triangles only, in file order, and renumber.
    used, T = np.unique(T, return_inverse=True)
    T = T.reshape(-1, 3)
    X = points[used]
    if not np.isfinite(X).all():
        raise ValueError(f"the vertices of {path} must be finite")
    if X.shape[1] == 3:
        z = X[:, 2]
        size = float(np.ptp(X[:, :2], axis=0).max())
        if np.ptp(z) > plane_tol * size:
            raise ValueError(f"the vertices of {path} are not in one plane z = const: z spans [{z.min():.6g}, "
                             f"{z.max():.6g}], more than plane_tol = {plane_tol:g} of the in-plane size {size:.6g}; "
                             "a plate mesh lies in the xy-plane (rotate it there first)")
        X = X[:, :2]

    # Twice the signed area; zero (to round-off of the triangle's own size, as check_mesh judges it)
    # leaves no orientation to fix.
    P = X[T]
    e1, e2 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
    area2 = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    scale = np.max(np.linalg.norm(P - P.mean(axis=1, keepdims=True), axis=2), axis=1)
    degenerate = np.flatnonzero(~(np.abs(area2) > 1e-10 * scale**2))
    if degenerate.size:
        raise ValueError(f"triangles {degenerate[:10].tolist()} of {path} are degenerate (zero area: collinear or "
                         "repeated vertices)")
    clockwise = area2 < 0
    T[clockwise] = T[clockwise][:, [0, 2, 1]]
    try:
        return check_mesh(X, T)
    except ValueError as e:
        raise ValueError(f"the mesh in {path}: {e}") from e


def plate_body_from_file(path: str | os.PathLike, element: TrianglePlate, slopes="cartesian",
                         **read_kwargs) -> PlateBody:
    """``plate_mesh.plate_body`` on the mesh in the file at ``path`` (``read_triangle_mesh``, which
    gets ``read_kwargs``: ``plane_tol``, ``file_format``) with ``element`` on every triangle and
    the vertices' ``slopes`` (see ``plate_body``)."""
    vertices, triangles = read_triangle_mesh(path, **read_kwargs)
    return plate_body(vertices, triangles, element, slopes=slopes)


def _read(path: pathlib.Path, file_format: str | None):
    """``meshio.read``, with every failure as a ``ValueError`` naming the file. meshio prints its
    readers' complaints and, when no reader for the extension succeeds, calls ``sys.exit``; both
    are caught here (its printout becomes the message). Redirecting the standard streams is
    process-wide, acceptable for a file read."""
    import meshio  # here, not at import: meshio takes a fifth of a second to import

    out = io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
            return meshio.read(path, file_format=file_format)
    except (Exception, SystemExit) as e:
        reasons = [] if isinstance(e, SystemExit) else [f"{type(e).__name__}: {e}"]
        reasons += [" ".join(out.getvalue().replace("Error:", "").split())]
        reason = "; ".join(filter(None, reasons)) or "no reason given"
        as_format = f" as {file_format!r}" if file_format else ""
        raise ValueError(f"meshio cannot read {path}{as_format}: {reason}") from e


__all__ = ["plate_body_from_file", "read_triangle_mesh"]
