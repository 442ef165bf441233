"""The robust objective (``[solver] objective = "robust"``): a design whose builds, each set back
by its adjustment, are best — not the design itself.

A scenario is one build: every part drawn within its ``[tolerances]`` as the simulated builds
are (:func:`cadcam.variation.draws` over :func:`cadcam.variation.directions`, from a stream of
its own seeded by ``[builds] seed``; the friction coefficients, which move no parameter but
the friction band's centre, are left to the simulated builds), so that its parameters are the
design's moved by a step
Δ_s of p = [c; k; x₀; F0; q], and set by its own settings of the ``[adjustment]``
(:func:`cadcam.variation.settings`), variables of the NLP within their ranges, so that each
build is set where it is best for it. Its torque is the network's
(:meth:`cadcam.physics.springs.Network.torque_terms`) with its springs' rates, preloads and
pre-extensions (a screw's setting among them) exact, plus its first-order change along its
geometry's steps — its placed numbers (a slot's setting among them) and its profiles' offsets —
at those springs (:func:`cadcam.solve.objective._torque_change_function` along the changes per
millimetre the tolerance band's rows lift, :func:`cadcam.solve.objective.port_changes`), plus
½ T Δ² along a slot, T its curvature from the design at the slot's ends: the model the
simulated builds evaluate (:class:`cadcam.verify.builds.BuildModel`), every product of a
spring's parameter with another deviation kept.

With E_0 the design's own largest |τ − τ_d| over its goal joints' grids, unadjusted, and E_s
build s's after its settings, each a share of its joint's scale (epigraph variables), the
objective is the mean of the worst ``tail`` share of these S + 1, by the epigraph of their
conditional value at risk (Rockafellar and Uryasev):

    min  η + 1/(tail·(S + 1)) Σ_s u_s,   u_s ≥ E_s − η,  u_s ≥ 0,

a smooth stand-in for a high percentile of the builds' error after adjusting; the design
itself, a member, stays as good as its builds' tail. The simulated builds then re-check it on
ten thousand others. Where a screw tensions a spring, the spring's extension keeps the screw's
travel from its ends (slack, and :meth:`cadcam.problem.Problem.extension_limit`), the range
being a limit of the design.
"""
from __future__ import annotations

import json

import casadi as ca
import numpy as np

from .blocks import LENGTH_SCALE
from .objective import _torque_change_function, port_changes
from .rows import _departure_rows, _limit_rows, _MechanismSymbols, _travel, _wrapped_length_rows
from .variables import _nonnegative, _Rows, _Vars
from ..designs import Design
from ..errors import SpecError
from ..physics.wrap import length_function
from ..problem import Problem
from ..variation import Layout, directions, draws, joint_scale, settings

#: The unit of the scenarios' errors in the NLP [share of a joint's scale]: a percent, so that
#: the epigraph variables of a balancer's builds are O(1).
ROBUST_UNIT = 0.01
#: The stream of the scenarios' draws beside ``[builds] seed``: not the simulated builds', so that
#: those re-check the design on builds it was not designed for.
SCENARIO_STREAM = 1
#: A slot's ends: the sign of its step and the name of their blocks.
ENDS = ((1.0, "plus"), (-1.0, "minus"))


def robust(problem: Problem) -> bool:
    """Whether ``problem`` is designed for its builds (``[solver] objective = "robust"``)."""
    return problem.options.objective == "robust"


def check_robust(problem: Problem) -> None:
    """SpecError in one line where the robust objective cannot design ``problem``: it needs
    springs, each acting on one joint (a joint's torque on its own angle: one grid per joint
    holds a build's error), and mechanisms whose poses do not hang on a constant cable length
    (whose change the band's rows leave out, :func:`cadcam.solve.objective.port_changes`)."""
    word = "solver.objective = 'robust'"
    if not problem.springs:
        raise SpecError(f"{word} designs for the builds of a design with springs; this one has none")
    net = problem.network()
    coupled = [j + 1 for j in range(net.S) if len(net.joints_of(j)) > 1]
    if coupled:
        raise SpecError(f"{word} needs joint torques that each depend on their own joint's angle; spring "
                        f"{coupled[0]} joins several joints: use 'least_squares'")
    closed = [mech.name for mech in problem.mechanisms if mech.closure_rows]
    if closed:
        raise SpecError(f"{word} cannot design {closed[0]!r}, whose poses hang on a constant cable length: "
                        "use 'least_squares'")


