"""What is done with a run's results: the accuracy measure χ_rel (``metrics``; docs/theory.md, §9
Accuracy measures and checks), the paper's figures (``plotting``, matplotlib imported only when a
figure is drawn) and ParaView files (``vtk``, through meshio).

``chi_rel(w_ref, w)`` is Eq. 40 in per cent, over whatever displacements it is given (the
benchmarks use all nodal displacements q − q̂, positions alone would hide the error behind the
geometry). ``plotting`` draws the analogues of the paper's figures: tip deflections, full against
reduced (``plot_tip``, Figs. 6 and 9), MMI bar plots (``plot_mmi``, Figs. 5, 8, 16, 22), the
membrane's rim and mode shapes (Figs. 11-14), the truss's tip and modes (Figs. 20, 24), and the
pendulum's shapes and right ends (``plot_pendulum``, Figs. 17 and 18) with ``animate_pendulum``.
``vtk`` writes frames and plates (``.vtu``, the displacement as point data, and for a time series
a ``series.pvd``). ``stress`` evaluates the Green-Lagrange strain and the second Piola-Kirchhoff
stress as the elements define them (docs/theory.md, §2 Elastic force) at chosen points of an element, and their
resultants: a beam's axial force, shear forces, torque and bending moments along it
(``beam_resultants``), a plate's membrane forces, bending moments and transverse shears per length
(``plate_resultants``); ``vtk.stress_fields`` gives them as cell fields for the writers'
``cell_data``."""

from .metrics import chi_rel as chi_rel
from .stress import BEAM_RESULTANTS as BEAM_RESULTANTS
from .stress import PLATE_RESULTANTS as PLATE_RESULTANTS
from .stress import SectionResultant as SectionResultant
from .stress import bar_strain_stress as bar_strain_stress
from .stress import beam_element_resultants as beam_element_resultants
from .stress import beam_resultants as beam_resultants
from .stress import beam_section_forces as beam_section_forces
from .stress import beam_section_resultants as beam_section_resultants
from .stress import beam_strain_stress as beam_strain_stress
from .stress import element_vectors as element_vectors
from .stress import plate_resultants as plate_resultants
from .stress import plate_section_resultants as plate_section_resultants
from .stress import plate_strain_stress as plate_strain_stress
from .vtk import stress_fields as stress_fields
