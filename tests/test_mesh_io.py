"""Plate meshes read from files (``bodies.mesh_io``): meshes written by meshio itself, as gmsh would
write them (3-D points at z = const, boundary curves as line cells), in gmsh 2.2, gmsh 4.1, VTU
and legacy VTK come back as the same vertices and triangles; clockwise triangles come back
counter-clockwise; unused points are dropped; the body built from a file is the body built from
the arrays; and every bad file is a ``ValueError`` that says what is wrong."""

import meshio
import numpy as np
import pytest

from nrrncf_jax.bodies import plate_body_from_file, read_triangle_mesh
from nrrncf_jax.bodies.plate_mesh import annulus, hexagonal_disk, plate_body
from nrrncf_jax.elements import TrianglePlate

N_THETA = 8


def _annulus():
    """48 triangles, 24 vertices; the hub ring (vertices 0..7) comes first."""
    return annulus(0.5, 1.0, 2, N_THETA)


def _write(path, vertices, triangles, file_format=None, lines=None, z=0.0, extra_points=0):
    """Write a plate mesh the way gmsh does: 3-D points at ``z``, the triangles on surface entity 1,
    the boundary ``lines`` (default: the ring of the first ``N_THETA`` vertices) on curve entity 1,
    with physical tags. ``extra_points`` points at the front that no triangle uses (a gmsh
    geometry point each, as a vertex cell)."""
    v = np.asarray(vertices, dtype=float)
    points = np.column_stack([v, np.full(len(v), z)])
    points = np.concatenate([np.column_stack([np.arange(extra_points) + 5.0, np.zeros(extra_points),
                                              np.full(extra_points, z)]), points])
    t = np.asarray(triangles) + extra_points
    if lines is None:
        lines = np.column_stack([np.arange(N_THETA), np.roll(np.arange(N_THETA), -1)])
    lines = np.asarray(lines) + extra_points
    cells = [("line", lines), ("triangle", t)]
    physical, geometrical = [np.full(len(lines), 1), np.full(len(t), 2)], [np.full(len(lines), 1), np.full(len(t), 1)]
    if extra_points:
        cells.insert(0, ("vertex", np.arange(extra_points)[:, None]))
        physical.insert(0, np.full(extra_points, 3))
        geometrical.insert(0, np.arange(extra_points) + 1)
    point_data = {}
    cell_data = {}
    if file_format in ("gmsh22", "gmsh"):
        cell_data = {"gmsh:physical": physical, "gmsh:geometrical": geometrical}
    if file_format == "gmsh":
        # gmsh 4 files list each node under one entity: the curve's nodes, the rest on the surface.
        # (meshio writes the nodes grouped by entity, so the curve's come first.)
        dim_tags = np.tile([2, 1], (len(points), 1))
        dim_tags[np.unique(lines)] = [1, 1]
        dim_tags[:extra_points, 0] = 0
        dim_tags[:extra_points, 1] = np.arange(extra_points) + 1
        point_data = {"gmsh:dim_tags": dim_tags}
    meshio.Mesh(points, cells, point_data=point_data, cell_data=cell_data).write(path, file_format=file_format)
    return path


FORMATS = [("plate.msh", "gmsh22"), ("plate.msh", "gmsh"), ("plate.vtu", None), ("plate.vtk", None)]


@pytest.mark.parametrize("name, file_format", FORMATS, ids=["gmsh22", "gmsh41", "vtu", "vtk"])
def test_round_trip(tmp_path, name, file_format):
    """The mesh comes back exactly: the same vertex order, the same triangles (and the line cells
    of the boundary are ignored), as float (V, 2) and int (F, 3) arrays."""
    v, t = _annulus()
    V, T = read_triangle_mesh(_write(tmp_path / name, v, t, file_format))
    assert V.shape == v.shape and V.dtype == np.float64 and np.array_equal(V, v)
    assert T.shape == t.shape and np.issubdtype(T.dtype, np.integer) and np.array_equal(T, t)


def test_gmsh4_renumbers_nodes(tmp_path):
    """gmsh 4 lists the nodes entity by entity, so a disk whose rim is a curve comes back with its
    vertices in another order; each triangle still has the same corners, in the same order."""
    v, t = hexagonal_disk(1.0, 2)
    rim = np.arange(7, 19)
    V, T = read_triangle_mesh(_write(tmp_path / "disk.msh", v, t, "gmsh",
                                     lines=np.column_stack([rim, np.roll(rim, -1)])))
    assert V.shape == v.shape and not np.array_equal(V, v)
    assert np.array_equal(V[T], v[t])


def test_clockwise_triangles_are_turned(tmp_path):
    """Triangles written clockwise (every other one here) come back counter-clockwise: the two last
    vertices swapped, which is a cyclic shift of the original triangle."""
    v, t = _annulus()
    mixed = t.copy()
    mixed[::2] = t[::2, ::-1]
    V, T = read_triangle_mesh(_write(tmp_path / "plate.msh", v, mixed, "gmsh22"))
    expected = t.copy()
    expected[::2] = np.roll(t[::2], 1, axis=1)
    assert np.array_equal(V, v) and np.array_equal(T, expected)
    e1, e2 = V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]
    assert (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] > 0).all()