def scenario_layout(problem: Problem) -> tuple[Layout, list]:
    """The layout of p for ``problem``'s profiles (its values are not used) and the adjustment's
    settings (:func:`cadcam.variation.settings`)."""
    bases = [pr.basis for pr in problem.profiles]
    zero = Design(bases, [np.zeros(b.size) for b in bases], np.zeros(len(problem.springs)))
    layout = Layout(problem, zero)
    return layout, settings(problem, layout)


def scenario_steps(problem: Problem, layout: Layout) -> np.ndarray:
    """The scenarios' steps Δ_s of p (P × S): ``[builds] scenarios`` draws, as
    ``[builds] distribution`` says, over every tolerance's steps."""
    D = np.concatenate(list(directions(problem, [pr.basis for pr in problem.profiles], layout)[0].values()),
                       axis=1)
    options = problem.build_options
    return D @ draws((options["seed"], SCENARIO_STREAM), options["scenarios"], D.shape[1], options["distribution"])


def structure(problem: Problem) -> str:
    """What a built robust NLP depends on beyond its parameters (its scenarios and which
    parameters its settings move; empty for another objective), for
    :func:`cadcam.solve.builds.structure_key`."""
    if not robust(problem):
        return ""
    layout, chosen = scenario_layout(problem)
    return json.dumps([problem.build_options["scenarios"], [[s.kind, s.index] for s in chosen],
                       [joint.tracking_weight > 0 and joint.target.kind != "none" for joint in problem.joints]])


def parameter_blocks(p: _Vars, problem: Problem) -> None:
    """Add the robust objective's parameters to ``p``: the scenarios' steps, the settings'
    ranges, each joint's weight and the tail's, and the tolerances' steps the band's rows read
    where no joint weighs its band (:func:`cadcam.solve.variables._parameter_blocks`)."""
    layout, chosen = scenario_layout(problem)
    if "tol" not in p.blocks:
        p.add("dk", len(problem.springs))
        p.add("dF", len(problem.springs))
        for u, mech in enumerate(problem.mechanisms):
            p.add("dq", len(mech.parameter_names), u)
        p.add("tol", 2)
    p.add("rsteps", layout.size * problem.build_options["scenarios"])
    p.add("rbound", len(chosen))
    p.add("rw", len(problem.joints))
    p.add("rtail", 1)


def put_parameters(p: _Vars, vec: np.ndarray, problem: Problem, targets: list) -> None:
    """Put the robust objective's numbers into ``vec``, given each joint's target samples
    ``targets`` on the design grid."""
    layout, chosen = scenario_layout(problem)
    p.put(vec, "rsteps", scenario_steps(problem, layout).ravel(order="F"))
    p.put(vec, "rbound", [s.bound for s in chosen])
    weights = [1.0 / joint_scale(problem, i, td) if _goal(problem, i) else 0.0 for i, td in enumerate(targets)]
    p.put(vec, "rw", weights)
    options = problem.build_options
    p.put(vec, "rtail", 1.0 / ((options["scenarios"] + 1) * options["tail"]))  # the design is one more


def _goal(problem: Problem, i: int) -> bool:
    """Whether joint ``i`` has a torque goal the builds are judged on."""
    joint = problem.joints[i]
    return joint.tracking_weight > 0 and joint.target.kind != "none"


