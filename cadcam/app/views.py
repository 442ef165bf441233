"""What the design page's live view draws of a design, as columns of numbers, without the page:
the torque against its target with the error, the tolerance and friction bands
(:func:`torque_columns`), a mechanism at one joint angle (:func:`pose_columns`: outline, cable,
springs at their length, idlers, the link and its mass), the box that view keeps
(:func:`view_box`), the spring ends a designer drags (:func:`spring_ends`) and the lines above
the plots (:func:`verdict_lines`).

:mod:`cadcam.app.live` puts each set of columns in a Bokeh ``ColumnDataSource``, whose data a new
design replaces in place. Lengths are in millimetres, angles in degrees and torques in
newton-millimetres, as the figures draw them (:mod:`cadcam.outputs.plots`); the data stay SI.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from matplotlib.colors import to_hex

from ..outputs.plots import PROFILE_COLOURS, mechanism_poses
from ..problem import Problem
from ..result import Result
from ..verify.evaluate import Evaluation
from ..units import MM

#: Poses spread over the range whose drawings the view of a mechanism holds (:func:`view_box`), and
#: whose room a spring without a free length is drawn to fit at every angle.
BOX_POSES = 3
#: The margin around the drawings in a mechanism's view, as a share of its larger side.
BOX_MARGIN = 0.08
#: The profiles' colours (the figures', :data:`cadcam.outputs.plots.PROFILE_COLOURS`), as a browser names them.
COLOURS = tuple(to_hex(c) for c in PROFILE_COLOURS)
#: Points of a profile's outline in the view (the browser's screen shows no more; fewer to send).
OUTLINE_POINTS = 400

#: The columns of a joint's torque source (:func:`torque_columns`).
TORQUE_COLUMNS = ("theta", "tau", "tau_d", "error", "band_lo", "band_hi", "friction_lo", "friction_hi")
#: The sources of a mechanism's view and their columns (:func:`pose_columns`).
POSE_COLUMNS = {
    "outline": ("xs", "ys", "colour"),  # each profile over its designed range
    "wound": ("xs", "ys", "colour"),  # the part of each profile the cable lies on
    "cable": ("xs", "ys"),  # the free spans and the cable on idlers
    "springs": ("xs", "ys"),  # each spring's zigzag, free length plus extension
    "idlers": ("x", "y", "r"),
    "points": ("x", "y"),  # point idlers and spring ends
    "anchors": ("x", "y"),
    "contacts": ("x", "y"),
    "binding": ("x", "y"),  # where ρ or the convexity margin sits at its limit
    "arm": ("xs", "ys"),
    "mass": ("x", "y", "words"),
}


class Box(NamedTuple):
    """A mechanism view's corners [mm]."""

    lo: tuple[float, float]
    hi: tuple[float, float]


class SpringEnd(NamedTuple):
    """A spring end a designer may drag on a mechanism's view: its field (``mechanisms.1.spring_end``)
    and where it is drawn now [mm]."""

    key: str
    x: float
    y: float


def joint_line(ev: Evaluation, i: int) -> np.ndarray:
    """The indices into ``ev``'s tensor grid of joint ``i``'s angles, every other joint at the
    first angle of its grid (the whole grid for one joint)."""
    m, n = len(ev.problem.joints), ev.grid
    along = tuple(np.arange(n) if c == i else np.zeros(n, dtype=int) for c in range(m))
    return np.ravel_multi_index(along, (n,) * m)


