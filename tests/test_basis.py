"""``reduction.modal_basis``, the one construction of the NR-RNCF basis (modes, modal derivatives,
extra columns, SVD deflation): its columns and deflation, and that each of its users (``nr_rncf``
with and without the spinning-state enrichment, the offline family's ``X T0``, the reduced
pendulum's beams) gets the basis of the direct construction from ``vibration_modes``,
``modal_derivatives`` and ``deflate``.

Tolerances: both sides do the same arithmetic on the same numbers (the MDs solved in the same
batches: a batch of another size rounds otherwise, by eps κ(K|eq)), so the bases agree to the last
bit; 1e-12 (absolute, on bases of unit columns) is a margin of round-off. The offline family's
X T0 is a product, not the SVD's U itself, and differs from Ψ by eps κ(X̂) (stated there)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import paper_body

from nrrncf_jax import Basis, RotatingFrameModel, SpinState, SpinUp, nr_rncf
from nrrncf_jax.reduction import (
    ModalBasis,
    align_degenerate_modes,
    deflate,
    modal_basis,
    modal_derivatives,
    purify_close_modes,
    spinning_modes,
    vibration_modes,
)
from nrrncf_jax.reduction.deflation import deflation_map
from nrrncf_jax.reduction.modes import frame_stiffened
from nrrncf_jax.reduction.pipeline import _mmi_loads

ATOL = 1e-12
TS = np.linspace(0.0, 2.0, 21)


@pytest.fixture(scope="module")
def curved():
    """The curved beam (2 elements; no repeated eigenvalues) spun to 2 rad/s in 1.47 s, its modes."""
    full = RotatingFrameModel(paper_body(2, "curved-upwind"), SpinUp(2.0, 1.47))
    return full, vibration_modes(full.body, full.free_mask(), 6)


def _rest_modes(full, n_modes):
    """The modes ``nr_rncf`` selects from: ``vibration_modes`` with each degenerate cluster
    rotated by its MMI loads (``align_degenerate_modes``), then purified of the eigensolver's
    round-off by the MMI load history (``purify_close_modes``)."""
    modes = vibration_modes(full.body, full.free_mask(), n_modes)
    _, vectors, _ = _mmi_loads(full, modes.phi, jnp.asarray(TS))
    phi = align_degenerate_modes(modes.phi, modes.omega, vectors)
    history, _, _ = _mmi_loads(full, phi, jnp.asarray(TS))
    return np.asarray(purify_close_modes(phi, modes.omega, np.asarray(history).T, modes.lambda_max))


def test_modal_basis_columns_and_deflation(curved):
    """X = [Φ_vms, Θ_pairs, extra] in that order; Ψ = deflate(X); X T = Ψ; precomputed MDs
    give the same columns; the same columns inside a trace."""
    full, modes = curved
    body, free = full.body, full.free_mask()
    phi = np.asarray(modes.phi)
    pairs = [(0, 0), (0, 3)]
    theta = np.asarray(modal_derivatives(body, free, modes.phi, pairs).theta)
    extra = np.random.default_rng(0).standard_normal((body.n_dof, 2)) * np.asarray(free)[:, None]
    b = modal_basis(body, free, modes.phi, pairs, vms=[3, 0, 1], extra=[extra])
    assert isinstance(b, ModalBasis) and (b.n_vms, b.n_mds) == (3, 2)
    np.testing.assert_array_equal(b.columns, np.concatenate([phi[:, [3, 0, 1]], theta, extra], axis=1))
    np.testing.assert_array_equal(b.theta, theta)
    np.testing.assert_array_equal(b.Psi, deflate(b.columns))
    np.testing.assert_allclose(b.columns @ b.deflation_map(), b.Psi, rtol=0, atol=ATOL)
    np.testing.assert_array_equal(b.deflation_map(3), deflation_map(b.columns, 3))
    again = modal_basis(body, free, modes.phi, pairs, vms=[3, 0, 1], extra=[extra], theta=b.theta)
    np.testing.assert_array_equal(again.columns, b.columns)
    # all modes by default; no pairs, no MDs
    plain = modal_basis(body, free, modes.phi)
    assert plain.theta is None and plain.n_vms == 6
    np.testing.assert_array_equal(plain.columns, phi)
    # traced (the offline family's differentiable path): a JAX array of the same columns, the MDs
    # as modal_derivatives computes them in a trace (the solve with K|eq compiled into the one
    # kernel rounds otherwise than alone, by eps κ(K|eq))
    traced = jax.jit(lambda p: modal_basis(body, free, p, pairs, vms=[3, 0, 1]).columns)(modes.phi)
    theta_traced = jax.jit(lambda p: modal_derivatives(body, free, p, pairs).theta)(modes.phi)
    np.testing.assert_allclose(traced, np.concatenate([phi[:, [3, 0, 1]], theta_traced], axis=1), rtol=0,
                               atol=ATOL * np.abs(theta).max())
    with pytest.raises(ValueError, match="out of range in vms"):
        modal_basis(body, free, modes.phi, vms=[6])
    with pytest.raises(ValueError, match="theta must hold the 2 modal derivatives"):
        modal_basis(body, free, modes.phi, pairs, theta=theta[:, :1])


def test_nr_rncf_basis_is_the_direct_construction(curved):
    """``nr_rncf``'s Ψ (no enrichment) = deflate([Φ_vms, Θ_pairs]) of its selection."""
    full, _ = curved
    red = nr_rncf(full, jnp.asarray(TS), Basis(n_modes=6, vms=2, mds=2, max_dofs=None, spin_state=False))
    phi = _rest_modes(full, 6)
    sel = red.selection
    theta = modal_derivatives(full.body, full.free_mask(), phi, sel.pairs).theta
    X = np.concatenate([phi[:, list(sel.vms)], np.asarray(theta)], axis=1)
    np.testing.assert_allclose(red.model.Psi, deflate(X), rtol=0, atol=ATOL)