def robust_rows(rows: _Rows, p: _Vars, problem: Problem, changes: dict, poses: list, x0, e: dict, d: list,
                arm: list, terms: list):
    """The scenarios' variables and rows (see the module), given each joint's port changes per
    unit of its geometry's tolerances (``changes``, by joint: :func:`cadcam.solve.objective.port_changes`,
    made here where the band has not made them), the mechanisms' ``poses``, the pre-extensions
    ``x0`` [m], the spring shares ``e``, per joint its ports' displacements ``d`` and moment
    arms ``arm`` [m] and its torque ``terms`` (:func:`cadcam.solve.rows._spring_network_rows`).

    Returns
    -------
    errors : casadi.MX
        The weighted torque errors at every goal joint's grid angles (rows) in units of
        :data:`ROBUST_UNIT`: the design's, unadjusted, then each scenario's (columns).
    term : casadi.MX
        The objective's term, the tail's mean of the largest errors [:data:`ROBUST_UNIT`].
    """
    check_robust(problem)
    layout, chosen = scenario_layout(problem)
    count, net = problem.build_options["scenarios"], problem.network()
    moved = ca.reshape(p["rsteps"], layout.size, count)
    if chosen:  # each scenario's settings, shares of their ranges
        alpha = ca.reshape(rows.v.add("ra", len(chosen) * count), len(chosen), count)
        pick = ca.DM.zeros(layout.size, len(chosen))
        for a, s in enumerate(chosen):
            pick[s.index, a] = 1.0
        moved = moved + ca.mtimes(pick, ca.diag(p["rbound"]) @ alpha)
    _screw_range_rows(rows, problem, chosen, x0, e)
    goals = [i for i in range(len(problem.joints)) if _goal(problem, i)]
    lifted = {i: _lifted_ports(rows, p, problem, changes, poses, d, arm, i) for i in goals}
    bends = _slot_curvatures(rows, p, problem, layout, poses, chosen, x0, d, arm, terms)
    changes_of = {i: _torque_change_function(net, i).map(problem.options.grid) for i in goals}
    _, k_part, x0_part, F0_part, _ = _cut(layout)
    errors = [ca.vertcat(*[_error(p, i, terms[i][0]) for i in goals])]
    for s in range(count):
        k, x0_s, F0 = p["k"] + moved[k_part, s], x0 + moved[x0_part, s], p["F0"] + moved[F0_part, s]
        column = []
        for i in goals:
            (d_i, arm_i), columns = lifted[i]
            rows_of = [[m[r, :].T for r in range(m.shape[0])] for m in (d_i, arm_i)]
            shares = net.shares([rows_of[0] if c == i else d_c for c, d_c in enumerate(d)])
            dd, darm = _geometry_step(p, problem, layout, columns, moved[:, s])
            tau = (net.torque_terms(i, k, F0, x0_s, rows_of[1], shares)[0]
                   + changes_of[i](arm_i, d_i, darm, dd, k, F0, x0_s).T)
            for index, (joint, T) in bends.items():
                if joint == i:  # along a slot, to second order as the simulated builds take it
                    tau = tau + 0.5 * T * moved[index, s] ** 2
            column.append(_error(p, i, tau))
        errors.append(ca.vertcat(*column))
    members = len(errors)
    largest = rows.v.add("rmax", members)
    for s, err in enumerate(errors):
        rows.constrain(ca.vertcat(largest[s] - err, largest[s] + err), _nonnegative)
    level, excess = rows.v.add("rvar", 1), rows.v.add("rexc", members)
    rows.constrain(excess - largest + level, _nonnegative)
    return ca.horzcat(*errors), level + p["rtail"] * ca.sum1(excess)


def _slot_curvatures(rows: _Rows, p: _Vars, problem: Problem, layout: Layout, poses: list, chosen: list, x0,
                     d: list, arm: list, terms: list) -> dict:
    """Each slot's ends as a limit of the design and its torque's curvature along it.

    At either end of each slot's range (its mechanism's number moved by ± its range, nothing
    else), the mechanism's departure unknowns (``rz``, ``rref``: within their bounds, a cable
    still wound) and wrapped lengths (``rlen``) are variables tied by the nominal design's rows,
    with its own limits (:func:`cadcam.solve.rows._limit_rows`) and its joint's springs within
    their travel. Returns, by the slot's index in p, its joint and the torque's curvature there
    T = (τ₊ + τ₋ − 2τ)/h² [N·m per unit²] at the joint's grid angles, h the range: what
    :func:`cadcam.verify.builds.slot_curvature` takes from the design re-evaluated at the ends."""
    net, n, out = problem.network(), problem.options.grid, {}
    for a, setting in enumerate(chosen):
        if setting.screw:
            continue
        u = setting.number - 1
        mech, sl = problem.mechanisms[u], problem.profile_slices()[u]
        r = setting.index - int(layout.start["q"]) - _first_parameter(problem, u)
        first_port = sum(len(other.ports) for other in problem.mechanisms[:u] if other.joint == mech.joint)
        ends = []
        for sign, label in ENDS:
            q = poses[u].s.q + sign * p["rbound"][a] * ca.DM.eye(len(mech.parameters))[:, r]
            z = ca.vertcat(*[rows.v.add("rz", n, u, name, label).T for name in mech.unknowns])
            own = _MechanismSymbols(poses[u].s.c, z, rows.v.add("rref", len(mech.unknowns), u, label),
                                    poses[u].s.theta, q)
            wrapped = _wrapped_length_rows(rows, problem, mech, sl.start, own, "rlen", (label,))
            du, au = _departure_rows(rows, problem, mech, own, wrapped, ca.MX.zeros(len(mech.bases)))
            if mech.limits:
                _limit_rows(rows, n, mech, own, au)
            d_end, arm_end = list(d), list(arm)
            d_end[mech.joint] = _replaced(d[mech.joint], du, first_port)
            arm_end[mech.joint] = _replaced(arm[mech.joint], au, first_port)
            shares = net.shares(d_end)
            for j in range(net.S):
                if mech.joint in net.joints_of(j):
                    rows.constrain((x0[j] + shares[j, mech.joint]) / LENGTH_SCALE, lambda pr, j=j: _travel(pr, j))
            ends.append(net.torque_terms(mech.joint, p["k"], p["F0"], x0, arm_end[mech.joint], shares)[0])
        out[setting.index] = (mech.joint, (ends[0] + ends[1] - 2 * terms[mech.joint][0]) / p["rbound"][a] ** 2)
    return out