def test_unused_points_and_plane_offset(tmp_path):
    """Points no triangle uses (gmsh's geometry points) are dropped and the rest renumbered; a plate
    at z = const ≠ 0 is the same plate (its mid-plane becomes the body's z = 0); 2-D points are
    read as they are."""
    v, t = _annulus()
    V, T = read_triangle_mesh(_write(tmp_path / "plate.msh", v, t, "gmsh22", z=0.25, extra_points=3))
    assert np.array_equal(V, v) and np.array_equal(T, t)
    meshio.write_points_cells(tmp_path / "flat.mesh", v, [("triangle", t)])  # medit keeps 2-D points
    V, T = read_triangle_mesh(tmp_path / "flat.mesh")
    assert np.array_equal(V, v) and np.array_equal(T, t)


def test_file_format_for_an_unknown_extension(tmp_path, capsys):
    """``file_format`` reads a file whose extension does not name its format; meshio's printout
    (its readers' complaints, its warnings) does not reach the terminal."""
    v, t = _annulus()
    path = _write(tmp_path / "plate.msh", v, t, "gmsh22").rename(tmp_path / "plate.grid")
    with pytest.raises(ValueError, match="meshio cannot read .*plate.grid.*deduce file format"):
        read_triangle_mesh(path)
    V, T = read_triangle_mesh(path, file_format="gmsh")
    assert np.array_equal(V, v) and np.array_equal(T, t)
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""


def test_plate_body_from_file(tmp_path):
    """The body built from a file is the one built from the arrays: the same reference q̂, number
    of DOFs and mass matrix."""
    v, t = hexagonal_disk(1.0, 2)  # 24 triangles, 19 vertices
    element = TrianglePlate(1.0, 1.0, 0.3, 0.01)
    path = _write(tmp_path / "disk.msh", v, t, "gmsh22", lines=np.zeros((0, 2), dtype=int))
    from_file = plate_body_from_file(path, element, slopes="polar", plane_tol=1e-12)
    direct = plate_body(v, t, element, slopes="polar")
    assert from_file.body.n_dof == direct.body.n_dof
    assert np.array_equal(np.asarray(from_file.body.q_hat), np.asarray(direct.body.q_hat))
    M_file, M = np.asarray(from_file.body.mass_matrix()), np.asarray(direct.body.mass_matrix())
    assert np.abs(M_file - M).max() <= 1e-12 * np.abs(M).max()


# --- bad files ----------------------------------------------------------------------------------


def test_missing_file(tmp_path):
    with pytest.raises(ValueError, match="no mesh file at .*nothing.msh"):
        read_triangle_mesh(tmp_path / "nothing.msh")
    with pytest.raises(ValueError, match="no mesh file at .*directory"):
        read_triangle_mesh(tmp_path)


@pytest.mark.parametrize("name", ["garbage.msh", "garbage.vtu", "garbage.vtk"])
def test_garbage_file(tmp_path, name):
    """meshio's own failure (an exception, or its ``sys.exit`` when no reader fits) is a
    ``ValueError`` naming the file."""
    path = tmp_path / name
    path.write_text("this is not a mesh\n1 2 3\n")
    with pytest.raises(ValueError, match=f"meshio cannot read .*{name}"):
        read_triangle_mesh(path)


def test_quadrilaterals(tmp_path):
    """Only triangles: a quad mesh, or quads beside triangles, is refused (not partly read)."""
    pts = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]])
    quads = np.array([[0, 1, 2, 3], [1, 4, 5, 2]])
    meshio.write_points_cells(tmp_path / "quads.vtu", pts, [("quad", quads)])
    with pytest.raises(ValueError, match="quads.vtu holds quad cells: only linear 3-node triangle"):
        read_triangle_mesh(tmp_path / "quads.vtu")
    meshio.write_points_cells(tmp_path / "mixed.vtu", pts, [("quad", quads[:1]), ("triangle", [[1, 4, 5], [1, 5, 2]])])
    with pytest.raises(ValueError, match="holds quad cells"):
        read_triangle_mesh(tmp_path / "mixed.vtu")


def test_no_triangles(tmp_path):
    pts = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0]])
    meshio.write_points_cells(tmp_path / "curve.vtu", pts, [("line", [[0, 1], [1, 2]])])
    with pytest.raises(ValueError, match=r"holds no triangle cells \(found: line\); only triangle meshes"):
        read_triangle_mesh(tmp_path / "curve.vtu")


def test_points_off_the_plane(tmp_path):
    v, t = _annulus()
    path = tmp_path / "bent.vtu"
    points = np.column_stack([v, 1e-3 * v[:, 0] ** 2])
    meshio.write_points_cells(path, points, [("triangle", t)])
    with pytest.raises(ValueError, match="bent.vtu are not in one plane z = const"):
        read_triangle_mesh(path)
    V, _ = read_triangle_mesh(path, plane_tol=1e-2)  # a looser tolerance takes it as flat
    assert np.array_equal(V, v)
    with pytest.raises(ValueError, match="plane_tol must be"):
        read_triangle_mesh(path, plane_tol=-1.0)


def test_degenerate_and_bad_meshes(tmp_path):
    """A zero-area triangle; and a fault that ``check_mesh`` finds (a triangle listed twice), with
    the file's name."""
    pts = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]])
    meshio.write_points_cells(tmp_path / "flat.vtu", pts, [("triangle", [[0, 1, 2], [0, 1, 3]])])
    with pytest.raises(ValueError, match=r"triangles \[1\] of .*flat.vtu are degenerate"):
        read_triangle_mesh(tmp_path / "flat.vtu")
    meshio.write_points_cells(tmp_path / "twice.vtu", pts, [("triangle", [[0, 1, 2], [0, 1, 2]])])
    with pytest.raises(ValueError, match="the mesh in .*twice.vtu: .*same direction"):
        read_triangle_mesh(tmp_path / "twice.vtu")