def test_spin_enriched_basis_is_the_direct_construction(curved):
    """With the spinning-state enrichment and the rest MDs cut to make room for it (``max_dofs``):
    Ψ = deflate([Φ_vms, Θ_pairs (the kept ones), Φ*_spin, Θ*_spin pairs]). The MDs are solved in
    the batches nr_rncf solves them in (the rest selection's pairs before the cut; the spinning
    modes' padded to that count), for the same round-off."""
    full, _ = curved
    kw = dict(n_modes=6, vms=2, mds="auto", max_dofs=6)
    red = nr_rncf(full, jnp.asarray(TS), Basis(spin_state=SpinState(check=True, mds=2), **kw))
    uncut = nr_rncf(full, jnp.asarray(TS), Basis(spin_state=False, **kw)).selection.pairs
    check, sel = red.spin, red.selection
    assert check.enriched and len(check.pairs) == 2 and sel.pairs == uncut[: 6 - 2 - 1 - 2]  # the rest MDs were cut
    body, free = full.body, full.free_mask()
    phi = _rest_modes(full, 6)
    _, smodes = spinning_modes(full, check.omega, 6)
    theta = np.asarray(modal_derivatives(body, free, phi, uncut).theta)[:, : len(sel.pairs)]
    cols = [phi[:, list(sel.vms)], theta, np.asarray(smodes.phi)[:, list(check.vms)],
            modal_derivatives(body, free, smodes.phi, check.pairs, pad_to=len(uncut)).theta]
    X = np.concatenate([np.asarray(c) for c in cols], axis=1)
    np.testing.assert_allclose(red.model.Psi, deflate(X), rtol=0, atol=ATOL)