def torque_columns(result: Result, bands: bool = True) -> list[dict[str, np.ndarray]]:
    """Per joint, along its angle (:func:`joint_line`): θ [deg], τ, τ_d and τ − τ_d [N·mm],
    the tolerance band τ ± w and the friction band [τ⁻, τ⁺] [N·mm] (each τ itself where the
    design has none, or where ``bands`` is False: a design shown while a slider moves). Empty
    where the design has no springs, so no torque."""
    if not result.problem.springs:
        return []
    ev = result.evaluation
    band = result.band if bands else None
    friction = result.friction if bands else None
    out = []
    for i in range(len(result.problem.joints)):
        at = joint_line(ev, i)
        tau = MM * ev.tau[i][at]
        half = MM * band.half_width[i][at] if band is not None else np.zeros_like(tau)
        lo, hi = (MM * friction.minus[i][at], MM * friction.plus[i][at]) if friction is not None else (tau, tau)
        out.append(dict(zip(TORQUE_COLUMNS, (np.degrees(ev.theta[i][at]), tau, MM * ev.tau_d[i][at],
                                             tau - MM * ev.tau_d[i][at], tau - half, tau + half, lo, hi))))
    return out


def accepted_error(problem: Problem, i: int) -> float | None:
    """Joint ``i``'s accepted |τ − τ_d| [N·mm] (its acceptance's ``max_abs_error``), or None."""
    limit = problem.joints[i].limits.get("max_abs_error")
    return None if limit is None else MM * limit


def torque_title(result: Result, i: int) -> str:
    """The torque plot's title for joint ``i``: its name, RMSE and largest error."""
    m = result.evaluation.metrics
    return (f"{result.problem.joints[i].name}: RMSE {MM * m.rmse[i]:.3g} N·mm, "
            f"max |τ − τ_d| {MM * m.max_abs_error[i]:.3g} N·mm")


def pose_columns(ev: Evaluation, u: int, k: int) -> dict[str, dict]:
    """What mechanism ``u``'s view draws at index ``k`` of its joint grid
    (:func:`cadcam.outputs.plots.mechanism_poses`), as the columns of :data:`POSE_COLUMNS` [mm]:
    a curve's coordinates (``xs``, ``ys``) an array each, a point's one number each."""
    k = int(np.clip(k, 0, ev.units[u].theta.size - 1))
    (pose,), _, _ = mechanism_poses(ev, u, [k], OUTLINE_POINTS, fit_poses=BOX_POSES)
    _, profiles, spans, circles, wraps, arms, springs = pose
    out: dict[str, dict[str, list]] = {name: {c: [] for c in columns} for name, columns in POSE_COLUMNS.items()}
    for p, (x, y, wound, contact, anchor, bound) in enumerate(profiles):
        colour = COLOURS[p % len(COLOURS)]
        _append(out["outline"], xs=x, ys=y, colour=colour)
        _append(out["wound"], xs=x[wound], ys=y[wound], colour=colour)
        _append(out["anchors"], x=anchor[0], y=anchor[1])
        _append(out["contacts"], x=contact[0], y=contact[1])
        for _, point in bound:
            _append(out["binding"], x=point[0], y=point[1])
    for a, b in spans:
        _append(out["cable"], xs=np.array([a[0], b[0]]), ys=np.array([a[1], b[1]]))
    for x, y in wraps:
        _append(out["cable"], xs=x, ys=y)
    for points, _ in springs:
        _append(out["springs"], xs=points[:, 0], ys=points[:, 1])
    for centre, r in circles:
        if r > 0:
            _append(out["idlers"], x=centre[0], y=centre[1], r=r)
        else:
            _append(out["points"], x=centre[0], y=centre[1])
    for end, words in arms:
        _append(out["arm"], xs=np.array([0.0, end[0]]), ys=np.array([0.0, end[1]]))
        _append(out["mass"], x=end[0], y=end[1], words=words)
    return {name: {c: _column(c, values) for c, values in columns.items()} for name, columns in out.items()}


def _append(columns: dict[str, list], **row) -> None:
    for c, v in row.items():
        columns[c].append(v)


def _column(name: str, values: list):
    """A column as a Bokeh source takes it: curves a list of float arrays, numbers a float
    array, words a list."""
    if name in ("xs", "ys"):
        return [np.asarray(v, dtype=float) for v in values]
    if name in ("colour", "words"):
        return list(values)
    return np.asarray(values, dtype=float)