def _replaced(values: list, rows_of, first: int) -> list:
    """``values`` (a joint's port rows) with the rows of ``rows_of`` (ports × angles) in place
    from ``first`` on."""
    out = list(values)
    for r in range(rows_of.shape[0]):
        out[first + r] = rows_of[r, :].T
    return out


def _first_parameter(problem: Problem, u: int) -> int:
    """Where mechanism ``u``'s numbers start within q."""
    return sum(len(mech.parameters) for mech in problem.mechanisms[:u])


def _error(p: _Vars, i: int, tau):
    """Joint ``i``'s torque error at its grid angles, a share of its scale, in units of
    :data:`ROBUST_UNIT`."""
    return p["rw"][i] * (tau - p[f"td{i}"]) / ROBUST_UNIT


def _lifted_ports(rows: _Rows, p: _Vars, problem: Problem, changes: dict, poses: list, d: list, arm: list,
                  i: int) -> tuple:
    """Joint ``i``'s port displacements and moment arms [m] (ports × grid angles), and their
    changes per millimetre of each geometry column (the tolerance band's, made here where the
    band has not made them), as lifted variables: every scenario's torque is then a polynomial
    of a few of them, whose second derivatives cost nothing to build, instead of a copy of the
    poses' graph."""
    if i not in changes:
        changes[i] = port_changes(rows, p, problem, i, poses)
    L = LENGTH_SCALE
    shape = (len(d[i]), problem.options.grid)
    ports = [ca.reshape(rows.lift(family, ca.vec(ca.horzcat(*values).T), L, i), *shape)
             for family, values in (("rd", d[i]), ("rarm", arm[i]))]
    columns = [(family, index, *(ca.reshape(rows.lift(name, ca.vec(value), L, i, family, *index), *shape)
                                 for name, value in (("rdd", dd), ("rdarm", darm))))
               for family, index, dd, darm, _ in changes[i]]
    return ports, columns


def _geometry_step(p: _Vars, problem: Problem, layout: Layout, columns: list, step) -> tuple:
    """The change of a joint's port displacements and moment arms [m] (ports × grid angles) to
    first order in a build's ``step`` of p, through its geometry's ``columns``
    (:func:`_lifted_ports`)."""
    dd, darm = 0, 0
    for family, index, dd_g, darm_g in columns:
        amount = _column_amount(p, problem, layout, family, index, step)
        dd, darm = dd + amount * dd_g, darm + amount * darm_g
    return dd, darm


def _column_amount(p: _Vars, problem: Problem, layout: Layout, family: str, index: tuple, step):
    """How many millimetres of a geometry column (:func:`cadcam.solve.objective._band_columns`:
    ``bq`` a placed number of a mechanism, ``bf`` a uniform offset of a profile) the step of p
    ``step`` takes: the number's change over its step per millimetre, or the coefficients'
    projection onto the profile's offset."""
    if family == "bq":
        u, name = index
        r = problem.mechanisms[u].parameter_names.index(name)
        first = int(layout.start["q"]) + _first_parameter(problem, u)
        return step[first + r] / p[f"dq{u}"][r]
    (k,) = index
    first = int(layout.start["c"]) + sum(pr.basis.size for pr in problem.profiles[:k])
    basis = problem.profiles[k].basis
    offset = ca.DM(basis.offset(LENGTH_SCALE))  # a millimetre's
    return ca.dot(offset, step[first:first + basis.size]) / ca.dot(offset, offset)


