"""Full-order equations of motion of one body: the residuals and iteration matrices that the
integrator solves (``base.AbstractModel``), for the RNCF body in a moving frame and the ANCF body
in the inertial frame (``full_order``), a linear model (``linear``), Rayleigh damping
(``damping``) and the tip observer (``observe``). The reduced NR-RNCF model is
``reduction.reduced_model``; constrained systems of bodies are ``multibody``."""

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
