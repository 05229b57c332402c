"""Finite elements: shape functions, quadrature, and the element integrals κ, M, ϱ, m."""

from .beam import (
    NODAL_VECTORS_PER_NODE as NODAL_VECTORS_PER_NODE,
)
from .beam import (
    beam_element_integrals as beam_element_integrals,
)
from .beam import (
    beam_shape_functions as beam_shape_functions,
)
