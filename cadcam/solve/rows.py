"""The NLP's constraint rows of the mechanisms and of the spring network, which
:class:`cadcam.solve.transcription.Transcription` adds in this order: per mechanism its
wrapped lengths, its residuals at every grid angle and at its reference pose, its profiles'
convexity, ρ-bound, curvature and outline rows and its own limits (:func:`_mechanism_rows`);
then every spring's travel rows and every joint's torque terms (:func:`_spring_network_rows`).
Also how the NLP calls a CasADi function (:func:`_apart`) and the quadrature orders of the
wrapped lengths."""
from __future__ import annotations

from contextvars import ContextVar
from dataclasses import dataclass
from functools import lru_cache

import casadi as ca
import numpy as np

from .blocks import FORCE_SCALE, LENGTH_SCALE, TORQUE_SCALE
from .variables import _equal, _nonnegative, _Rows, _Vars
from ..mechanisms.base import (Mechanism, margin_function, port_function, pose_residual_function,
                               room_function, split_coefficients, wound_lengths)
from ..physics.profile import convexity_margin, curvature, inside_tangent, profile_function, support_distance
from ..physics.springs import Network
from ..physics.wrap import friction_order, segment_lengths
from ..problem import Options, Problem

#: Gauss–Legendre points of the segment from the reference pose to the grid's first angle, at
#: most: the rule grows with that segment's length in grid steps, which a narrow range far from
#: the reference pose would make unbounded (the re-check's own quadrature judges the accuracy).
FIRST_SEGMENT_MAX_ORDER = 256
#: A profile with more coefficients than this has its convexity, ρ-bound and curvature rows
#: written on lifted ρ, ρ′, ρ″ (:func:`_lifted_profile`), not as dense functions of its
#: coefficients, whose second derivatives grow as the square of their number: less build work
#: and memory at high degree. Lower degrees keep the rows they had: there lifting saves
#: little, and IPOPT's path on the lifted rows differs: on the shipped specs (order ≤ 15) it
#: took other iterates, one of them (ludovico2021_generic) to no optimum.
LIFTED_PROFILE_SIZE = 20
#: A profile with more coefficients than this is checked at fixed angles over a range set from
#: its start (:func:`_fixed_check_angles`), not at angles that scale with its unknown wrap.
#: From a start far from the optimum (a circle) that range restricts the design (the 1-DOF
#: cam's optimum is then worse); a high-degree profile, whose start is a synthesis of its shape
#: (Fedorov's envelope), gains robustness from it.
FIXED_RANGE_SIZE = 20


def _apart(options: Options, f: ca.Function, n: int | None = None):
    """``f`` (mapped over ``n`` columns, if given) as the NLP calls it: a callable returning
    its outputs in order. Where the NLP's functions are evaluated as the MX graph (``mapped``,
    and the graph compiled functions are generated from:
    :meth:`cadcam.solve.transcription.Transcription._split_graph`), each output comes from a call of
    its own, a function rebuilt from ``f``'s graph.

    CasADi's reverse mode through one MX call of a function with several outputs seeds each
    unused output with a dense zero, so the Hessian of anything using that call counts every
    output's second derivatives: a dense block over all of the call's inputs (on a cable
    robot's pair, every pose's unknowns coupled to all of both profiles' coefficients). A call
    per output keeps the sparsity exact, and an output nothing uses is never evaluated.
    Expanded into SX the sparsity is exact anyway, and one call shares its outputs' common
    work; this one-call graph also names a compiled library (:mod:`cadcam.solve.compiled`)."""
    if options.functions != "mapped":
        return f if n is None else f.map(n)
    parts = _output_functions(f, n)
    return lambda *values: [part(*values) for part in parts]


