"""One call from a placed flexible body to its mechanism body: ``reduce(body, interfaces, ...)``
returns the ``FloatingBody`` of NR-RNCF (docs/theory.md, §5 and §6; paper Algorithm 1), or the full-order RNCF
body, choosing the reference conditions from where the body is joined.

The recipe it runs, the one the paper's examples run by hand:

1. the floating frame: at the first interface's node, its axes the node's unit gradient vectors
   (a C1 beam's tangent and section vectors); the body is expressed in that frame (with
   ``"mean-axis"`` conditions its origin at the body's undeformed centre of mass instead);
2. the reference conditions (``conditions``): ``"clamped"``, that node's position and its unit
   gradient vectors but the first (a beam's section vectors: r, r_y, r_z held, the cantilever of
   the paper's pendulum); ``"pinned"``, for a body joined at two points by joints that carry no
   moment (balls, hinges across a planar link): the frame's first axis along the chord from the
   first interface to the second, the first interface's position, the second's two transverse
   components and the first section's twist about the chord held (a simply supported beam with
   its spin about the chord fixed: six conditions, the rigid motions). The pinned modes are those
   of a connecting rod's classic analyses: the frame follows the chord, so the joints place it
   and the modes carry only the bending between the pins, where cantilever modes must meet the
   second pin with a sum of high modes; ``"bearing"``, for
   a shaft clamped at its first interface and held in a bearing at its second: the frame along
   the chord, the first interface's position and section vectors held (as ``"clamped"``), the
   second's two transverse components and its section's two bending rotations (its section
   vectors' components along the chord) held, its axial motion and twist free; ``"mean-axis"``,
   for a free-free body (a flying beam, a link whose joints should not fix its modes): no
   coordinate held, the mean axes of Buckens (the linearised Tisserand conditions) instead, six
   linear conditions Rᵀ M w = 0 on the deformation w, R the body's six infinitesimal rigid motions
   (three with ``plane_normal``, the in-plane ones: the others are mirror-odd and M-orthogonal
   to every in-plane deformation already), M = M_b ⊗ I₃ its mass matrix. Their rows are the
   deformation's linear momentum Σ_w μ_w w_w and its angular momentum Σ M_vw q̂_v × w_w about the
   frame's origin (``FloatingBody``'s invariants C and G: the frame's inertia coupling to the
   deformation vanishes to first order), so to first order the deformation carries no momentum
   relative to the frame, whose origin follows the centre of mass and whose axes the body's mean
   rotation. The vibration modes are the free-free elastic modes (the rigid ones left out), the
   modal derivatives and attachment modes solve the static problems on that constrained space
   (Galerkin on its orthonormal basis T: Tᵀ K T θ' = −Tᵀ f, θ = T θ', the Lagrange-multiplier
   form K θ + M R λ = −f, Rᵀ M θ = 0 of inertia relief; ``MeanAxisSpace``), as the clamped ones
   solve them on the free coordinates;
3. with ``plane_normal`` (a planar mechanism), the coordinates odd under the mirror through the
   plane held at zero (``elements.beam.mirror_even``: exactly the in-plane modes, C1 beams whose
   section axes contain the normal);
4. ``vms`` vibration modes of the held body, the modal derivatives of ``mds`` pairs
   (``"all"``: every i ≤ j; a list of (i, j); ``()``: none; ``"mmi"``: none yet, the pairs of
   largest modal interaction in the mechanism's own motion added by
   ``modal_interaction.select_modal_derivatives(system, ts)`` once the body is in its system,
   as maximum modal interaction needs that motion), deflated by SVD (``reduction.modal_basis``);
   ``basis="craig-bampton"`` (not with ``"mean-axis"``): the extended Craig-Bampton basis instead, the other interfaces'
   positions its boundary coordinates (``reduction.craig_bampton``); with ``interface_modes``
   the free basis holds those positions' static modes too (``reduction.static_modes``); with
   ``interface_rotations`` the interfaces' section vectors too (their moments' attachment modes);
   with ``interface_sections`` the attachment modes of their sections' own stretch and shear
   (``"all"``: every free section's);
   with ``interface_mds`` the modal derivatives of all those force and moment modes, or of the
   named loads' alone (``INTERFACE_LOADS``); ``basis="full"``: every
   free coordinate kept, the elements' own force (the full-order RNCF reference,
   ``full_order_frame``; not with ``"mean-axis"``, whose conditions are no selection of coordinates);
5. the reduced cubic elastic force's tensors (``reduction.elastic_tensors``, Eq. 24).
"""

