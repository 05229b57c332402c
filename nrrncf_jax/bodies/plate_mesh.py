"""Triangle meshes of flat plates and the plate body builder (``elements.TrianglePlate``).

- ``hexagonal_disk(radius, rings)``: the hexagonal-ring disk of the paper's membrane
  (6·rings² triangles; 15 rings: 1350 triangles, 721 vertices, 2070 edges). Ring k keeps the
  topology of the k-th hexagon of a hexagonal lattice (6k vertices) but its vertices are mapped
  onto the circle of radius k·radius/rings at equal angles, so the rim is a regular polygon
  inscribed in the circle and every ring is rotationally uniform.
- ``annulus(a, b, n_r, n_theta, graded=False)``: a structured annulus a ≤ r ≤ b, n_r rings of
  n_theta quadrilaterals, each cut by the diagonal from (i, j) to (i+1, j+1); ``graded``
  spaces the rings geometrically (r_i = a (b/a)^{i/n_r}), which keeps the elements near a
  small hub about as long as wide.
- ``plate_layout(vertices, triangles)``: the numbering of the nodal vectors (4 per vertex,
  ``[r, r_1, r_2, r_z]``; one director per edge; one centroid per face) and each element's 16
  vectors, after checking the mesh (``check_mesh``).
- ``plate_body(vertices, triangles, element, slopes="cartesian")``: the ``body.Body`` with one
  element group, and the index helpers of ``PlateBody`` (clamped vectors, in-plane and
  out-of-plane DOFs, vertex displacements).

Vertices are 2-D: the plate lies in the xy-plane of its body frame, its directors along z.
"""

import dataclasses

import numpy as np

from ..elements.plate import N_VECTORS, TrianglePlate
from .body import Body, element_group

# --- meshes -------------------------------------------------------------------------------------


def hexagonal_disk(radius: float, rings: int) -> tuple[np.ndarray, np.ndarray]:
    """The hexagonal-ring disk mesh (see the module): ``(vertices (V, 2), triangles (F, 3))``,
    counter-clockwise, vertex 0 at the centre, ring k's vertices 1 + 3k(k−1) … 3k(k+1)."""
    if not np.isfinite(radius) or radius <= 0:
        raise ValueError(f"radius must be finite and > 0, got {radius!r}")
    if isinstance(rings, bool) or not isinstance(rings, (int, np.integer)) or rings < 1:
        raise ValueError(f"rings must be an integer >= 1, got {rings!r}")
    verts = [np.zeros(2)]
    for k in range(1, rings + 1):
        phi = 2 * np.pi * np.arange(6 * k) / (6 * k)
        verts.append(radius * k / rings * np.stack([np.cos(phi), np.sin(phi)], axis=1))
    start = lambda k: 0 if k == 0 else 1 + 3 * k * (k - 1)  # noqa: E731
    tris = []
    for k in range(1, rings + 1):
        outer = lambda s, t: start(k) + (s * k + t) % (6 * k)  # noqa: E731
        inner = lambda s, t: 0 if k == 1 else start(k - 1) + (s * (k - 1) + t) % (6 * (k - 1))  # noqa: E731
        for s in range(6):
            for t in range(k):
                tris.append((outer(s, t), outer(s, t + 1), inner(s, t)))
                if t < k - 1:
                    tris.append((inner(s, t), outer(s, t + 1), inner(s, t + 1)))
    return np.vstack(verts), np.array(tris)