@lru_cache(maxsize=256)
def _output_functions(f: ca.Function, n: int | None) -> tuple[ca.Function, ...]:
    """One function per output of ``f``, rebuilt from its graph (mapped over ``n`` columns if
    given): kept, since the band's rows ask for the same ones once per tolerance."""
    args = f.sx_in() if f.is_a("SXFunction") else f.mx_in()
    outs = f.call(args)
    parts = [ca.Function(f"{f.name()}_{f.name_out(o)}", args, [outs[o]], f.name_in(), [f.name_out(o)])
             for o in range(f.n_out())]
    return tuple(part if n is None else part.map(n) for part in parts)


def _start_order(problem: Problem) -> int:
    """Gauss–Legendre order of the wrapped lengths the NLP starts from, each over its whole
    wrap (:meth:`cadcam.solve.transcription.Transcription.start_order`)."""
    return 4 * problem.options.quadrature_order


@dataclass(frozen=True)
class _MechanismSymbols:
    """One mechanism's symbols in the NLP: its profiles' stacked coefficients ``c`` [m], its
    departure unknowns ``z`` at its joint's grid angles ``theta`` [rad] (unknowns × n) and
    ``ref`` at its reference angle, and its numbers ``q`` (SI)."""

    c: ca.MX
    z: ca.MX
    ref: ca.MX
    theta: ca.MX
    q: ca.MX


@dataclass(frozen=True)
class _Pose:
    """One mechanism's poses in the NLP: its symbols, its profiles' ``wrapped`` lengths on the
    grid [m] (profiles × n) and its wound lengths ``wound_ref`` at the reference pose [m]
    (zeros where no closure row reads them)."""

    s: _MechanismSymbols
    wrapped: ca.MX
    wound_ref: ca.MX


def _mechanism_rows(rows: _Rows, p: _Vars, problem: Problem, u: int, first_profile: int):
    """Variables and rows of mechanism ``u``, whose profiles start at ``first_profile``.

    Returns
    -------
    d, arm : casadi.MX
        Its port displacements and moment arms [m] on the grid (ports × n).
    output : casadi.MX or None
        Its output unknown on the grid (n), where it has an output law.
    pose : _Pose
        Its poses on the grid, for the tolerance band's rows.
    """
    mech, n, v = problem.mechanisms[u], problem.options.grid, rows.v
    c = ca.vertcat(*[LENGTH_SCALE * v.add("c", b.size, first_profile + k)
                     for k, b in enumerate(mech.bases)])
    z = ca.vertcat(*[v.add("z", n, u, name).T for name in mech.unknowns])
    s = _MechanismSymbols(c, z, v.add("ref", len(mech.unknowns), u),
                          p[f"theta{mech.joint}"], _mechanism_parameters(v, p, mech, u))
    output = z[mech.unknowns.index(mech.output), :].T if mech.output_target is not None else None
    wrapped = _wrapped_length_rows(rows, problem, mech, first_profile, s)
    # lengths wound from each anchor, for closure rows (a constant cable length): the
    # wound length at the reference pose plus the lifted wrapped lengths
    wound_ref = (rows.lift("wound", wound_lengths(mech.bases, s.ref, c), LENGTH_SCALE, u)
                 if mech.closure_rows else ca.MX.zeros(len(mech.bases)))
    d, arm = _departure_rows(rows, problem, mech, s, wrapped, wound_ref)
    _profile_rows(rows, p, problem, mech, first_profile, s)
    if mech.limits:
        _limit_rows(rows, n, mech, s, arm)
    return d, arm, output, _Pose(s, wrapped, wound_ref)


def placement_scales(mech: Mechanism) -> np.ndarray:
    """The scale of each parameter mechanism ``mech`` places (its :meth:`placement_region`'s
    order): lengths in mm, angles in rad."""
    units = dict(zip(mech.parameter_names, (quantity.unit for quantity in mech.parameters)))
    return np.array([LENGTH_SCALE if units[name] == "m" else 1.0 for name in mech.placement_region()])


