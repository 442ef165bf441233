"""The NLP's objective, term by term (Johnston2023 Eq. 46, 47), with the rows and variables
each term needs: torque tracking, ∫(τ_d − τ)² exactly or minimax (:func:`_tracking_terms`),
sensitivity to the spring rates (:func:`_sensitivity_rows`), the tolerance band
(:func:`_band_rows`) and the mechanisms' output laws (:func:`_output_law_terms`)."""
from __future__ import annotations

import casadi as ca
import numpy as np

from .blocks import BAND_SCALE, FORCE_SCALE, LENGTH_SCALE, SENSITIVITY_SCALE, TORQUE_SCALE, block_name
from .rows import _apart, _first_segment_order, _Pose, _start_order
from .variables import _equal, _Rows, _Vars
from ..mechanisms.base import (port_change_function, pose_change_function, split_coefficients,
                               wound_change_function)
from ..physics.springs import Network
from ..physics.wrap import friction_order, length_change_function, segment_lengths
from ..problem import Problem
from ..errors import SpecError

#: The objective is scaled so that a zero torque scores this much. The barrier terms of
#: IPOPT's ~10³ inequality rows must not swamp it: at a scale of 1, started from Johnston2023's
#: feasible Table 4 design (Eq. 47 value 6.01), IPOPT ends at 17.8; at 1000 it reaches 5.55
#: (and the 1-DOF and Sec. 10.4 problems converge in fewer iterations).
OBJECTIVE_SCALE = 1000.0


def _tracking_terms(rows: _Rows, p: _Vars, problem: Problem, terms: list, e: dict, w: list,
                    span: list) -> list:
    """The objective's torque-tracking term of each joint (Johnston2023 Eq. 46 term 1, Eq. 47
    term 1), given its torque ``terms``, the spring shares ``e``, the joints' trapezoidal
    weights ``w`` and their sums ``span``: ∫(τ_d,i − τ_i)² exactly, or for objective
    ``minimax`` max |τ_i − τ_d,i| over the grid as an epigraph variable t_i."""
    n, m = problem.options.grid, len(problem.joints)
    out = []
    for i in range(m):  # Johnston2023 Eq. 46 term 1, Eq. 47 term 1: ∫(τ_d,i − τ_i)² exactly
        U, V = terms[i]
        if problem.joints[i].tracking_weight == 0:
            continue  # no torque goal on this joint (an output law may drive it; it may have no springs)
        if problem.options.objective == "minimax":  # max |τ_i − τ_d,i| over the grid: an epigraph t_i
            if V:
                raise SpecError(f"solver.objective = 'minimax' needs joint torques that each depend "
                                f"on their own joint's angle; {problem.joints[i].name!r} is coupled "
                                f"to other joints by a spring: use 'least_squares'")
            t = rows.epigraph("t", (U - p[f"td{i}"]) / TORQUE_SCALE, i)
            out.append(p[f"weights{i}"] * TORQUE_SCALE * t)
            continue
        mt = {c: ca.reshape(p[f"Mt{i}_{c}"], n, n) for c in range(m) if c != i}
        out.append(p[f"weights{i}"] * _squared_error(U, V, e, w, span, i, p[f"rt{i}"], mt,
                                                     p[f"td2{i}"], rows.lift))
    return out


def _squared_error(U, V, e, w, span, i, rt, mt, td2, lift):
    """∫(τ_d,i − τ_i)² over the tensor grid of all cams with trapezoidal weights, exactly.

    With τ_i = U(θ_i) + Σ_q V_q(θ_i) e_q(θ_c(q)) (q = (spring j, cam c), see
    :func:`cadcam.physics.springs.torque_terms`) the square expands into one-angle sums and bilinear
    forms V_qᵀ M̃_ic e_q with the target's weighted marginals (``rt``, ``mt``, ``td2``; see
    :meth:`cadcam.solve.transcription.Transcription.parameters`): O(n²) constants instead of O(n^m)
    model evaluations.
    The products that couple two cams' angles go through lifted variables (``lift``:
    M̃_ic e_q and the one-angle moments), so the Hessian stays sparse.
    """
    def others(*cams):
        out = 1
        for c, s in enumerate(span):
            if c != i and c not in cams:
                out = out * s
        return out

    wi = w[i]
    moment = {q: lift("mom", ca.dot(w[q[1]], e[q]), LENGTH_SCALE, i, *q) for q in V}
    total = td2 - 2 * ca.dot(U, rt) + others() * ca.dot(wi, U * U)
    for q, Vq in V.items():
        c = q[1]
        y = lift("Me", ca.mtimes(mt[c], e[q]), LENGTH_SCALE, i, *q)
        total += -2 * ca.dot(Vq, y)
        total += 2 * others(c) * lift("UV", ca.dot(wi, U * Vq), 1.0, i, *q) * moment[q]
        for r, Vr in V.items():
            cr = r[1]
            vv = lift("VV", ca.dot(wi, Vq * Vr), FORCE_SCALE**2, i, *q, *r)
            if cr == c:
                total += others(c) * vv * lift("ee", ca.dot(w[c], e[q] * e[r]), LENGTH_SCALE**2,
                                               i, *q, *r)
            else:
                total += others(c, cr) * vv * moment[q] * moment[r]
    return total