def annulus(a: float, b: float, n_r: int, n_theta: int, graded: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """A structured annulus mesh (see the module): vertex ``i·n_theta + j`` at radius r_i and angle
    2πj/n_theta (ring 0 at r = a, ring n_r at r = b); 2·n_r·n_theta counter-clockwise triangles."""
    if not (np.isfinite(a) and np.isfinite(b) and 0 < a < b):
        raise ValueError(f"the annulus needs 0 < a < b, got a={a!r}, b={b!r}")
    for name, n, least in (("n_r", n_r, 1), ("n_theta", n_theta, 3)):
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < least:
            raise ValueError(f"{name} must be an integer >= {least}, got {n!r}")
    r = a * (b / a) ** np.linspace(0.0, 1.0, n_r + 1) if graded else np.linspace(a, b, n_r + 1)
    r[-1] = b
    phi = 2 * np.pi * np.arange(n_theta) / n_theta
    verts = (r[:, None, None] * np.stack([np.cos(phi), np.sin(phi)], axis=1)[None]).reshape(-1, 2)
    i, j = np.meshgrid(np.arange(n_r), np.arange(n_theta), indexing="ij")
    v = lambda i, j: i * n_theta + j % n_theta  # noqa: E731
    lower = np.stack([v(i, j), v(i + 1, j), v(i + 1, j + 1)], axis=-1)
    upper = np.stack([v(i, j), v(i + 1, j + 1), v(i, j + 1)], axis=-1)
    return verts, np.stack([lower, upper], axis=2).reshape(-1, 3)


def check_mesh(vertices, triangles) -> tuple[np.ndarray, np.ndarray]:
    """``(vertices, triangles)`` as float (V, 2) and int (F, 3) arrays, or a ``ValueError`` naming
    what is wrong: shapes, indices, degenerate or clockwise (inverted) triangles, unreferenced
    vertices, an edge shared by more than two triangles (non-manifold) or twice in the same
    direction (overlapping triangles)."""
    V = np.asarray(vertices, dtype=float)
    if V.ndim != 2 or V.shape[1] != 2 or V.shape[0] < 3:
        raise ValueError(f"vertices must have shape (n_vertices >= 3, 2) (a plate in the xy-plane), got {V.shape}")
    if not np.isfinite(V).all():
        raise ValueError("vertices must be finite")
    T = np.asarray(triangles)
    if T.ndim != 2 or T.shape[1] != 3 or T.shape[0] == 0:
        raise ValueError(f"triangles must have shape (n_triangles >= 1, 3), got {T.shape}")
    if not np.issubdtype(T.dtype, np.integer):
        raise ValueError(f"triangles must hold integer vertex indices, got dtype {T.dtype}")
    if T.min() < 0 or T.max() >= len(V):
        raise ValueError(f"triangles refer to vertex {int(T.max())} (or a negative one); there are {len(V)}")
    X = V[T]
    e1, e2 = X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]
    area2 = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    scale = np.max(np.linalg.norm(X - X.mean(axis=1, keepdims=True), axis=2), axis=1)
    degenerate = np.flatnonzero(np.abs(area2) <= 1e-10 * scale**2)
    if degenerate.size:
        raise ValueError(f"triangles {degenerate[:10].tolist()} are degenerate (zero area or a repeated vertex)")
    clockwise = np.flatnonzero(area2 < 0)
    if clockwise.size:
        raise ValueError(f"triangles {clockwise[:10].tolist()} are clockwise (inverted); list every triangle's "
                         "vertices counter-clockwise")
    unused = np.setdiff1d(np.arange(len(V)), T)
    if unused.size:
        raise ValueError(f"vertices {unused[:10].tolist()} belong to no triangle")
    directed = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    undirected, counts = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    if (counts > 2).any():
        raise ValueError(f"edges {undirected[counts > 2][:5].tolist()} are shared by more than two triangles "
                         "(a non-manifold mesh)")
    same, dcounts = np.unique(directed, axis=0, return_counts=True)
    if (dcounts > 1).any():
        raise ValueError(f"edges {same[dcounts > 1][:5].tolist()} are used twice in the same direction: two "
                         "triangles overlap on the same side of the edge")
    return V, T.astype(np.int64)