def _mechanism_parameters(v: _Vars, p: _Vars, mech: Mechanism, u: int):
    """The numbers q of mechanism ``u``: its parameters, but those it places within the spec's
    region (:meth:`~cadcam.mechanisms.base.Mechanism.placement_region`) variables of the NLP
    (the block ``mount``, scaled by :func:`placement_scales`)."""
    q, region = p[f"q{u}"], list(mech.placement_region())
    if not region:
        return q
    placed = v.add("mount", len(region), u) * ca.DM(placement_scales(mech))
    return ca.vertcat(*[placed[region.index(name)] if name in region else q[i]
                        for i, name in enumerate(mech.parameter_names)])


def _first_segment_order(problem: Problem, mech: Mechanism) -> int:
    """Gauss–Legendre order of the segment from ``mech``'s reference angle to its joint's first
    grid angle: the per-step order times that span in grid steps, at most
    :data:`FIRST_SEGMENT_MAX_ORDER`."""
    opt, joint = problem.options, problem.joints[mech.joint]
    h = (joint.theta_range[1] - joint.theta_range[0]) / (opt.grid - 1)
    return min(FIRST_SEGMENT_MAX_ORDER, opt.quadrature_order * int(np.ceil(max(
        abs(joint.theta_range[0] - mech.reference_angle) / h, 1))))


def _wrapped_length_rows(rows: _Rows, problem: Problem, mech: Mechanism, first_profile: int,
                         s: _MechanismSymbols, family: str = "len", index: tuple = ()):
    """Each profile's wrapped length [m] at the grid angles (profiles × n) as lifted variables,
    the running sum of Gauss–Legendre segment lengths (Johnston2023 Eq. 10, 14); the blocks of
    ``family`` at the profile's number and ``index`` (an adjustment's end,
    :mod:`cadcam.solve.robust`)."""
    n, L = problem.options.grid, LENGTH_SCALE
    first = _first_segment_order(problem, mech)
    # wrapped lengths are lifted to variables, tied segment by segment (Johnston2023
    # Eq. 10, 14), which keeps the Lagrangian Hessian banded instead of dense
    wrapped = []
    for k, (b, ck) in enumerate(zip(mech.bases, split_coefficients(mech.bases, s.c))):
        lk = L * rows.v.add(family, n, first_profile + k, *index)
        seg = segment_lengths(b, problem.options.quadrature_order, first, s.ref[k], s.z[k, :].T, ck)
        rows.constrain((lk - ca.vertcat(0, lk[:n - 1]) - seg) / L, _equal)
        wrapped.append(lk.T)
    return ca.vertcat(*wrapped)


def _departure_rows(rows: _Rows, problem: Problem, mech: Mechanism, s: _MechanismSymbols,
                    wrapped, wound_ref):
    """The mechanism's residuals R = 0 at every grid angle and at its reference pose, given its
    ``wrapped`` lengths on the grid and its wound lengths ``wound_ref`` at the reference pose.

    Returns
    -------
    d, arm : casadi.MX
        The port displacements and moment arms [m] on the grid (ports × n).
    """
    n, structure = problem.options.grid, mech.structure()
    ports = _apart(problem.options, port_function(structure, problem.torque_model,
                                 friction_order(problem.options.quadrature_order), "closed-form"), n)
    d, arm, res, _ = ports(s.theta.T, s.z, s.ref, wrapped, ca.repmat(wound_ref, 1, n) + wrapped,
                           s.c, s.q)
    residual = _apart(problem.options, pose_residual_function(structure))
    res_ref = residual(mech.reference_angle, s.ref, wound_ref, s.c, s.q)[0]
    for r, unit in enumerate(mech.residual_units):  # the mechanism's R = 0 everywhere
        rows.constrain(ca.vertcat(res[r, :].T, res_ref[r]) / (LENGTH_SCALE if unit == "m" else 1.0),
                       _equal)
    return d, arm


