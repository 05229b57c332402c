"""The rotating shaft of the validation set (``examples/rotating_shaft.py``): a driven hinge at the
root, a cylindrical bearing at the tip, an unbalanced disk welded at mid-span.

Closed form: the first bending frequency of the shaft at rest, clamped in bending at both ends
with the disk at mid-span, lies just below Rayleigh's quotient with the static deflection shape
(``critical_speed``, 57.1 rad/s; an upper bound, within 1 % of the exact value for this mass
ratio), once in each bending plane (the two differ by the disk's offset). Whirl: accelerated
through that speed, the disk's whirl grows and persists (no damping); its peak after the crossing
agrees between 8 and 16 elements to the integration error's share at rtol 1e-4 (5e-3).
"""

import numpy as np
import pytest

from nrrncf_jax.examples.rotating_shaft import critical_speed, mechanism
from nrrncf_jax.integrate import constrained_equilibrium, vibration_frequencies
from nrrncf_jax.scenarios.mechanism_file import run_setup


def test_the_shafts_first_bending_frequencies_are_rayleighs():
    setup = mechanism(elements=4)
    omega = vibration_frequencies(setup.system, constrained_equilibrium(setup.system), count=3)
    w_c = critical_speed()
    assert np.all((0.99 * w_c < omega[:2]) & (omega[:2] < w_c)), (omega, w_c)
    assert omega[2] > 3 * w_c  # the next mode (torsion of the disk on the shaft) far above
    with pytest.raises(ValueError, match="even integer"):
        mechanism(elements=5)


@pytest.mark.slow
def test_the_whirl_through_the_critical_speed_converges_with_the_mesh():
    """The whirl's peaks before and after the crossing: 8 against 16 elements within 0.5 %, and the
    reduced shaft (held in its bearing, ``reduce(..., conditions="bearing")``) within 1 % of the
    full one on the same mesh (its basis error, a few tenths of a per cent)."""
    runs = {n: run_setup(mechanism(elements=n), n_out=501) for n in (8, 16)}
    runs["nr-rncf"] = run_setup(mechanism(formulation="nr-rncf", elements=8), n_out=501)
    whirl = {n: np.hypot(r.series["mid_y"], r.series["mid_z"]) for n, r in runs.items()}
    ts = runs[8].ts
    before, after = (ts > 0.5) & (ts < 1.0), ts > 1.25
    for n in (8, 16):  # the second ramp crosses the critical speed: the whirl grows and persists
        assert whirl[n][after].max() > 1.5 * whirl[n][before].max()
    assert abs(whirl[8][after].max() / whirl[16][after].max() - 1) < 5e-3
    assert abs(whirl[8][before].max() / whirl[16][before].max() - 1) < 5e-3
    for window in (before, after):
        assert abs(whirl["nr-rncf"][window].max() / whirl[8][window].max() - 1) < 1e-2
