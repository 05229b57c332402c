"""What builds a flexible body from elements (``elements/``, with their material and section): its
reference geometry and the body itself, element groups on one set of nodal vectors (docs/theory.md,
§1 RNCF kinematics and §2 Elastic force).

- ``mesh``: beam reference geometry (straight, circular arcs, any framed curve);
- ``body.Body``: element groups (``elements/``) on one set of nodal vectors, with the elastic
  force F(q), the tangent stiffness, the mass integrals and the rigid modes; ``beam_body`` and
  ``truss_body`` build the simple cases;
- ``frame.frame_body``: straight beams rigidly joined at joints of any angle, and pin-ended bars;
- ``plate_mesh.plate_body``: triangle meshes (a hexagonal disk, an annulus) of plates and membranes;
- ``rigid.RigidBody``: a rigid body (mass, centre of mass, inertia tensor, attachment points) on
  nodal vectors, for mechanisms (``multibody.Mechanism``);
- ``mesh_io``: plate triangle meshes read from files (gmsh ``.msh``, VTK; through meshio) and
  ``plate_body_from_file``.

A body holds groups of elements of several types on one set of nodal vectors
(``body.ElementGroup``): beams, bars and joint cells share one body, with one constant κ, one
mass matrix and one iteration matrix, which ``linalg`` factors dense, block-tridiagonal or sparse
by its size and pattern. ``frame.frame_body`` joins straight C1 beams rigidly at joints of any
angle (``elements.JointLink``, ``elements.JointCell``) and adds pin-ended bars: the paper's beamlike
truss is built so (``scenarios.truss``, ``notebooks/06_truss.ipynb``). ``plate_mesh`` numbers a
plate's nodal vectors (four a vertex, a director an edge, a centroid a face) and checks its mesh:
the paper's rotating membrane is a 15-ring hexagonal disk of them (``scenarios.membrane``,
``notebooks/05_membrane.ipynb``). Frames and plates are written to ParaView by ``post.vtk``.
"""

from ..elements.material import Material as Material
from ..elements.section import RectangleSection as RectangleSection
from ..elements.section import TubeSection as TubeSection
from ..elements.section import sectional as sectional
from .body import Body as Body
from .body import ElementGroup as ElementGroup
from .body import beam_body as beam_body
from .body import element_group as element_group
from .body import truss_body as truss_body
from .frame import Frame as Frame
from .frame import frame_body as frame_body
from .mesh import BeamReference as BeamReference
from .mesh import arc_reference as arc_reference
from .mesh import centerline_reference as centerline_reference
from .mesh import straight_reference as straight_reference
from .mesh_io import plate_body_from_file as plate_body_from_file
from .mesh_io import read_triangle_mesh as read_triangle_mesh
from .plate_mesh import PlateBody as PlateBody
from .plate_mesh import annulus as annulus
from .plate_mesh import hexagonal_disk as hexagonal_disk
from .plate_mesh import plate_body as plate_body
from .rigid import RigidBody as RigidBody
from .rigid import slender_rod as slender_rod