def _profile_rows(rows: _Rows, p: _Vars, problem: Problem, mech: Mechanism, first_profile: int,
                  s: _MechanismSymbols):
    """Convexity, ρ-bound and curvature rows of the mechanism's profiles (Johnston2023
    Eq. 40); a profile with a curvature limit (its own or its cable's:
    :meth:`cadcam.problem.Problem.curvature_limit`) adds it as a parameter ``rc``."""
    n, M, L = problem.options.grid, problem.options.convexity_points, LENGTH_SCALE
    # convexity and ρ bounds over each wrapped range [0, α(most wound)] (Johnston2023
    # Eq. 40; a high-degree profile's over [0, φ_c] ⊇ it), and the radius of curvature (ρ² + ρ′²)^{3/2} / margin ≥ r_c where asked
    for k, (b, ck) in enumerate(zip(mech.bases, split_coefficients(mech.bases, s.c))):
        end = mech.wrap_end(s.z[k, 0], s.z[k, n - 1], s.q)
        pk = first_profile + k
        phi = (_fixed_check_angles(rows, p, end, M, pk) if b.size > FIXED_RANGE_SIZE
               else end * ca.DM(np.linspace(0, 1, M)).T)
        if b.size > LIFTED_PROFILE_SIZE:
            rho, drho, ddrho = _lifted_profile(rows, problem.options, b, phi, ck, pk)
            conv = convexity_margin(rho, drho, ddrho)  # Johnston2023 Eq. 40
        else:
            rho, drho, _, conv = (v.T for v in _apart(problem.options, profile_function(b), M)(phi, ck))
        rows.constrain(conv / L**2, lambda pr, pk=pk: (
            pr.options.convexity_epsilon * (pr.profiles[pk].rho_min / L) ** 2, np.inf))
        rows.constrain(rho / L, lambda pr, pk=pk: (
            pr.profiles[pk].rho_min * (1 + pr.options.limit_margin) / L,
            pr.profiles[pk].rho_max * (1 - pr.options.limit_margin) / L))
        if mech.planar():
            _outline_rows(rows, phi.T, rho, drho, conv)
        if problem.curvature_limit(pk) > 0:
            rc = p.add("rc", 1, pk)
            rows.constrain(((rho**2 + drho**2) ** 1.5 - rc * conv) / L**3, _nonnegative)


#: Whether the builds made now impose two outline rows from the first solve instead of
#: deferring them with the others (:func:`_outline_rows`): the anchor's distance from the
#: centre and the hub's clearance at the anchor. A catalogue search's builds do
#: (:func:`cadcam.sweep.springs.search_solves`): each spring moves the anchor end, and there
#: those two rows bind in most designs, so that most designs would need a second solve with every
#: deferred row; a build's structure (:func:`cadcam.solve.builds.structure_key`) names it.
ANCHOR_ROWS_FIRST: ContextVar[bool] = ContextVar("anchor_rows_first", default=False)


def _outline_rows(rows: _Rows, phi, rho, drho, conv):
    """Rows that let the designed arc, given as ρ, ρ′ and the Eq. 40 margin at the check angles
    ``phi`` [rad] from its anchor φ = 0 to its most-wound end (columns), be closed into a
    convex outline round the hub once cut a cable's radius inside it: the convex hull of the
    arc and the hub's disk keeps the whole arc on its boundary (every free cable span a tangent
    of a convex part, clear of it) when each tangent line passes outside the hub and has both
    ends of the arc inside it; the anchor lies far enough out for the anchor hole, a wall deep,
    to clear the hub; and the arc bends no tighter than the cable's radius and a cutter's. All
    are deferred rows, but for those at the anchor where :data:`ANCHOR_ROWS_FIRST` is set."""
    L, deferred = LENGTH_SCALE, not ANCHOR_ROWS_FIRST.get()
    hub = support_distance(rho, drho) / L

    def clear(pr):
        return (pr.workshop.hub_radius + pr.workshop.cable_radius) / L, np.inf
    if deferred:
        rows.constrain(hub, clear, True)
    else:  # the anchor's row first, the others deferred
        rows.constrain(hub[0], clear)
        rows.constrain(hub[1:], clear, True)
    rows.constrain(rho[0] / L, lambda pr: ((pr.workshop.anchor_radius + pr.workshop.cable_radius) / L, np.inf),
                   deferred)
    for inner, end in ((slice(1, None), 0), (slice(None, -1), -1)):
        rows.constrain(inside_tangent(rho[inner], drho[inner], rho[end], phi[inner] - phi[end]) / L**2,
                       _nonnegative, True)
    rows.constrain(curvature(rho, drho, conv) * L, lambda pr: (-np.inf, pr.workshop.greatest_curvature * L), True)


