"""What is done with a run's results: the accuracy measure χ_rel (``metrics``, THEORY §9), the
paper's figures (``plotting``, matplotlib imported only when a figure is drawn) and ParaView
files (``vtk``, through meshio).

``chi_rel(w_ref, w)`` is Eq. 40 in per cent, over whatever displacements it is given (the
benchmarks use all nodal displacements q − q̂, positions alone would hide the error behind the
geometry). ``plotting`` draws the analogues of the paper's figures: tip deflections, full against
reduced (``plot_tip``, Figs. 6 and 9), MMI bar plots (``plot_mmi``, Figs. 5, 8, 16, 22), the
membrane's rim and mode shapes (Figs. 11-14), the truss's tip and modes (Figs. 20, 24), and the
pendulum's shapes and right ends (``plot_pendulum``, Figs. 17 and 18) with ``animate_pendulum``.
``vtk`` writes frames and plates (``.vtu``, the displacement as point data, and for a time series
a ``series.pvd``)."""

from .metrics import chi_rel as chi_rel