def _sensitivity_rows(rows: _Rows, p: _Vars, net: Network, pairs: list, x0, e: dict, arm: list,
                      w: list, span: list) -> tuple[list, list]:
    """The rate-sensitivity split rows of each (joint i, spring j) in ``pairs`` and their
    objective terms (Johnston2023 Eq. 46 terms 2–3, Eq. 47 terms 2–7), given the
    pre-extensions ``x0`` [m], the spring shares ``e``, the joints' moment arms ``arm``, their
    trapezoidal weights ``w`` and the sums ``span``.

    Returns
    -------
    sens : list
        x̄_j a_ij per pair, in units of :data:`SENSITIVITY_SCALE` (the start of s±).
    terms : list
        The objective's term of each pair.
    """
    # Eq. 46/47 sensitivity terms: ∂τ_i/∂k_j = x_j a_ij(θ_i), and the integral over the other
    # joints' angles of |x_j a_ij| = x_j |a_ij| (x_j ≥ 0 is a constraint) is separable: x̄_j
    # |a_ij| with x̄_j the mean of x_j = x₀_j + Σ_c e_jc over the other joints' grids. Its
    # value is split, x̄_j a_ij = s⁺ − s⁻ with s± ≥ 0, and s⁺ + s⁻ is minimised (no abs). The
    # split is of the product, not of a_ij weighted by x̄_j: where x̄_j reaches 0 (a spring
    # slack at some angle), s± of a_ij alone cost nothing, and IPOPT's barrier drove both up
    # together (steps of 10⁷ on the 1-DOF spec).
    sens, terms = [], []
    for i, j in pairs:
        n = w[i].numel()
        sp, sn = rows.v.add("sp", n, i, j), rows.v.add("sn", n, i, j)
        others = [c for c in range(net.m) if c != i]
        s_ij = _mean_extension(x0, e, w, span, i, j) * net.arm_term(j, i, arm[i]) / SENSITIVITY_SCALE
        rows.constrain(sp - sn - s_ij, _equal)
        sens.append(s_ij)
        integral = SENSITIVITY_SCALE * ca.dot(w[i], sp + sn)
        for c in others:
            integral = integral * span[c]
        terms.append(p[f"wsens{i}"][j] * integral)  # Eq. 46 terms 2–3, Eq. 47 terms 2–7
    return sens, terms


def _mean_extension(x0, e: dict, w: list, span: list, i: int, j: int):
    """Spring ``j``'s extension x_j = x₀_j + Σ_c e_jc(θ_c) [m] at joint ``i``'s grid angles,
    averaged over the other joints' angles with their trapezoidal weights ``w`` (sums
    ``span``): what an integral over them of a term linear in x_j takes."""
    return x0[j] + e[j, i] + sum(ca.dot(w[c], e[j, c]) / span[c] for c in range(len(w)) if c != i and (j, c) in e)