def _cut(layout: Layout) -> list[slice]:
    """The slices of c, k, x₀, F0 and q in p."""
    ends = [*layout.start.values(), layout.size]
    return [slice(int(a), int(b)) for a, b in zip(ends[:-1], ends[1:])]


def _screw_range_rows(rows: _Rows, problem: Problem, chosen: list, x0, e: dict) -> None:
    """Where a screw tensions spring j, its extension keeps the screw's travel from slack and
    from its largest extension at every grid angle: the screw's range a limit of the design
    (what :func:`cadcam.verify.builds.screw_limits` checks)."""
    net = problem.network()
    for setting in chosen:
        if setting.screw:
            j = setting.number - 1
            (joint,) = net.joints_of(j)
            rows.constrain((x0[j] + e[j, joint]) / LENGTH_SCALE, lambda pr, j=j: (
                pr.adjustment["preload_travel"] / LENGTH_SCALE,
                (pr.extension_limit(j) - pr.adjustment["preload_travel"]) / LENGTH_SCALE))


def slot_ends(chosen: list) -> list:
    """(setting, sign, label) of each slot's ends, in the order their blocks and their start's
    samples take (:func:`_slot_curvatures`, :func:`initial_guess`)."""
    return [(setting, sign, label) for setting in chosen if not setting.screw for sign, label in ENDS]


def variable_bounds(v: _Vars, problem: Problem, lbx: np.ndarray, ubx: np.ndarray) -> None:
    """Bounds of the scenarios' variables: each setting within its range, the largest errors
    and the excesses ≥ 0, and a slot's ends' unknowns within their mechanism's bounds."""
    if "ra" in v.blocks:
        v.put(lbx, "ra", -1.0)
        v.put(ubx, "ra", 1.0)
    for name in ("rmax", "rexc"):
        v.put(lbx, name, 0.0)
    for name, (family, index) in v.families.items():
        mech = problem.mechanisms[index[0]] if family in ("rz", "rref") else None
        if family == "rz":
            lo, hi = mech.unknown_bounds[mech.unknowns.index(index[1])]
            v.put(lbx, name, lo)
            v.put(ubx, name, hi)
        elif family == "rref":
            lo, hi = np.array(mech.unknown_bounds, dtype=float).T
            v.put(lbx, name, lo)
            v.put(ubx, name, hi)


def initial_guess(v: _Vars, problem: Problem, w0: np.ndarray, ends: list, errors: ca.Function, pv,
                  order: int) -> None:
    """Start the scenarios in ``w0``: each build's settings at the middle of their ranges, each
    slot's ends from ``ends`` (per end of :func:`slot_ends`, its mechanism's samples of the
    design there, as :meth:`cadcam.solve.transcription.Transcription.initial_guess` takes them,
    wrapped lengths on ``order`` points), and the largest errors, the tail's level and the
    excesses on their definitions there (``errors``: :func:`robust_rows`'s as a function of
    (x, p))."""
    for (setting, _, label), samples in zip(slot_ends(scenario_layout(problem)[1]), ends):
        u = setting.number - 1
        mech, sl = problem.mechanisms[u], problem.profile_slices()[u]
        for r, name in enumerate(mech.unknowns):
            v.put(w0, f"rz{u}_{name}_{label}", samples.z[r])
        v.put(w0, f"rref{u}_{label}", samples.z_ref)
        for k in range(sl.start, sl.stop):
            c = v.part(w0, f"c{k}") * LENGTH_SCALE
            basis = problem.profiles[k].basis
            wrapped = length_function(basis, order).map(problem.options.grid)(
                samples.z_ref[k - sl.start], samples.z[k - sl.start], c)
            v.put(w0, f"rlen{k}_{label}", np.asarray(wrapped).ravel() / LENGTH_SCALE)
    largest = np.abs(np.asarray(errors(w0, pv))).max(axis=0)
    level = np.percentile(largest, 100 * (1 - problem.build_options["tail"]))
    v.put(w0, "rmax", largest)
    v.put(w0, "rvar", level)
    v.put(w0, "rexc", np.maximum(largest - level, 0.0))