def _fixed_check_angles(rows: _Rows, p: _Vars, end, M: int, pk: int):
    """``M`` check angles of profile ``pk`` spread over [0, φ_c] [rad] (a row), φ_c a parameter
    (``wc``, set from the start by :meth:`cadcam.solve.transcription.Transcription.start_point`), with
    a row that keeps the wrap's most-wound end ``end`` inside.

    Angles that scale with the unknown ``end`` (as a low-degree profile's do) move these rows'
    feasible set with every iterate, and on the cable robot's degree-30 pairs IPOPT's iteration
    count then swung several-fold with settings that should not matter. Fixed up to the basis domain's end instead, the rows bind
    the profile beyond its wrap, which pulled the end effector off its path wherever a
    profile's departure neared that end."""
    hi = p.add("wc", 1, pk)
    rows.constrain(hi - end, _nonnegative)
    return hi * ca.DM(np.linspace(0.0, 1.0, M)).T


def _lifted_profile(rows: _Rows, options: Options, basis, phi, c, pk: int):
    """ρ, ρ′ and ρ″ of profile ``pk`` at the angles ``phi`` (a row) as lifted variables [m,
    m/rad, m/rad²] (columns), tied to the coefficients ``c`` (Johnston2023 Eq. 38): each tie is
    linear in ``c`` at a given angle, so the rows written on them (Eq. 40) hold no product of
    two coefficients: their second derivatives grow with the degree, not with its square."""
    rho, drho, ddrho, _ = _apart(options, profile_function(basis), phi.shape[1])(phi, c)
    return tuple(rows.lift(family, value.T, LENGTH_SCALE, pk)
                 for family, value in (("rho", rho), ("drho", drho), ("ddrho", ddrho)))


def _limit_rows(rows: _Rows, n: int, mech: Mechanism, s: _MechanismSymbols, arm):
    """The mechanism's own per-pose limits (moment arm, span…) at the ``n`` grid angles, given
    its moment arms ``arm`` there; each margin ≥ 0 in units of its limit's scale."""
    marg = margin_function(mech.structure()).map(n)(s.theta.T, s.z, s.c, s.q, arm)
    scale = ca.DM([lim.nlp_scale for lim in mech.limits])
    rows.constrain(ca.vec((marg / ca.repmat(scale, 1, n)).T), _nonnegative)