def view_box(ev: Evaluation, u: int) -> Box:
    """The box [mm] that holds mechanism ``u`` drawn at :data:`BOX_POSES` angles over its range
    (:func:`cadcam.outputs.plots.mechanism_poses`), a margin around it, made square: the view
    keeps it while the joint angle and the design change, so that the part does not jump."""
    n = ev.units[u].theta.size
    _, lo, hi = mechanism_poses(ev, u, np.unique(np.linspace(0, n - 1, BOX_POSES).round().astype(int)),
                                OUTLINE_POINTS, fit_poses=BOX_POSES)
    centre, half = (lo + hi) / 2, (1 + BOX_MARGIN) * float(np.max(hi - lo)) / 2
    return Box((float(centre[0] - half), float(centre[1] - half)), (float(centre[0] + half), float(centre[1] + half)))


def limit_circles(problem: Problem, u: int) -> dict[str, list]:
    """The ρ_min and ρ_max circles [mm] about mechanism ``u``'s joint axis."""
    radii = sorted({MM * r for p in problem.mechanisms[u].profiles for r in (p.rho_min, p.rho_max)})
    return {"x": [0.0] * len(radii), "y": [0.0] * len(radii), "r": radii}


def spring_ends(problem: Problem, u: int, theta: float, keys) -> list[SpringEnd]:
    """The spring end of mechanism ``u`` a designer may drag at joint angle ``theta`` [rad]:
    where the mechanism's ``spring_end`` puts it [mm], where the form has its field
    (``mechanisms.N.spring_end`` among ``keys``); none for a mechanism without one."""
    mech, key = problem.mechanisms[u], f"mechanisms.{u + 1}.spring_end"
    if key not in keys or not callable(getattr(mech, "spring_end", None)):
        return []
    x, y = (MM * float(v) for v in mech.spring_end(theta))
    return [SpringEnd(key, x, y)]


def dragged_end(problem: Problem, u: int, theta: float, x: float, y: float) -> list[float]:
    """The value [m] of mechanism ``u``'s ``spring_end`` field that puts its spring end at
    (``x``, ``y``) [mm] at joint angle ``theta`` [rad]: the end turns about the joint axis with
    the joint (or stays), so the point dragged is turned back by the angle it has turned there.
    Rounded to 0.1 mm, as a hand places it."""
    mech = problem.mechanisms[u]
    now, given = (np.asarray(mech.spring_end(t), dtype=float) for t in (theta, 0.0))  # at θ = 0: the field's value
    turned = math.atan2(now[1], now[0]) - math.atan2(given[1], given[0])
    c, s = math.cos(-turned), math.sin(-turned)
    return [round((c * x - s * y) / MM, 4), round((s * x + c * y) / MM, 4)]


def legend(problem: Problem, ends: bool) -> list[tuple[str, str]]:
    """The key of the mechanisms' views: (mark, words) of each thing drawn, in the words of the
    mechanisms' pictures (each joined with " / " where kinds differ); the spring end's handle
    where ``ends``."""
    pictures = list(dict.fromkeys(m.picture for m in problem.mechanisms))

    def words(name: str) -> str:
        return " / ".join(dict.fromkeys(w for w in (getattr(p, name) for p in pictures) if w))

    wound = words("wound")
    return [("outline", "profile" + (f" (thick: {wound})" if wound else "")), ("cable", words("free")),
            ("spring", "spring: free length + extension"), ("idler", words("circle")),
            ("anchor", words("anchor")), ("contact", words("contact")), ("binding", "a limit binds"),
            *([("handle", "spring end: drag it")] if ends else [])]


__all__ = ["BOX_POSES", "COLOURS", "Box", "POSE_COLUMNS", "SpringEnd", "TORQUE_COLUMNS", "accepted_error", "dragged_end",
           "joint_line", "legend", "limit_circles", "pose_columns", "spring_ends", "torque_columns", "torque_title",
           "view_box"]
