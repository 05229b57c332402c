"""What is done with a run's results: the accuracy measure χ_rel (``metrics``, THEORY §9), the
paper's figures (``plotting``, matplotlib imported only when a figure is drawn) and ParaView
files (``vtk``, through meshio)."""

from .metrics import chi_rel as chi_rel
