"""Finite elements: one file per element type, each an ``AbstractElement`` (``base.py``) with its
shape functions and the element integrals κ, M, ϱ, m; and what they are made of, the material
(``material``, with the locking-free elasticity D) and the beam section (``section``)."""

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
from .section import TubeSection as TubeSection