# --- numbering ----------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class PlateLayout:
    """The nodal vectors of a plate mesh: vertex v's ``[r, r_1, r_2, r_z]`` are
    ``vertex_vectors[v]``, edge e's director ``edge_vectors[e]`` (edge e joins
    ``edges[e]``), face f's centroid ``face_vectors[f]``; ``connectivity[f]`` the 16 vectors of
    element f in ``TrianglePlate``'s order."""

    edges: np.ndarray  # (E, 2) vertex pairs, sorted
    triangle_edges: np.ndarray  # (F, 3) edges 01, 12, 20 of each triangle
    vertex_vectors: np.ndarray  # (V, 4)
    edge_vectors: np.ndarray  # (E,)
    face_vectors: np.ndarray  # (F,)
    connectivity: np.ndarray  # (F, 16)

    @property
    def n_vectors(self) -> int:
        return self.vertex_vectors.size + self.edge_vectors.size + self.face_vectors.size

    @property
    def n_dof(self) -> int:
        return 3 * self.n_vectors

    @property
    def is_position(self) -> np.ndarray:
        """Vertex positions and face centroids."""
        pos = np.zeros(self.n_vectors, bool)
        pos[self.vertex_vectors[:, 0]] = True
        pos[self.face_vectors] = True
        return pos

    @property
    def is_director(self) -> np.ndarray:
        """Vertex and edge directors (the rest are mid-surface vectors)."""
        d = np.zeros(self.n_vectors, bool)
        d[self.vertex_vectors[:, 3]] = True
        d[self.edge_vectors] = True
        return d


def plate_layout(vertices, triangles) -> PlateLayout:
    """The numbering of a checked mesh (``check_mesh``): vertex vectors first (4 a vertex), then one
    director per edge, then one centroid per face."""
    V, T = check_mesh(vertices, triangles)
    nV, nF = len(V), len(T)
    directed = np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]])
    edges, inverse = np.unique(np.sort(directed, axis=1), axis=0, return_inverse=True)
    tri_edges = inverse.reshape(3, nF).T
    vv = 4 * np.arange(nV)[:, None] + np.arange(4)[None, :]
    ev = 4 * nV + np.arange(len(edges))
    fv = 4 * nV + len(edges) + np.arange(nF)
    conn = np.concatenate([vv[T].reshape(nF, 12), ev[tri_edges], fv[:, None]], axis=1)
    assert conn.shape[1] == N_VECTORS
    return PlateLayout(edges=edges, triangle_edges=tri_edges, vertex_vectors=vv, edge_vectors=ev, face_vectors=fv,
                       connectivity=conn)


def polar_slopes(vertices, center=(0.0, 0.0)) -> np.ndarray:
    """Per vertex the slope directions (radial, tangential) about ``center`` (V × 2 × 2); x and y
    at the centre itself. With these, a clamped circular edge fixes the tangential slope and
    leaves the radial one free (``PlateBody.clamped(..., slopes=(1,))``)."""
    d = np.asarray(vertices, dtype=float) - np.asarray(center, dtype=float)
    r = np.linalg.norm(d, axis=1)
    at_centre = r <= 1e-12 * max(1.0, float(r.max()))
    radial = np.where(at_centre[:, None], [1.0, 0.0], d / np.where(at_centre, 1.0, r)[:, None])
    tangential = np.stack([-radial[:, 1], radial[:, 0]], axis=1)
    return np.stack([radial, tangential], axis=1)


# --- the body -----------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class PlateBody:
    """A plate body with its mesh and numbering (``layout``; see ``PlateLayout``)."""

    body: Body
    vertices: np.ndarray
    triangles: np.ndarray
    layout: PlateLayout

    def clamped(self, vertex_ids, slopes=(0, 1)) -> np.ndarray:
        """The nodal vectors to fix for an edge (or region) clamped at ``vertex_ids``: their
        positions and directors, the slope vectors listed in ``slopes`` (0: r_1, 1: r_2), the
        directors of the edges between two of them and the centroids of faces whose three
        vertices are among them. On a circular edge with ``polar_slopes``, ``slopes=(1,)`` fixes
        the tangential slope only: the radial strain at a clamped edge is not zero."""
        ids = np.unique(np.asarray(vertex_ids, dtype=int).reshape(-1))
        n_v = len(self.vertices)
        if ids.size == 0 or ids.min() < 0 or ids.max() >= n_v:
            raise ValueError(f"vertex_ids must be vertices of the mesh (0..{n_v - 1}), got {ids[:10].tolist()}")
        slopes = tuple(slopes)
        if not set(slopes) <= {0, 1}:
            raise ValueError(f"slopes lists slope vectors 0 (r_1) and/or 1 (r_2), got {slopes}")
        lay = self.layout
        inside = np.zeros(n_v, bool)
        inside[ids] = True
        cols = [0, 3] + [1 + s for s in slopes]
        vec = [lay.vertex_vectors[ids][:, cols].reshape(-1), lay.edge_vectors[inside[lay.edges].all(axis=1)],
               lay.face_vectors[inside[self.triangles].all(axis=1)]]
        return np.sort(np.concatenate(vec))

    def in_plane(self) -> np.ndarray:
        """DOF mask (n_dof,) of the in-plane motion: x, y of the mid-surface vectors and z of the
        directors. At the flat reference the linearised in-plane and bending motions decouple,
        and the rest (``~in_plane()``) is the bending motion."""
        lay = self.layout
        mask = np.zeros((lay.n_vectors, 3), bool)
        mask[~lay.is_director, :2] = True
        mask[lay.is_director, 2] = True
        return mask.reshape(-1)

    def vertex_displacements(self, q) -> np.ndarray:
        """Displacements of the mesh vertices, ``q − q̂`` at the position vectors (V × 3)."""
        idx = self.layout.vertex_vectors[:, 0]
        q = np.asarray(q).reshape(-1, 3)
        return q[idx] - np.asarray(self.body.q_hat)[idx]


