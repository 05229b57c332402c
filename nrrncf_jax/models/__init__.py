"""Full-order equations of motion of one body: the residuals and iteration matrices that the
integrator solves (``base.AbstractModel``), for the RNCF body in a moving frame and the ANCF body
in the inertial frame (``full_order``), a linear model (``linear``), Rayleigh damping
(``damping``) and the tip observer (``observe``). The reduced NR-RNCF model is
``reduction.reduced_model``; constrained systems of bodies are ``multibody``.

``RotatingFrameModel`` is the RNCF body in the frame of its clamped root under a prescribed motion
of that frame (``motion``; paper Eqs. 8 and 41), the full model that NR-RNCF reduces;
``InertialFrameModel`` the same body as plain ANCF in the inertial frame with its root driven.
Both take gravity and point loads (``Loads``, ``Harmonic``), reach static equilibrium by load
stepping (``integrate.static_equilibrium``), and have their iteration matrix factored by ``linalg``
as the body's size and pattern suggest (``solver=``: dense, block-tridiagonal for beam chains,
sparse for large bodies). At high spin rates RNCF takes far fewer and larger steps than ANCF.
``RayleighDamping``, D = αM + βK̂, is off by default; ``RayleighDamping.from_ratio(ζ, ωa, ωb)``
sets it from a damping ratio at two frequencies, in the RNCF and the reduced models alike, and
free decay matches the closed form (``tests/test_damping.py``)."""

from .base import AbstractModel as AbstractModel
from .damping import RayleighDamping as RayleighDamping
from .full_order import (
    Harmonic as Harmonic,
)
from .full_order import (
    InertialFrameModel as InertialFrameModel,
)
from .full_order import (
    Loads as Loads,
)
from .full_order import (
    RotatingFrameModel as RotatingFrameModel,
)
from .linear import LinearModel as LinearModel
from .observe import TipObserver as TipObserver
from .observe import tip_index as tip_index
from .observe import tip_observer as tip_observer