import equinox as eqx
import jax
import numpy as np
import scipy.linalg as sla

from ..bodies.body import Body
from ..elements.beam import NODAL_VECTORS_PER_NODE, mirror_even
from ..reduction import attachment_modes, elastic_tensors, modal_basis, vibration_modes
from ..reduction import craig_bampton as craig_bampton_basis
from ..reduction.modal_derivatives import ModalDerivatives, dK_deta_times, mode_pairs
from ..reduction.modes import VibrationModes, frame_stiffened
from .floating import FloatingBody, rigid_motions_left
from .full_order_frame import full_floating_body
from .markers import BodyGeometry, Marker
from .system import placed


def _point(p):
    return p.point if isinstance(p, Marker) else tuple(float(x) for x in np.asarray(p, dtype=float).reshape(3))


CONDITIONS = ("clamped", "pinned", "bearing", "mean-axis")
"""``reduce``'s reference conditions (module docstring, step 2)."""

INTERFACE_LOADS = ("fx", "fy", "fz", "mx", "my", "mz")
"""The interface modes' loads by name, in the body's frame (x its first unit gradient vector, a
beam's tangent; y, z its section vectors): ``"fx"``, ``"fy"``, ``"fz"`` the force's components on
the other interfaces' positions, ``"mx"``, ``"my"``, ``"mz"`` the moment's about those axes on
their sections (``interface_rotations``); ``reduce``'s ``interface_mds`` chooses among them."""