def _band_rows(rows: _Rows, p: _Vars, problem: Problem, banded: list, x0, e: dict, d: list, arm: list,
               poses: list, w: list, span: list, changes: dict) -> tuple[list, list, list]:
    """The tolerance band's split rows and objective terms of each joint in ``banded``: the
    band's first-order half-width w(θ) = Σ_p |∂τ/∂p| Δp (:mod:`cadcam.verify.tolerance`),
    integrated over the grid and weighed by the joint's ``band_weight``.

    Each part ∂τ/∂p Δp is split, v = s⁺ − s⁻ with s± ≥ 0, and s⁺ + s⁻ is minimised: |v| at
    the optimum without an ``abs``. The term is ∫w, not ∫w²: linear in s±, it pushes each
    split with the same weight wherever the band is narrow (the square's push 2w vanishes
    there and leaves s⁺ and s⁻ to IPOPT's barrier, as :func:`_sensitivity_rows` found), and its
    rate part is Δk_j times Johnston2023's ∫|∂τ/∂k_j|. Given the pre-extensions ``x0``, the
    spring shares ``e``, the joints' port displacements ``d`` and moment arms ``arm``, the
    mechanisms' ``poses`` (:class:`_Pose`), the trapezoidal weights ``w`` and their sums ``span``;
    each joint's port changes (:func:`port_changes`) are kept in ``changes`` (by joint), made
    where they are not there yet.

    Returns
    -------
    splits : list
        (joint, positive block, negative block) of each part.
    values : list
        Each part's value on its joint's grid, in units of :data:`BAND_SCALE`.
    terms : list
        Each joint's objective term.
    """
    net = problem.network()
    splits, values, terms = [], [], []
    for i in banded:
        springs = [j for j in range(net.S) if i in net.joints_of(j)]
        if not springs:
            continue  # no spring, no band
        parts = _band_spring_parts(p, net, i, x0, e, arm, w, span)
        if all(net.joints_of(j) == [i] for j in springs):
            if i not in changes:
                changes[i] = port_changes(rows, p, problem, i, poses)
            parts += _band_part_changes(p, problem, net, i, x0, d[i], arm[i], changes[i])
        total = 0
        for family, index, value in parts:
            n = value.shape[0]
            pos, neg = rows.v.add(family + "p", n, i, *index), rows.v.add(family + "n", n, i, *index)
            rows.constrain(pos - neg - value / BAND_SCALE, _equal)
            splits.append((i, block_name(family + "p", (i, *index)), block_name(family + "n", (i, *index))))
            values.append(value / BAND_SCALE)
            total = total + pos + neg
        integral = BAND_SCALE * ca.dot(w[i], total)
        for c in range(len(w)):
            if c != i:
                integral = integral * span[c]
        terms.append(p[f"wband{i}"] * integral)
    return splits, values, terms


def _band_spring_parts(p: _Vars, net, i: int, x0, e: dict, arm: list, w: list, span: list) -> list:
    """The band's parts of joint ``i`` from each spring j on it: ∂τ_i/∂k_j = x_j a_ij,
    ∂τ_i/∂F0_j = a_ij and ∂τ_i/∂x₀_j = k_j a_ij (Johnston2023 Eq. 36, 43;
    :meth:`cadcam.physics.springs.Network.arm_term`), whose sum over the three tolerances is
    |a_ij| (Δk_j x_j + ΔF0_j + k_j Δx₀), x_j ≥ 0 being a row: one split (family ``bs``) of
    (Δk_j x̄_j + ΔF) a_ij, x̄_j averaged over the other joints' angles (exact in the integral)."""
    return [("bs", (j,), (p["dk"][j] * _mean_extension(x0, e, w, span, i, j) + p["dF"][j]) * net.arm_term(j, i, arm[i]))
            for j in range(net.S) if i in net.joints_of(j)]


def _band_part_changes(p: _Vars, problem: Problem, net, i: int, x0, d_i: list, arm_i: list, columns: list) -> list:
    """The band's parts of joint ``i`` (whose springs act on it alone) from each of its
    ``columns`` (:func:`port_changes`): ∂τ_i/∂p Δp at its grid angles, the torque's change by
    :meth:`cadcam.physics.springs.Network.torque_terms` differentiated along its ports' change."""
    change = _torque_change_function(net, i).map(problem.options.grid)
    return [(family, index, tol * change(ca.horzcat(*arm_i).T, ca.horzcat(*d_i).T, darm, dd, p["k"], p["F0"], x0).T)
            for family, index, dd, darm, tol in columns]


