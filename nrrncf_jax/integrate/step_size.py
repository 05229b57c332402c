"""Step-size controllers of the adaptive loop (``simulate``), diffrax's ``stepsize_controller``
in this library's terms: how large the first step is, whether a step is accepted, and the size
of the next one.

- ``AdaptiveStepSize``: the step follows the local error estimate of the stepping method (RMS over
  the model's error space, weighted by ``atol + rtol |x|``), grown or shrunk by
  ``0.9 err^(-1/3)`` within [0.2, 5] (generalized-α is second order: the error of q goes as h³).
  With ``pcoeff``/``icoeff`` (diffrax's ``PIDController`` names) it is a PI controller
  (Gustafsson): an accepted step's growth also looks at the last accepted step's error,
  ``0.9 err^(-(pcoeff + icoeff)/3) err_prev^(pcoeff/3)``, which damps the step size's oscillation
  between accepted and rejected steps (Gustafsson's stabilised control: Hairer, Nørsett & Wanner,
  Solving ODEs I, Sec. II.4). The default,
  ``pcoeff = 0, icoeff = 1``, is the plain controller above.
- ``ConstantStepSize``: every step of size ``dt`` (shortened only to land on output times); a
  step whose Newton fails is split (h/4, then growing back by factors of 2 to ``dt``).

Both scale Newton's stopping test by the tolerance (``atol + rtol |x|``), so ``rtol`` and
``atol`` also say how accurately a fixed step's implicit equations are solved. The tolerances are
arrays: runs that differ only in them share one compilation.
"""

import abc
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._types import Array, Float, Scalar


def _positive(name: str, value) -> Float[Array, ""]:
    """``value`` as a float array, checked > 0 when it is concrete."""
    x = jnp.asarray(value, dtype=float)
    try:
        ok = float(x) > 0.0
    except Exception:  # traced: checked by the caller's values, not here
        return x
    if not ok:
        raise ValueError(f"{name} must be > 0, got {name}={value!r}")
    return x


class AbstractStepSizeController(eqx.Module):
    """What the adaptive loop asks of a step-size controller (see the module docstring)."""

    rtol: eqx.AbstractVar[Float[Array, ""]]
    atol: eqx.AbstractVar[Float[Array, ""]]
    dt_min: eqx.AbstractVar[Float[Array, ""]]
    dt_max: eqx.AbstractVar[Float[Array, ""]]

    adaptive: ClassVar[bool]
    """Whether the step follows the error estimate: decides the default number of Newton
    corrections (10 adaptive, 50 fixed) and whether a Newton whose corrections grow fails at once
    (``Newton``)."""

    @abc.abstractmethod
    def first_step(self, t0: Scalar, t_end: Scalar) -> Scalar:
        """The first step's size, before it is shortened to an output time."""

    def scale(self, x0, x1=None):
        """The error weight ``atol + rtol max(|x0|, |x1|)`` of each coordinate."""
        x = jnp.abs(x0) if x1 is None else jnp.maximum(jnp.abs(x0), jnp.abs(x1))
        return self.atol + self.rtol * x

    @abc.abstractmethod
    def adapt(self, h: Scalar, err: Scalar, ok, err_prev: Scalar = 1.0) -> tuple:
        """``(accept, h_next)`` after a step of size ``h`` whose error norm is ``err`` (in units
        of the tolerance) and whose solve succeeded (``ok``); ``h_next`` before the loop limits
        it by ``dt_max`` and the output times. ``err_prev``: the error norm of the last accepted
        step (the loop carries it; 1 before the first)."""


class AdaptiveStepSize(AbstractStepSizeController):
    """Error-controlled steps: ``rtol``, ``atol`` (in the model's error space), the first step
    ``dt0`` (default 1e-3 of the run's span), the smallest step ``dt_min`` below which a failing
    run stops, and the largest ``dt_max``. ``pcoeff``, ``icoeff``: the PI controller's
    coefficients (module docstring; diffrax's names and meaning, for an error of order 3);
    ``pcoeff=0.4, icoeff=0.3`` is Gustafsson's choice."""

    rtol: Float[Array, ""]
    atol: Float[Array, ""]
    dt0: Float[Array, ""] | None
    dt_min: Float[Array, ""]
    dt_max: Float[Array, ""]
    pcoeff: float = eqx.field(static=True, default=0.0)
    icoeff: float = eqx.field(static=True, default=1.0)

    adaptive: ClassVar[bool] = True

    def __init__(self, rtol=1e-4, atol=1e-6, *, dt0=None, dt_min=1e-10, dt_max=np.inf, pcoeff=0.0, icoeff=1.0):
        self.rtol = _positive("rtol", rtol)
        self.atol = _positive("atol", atol)
        self.dt0 = None if dt0 is None else _positive("dt0", dt0)
        self.dt_min = _positive("dt_min", dt_min)
        self.dt_max = _positive("dt_max", dt_max)
        pcoeff, icoeff = float(pcoeff), float(icoeff)
        if not (np.isfinite(pcoeff) and np.isfinite(icoeff) and pcoeff >= 0.0 and pcoeff + icoeff > 0.0):
            raise ValueError(f"the PI coefficients need pcoeff >= 0 and pcoeff + icoeff > 0, got "
                             f"pcoeff={pcoeff!r}, icoeff={icoeff!r}")
        self.pcoeff, self.icoeff = pcoeff, icoeff

    def first_step(self, t0, t_end):
        return 1e-3 * (t_end - t0) if self.dt0 is None else self.dt0

    def adapt(self, h, err, ok, err_prev=1.0):
        accept = ok & (err <= 1.0)
        err = jnp.where(err > 0, err, 1e-10)
        # The step's error is O(h³): the plain controller's exponent is 1/3 (icoeff = 1).
        grow = 0.9 * err ** (-(self.pcoeff + self.icoeff) / 3.0)
        if self.pcoeff:
            # The last accepted step's error, floored at 1e-4: a step far inside the tolerance
            # should not let the next one grow without bound (the clip below bounds it too).
            grow = grow * jnp.maximum(err_prev, 1e-4) ** (self.pcoeff / 3.0)
            # A rejected step shrinks as the plain controller shrinks it.
            grow = jnp.where(accept, grow, jnp.minimum(0.9 * err ** (-1.0 / 3.0), 1.0))
        grow = jnp.clip(grow, 0.2, 5.0)
        return accept, jnp.where(ok, h * grow, 0.25 * h)


