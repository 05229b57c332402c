"""A flexible two-link arm in a horizontal plane: two aluminium links (1 m each, a solid circular
section of radius 10 mm) on driven hinges about Z, the first to the ground at the origin, the
second at the first's tip, and a payload (a point mass, 0.1 kg) at the second's tip. Each hinge
follows a rest-to-rest move (``motion.RestToRest``: a cycloid by Δ in T plus the correction
Σ c_k sin²(πτ) sin kπτ), and the arm's vibration after the move is what a trajectory
optimisation removes: the tip's distance from its target, the rigid arm's final tip position,

    J(c) = mean over the output times t ≥ T of |x_tip(t) − x*|²,

is minimised over the two hinges' coefficients by Adam (optax) on gradients through the whole
jointed simulation (forward mode, one tangent per coefficient: ``jax.jvp`` passes through the
index-3 integrator). The run uses constant steps, so that J is a smooth function of c: an
adaptive step sequence changes discretely with the parameters (``trajectory_objective``).

``formulation="ancf"``: the links are C1 elements in the inertial frame; ``"nr-rncf"``: each in
a floating frame at its root, ``vms`` in-plane cantilever modes and their modal derivatives
(``multibody.reduce``). Sensors: ``tip`` the payload's position (x, y, z), ``torque_1`` and
``torque_2`` the hinges' driving torques, ``angle_2`` the second hinge's angle.
"""

import dataclasses
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optax

from ..bodies import Material, TubeSection, beam_body, straight_reference
from ..integrate import ConstantStepSize, GeneralizedAlphaIndex3, simulate
from ..motion import RestToRest
from ..multibody import Marker, Mechanism, PointMass, ball, hinge, placed
from ..multibody.modal_interaction import select_modal_derivatives
from ..multibody.reduce import reduce
from ..multibody.sensors import DriverEffort, Position, observe
from ..scenarios.mechanism_file import MechanismSetup

Z = (0.0, 0.0, 1.0)
DRIVERS = (1, 3)  # the two hinges' drivers among the resolved joints: hinge, driver, hinge, driver, ball


def _rotation_z(a):
    return np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])


def mechanism(formulation: str = "nr-rncf", elements: int = 4, vms: int = 3, mds="all", n_terms: int = 3,
              coeffs=None, move_time: float = 1.0, angle_1: float = np.pi / 2, angle_2: float = np.pi / 3,
              length: float = 1.0, radius: float = 0.01, E: float = 70e9, rho: float = 2700.0, nu: float = 0.3,
              payload: float = 0.1, t_end: float = 1.6, rtol: float = 1e-5, rho_inf: float = 0.5,
              basis: str = "free", n_mds: int = 4) -> MechanismSetup:
    """The arm (module docstring); ``coeffs`` (2, n_terms): the hinges' correction coefficients
    [rad] (zero: the plain cycloids); ``basis``: the reduced links' (``reduce``: ``"free"``
    cantilever modes, or ``"craig-bampton"`` with the tip's boundary coordinates). ``mds="mmi"``
    (nr-rncf): each reduced body's ``n_mds`` modal derivatives of largest modal interaction in a
    first run of the mechanism with its VMs alone over 0-``t_end``
    (``multibody.modal_interaction``)."""
    if formulation not in ("ancf", "nr-rncf"):
        raise ValueError(f"formulation must be 'ancf' or 'nr-rncf', got {formulation!r}")
    c = np.zeros((2, int(n_terms))) if coeffs is None else np.asarray(coeffs, dtype=float)
    if c.ndim != 2 or c.shape[0] != 2:
        raise ValueError(f"coeffs must be (2, n): one row a hinge, got shape {c.shape}")
    L = float(length)
    root_1, root_2, tip = (0.0, 0.0, 0.0), (L, 0.0, 0.0), (2 * L, 0.0, 0.0)
    links = []
    for root, end in ((root_1, root_2), (root_2, tip)):
        body = placed(beam_body(Material(E, rho, nu), TubeSection(radius), straight_reference(L, int(elements))),
                      translation=root)
        links.append(body if formulation == "ancf" else reduce(body, [root, end], vms=int(vms), mds=mds,
                                                               basis=basis, plane_normal=Z))
    joints = [hinge(None, Marker(0, root_1), Z, drive=RestToRest(angle_1, move_time, c[0])),
              hinge(Marker(0, root_2), Marker(1, root_2), Z, drive=RestToRest(angle_2, move_time, c[1])),
              ball(Marker(1, tip), Marker(2, tip))]
    system = Mechanism([*links, PointMass(payload, tip)], joints)
    if mds == "mmi" and formulation == "nr-rncf":
        system, _ = select_modal_derivatives(system, np.linspace(0.0, t_end, 201), n_mds=int(n_mds), rho_inf=rho_inf)
    sensors = {"tip": Position(Marker(2, tip)), "torque_1": DriverEffort(DRIVERS[0]),
               "torque_2": DriverEffort(DRIVERS[1])}
    return MechanismSetup(system, sensors, t_end=t_end, rtol=rtol, rho_inf=rho_inf, compare=("tip",),
                          info={"formulation": formulation, "move_time": float(move_time), "target":
                                target(angle_1, angle_2, L).tolist()})


