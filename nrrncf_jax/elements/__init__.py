"""Finite elements: one file per element type, each an ``AbstractElement`` (``base.py``) with its
shape functions and the element integrals κ, M, ϱ, m; and what they are made of, the material
(``material``, with the locking-free elasticity D) and the beam section (``section``).

- ``beam.C1Beam``: the C1 spatial ANCF beam, six nodal vectors a node (r, r_x, r_y, r_xy, r_z,
  r_xz; 18 coordinates). Its constant fourth-order elastic tensor κ and inertia integrals (m, ϱ_α,
  M_αβ) come from Green-Lagrange strains by Gauss quadrature along the element and over the
  section (``section``: a tube or solid circle, a rectangle with Saint-Venant's torsion and a shear
  correction, or a section given by its stiffnesses), on straight and curved references
  (``bodies.mesh``: circular arcs in or out of plane, any framed curve). The locking-free D of
  ``material`` keeps it free of Poisson and shear locking: the cantilever's frequencies converge
  to Euler-Bernoulli's, up to the rotary inertia and shear that theory leaves out
  (``tests/test_frequencies.py``), and the large-deflection elastica is reproduced
  (``tests/test_elastica.py``). ``mirror_even`` gives the coordinates that a mirror leaves
  unchanged, the way to keep a beam's modes in one plane.
- ``bar.Bar``: the 3-D pin-ended bar (axial Green-Lagrange strain, κ in closed form), tested on the
  von Mises truss's snap-through path, axial frequencies and a beam braced by a bar against closed
  forms (``tests/test_bar.py``).
- ``plate.TrianglePlate``: a triangular plate and membrane element whose position is linear in its
  nodal vectors: a cubic Hermite mid-surface (r, r_x, r_y at the vertices, r at the centroid) and
  a quadratic director (one on each edge), with patch tests and annulus closed forms
  (``tests/test_plate.py``); meshes in ``bodies.plate_mesh``, the paper's rotating membrane in
  ``scenarios.membrane``.
- ``joint_link.JointLink`` and ``joint_cell.JointCell``: what makes a rigid joint of beams at any
  angle (``bodies.frame``). The joint carries its position and its full position gradient F; each
  member end shares the position and is tied to F by a link, in rotation and shear but not in
  stretch, and the joint cell, the joint's own small solid, keeps F a rotation, so that the joint
  stays rigid and the frequencies converge under mesh refinement.
"""

from .bar import Bar as Bar
from .base import AbstractElement as AbstractElement
from .base import ElementIntegrals as ElementIntegrals
from .beam import NODAL_VECTORS_PER_NODE as NODAL_VECTORS_PER_NODE
from .beam import C1Beam as C1Beam
from .beam import beam_element_integrals as beam_element_integrals
from .beam import beam_shape_functions as beam_shape_functions
from .beam import mirror_even as mirror_even
from .joint_cell import JointCell as JointCell
from .joint_link import JointLink as JointLink
from .material import Material as Material
from .plate import TrianglePlate as TrianglePlate
from .section import AbstractSection as AbstractSection
from .section import RectangleSection as RectangleSection
from .section import TubeSection as TubeSection
from .section import rectangle_torsion_constant as rectangle_torsion_constant
from .section import sectional as sectional