def test_offline_family_map_reproduces_the_reduction_basis(curved):
    """The offline family's nominal X T0 is the reduction's Ψ, column signs included: T0 comes
    from the SVD that ``deflate`` takes of the same X. X T0 differs from U_r by the round-off of
    the product, eps · κ(X̂) in size (κ the condition number of X with normalised columns), and
    by the round-off of the recomputed modes, amplified by κ(K|eq) in their modal derivatives."""
    from nrrncf_jax.scenarios import beam_preset
    from nrrncf_jax.studies.families import offline_family

    full, _ = curved
    red = nr_rncf(full, jnp.asarray(TS), Basis(n_modes=6, vms=2, mds=2, max_dofs=None, spin_state=False))
    fam = offline_family(full, red, beam_preset("curved-upwind"))
    body, free = full.body, full.free_mask()
    sel = red.selection
    modes = vibration_modes(body, free, 6)
    # R0 takes the nominal eigenvectors to the reduction's purified modes: a rotation inside the
    # eigensolver's uncertainty ε λ_max / |ω_i² − ω_j²| (test_close_modes)
    w2 = np.asarray(modes.omega) ** 2
    theta = np.finfo(float).eps * float(modes.lambda_max) / np.abs(w2[:, None] - w2[None, :] + np.eye(6))
    off = np.abs(np.asarray(fam.R0) - np.eye(6))
    assert np.all(off <= theta + 1e-12)
    phi = np.asarray(fam.phi0) @ np.asarray(fam.R0)
    X = np.concatenate([phi[:, list(sel.vms)], np.asarray(modal_derivatives(body, free, phi, sel.pairs).theta)],
                       axis=1)
    np.testing.assert_allclose(fam.T0, deflation_map(X, red.model.n_dof), rtol=0, atol=0)
    s = np.linalg.svd(X / np.linalg.norm(X, axis=0), compute_uv=False)
    kappa = s[0] / s[-1]
    # The family recomputes the modes and turns them by R0: the reduction's modes to round-off,
    # which the modal derivatives' solve amplifies by κ(K|eq).
    K = np.asarray(frame_stiffened(body, body.q_hat))[np.ix_(np.asarray(free), np.asarray(free))]
    atol = 10 * np.finfo(float).eps * (kappa + np.linalg.cond(K))
    np.testing.assert_allclose(fam.basis(body, free), red.model.Psi, rtol=0, atol=atol)


@pytest.mark.slow
def test_pendulum_beam_bases_are_the_direct_construction():
    """``build_reduced_pendulum``'s beams (2 elements, reduced by ``multibody.reduce`` and moved
    along the chain): deflate([Φ, Θ_pairs, joint static modes]) of the in-plane cantilever modes,
    the same pairs for all beams or one list a beam (``PendulumBasis.body_pairs``)."""
    from nrrncf_jax.elements.beam import mirror_even
    from nrrncf_jax.motion import Stationary
    from nrrncf_jax.reduction import static_modes
    from nrrncf_jax.scenarios.pendulum import (
        _PER_NODE,
        REFERENCE_CONDITIONS,
        PendulumBasis,
        PendulumSpec,
        _beam,
        build_reduced_pendulum,
    )

    spec = PendulumSpec(elements=2)
    beam = _beam(spec)
    free = RotatingFrameModel(beam, Stationary(), clamped=list(REFERENCE_CONDITIONS)).free_mask()
    free = free & jnp.asarray(mirror_even(spec.elements + 1, "z"))
    modes = vibration_modes(beam, free, 3)
    tip = 3 * _PER_NODE * spec.elements + np.arange(3)  # the right end's position: its in-plane components
    tip = static_modes(beam, free, tip[np.asarray(free)[tip]])

    def direct(pairs, extra):
        mds = [np.asarray(modal_derivatives(beam, free, modes.phi, pairs).theta)] if pairs else []
        return deflate(np.concatenate([np.asarray(modes.phi)] + mds + extra, axis=1))

    pairs = [(0, 0), (0, 2), (1, 1)]
    system, info = build_reduced_pendulum(spec, PendulumBasis(3, pairs, joint_modes=True))
    expected = direct(pairs, [tip])
    assert info["k"] == expected.shape[1]
    for b in system.bodies:
        np.testing.assert_allclose(b.basis, expected, rtol=0, atol=ATOL)
    body_pairs = [[(0, 0)], [(0, 1), (2, 2)], []]
    system, info = build_reduced_pendulum(spec, PendulumBasis(3, body_pairs=body_pairs))
    for b, bp in zip(system.bodies, body_pairs):
        np.testing.assert_allclose(b.basis, direct(bp, []), rtol=0, atol=ATOL)
