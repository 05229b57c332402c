"""The step error measured on what the user observes (``Mechanism.observed_error``, a model
file's ``error_on``): the error space is the sensors' first-order change, Newton still measures
every nodal vector, and a run controlled on the sensors converges in them."""

import jax.numpy as jnp
import numpy as np
import pytest

from nrrncf_jax.cli import main
from nrrncf_jax.examples.slider_crank import mechanism
from nrrncf_jax.multibody.sensors import DriverEffort
from nrrncf_jax.post.metrics import chi_rel
from nrrncf_jax.scenarios.mechanism_file import MechanismSetup, run_setup


@pytest.fixture(scope="module")
def crank():
    return mechanism("nr-rncf", elements=2, t_end=0.02)


def test_the_error_space_on_sensors_is_their_first_order_change(crank):
    """``error_space(z, e)`` of a mechanism observed on w_mid and x_B is (y(z), J_y e): against
    central differences of the sensors (step 1e-6 of a unit-scale e: truncation ~1e-12 m,
    round-off ~1e-10 of y's size over the step); ``newton_space`` stays on every nodal vector."""
    system = crank.system.observed_error({k: crank.sensors[k] for k in ("w_mid", "x_B")})
    z = crank.y0[0]
    e = jnp.asarray(np.random.default_rng(3).standard_normal(system.n_dof)) * 1e-2
    y, dy, mask = system.error_space(z, e)
    assert y.shape == dy.shape == mask.shape == (2,) and bool(mask.all())
    eps = 1e-6
    plus, minus = (system.error_space(z + s * eps * e, 0.0 * e)[0] for s in (1.0, -1.0))
    np.testing.assert_allclose(dy, (plus - minus) / (2 * eps), rtol=0, atol=1e-8 * float(jnp.abs(dy).max()) + 1e-12)
    x_n = system.newton_space(z, e)[0]
    assert x_n.shape == (3 * sum(system.vector_counts()),)
    assert system.describe()[-1] == "step error on the sensors w_mid, x_B"
    # without sensors the error space is the nodal vectors again
    np.testing.assert_array_equal(system.observed_error({}).error_space(z, e)[1], system.newton_space(z, e)[1])


def test_error_on_names_the_models_configuration_sensors(crank):
    with pytest.raises(ValueError, match="configuration sensors"):
        crank.system.observed_error({"torque": DriverEffort(1)})
    with pytest.raises(ValueError, match="does not have"):
        run_setup(crank, error_on="w_mid,nope")
    with pytest.raises(ValueError, match="does not have"):
        MechanismSetup(crank.system, crank.sensors, error_on=("tip",))
    assert MechanismSetup(crank.system, crank.sensors, error_on="nodes").error_on == ()
    assert main(["run", "slider_crank", "--error-on", "nope", "--no-progress"]) == 2


@pytest.mark.slow
def test_a_run_controlled_on_its_sensors_converges_in_them(crank):
    """The reduced slider-crank with its step error on w_mid and x_B (the example's default): its
    w_mid error against its own run at rtol 1e-8 falls with the tolerance as a second-order
    method's should (global error ∝ tol^(2/3): 10× tighter, ≥ 3× smaller; the ratio here is
    about 4-5)."""
    assert crank.error_on == ("w_mid", "x_B")
    runs = {rtol: run_setup(crank, n_out=101, controller=crank.controller(rtol)) for rtol in (1e-8, 1e-4, 1e-5)}
    ref = runs[1e-8].series["w_mid"]
    err = {rtol: float(chi_rel(ref, runs[rtol].series["w_mid"])) for rtol in (1e-4, 1e-5)}
    assert err[1e-5] < err[1e-4] / 3
    assert runs[1e-4].steps < runs[1e-5].steps < runs[1e-8].steps


def test_a_chain_measures_its_step_error_on_its_tips():
    """``run_chain(error_on="tips")``: the sensors are the beams' right ends (at the reference, the
    chain's nodes there), the run records what it measured, and it follows the run measured on
    every nodal vector to the two runs' tolerances (rtol 1e-5 on tips of 1-3 m: the local errors
    add up over ~50 steps to well under the 1e-3 m asked); a name it does not know is refused."""
    from nrrncf_jax.integrate import AdaptiveStepSize
    from nrrncf_jax.scenarios.pendulum import PendulumSpec, build_pendulum, run_chain, tip_sensors

    system = build_pendulum(PendulumSpec(elements=1))
    sensors = tip_sensors(system)
    z = system.reference()
    assert [float(s.resolve(system)(system, 0.0, z, None)[0]) for s in sensors.values()] == [1.0, 2.0, 3.0]
    with pytest.raises(ValueError, match="error_on must be one of"):
        run_chain(system, t_end=0.05, error_on="tip")
    kw = dict(t_end=0.1, dt_out=0.01, controller=AdaptiveStepSize(1e-5, 1e-6))
    tips, nodes = run_chain(system, error_on="tips", **kw), run_chain(system, **kw)
    assert tips.summary()["error_on"] == "tips" and "error_on" not in nodes.summary()
    assert np.abs(tips.tips - nodes.tips).max() < 1e-3
    assert np.abs(tips.tips - tips.tips[0]).max() > 1e-2  # the chain did fall