def _spring_network_rows(rows: _Rows, p: _Vars, net: Network, x0, d: list, arm: list):
    """Travel rows of every spring and the torque terms of every joint, given the pre-extensions
    ``x0`` [m] and per joint its ports' displacements ``d`` and moment arms ``arm`` [m].

    Returns
    -------
    e : dict
        (spring j, joint c) → e_jc(θ_c) [m], joint c's share of spring j's extension.
    terms : list
        Per joint i, (U_i, {(j, c): V_ij}) of τ_i = U_i(θ_i) + Σ V_ij(θ_i) e_jc(θ_c).
    """
    # Every spring's extension is a sum of one-angle shares e_jc(θ_c) (Network.term), so its
    # range over the tensor grid is the sum of the shares' ranges, and every joint torque is
    # τ_i = U_i(θ_i) + Σ V_ij(θ_i) e_jc(θ_c) (Network.torque_terms). Shares of springs that
    # join several joints, and the terms that couple joints, are lifted.
    e = net.shares(d)
    terms = [net.torque_terms(i, p["k"], p["F0"], x0, arm[i], e) for i in range(net.m)]
    for j in range(net.S):
        joints = net.joints_of(j)
        if len(joints) == 1:  # Johnston2023 Eq. 46: 0 ≤ x_j ≤ x_j,max on the grid
            rows.constrain((x0[j] + e[j, joints[0]]) / LENGTH_SCALE, lambda pr, j=j: _travel(pr, j))
        else:
            e.update(_coupled_travel_rows(rows, j, joints, x0, e))
    for i, (U, V) in enumerate(terms):
        if V:
            terms[i] = (rows.lift("U", U, TORQUE_SCALE, i),
                        {q: rows.lift("V", Vq, FORCE_SCALE, i, *q) for q, Vq in V.items()})
    return e, terms


def _spring_fit_rows(rows: _Rows, problem: Problem, poses: list, x0, e: dict) -> None:
    """Each mounted spring fits between its mount and the profile at every grid angle: its
    room (:meth:`~cadcam.mechanisms.base.Mechanism.spring_room`) less its extension x₀ + e_j
    is at least its free length L0 (with the limit margin in reserve), so that the cable from
    the profile to its hook never runs out. Deferred: most springs fit with room to spare, and
    the optimum of a design where one does is the one it had without the row."""
    n = problem.options.grid
    for j, u, port, joint in problem.mounted_springs():
        s = poses[u].s
        room = room_function(problem.mechanisms[u].structure(), port).map(n)(s.theta.T, s.z, s.c, s.q)
        rows.constrain((room.T - x0[j] - e[j, joint]) / LENGTH_SCALE, lambda pr, j=j: (
            pr.springs[j].free_length * (1 + pr.options.limit_margin) / LENGTH_SCALE, np.inf), True)


def _coupled_travel_rows(rows: _Rows, j: int, joints: list, x0, e: dict) -> dict:
    """Travel rows of spring ``j`` that joins several ``joints``: its extension ranges over
    x₀ + Σ_c [lo_c, hi_c] on the tensor grid, with lifted bounds lo_c ≤ e_jc ≤ hi_c of its
    shares (Johnston2023 Eq. 46). Returns its shares in ``e`` lifted, by (j, c)."""
    L = LENGTH_SCALE
    lifted = {(j, c): rows.lift("e", e[j, c], L, j, c) for c in joints}
    hi, lo = rows.v.add("hi", len(joints), j), rows.v.add("lo", len(joints), j)  # share ranges
    for k, c in enumerate(joints):
        rows.constrain(ca.vertcat(L * hi[k] - lifted[j, c], lifted[j, c] - L * lo[k]) / L,
                       _nonnegative)
    rows.constrain(ca.vertcat(x0[j] / L + ca.sum1(lo), x0[j] / L + ca.sum1(hi)),
                   lambda pr: ([_travel(pr, j)[0], -np.inf], [np.inf, _travel(pr, j)[1]]))
    return lifted


def _travel(problem: Problem, j: int) -> tuple[float, float]:
    """Bounds of spring j's extension [mm] up to its largest (its travel, or its cable's
    tension limit: :meth:`cadcam.problem.Problem.extension_limit`) with the limit margin kept
    in reserve (below a fixed pre-extension only down to it: the extension equals it at the
    reference pose)."""
    spring, margin, largest = problem.springs[j], problem.options.limit_margin, problem.extension_limit(j)
    lo = margin * largest
    if spring.preextension is not None:
        lo = min(lo, spring.preextension)
    return lo / LENGTH_SCALE, (1 - margin) * largest / LENGTH_SCALE