def target(angle_1: float, angle_2: float, length: float = 1.0) -> np.ndarray:
    """x*: the rigid arm's tip after the move."""
    return _rotation_z(angle_1) @ np.array([length, 0.0, 0.0]) + _rotation_z(angle_1 + angle_2) @ np.array(
        [length, 0.0, 0.0])


def with_coeffs(system: Mechanism, coeffs) -> Mechanism:
    """The system with the hinges' correction coefficients replaced (traceable)."""
    coeffs = jnp.asarray(coeffs)
    return eqx.tree_at(lambda s: (s.joints[DRIVERS[0]].motion.coeffs, s.joints[DRIVERS[1]].motion.coeffs), system,
                       (coeffs[0], coeffs[1]))


def trajectory_objective(setup: MechanismSetup, dt: float = 2e-3, n_out: int = 121):
    """``objective(coeffs, stiffness=1.0) -> (J, tips)``: the mean square distance of the tip
    from its target over the output times t ≥ T (module docstring) and the tip's history, a run
    with constant steps ``dt`` and ρ∞ of the setup, the links' Young's modulus times
    ``stiffness`` (``Mechanism.stiffened``). Differentiable in forward mode in both."""
    system = setup.system
    ts = np.linspace(0.0, setup.t_end, int(n_out))
    after = jnp.asarray(ts >= float(system.joints[DRIVERS[0]].motion.T) - 1e-12)
    x_star = jnp.asarray(setup.info["target"])
    tip = setup.sensors["tip"]

    def objective(coeffs, stiffness=1.0):
        s = with_coeffs(system, coeffs).stiffened(stiffness)
        sol = simulate(s, GeneralizedAlphaIndex3(setup.rho_inf), ConstantStepSize(dt, rtol=1e-8, atol=1e-10), ts,
                       observe=observe(s, {"tip": tip}))
        tips = sol.ys["tip"]
        d2 = jnp.sum((tips - x_star) ** 2, axis=1)
        return jnp.sum(jnp.where(after, d2, 0.0)) / jnp.sum(after), tips

    return objective, ts


def value_and_grad_forward(fn):
    """``(fn(x), ∇fn(x))`` for a scalar ``fn(x) -> (value, aux)`` by forward mode: one tangent
    per entry of x, pushed together (``jax.jacfwd``)."""

    def both(x):
        grad, (value, aux) = jax.jacfwd(lambda y: (lambda r: (r[0], r))(fn(y)), has_aux=True)(x)
        return value, grad, aux

    return both


@dataclasses.dataclass
class ArmOptimisation:
    """``initial``/``final`` coefficients, the objective's and its gradient's history, the tip's
    history ``tips_initial``/``tips_final`` at the output times ``ts``, the residual amplitude
    max_{t ≥ T} |x_tip − x*| before and after, and the optimisation's wall time."""

    initial: np.ndarray
    final: np.ndarray
    history: list
    gradients: list
    ts: np.ndarray
    tips_initial: np.ndarray
    tips_final: np.ndarray
    amplitude_initial: float
    amplitude_final: float
    seconds: float

    @property
    def reduction(self) -> float:
        return self.amplitude_initial / self.amplitude_final


def optimise_trajectory(setup: MechanismSetup, steps: int = 40, learning_rate: float = 0.02, dt: float = 2e-3,
                        n_out: int = 121, coeffs=None) -> ArmOptimisation:
    """Adam (optax) on the hinges' coefficients, gradients by forward mode through the
    simulation (``trajectory_objective``); keeps the best iterate."""
    objective, ts = trajectory_objective(setup, dt, n_out)
    step = jax.jit(value_and_grad_forward(objective))
    after = ts >= float(setup.system.joints[DRIVERS[0]].motion.T) - 1e-12
    x_star = np.asarray(setup.info["target"])
    x = jnp.asarray(np.asarray(coeffs if coeffs is not None else jnp.stack(
        [setup.system.joints[i].motion.coeffs for i in DRIVERS])), dtype=float)
    opt = optax.adam(learning_rate)
    state = opt.init(x)
    t0 = time.perf_counter()
    history, gradients, best = [], [], (np.inf, x, None)
    x_initial = np.asarray(x)
    for _ in range(int(steps) + 1):
        value, grad, tips = step(x)
        value = float(value)
        history.append(value)
        gradients.append(np.asarray(grad))
        if value < best[0]:
            best = (value, x, tips)
        if len(history) == 1:
            first_tips = tips
        updates, state = opt.update(grad, state)
        x = optax.apply_updates(x, updates)

    def amplitude(tips):
        return float(np.sqrt(np.sum((np.asarray(tips) - x_star) ** 2, axis=1))[after].max())

    return ArmOptimisation(x_initial, np.asarray(best[1]), history, gradients, ts, np.asarray(first_tips),
                           np.asarray(best[2]), amplitude(first_tips), amplitude(best[2]), time.perf_counter() - t0)


__all__ = ["ArmOptimisation", "mechanism", "optimise_trajectory", "target", "trajectory_objective",
           "value_and_grad_forward", "with_coeffs"]