def reduce(body: Body, interfaces, vms: int = 5, mds="all", basis: str = "free", plane_normal=None,
           interface_modes: bool = False, deflation_tol: float = 1e-6, interface_rotations: bool = False,
           interface_mds=False, conditions: str = "clamped", interface_sections: bool | str = False) -> FloatingBody:
    """``body`` (placed in space: its ``q_hat`` the stress-free, initial state) as a floating-frame
    body of a mechanism, its deformation reduced (see the module docstring). ``interfaces``: the
    points (or ``Marker``s) where it is joined, the first one holding its frame.
    ``conditions``: ``"clamped"`` (a cantilever at the first interface), ``"pinned"`` (simply
    supported between the first two, the frame along their chord), ``"bearing"`` (clamped at
    the first, in a bearing at the second) or ``"mean-axis"`` (free-free: the frame's origin at
    the undeformed centre of mass, its axes the first interface's, the deformation mass-orthogonal
    to the rigid motions, Buckens' mean axes), module docstring step 2. ``"mean-axis"`` goes with
    ``basis="free"`` only (``ValueError`` otherwise); its ``interface_modes`` are inertia-relief
    attachment modes of loads on every interface, the first included (none is held).
    ``basis``: ``"free"`` (vibration modes and modal derivatives), ``"craig-bampton"`` or
    ``"full"``. ``plane_normal``: the normal of the plane of a planar mechanism (in-plane modes
    only), or None. ``interface_modes`` (with ``basis="free"``): the other interfaces' static
    modes too, the body's static deflections under unit forces on their positions
    (``reduction.static_modes``), so that a joint's load is carried as Craig-Bampton carries it,
    without its boundary coordinates. ``interface_rotations``: the joints' moments too, so that the
    basis carries them (a joint that carries a moment otherwise bends the body only as far as its
    vibration modes reach): with ``interface_modes`` the attachment modes of unit moments on the
    other interfaces' sections (``moment_loads``: on the section vectors r_y, r_z, where a hinge's
    or a clamp's reaction moments act, ``section_frame``), with Craig-Bampton the section vectors'
    coordinates among the boundary coordinates. ``interface_mds`` (with ``interface_modes``): ``True``, the
    modal derivatives of the interface modes with each other and with the vibration modes, for a
    body whose joints' loads deform it beyond the linear range of its attachment modes; or a
    sequence of load names (``INTERFACE_LOADS``, e.g. ``("fz", "mx", "my")``), the derivatives of
    those loads' modes with each other and with the vibration modes only, the other loads' modes
    kept without derivatives: for a body that only some of its joints' loads deform beyond the
    linear range (a bar pushed out of its mechanism's plane). Each derivative adds a column, and
    the reduced cubic force's cost grows as the fourth power of the columns.
    ``interface_sections`` (with ``interface_modes``): also the attachment modes of loads that
    stretch the other interfaces' section vectors along themselves and shear them toward each
    other (``section_loads``: the section's own deformation, which the moments leave out),
    without derivatives. No joint loads a section so, but the force and moment modes and their
    derivatives turn the joint's section vectors in fixed shapes that also stretch and shear
    them, where the full body's section there stays undistorted: these modes let it relax. The
    distortion hardly moves the body, but it shifts the body's axial strain, and an axial force
    read from the strains shows it (``post.stress.SectionResultant``: in a stiff bar a small
    strain times a large EA). ``interface_sections="all"``: the same modes at every node whose
    section is free, for a body whose sections all turn far (a strip twisted by lateral
    buckling): a fixed-shape basis turns a section by a polynomial in its amplitudes, which also
    stretches it, and a section far stiffer in stretch than the body in torsion then locks it.
    ``vms`` may be 0 with ``interface_modes``: a body loaded at its joints alone that moves
    slowly against its vibrations (a quasi-static mechanism) carries its deformation in the
    attachment modes."""
    if not isinstance(body, Body):
        raise ValueError(f"reduce takes a flexible bodies.Body, got {type(body).__name__}")
    if basis not in ("free", "craig-bampton", "full"):
        raise ValueError(f"basis must be 'free', 'craig-bampton' or 'full', got {basis!r}")
    if conditions not in CONDITIONS:
        raise ValueError(f"conditions must be 'clamped', 'pinned', 'bearing' or 'mean-axis', got {conditions!r}")
    mean_axis = conditions == "mean-axis"
    if mean_axis and basis == "craig-bampton":
        raise ValueError("conditions='mean-axis' goes with basis='free': a Craig-Bampton basis holds its boundary "
                         "coordinates (fixed-interface modes), which a free-free body does not; for its joints' "
                         "loads use interface_modes (inertia-relief attachment modes)")
    if mean_axis and basis == "full":
        raise ValueError("conditions='mean-axis' goes with basis='free': its conditions are six linear constraints "
                         "on every nodal coordinate (Rᵀ M w = 0), not a selection of held coordinates, which the "
                         "full-order body keeps (full_order_frame); the full-order motion does not depend on the "
                         "reference conditions: use conditions='clamped' for it")
    if isinstance(vms, bool) or not isinstance(vms, (int, np.integer)) or vms < 0:
        raise ValueError(f"vms must be a non-negative integer, got {vms!r}")
    md_loads = _interface_md_loads(interface_mds)
    every_md = isinstance(interface_mds, (bool, np.bool_)) and bool(interface_mds)  # all the body's interface modes
    if interface_sections not in (True, False, "all"):
        raise ValueError(f"interface_sections must be True, False or 'all', got {interface_sections!r}")
    if interface_sections and not interface_modes:
        raise ValueError("interface_sections needs interface_modes (the sections' attachment modes go with the "
                         "interfaces' force modes, basis='free')")
    points = [_point(p) for p in interfaces]
    if not points:
        raise ValueError("reduce needs at least one interface point (the first one holds the body's frame)")
    if conditions in ("pinned", "bearing") and len(points) < 2:
        raise ValueError(f"conditions={conditions!r} needs two interfaces (whose chord the frame follows)")
    geometry = BodyGeometry(np.asarray(body.q_hat), np.asarray(body.is_position), body.vectors_per_node,
                            body.section_slots)
    nodes = [geometry.node(Marker(0, p)) for p in points]
    frame = nodes[0]
    gradients = geometry.unit_gradients(frame)
    if len(gradients) != 3:
        raise ValueError(f"the first interface's node has {len(gradients)} unit gradient vectors; its frame needs "
                         "three")
    A0 = np.stack([geometry.vectors[v] for v in gradients], axis=1)
    if not np.allclose(A0.T @ A0, np.eye(3), atol=1e-9) or np.linalg.det(A0) < 0:
        raise ValueError("the first interface's node's unit gradient vectors are not a right-handed orthonormal frame")
    R0 = centre_of_mass(body) if mean_axis else geometry.vectors[frame]
    if conditions in ("pinned", "bearing"):
        A0 = _chord_frame(geometry.vectors[nodes[1]] - R0, A0, conditions)
    local = placed(body, A0.T, -A0.T @ R0)
    free = np.ones((body.n_vectors, 3), bool)
    if conditions == "pinned":  # A's position and its section's twist (r_y's z)
        free[frame] = False
        free[gradients[1], 2] = False
    elif conditions != "mean-axis":  # A clamped: its position and section vectors
        free[[frame] + gradients[1:]] = False
    if conditions in ("pinned", "bearing"):  # B's transverse components, and in a bearing its bending rotations
        free[nodes[1], 1:] = False
        if conditions == "bearing":
            free[list(geometry.section(0, nodes[1])), 0] = False
    free = free.reshape(-1)
    if plane_normal is not None:
        n_local = A0.T @ (np.asarray(plane_normal, dtype=float) / np.linalg.norm(plane_normal))
        axis = int(np.argmax(np.abs(n_local)))
        if body.vectors_per_node != NODAL_VECTORS_PER_NODE or axis == 0 or abs(abs(n_local[axis]) - 1) > 1e-9:
            raise ValueError("plane_normal: in-plane modes are built for C1 beams whose section axes hold the "
                             "plane's normal")
        free &= mirror_even(body.n_vectors // NODAL_VECTORS_PER_NODE, "yz"[axis - 1])
    described = {"clamped": "frame and cantilever conditions at the first interface",
             "pinned": "frame along the chord of the first two interfaces, simply supported (pinned) conditions",
             "bearing": "frame along the chord of the first two interfaces, clamped at the first, a bearing at the "
                        "second",
             "mean-axis": "mean axes (Buckens conditions: free-free, the deformation without linear and angular "
                          "momentum relative to the frame), frame at the undeformed centre of mass, its axes the "
                          "first interface's"}[conditions]
    if basis == "full":
        return full_floating_body(local, free, R0=R0, A0=A0)
    if (isinstance(mds, str) and mds not in ("all", "mmi")) or not (
            isinstance(mds, str) or (np.ndim(mds) == 2 and np.shape(mds)[1] == 2) or np.size(mds) == 0):
        raise ValueError(f"mds must be 'all', 'mmi' or a list of pairs (i, j) ([] for none), got {mds!r}")
    if mds == "mmi" and basis != "free":
        raise ValueError("mds='mmi' goes with basis='free' (the vibration modes whose interaction chooses the pairs)")
    pairs = [(i, j) for i in range(vms) for j in range(i, vms)] if mds == "all" else \
        [] if mds == "mmi" else [tuple(p) for p in mds]
    if mds == "mmi" and interface_modes:
        raise ValueError("mds='mmi' rebuilds the body from its vibration modes and chosen pairs: pass interface_modes "
                         "with an explicit list of pairs")
    if any(not 0 <= i <= j < vms for i, j in pairs):
        raise ValueError(f"mds must be pairs (i, j) with 0 <= i <= j < vms = {vms}")
    loaded = nodes if mean_axis else nodes[1:]  # the interfaces whose loads the basis carries (all on a free body)
    positions = [3 * v + c for v in loaded for c in range(3) if free[3 * v + c]]
    sections = [3 * u + c for v in loaded for u in geometry.section(0, v) for c in range(3) if free[3 * u + c]] \
        if interface_rotations else []
    if basis == "craig-bampton":
        if interface_modes or interface_mds:
            raise ValueError("interface_modes (and interface_mds) goes with basis='free' (Craig-Bampton holds the "
                             "interfaces' static modes already)")
        if not positions:
            raise ValueError("a Craig-Bampton basis needs a second interface (its boundary coordinates)")
        Psi = np.asarray(craig_bampton_basis(local, free, positions + sections, vms, pairs,
                                             deflate_tol=deflation_tol).basis)
        note = (f"extended Craig-Bampton, {described}; {len(positions + sections)} boundary coordinates at the "
                f"other interfaces, {vms} fixed-interface VMs + {len(pairs)} MDs and the constraint modes' MDs")
        return FloatingBody(local, Psi, elastic_tensors(local, local.q_hat, Psi), R0=R0, A0=A0, free=free, note=note)
    if (interface_modes or interface_mds) and not positions:
        raise ValueError("interface_modes needs a second interface (the point whose static modes are added)")
    if interface_mds and not interface_modes:
        raise ValueError("interface_mds needs interface_modes (the modes whose derivatives it adds)")
    if vms == 0 and not interface_modes:
        raise ValueError("vms=0 leaves the body without a deformation basis: give it vibration modes or "
                         "interface_modes")
    space = MeanAxisSpace(local, free) if mean_axis else None
    phi = np.asarray((space.modes(vms) if mean_axis else vibration_modes(local, free, vms)).phi) if vms else \
        np.zeros((local.n_dof, 0))
    chosen = "MDs to be chosen by modal interaction" if mds == "mmi" else f"{len(pairs)} MDs"
    note = f"{described}; {vms} VMs + {chosen}"
    if interface_modes:
        note += (("; the interfaces' force" if mean_axis else "; the other interfaces' force")
                 + (" and moment" if interface_rotations else "")
                 + (" inertia-relief attachment modes" if mean_axis else " attachment modes")
                 + (", their sections' stretch and shear modes" if interface_sections else "")
                 + ("" if not md_loads else " and their MDs" if every_md
                    else f" and the MDs of {', '.join(md_loads)}"))
    if not interface_modes:
        return modal_body(local, free, phi, pairs, R0, A0, deflation_tol, awaiting_mds=mds == "mmi", note=note,
                          space=space)
    attach = space.solve if mean_axis else lambda F: attachment_modes(local, free, F)
    loads = [np.eye(local.n_dof)[:, positions]]
    names = ["f" + "xyz"[c] for v in loaded for c in range(3) if free[3 * v + c]]  # as `positions`
    if interface_rotations:
        loads += [moment_loads(local, geometry.section(0, v)) for v in loaded]
        names += ["mx", "my", "mz"] * len(loaded)
    loads, names = _in_plane(np.concatenate(loads, axis=1), free, names)
    attached = attach(loads)
    if interface_sections == "all":  # every node whose section is free, not only the interfaces'
        held = ~free.reshape(-1, 3).any(axis=1)
        section_nodes = [int(v) for v in np.flatnonzero(geometry.is_position)
                         if not held[list(geometry.section(0, int(v)))].any()]
    else:
        section_nodes = loaded
    stretched = [attach(_in_plane(np.concatenate([section_loads(local, geometry.section(0, v))
                                                  for v in section_nodes], axis=1), free)[0])] \
        if interface_sections else []
    if not md_loads:
        return modal_body(local, free, phi, pairs, R0, A0, deflation_tol, [attached] + stretched, note=note,
                          space=space)
    absent = [n for n in md_loads if n not in names]
    if absent and not every_md:
        raise ValueError(f"interface_mds names loads {absent} that have no interface mode here (its interface "
                         f"modes' loads: {sorted(set(names))}; moments need interface_rotations, and a held "
                         "component has none)")
    # the chosen interface modes' derivatives, with each other and with the VMs, beside `pairs`
    both = np.concatenate([phi, attached / np.abs(attached).max(axis=0)], axis=1)
    chosen = [vms + k for k, n in enumerate(names) if n in md_loads]
    pairs = list(pairs) + [(i, j) for i in list(range(vms)) + chosen for j in chosen if j >= i]
    return modal_body(local, free, both, pairs, R0, A0, deflation_tol, stretched, note=note, space=space)


def _in_plane(F: np.ndarray, free: np.ndarray, names=None) -> tuple[np.ndarray, list | None]:
    """The loads (columns of ``F``, named ``names``) that act on free coordinates only. With
    ``plane_normal`` the coordinates that leave the plane are held (``mirror_even``), and a load
    that acts on them alone (a moment about an in-plane axis, a section's shear out of the plane)
    has no in-plane part: it is dropped. A load that acts on both held and free coordinates has
    no attachment mode under these conditions and is refused, naming it."""
    held = ~free
    on_held = np.abs(F[held]).max(axis=0, initial=0.0) > 0
    on_free = np.abs(F[free]).max(axis=0, initial=0.0) > 0
    mixed = np.flatnonzero(on_held & on_free)
    if mixed.size:
        which = [names[k] for k in mixed] if names is not None else [int(k) for k in mixed]
        raise ValueError(f"reduce: the interface loads {which} act on coordinates the reference conditions (or "
                         "plane_normal's in-plane restriction) hold and on free ones at once, so they have no "
                         "attachment mode here; a plane_normal must be along one of the interfaces' section axes")
    keep = np.flatnonzero(~on_held)
    return F[:, keep], (None if names is None else [names[k] for k in keep])


def _interface_md_loads(interface_mds) -> tuple[str, ...]:
    """``reduce``'s ``interface_mds`` as the names of the loads whose modes get derivatives
    (``INTERFACE_LOADS``; all of them for ``True``, none for ``False``)."""
    if isinstance(interface_mds, (bool, np.bool_)):
        return INTERFACE_LOADS if interface_mds else ()
    try:
        md_loads = None if isinstance(interface_mds, str) else tuple(interface_mds)
    except TypeError:
        md_loads = None
    if not md_loads or any(n not in INTERFACE_LOADS for n in md_loads):
        raise ValueError(f"interface_mds must be True, False or a non-empty sequence of the load names "
                         f"{INTERFACE_LOADS}, got {interface_mds!r}")
    return tuple(dict.fromkeys(md_loads))


def _chord_frame(chord, A, conditions: str) -> np.ndarray:
    """The right-handed orthonormal frame whose first axis is along ``chord`` and whose second is
    the frame ``A``'s second axis made normal to it (the first pin's section vector r_y)."""
    e1 = chord / np.linalg.norm(chord)
    e2 = A[:, 1] - (A[:, 1] @ e1) * e1
    if np.linalg.norm(e2) < 1e-6:
        raise ValueError(f"conditions={conditions!r}: the first interface's section vector r_y lies along the "
                         "chord between the first two interfaces")
    e2 = e2 / np.linalg.norm(e2)
    return np.stack([e1, e2, np.cross(e1, e2)], axis=1)


def moment_loads(body: Body, section) -> np.ndarray:
    """The generalized forces of a unit moment about each axis on the node whose section vectors
    are ``section`` (two body indices; unit and normal in the reference): the forces on r_y, r_z
    whose virtual work on the section's rotation δθ e (δr = δθ e × r) is δθ, split between the two
    as their lever arms |e × r|² (n_dof × 3)."""
    q = np.asarray(body.q_hat)
    F = np.zeros((body.n_dof, 3))
    for k, e in enumerate(np.eye(3)):
        arms = [np.cross(e, q[v]) for v in section]
        c = 1.0 / sum(a @ a for a in arms)
        for v, a in zip(section, arms):
            F[3 * v:3 * v + 3, k] = c * a
    return F


def section_loads(body: Body, section) -> np.ndarray:
    """The generalized forces that deform the section of the node whose section vectors are
    ``section`` (two body indices a, b; unit and normal in the reference) in its own plane: a
    unit force on r_a along r_a (its stretch), on r_b along r_b, and on each toward the other
    (their shear), n_dof × 3. With ``moment_loads``' three they span every load on the two
    vectors; they do no work on the section's rotation."""
    q = np.asarray(body.q_hat)
    a, b = section
    F = np.zeros((body.n_dof, 3))
    F[3 * a:3 * a + 3, 0] = q[a]
    F[3 * b:3 * b + 3, 1] = q[b]
    F[3 * a:3 * a + 3, 2] = q[b]
    F[3 * b:3 * b + 3, 2] = q[a]
    return F


def modal_body(local: Body, free, phi, pairs, R0, A0, deflation_tol: float = 1e-6, extra=(),
               awaiting_mds: bool = False, note: str = "", space: "MeanAxisSpace | None" = None) -> FloatingBody:
    """The NR-RNCF body of ``local`` (in its frame, held on ``free``'s complement) from its
    vibration modes ``phi``, the modal derivatives of ``pairs`` and the column blocks ``extra``
    (static modes), deflated by SVD, with its tensors; it records ``free`` and ``phi``
    (``reduce`` step 4, and ``modal_interaction.select_modal_derivatives`` when it rebuilds a
    body with its pairs). Where ``free`` leaves rigid motions free (``"mean-axis"`` conditions)
    the modal derivatives are those of the mean-axis space (``space``, built here when not
    given; ``MeanAxisSpace``)."""
    if space is None and pairs and rigid_motions_left(local, free).shape[1]:
        space = MeanAxisSpace(local, free)
    theta = space.modal_derivatives(phi, pairs).theta if space is not None and pairs else None
    Psi = np.asarray(modal_basis(local, free, phi, pairs, extra=extra, theta=theta, deflation_tol=deflation_tol).Psi)
    return FloatingBody(local, Psi, elastic_tensors(local, local.q_hat, Psi), R0=R0, A0=A0, free=free, modes=phi,
                        awaiting_mds=awaiting_mds, note=note)


def centre_of_mass(body: Body) -> np.ndarray:
    """The body's centre of mass in its reference q̂: Σ_w μ_w q̂_w / m with μ = M_b 1_pos and m =
    1_posᵀ M_b 1_pos (the position shape functions sum to one, so Σ_w μ_w q̂_w = ∫ρ r dV; the
    gradient vectors carry the section's first moments, μ_w of them zero on a symmetric section)."""
    M, pos = np.asarray(body.mass_matrix()), np.asarray(body.is_position, dtype=float)
    mu = M @ pos
    return mu @ np.asarray(body.q_hat) / (pos @ mu)


@eqx.filter_jit
def _md_loads(body: Body, phi, ii, jj):
    """(∂K/∂η_j) φ_i for each pair (i, j) = (ii[m], jj[m]), as columns (n_dof × pairs): the
    right-hand sides of the static modal derivatives (``reduction.modal_derivatives``, Eq. 35)."""
    shape = body.q_hat.shape

    def one(i, j):
        return dK_deta_times(body, body.q_hat, phi[:, j].reshape(shape), phi[:, i].reshape(shape)).reshape(-1)

    return jax.vmap(one)(ii, jj).T


class MeanAxisSpace:
    """The deformations of ``body`` (in its frame, at its reference q̂) that satisfy the mean-axis
    (Buckens) conditions on its ``free`` coordinates: w zero on the held ones and Rᵀ M w = 0, R
    the rigid motions they leave free (``rigid_motions_left``), M = M_b ⊗ I₃. The rows of Rᵀ M w
    are the deformation's linear momentum Σ_w μ_w w_w and angular momentum Σ M_vw q̂_v × w_w about
    the frame's origin (per unit rate), so a basis in this space carries neither, to first order,
    relative to the frame (``reduce``'s ``conditions="mean-axis"``, module docstring step 2).

    Built once, dense (NumPy, SciPy): T (n_free × (n_free − r)), an orthonormal basis of the free
    coordinates' vectors orthogonal to the columns of M R (a complete QR of M R), and the Cholesky
    factor of Tᵀ K T, positive definite where the r rigid motions are the only zero-energy
    motions left. On it:

    - ``modes(k)``: the k lowest free-free elastic modes, the eigenproblem (Tᵀ K T, Tᵀ M T), φ = T y,
      mass-normalised (the rigid modes are not in the space, so none of them comes out);
    - ``solve(F)``: the static deflections under the loads F (n_dof × m) with inertia relief,
      w = T (Tᵀ K T)⁻¹ Tᵀ F: K w + M R λ = F, Rᵀ M w = 0 (λ = the rigid accelerations the loads'
      resultant drives, (Rᵀ M R)⁻¹ Rᵀ F); the attachment modes of a free body;
    - ``modal_derivatives(phi, pairs)``: θ_ij = ``solve``(−(∂K/∂η_j) φ_i), the static modal
      derivatives solved on the same space, as ``reduction.modal_derivatives`` solves the clamped
      ones on the free coordinates (the right-hand side of Eq. 35 unchanged; it is not
      self-equilibrated, K φ_i = ω_i² M φ_i carries momentum, and the projection takes out its
      rigid part).

    Each result is in the space to round-off: |Rᵀ M w| ~ ε ‖M R‖ ‖w‖. Cost: O(n_free³) (a QR, a
    Cholesky and a generalised symmetric eigenproblem of the free coordinates' size), as the dense
    solvers of ``reduction`` below ``linalg.DENSE_MAX_DOFS``."""

    def __init__(self, body: Body, free):
        free = np.asarray(free, dtype=bool).reshape(-1)
        if free.shape != (body.n_dof,):
            raise ValueError(f"free must be a mask of the body's {body.n_dof} coordinates, got {free.shape}")
        self.body, self.free, self.idx = body, free, np.flatnonzero(free)
        self.rigid = rigid_motions_left(body, free)
        r = self.rigid.shape[1]
        if r == 0:
            raise ValueError("the held coordinates already hold every rigid motion: these reference conditions are "
                             "not free-free (no mean-axis conditions to impose)")
        M = np.kron(np.asarray(body.mass_matrix()), np.eye(3))
        self.mass = M
        MR = (M @ self.rigid)[self.idx]
        Q, _ = np.linalg.qr(MR, mode="complete")
        self.T = Q[:, r:]
        K = np.asarray(frame_stiffened(body, body.q_hat))[np.ix_(self.idx, self.idx)]
        Kt = self.T.T @ K @ self.T
        Mt = self.T.T @ M[np.ix_(self.idx, self.idx)] @ self.T
        self.K_t, self.M_t = 0.5 * (Kt + Kt.T), 0.5 * (Mt + Mt.T)
        try:
            self._chol = sla.cho_factor(self.K_t)
        except np.linalg.LinAlgError:
            raise ValueError("the stiffness is singular on the mean-axis space: the body has a zero-energy motion "
                             "besides its rigid ones (a mechanism of its own)") from None

    def modes(self, k: int) -> VibrationModes:
        """The ``k`` lowest free-free elastic modes (ω ascending, φ mass-normalised, in the space)."""
        n = self.T.shape[1]
        k = min(int(k), n)
        w2, Y = sla.eigh(self.K_t, self.M_t, subset_by_index=[0, k - 1])
        if not w2[0] > 0.0:
            raise ValueError(f"the stiffness is not positive definite on the mean-axis space (lowest eigenvalue "
                             f"{w2[0]:.3g})")
        phi = np.zeros((self.body.n_dof, k))
        phi[self.idx] = self.T @ Y
        return VibrationModes(omega=np.sqrt(w2), phi=phi)

    def solve(self, F) -> np.ndarray:
        """T (Tᵀ K T)⁻¹ Tᵀ F: the static deflections with inertia relief under the loads ``F``
        (n_dof × m, zero where the body is held)."""
        F = np.asarray(F, dtype=float).reshape(self.body.n_dof, -1)
        if np.abs(F[~self.free]).max(initial=0.0) > 0:
            raise ValueError("a load acts on coordinates the reference conditions hold")
        w = np.zeros_like(F)
        w[self.idx] = self.T @ sla.cho_solve(self._chol, self.T.T @ F[self.idx])
        return w

    def modal_derivatives(self, phi, pairs=None) -> ModalDerivatives:
        """The static modal derivatives θ_ij of the modes ``phi`` (columns) for ``pairs`` (default
        all i ≤ j), on the mean-axis space (class docstring)."""
        phi = np.asarray(phi, dtype=float)
        pairs = mode_pairs(pairs, phi.shape[1])
        if not pairs:
            return ModalDerivatives(theta=np.zeros((self.body.n_dof, 0)), pairs=())
        ii = np.array([p[0] for p in pairs], dtype=int)
        jj = np.array([p[1] for p in pairs], dtype=int)
        f = np.array(_md_loads(self.body, phi, ii, jj))
        f[~self.free] = 0.0  # the held coordinates' reactions (mirror-odd: zero already)
        return ModalDerivatives(theta=-self.solve(f), pairs=pairs)

    def momenta(self, X) -> np.ndarray:
        """Rᵀ M X (r × m): the mean-axis conditions' residual of the columns of ``X``."""
        return self.rigid.T @ (self.mass @ np.asarray(X, dtype=float).reshape(self.body.n_dof, -1))


__all__ = ["CONDITIONS", "INTERFACE_LOADS", "MeanAxisSpace", "centre_of_mass", "modal_body", "moment_loads",
           "reduce", "rigid_motions_left", "section_loads"]