def plate_body(vertices, triangles, element: TrianglePlate, slopes="cartesian") -> PlateBody:
    """The body of a flat plate meshed by ``triangles`` (F × 3 counter-clockwise vertex indices into
    ``vertices``, V × 2 in the xy-plane) with ``element`` (a ``TrianglePlate``) on every triangle.

    ``slopes``: each vertex's two slope directions, ``"cartesian"`` (x, y), ``"polar"``
    (``polar_slopes`` about the origin) or an array (V × 2 × 2) of two independent in-plane
    vectors per vertex. The reference: vertex positions (x, y, 0), slope vectors (a, 0), directors
    e_z, centroids at the triangles' centroids. Raises ``ValueError`` for a bad mesh (``check_mesh``)
    before anything is traced.
    """
    if not isinstance(element, TrianglePlate):
        raise ValueError(f"element must be an elements.TrianglePlate, got {type(element).__name__}")
    layout = plate_layout(vertices, triangles)
    V, T = check_mesh(vertices, triangles)
    if isinstance(slopes, str):
        if slopes == "cartesian":
            a = np.broadcast_to(np.eye(2), (len(V), 2, 2))
        elif slopes == "polar":
            a = polar_slopes(V)
        else:
            raise ValueError(f"slopes must be 'cartesian', 'polar' or an array (n_vertices, 2, 2), got {slopes!r}")
    else:
        a = np.asarray(slopes, dtype=float)
        if a.shape != (len(V), 2, 2):
            raise ValueError(f"slopes must have shape ({len(V)}, 2, 2), got {a.shape}")
        det = a[:, 0, 0] * a[:, 1, 1] - a[:, 0, 1] * a[:, 1, 0]
        bad = np.flatnonzero(~(np.abs(det) > 1e-8 * np.linalg.norm(a, axis=(1, 2)) ** 2))
        if bad.size:
            raise ValueError(f"the slope directions of vertices {bad[:10].tolist()} are not two independent vectors")
    q_hat = np.zeros((layout.n_vectors, 3))
    vv = layout.vertex_vectors
    q_hat[vv[:, 0], :2] = V
    q_hat[vv[:, 1], :2] = a[:, 0]
    q_hat[vv[:, 2], :2] = a[:, 1]
    q_hat[vv[:, 3], 2] = 1.0
    q_hat[layout.edge_vectors, 2] = 1.0
    q_hat[layout.face_vectors, :2] = V[T].mean(axis=1)
    group = element_group(element, q_hat, layout.connectivity, np.ones(len(T)))
    body = Body(q_hat, [group], is_position=layout.is_position, vectors_per_node=1)
    return PlateBody(body=body, vertices=V, triangles=T, layout=layout)


__all__ = ["PlateBody", "PlateLayout", "annulus", "check_mesh", "hexagonal_disk", "plate_body", "plate_layout",
           "polar_slopes"]
