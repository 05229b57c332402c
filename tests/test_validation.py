"""Bad input: a clear ValueError naming the bad value, before any tracing."""

import pytest

from nrrncf_jax import Loads, Material, SpinUp, TubeSection, straight_reference
from nrrncf_jax.integrate import ConstantStepSize, GeneralizedAlpha, GeneralizedAlphaIndex3
from nrrncf_jax.scenarios import BeamPreset, run_spinup


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(E=0.0), "E"),
        (dict(E=-70e9), "E"),
        (dict(rho=0.0), "rho"),
        (dict(rho=-1.0), "rho"),
        (dict(nu=0.5), "nu"),
        (dict(E=float("nan")), "E"),
    ],
)
def test_bad_material(kwargs, match):
    args = dict(E=70e9, rho=2700.0, nu=0.3) | kwargs
    with pytest.raises(ValueError, match=match):
        Material(**args)


@pytest.mark.parametrize(
    "ro, ri, match",
    [(0.0, 0.0, "r_outer"), (-0.02, 0.0, "r_outer"), (0.02, -0.001, "r_inner"), (0.02, 0.02, "inner radius"),
     (0.02, 0.03, "inner radius")],
)
def test_bad_section(ro, ri, match):
    with pytest.raises(ValueError, match=match):
        TubeSection(ro, ri)


def test_bad_geometry_and_mesh():
    with pytest.raises(ValueError, match="L"):
        straight_reference(0.0, 4)
    with pytest.raises(ValueError, match="L"):
        straight_reference(-8.0, 4)
    with pytest.raises(ValueError, match="elements"):
        straight_reference(8.0, 0)
    with pytest.raises(ValueError, match="length"):
        BeamPreset("bad", -1.0, 70e9, 2700.0, 0.3, 0.02, 0.0)
    with pytest.raises(ValueError, match="inner radius"):
        BeamPreset("bad", 8.0, 70e9, 2700.0, 0.3, 0.02, 0.05)


def test_bad_spinup_arguments():
    with pytest.raises(ValueError, match="t_end"):
        run_spinup("rncf", "paper", 4.0, t_end=0.0)
    with pytest.raises(ValueError, match="t_end"):
        run_spinup("rncf", "paper", 4.0, t_end=-2.0)
    with pytest.raises(ValueError, match="elements"):
        run_spinup("rncf", "paper", 4.0, elements=0)
    with pytest.raises(ValueError, match="omega"):
        run_spinup("rncf", "paper", 0.0)
    with pytest.raises(ValueError, match="T_s"):
        SpinUp(4.0, -1.0)
    with pytest.raises(ValueError, match="formulation"):
        run_spinup("nope", "paper", 4.0)
    with pytest.raises(ValueError, match="unknown beam preset"):
        run_spinup("rncf", "steel", 4.0)
    with pytest.raises(ValueError, match="rho_inf"):
        run_spinup("rncf", "paper", 4.0, solver=GeneralizedAlpha(2.0))
    with pytest.raises(ValueError, match="solver must be an integrate.GeneralizedAlpha"):
        run_spinup("rncf", "paper", 4.0, solver=GeneralizedAlphaIndex3(0.9))
    with pytest.raises(ValueError, match="controller must be an integrate.AdaptiveStepSize"):
        run_spinup("rncf", "paper", 4.0, controller=ConstantStepSize(0.01))


def test_bad_loads():
    with pytest.raises(ValueError, match="point_forces"):
        Loads(point_vectors=[3], point_forces=[[1.0, 2.0]])