STEP_CONTROLS = {"plain": {}, "pi": {"pcoeff": 0.4, "icoeff": 0.3}}
"""The adaptive controllers the scenario runners and the command line offer by name: ``"plain"``
(``AdaptiveStepSize``'s default) and ``"pi"``, Gustafsson's PI controller."""


def adaptive_step_size(rtol, atol, step_control: str = "plain", **kw) -> AdaptiveStepSize:
    """``AdaptiveStepSize(rtol, atol, **kw)`` with the coefficients of the controller named
    ``step_control`` (``STEP_CONTROLS``)."""
    if step_control not in STEP_CONTROLS:
        raise ValueError(f"step_control must be one of {tuple(STEP_CONTROLS)}, got {step_control!r}")
    return AdaptiveStepSize(rtol, atol, **STEP_CONTROLS[step_control], **kw)


def step_control_name(controller: AbstractStepSizeController) -> str:
    """The name under which ``STEP_CONTROLS`` holds an ``AdaptiveStepSize``'s coefficients
    (``"plain"``, ``"pi"``), what a run's record says of its controller; other coefficients as
    ``"pi(pcoeff=…, icoeff=…)"``, a ``ConstantStepSize`` as ``"constant"``."""
    if not isinstance(controller, AdaptiveStepSize):
        return "constant" if isinstance(controller, ConstantStepSize) else type(controller).__name__
    coeffs = {"pcoeff": controller.pcoeff, "icoeff": controller.icoeff}
    for name, kw in STEP_CONTROLS.items():
        if coeffs == {"pcoeff": 0.0, "icoeff": 1.0, **kw}:
            return name
    return f"pi(pcoeff={controller.pcoeff:g}, icoeff={controller.icoeff:g})"


def with_tolerances(controller: AbstractStepSizeController, rtol, atol) -> AbstractStepSizeController:
    """``controller`` at the tolerances ``rtol``, ``atol`` (checked > 0), its other settings (the
    step limits, the PI coefficients, a constant step) kept: a run repeated at tightened
    tolerances (``rtol / k``, ``atol / k``) with the same step control."""
    return eqx.tree_at(lambda c: (c.rtol, c.atol), controller, (_positive("rtol", rtol), _positive("atol", atol)))



def tightened(controller: AbstractStepSizeController, factor) -> AbstractStepSizeController:
    """``controller`` for a repetition whose time-integration error is about ``factor`` times
    smaller (which measures a run's own): its tolerances divided by ``factor``, and a fixed step
    (``ConstantStepSize``) by √``factor``, generalized-α being second order in the step."""
    factor = float(_positive("factor", factor))
    tight = with_tolerances(controller, controller.rtol / factor, controller.atol / factor)
    if isinstance(controller, ConstantStepSize):
        tight = eqx.tree_at(lambda c: c.dt, tight, controller.dt / np.sqrt(factor))
    return tight

class ConstantStepSize(AbstractStepSizeController):
    """Steps of size ``dt``. ``rtol``/``atol`` scale Newton's stopping test only. A run whose
    Newton converges in every step is a smooth function of its parameters; ``num_rejected > 0``
    says that some step did not converge and was split."""

    dt: Float[Array, ""]
    rtol: Float[Array, ""]
    atol: Float[Array, ""]
    dt_min: Float[Array, ""]
    dt_max: Float[Array, ""]

    adaptive: ClassVar[bool] = False

    def __init__(self, dt, *, rtol=1e-4, atol=1e-6, dt_min=1e-10):
        self.dt = _positive("dt", dt)
        self.rtol = _positive("rtol", rtol)
        self.atol = _positive("atol", atol)
        self.dt_min = _positive("dt_min", dt_min)
        self.dt_max = jnp.asarray(np.inf)

    def first_step(self, t0, t_end):
        return self.dt

    def adapt(self, h, err, ok, err_prev=1.0):
        return ok, jnp.where(ok, jnp.minimum(2.0 * h, self.dt), 0.25 * h)


__all__ = ["STEP_CONTROLS", "AbstractStepSizeController", "AdaptiveStepSize", "ConstantStepSize", "adaptive_step_size",
           "step_control_name", "with_tolerances"]