def port_changes(rows: _Rows, p: _Vars, problem: Problem, i: int, poses: list) -> list:
    """The change per millimetre of each placed number of joint ``i``'s mechanisms and of a
    uniform offset of each of their profiles (:func:`_band_columns`) of the joint's ports'
    displacements and moment arms at its grid angles. Per millimetre of each, the poses'
    change at the grid angles and at the reference angle and the change of the wrapped lengths
    at fixed ends are lifted variables tied by linear rows (:func:`_pose_changes`); the ports'
    change follows (:func:`cadcam.mechanisms.base.port_change_function`).

    A mechanism with closure rows (a cable of constant length, whose poses at every angle hang
    on the lengths wound from its anchors) is left out: there the change of every pose hangs on
    each profile's whole coefficient vector through those lengths, and the exact Hessian of its
    rows grows too large to build.

    Returns
    -------
    list
        Per column: (family, index, dd, darm, tolerance [mm]) with ``dd`` and ``darm`` [m/mm]
        (the joint's ports × grid angles).
    """
    n, order = problem.options.grid, friction_order(problem.options.quadrature_order)
    own = [u for u, mech in enumerate(problem.mechanisms) if mech.joint == i]
    first_port = [int(a) for a in np.cumsum([0] + [len(problem.mechanisms[u].ports) for u in own])]
    columns = []
    for slot, u in enumerate(own):
        mech, pose, s = problem.mechanisms[u], poses[u], poses[u].s
        if mech.closure_rows:
            continue
        ports = _apart(problem.options,
                       port_change_function(mech.structure(), problem.torque_model, order, "closed-form"), n)
        for family, index, label, dc, dq, tol in _band_columns(p, problem, u):
            dz, dz_ref, dW, dW_ref = _pose_changes(rows, problem, u, pose, label, dc, dq)
            dd, darm = ports(s.theta.T, s.z, s.ref, pose.wrapped, ca.repmat(pose.wound_ref, 1, n) + pose.wrapped,
                             s.c, s.q, dz, dz_ref, dW, dW_ref, dc, dq)
            dd_i, darm_i = ca.MX.zeros(first_port[-1], n), ca.MX.zeros(first_port[-1], n)
            own_ports = slice(first_port[slot], first_port[slot + 1])  # the others' do not change
            dd_i[own_ports, :], darm_i[own_ports, :] = dd, darm
            columns.append((family, index, dd_i, darm_i, tol))
    return columns


def _band_columns(p: _Vars, problem: Problem, u: int) -> list:
    """Mechanism ``u``'s tolerances other than its springs', per millimetre: (family, index,
    label, dc, dq, tolerance [mm]) of each placed number (``bq``, index mechanism and name;
    steps ``dq{u}`` per mm of misplacement, :meth:`cadcam.mechanisms.base.Mechanism.placement_steps`)
    and of a uniform offset of each of its profiles by a millimetre (``bf``, index profile)."""
    mech = problem.mechanisms[u]
    nc, nq = sum(b.size for b in mech.bases), len(mech.parameters)
    first = problem.profile_slices()[u].start
    columns = [("bq", (u, quantity.name), quantity.name, ca.DM.zeros(nc), p[f"dq{u}"][r] * ca.DM.eye(nq)[:, r],
                p["tol"][0]) for r, quantity in enumerate(mech.parameters) if quantity.placed]
    for k in range(len(mech.bases)):
        offset = np.concatenate([b.offset(LENGTH_SCALE if kk == k else 0.0) for kk, b in enumerate(mech.bases)])
        columns.append(("bf", (first + k,), f"profile{first + k + 1}", ca.DM(offset), ca.DM.zeros(nq), p["tol"][1]))
    return columns


def _pose_changes(rows: _Rows, problem: Problem, u: int, pose: _Pose, label: str, dc, dq):
    """Mechanism ``u``'s change per millimetre of a tolerance (``label`` names its blocks) that
    changes its coefficients by ``dc`` and its numbers by ``dq`` (per mm): its unknowns' at the
    grid angles ``dz`` (unknowns × n) and at its reference angle ``dz_ref``, lifted variables
    tied by the linearised
    residuals (:func:`cadcam.mechanisms.base.pose_change_function`), and its wound lengths'
    own change there, ``dW`` (profiles × n) and ``dW_ref`` [m]: at the reference angle by
    their quadrature, on from there by the change of the wrapped lengths at fixed ends, lifted
    and summed segment by segment like the lengths themselves (Johnston2023 Eq. 10, 14)."""
    mech, s, n, L = problem.mechanisms[u], pose.s, problem.options.grid, LENGTH_SCALE
    structure, nz = mech.structure(), len(mech.unknowns)
    dW_ref = wound_change_function(structure)(s.ref, s.c, dc)
    dW = ca.repmat(dW_ref, 1, n)
    if np.any(np.asarray(dc)):
        order = problem.options.quadrature_order
        for k, (b, ck, dck) in enumerate(zip(mech.bases, split_coefficients(mech.bases, s.c),
                                             split_coefficients(mech.bases, dc))):
            if np.any(np.asarray(dck)):  # the profile that is offset: its wrapped length grows
                seg = segment_lengths(b, order, _first_segment_order(problem, mech), s.ref[k], s.z[k, :].T, ck, dck)
                start = length_change_function(b, _start_order(problem)).map(n)(s.ref[k], s.z[k, :], ck, dck).T
                dl = rows.tie("bl", lambda v: (v - ca.vertcat(0, v[:n - 1]) - seg) / L, start, L, u, label)
                dW[k, :] += dl.T
    scale = ca.DM([L if unit == "m" else 1.0 for unit in mech.unknown_units])  # per mm: mm/mm or rad/mm
    residual = ca.DM([L if unit == "m" else 1.0 for unit in mech.residual_units])
    change = _apart(problem.options, pose_change_function(structure))
    ref_angle = mech.reference_angle
    at_ref = (ref_angle, s.ref, pose.wound_ref, s.c, s.q)
    dz_ref = rows.tie("bzr", lambda v: change(*at_ref, v, dW_ref, dc, dq)[0] / residual,
                      change(*at_ref, ca.MX.zeros(nz), dW_ref, dc, dq)[1], scale, u, label)
    grid = _apart(problem.options, pose_change_function(structure), n)
    at_grid = (s.theta.T, s.z, ca.repmat(pose.wound_ref, 1, n) + pose.wrapped, s.c, s.q)
    dz = rows.tie("bz", lambda v: ca.vec(grid(*at_grid, ca.reshape(v, nz, n), dW, dc, dq)[0] / ca.repmat(residual, 1, n)),
                  ca.vec(grid(*at_grid, ca.MX.zeros(nz, n), dW, dc, dq)[1]), ca.repmat(scale, n, 1), u, label)
    return ca.reshape(dz, nz, n), dz_ref, dW, dW_ref


def _torque_change_function(net, i: int) -> ca.Function:
    """``change(arm, d, darm, dd, k, F0, x0) -> dtau``: the first-order change of joint ``i``'s
    torque [N·m] when its ports' moment arms and displacements (its port order) change by
    ``darm`` and ``dd``, for a joint whose springs act on it alone: τ_i of
    :meth:`cadcam.physics.springs.Network.torque_terms` differentiated."""
    P = len(net.joint_ports[i])
    arm, d, darm, dd = (ca.SX.sym(name, P) for name in ("arm", "d", "darm", "dd"))
    k, F0, x0 = (ca.SX.sym(name, net.S) for name in ("k", "F0", "x0"))
    shares = {(j, i): net.term(j, i, d) for j in range(net.S) if i in net.joints_of(j)}
    tau, _ = net.torque_terms(i, k, F0, x0, arm, shares)
    dtau = ca.jtimes(tau, ca.vertcat(arm, d), ca.vertcat(darm, dd))
    return ca.Function("torque_change", [arm, d, darm, dd, k, F0, x0], [dtau],
                       ["arm", "d", "darm", "dd", "k", "F0", "x0"], ["dtau"])


def _output_law_terms(rows: _Rows, p: _Vars, minimax: bool, outputs: list, w: list) -> list:
    """The objective's term of each mechanism's output law x_d(θ), given ``outputs`` (mechanism,
    its joint, its output unknown on the grid) and the joints' trapezoidal weights ``w``:
    ∫(x − x_d)², or with ``minimax`` max |x − x_d| as an epigraph variable (mm in the NLP).

    Returns
    -------
    list of (casadi.MX, casadi.MX)
        Per output law, its term in SI units and its term scaled by the law's own parameter.
    """
    # scaled by its own parameter so that it weighs as much as a torque term whatever the units
    L = LENGTH_SCALE
    out = []
    for u, i, xu in outputs:
        err = (xu - p[f"xd{u}"]) / L
        if minimax:
            t = rows.epigraph("to", err, u)
            out.append((L * t, p[f"xs{u}"] * t))
        else:
            sq = ca.dot(w[i], err * err)
            out.append((L**2 * sq, p[f"xs{u}"] * sq))
    return out
