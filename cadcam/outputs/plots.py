"""Figures of an evaluated design, as :class:`matplotlib.figure.Figure` objects.

Every figure is built with ``matplotlib.figure.Figure`` — no pyplot, no global state — so
importing this module never selects a backend and the figures work alike in a notebook (any
backend: a Figure displays itself) and headless; each is drawn, and saved, with matplotlib's
own defaults, whatever a ``matplotlibrc`` says (:func:`cadcam.library_files.matplotlib_defaults`).
:func:`figures` returns the figures of a design run by name; :func:`save_figure` writes one as
a PNG, atomically (what ``cadcam design`` writes). Views only: no physics here; the geometry
comes from the mechanisms' drawing hooks (``world_points``, ``segments``, ``circles``).

Lengths are drawn in millimetres and torques in newton-millimetres; the data stay SI.
"""
from __future__ import annotations

import math
import re
import textwrap
from collections.abc import Callable
from dataclasses import fields, replace
from functools import partial

import matplotlib
import numpy as np
from matplotlib.artist import Artist
from matplotlib.figure import Figure
from matplotlib.lines import TICKLEFT, TICKRIGHT, Line2D
from matplotlib.patches import Circle
from matplotlib.ticker import FuncFormatter, NullLocator

from ..verify.binding import limit_state
from ..verify.evaluate import METRICS, Evaluation, output_error, output_law
from ..verify.friction import FrictionBand
from ..verify.tolerance import Band
from ..make.png import save_png
from ..library_files import matplotlib_defaults
from ..mechanisms.base import Picture, mechanism_class, mechanism_kinds
from ..physics.profile import profile_function
from ..units import MM, UM

#: Resolution of the saved PNGs [dots per inch].
DPI = 110
#: A circle centre, spring end or cable end further from the joint than this many times the
#: largest drawn radius stays outside the profile view (its direction is labelled at the edge).
REACH = 2.5

# -- colours and styles of the profile view ---------------------------------------------------
PROFILE_COLOURS = ("tab:blue", "tab:green", "tab:purple", "tab:brown")
CABLE = dict(color="tab:orange", lw=1.6)
DEPARTURE = dict(marker="o", color="tab:red", ms=6, ls="none", zorder=5)
ANCHOR = dict(marker="s", color="black", ms=5, ls="none", zorder=5)
IDLER = dict(color="0.25", lw=1.0, ls="--")
SPRING_END = dict(marker="o", mfc="white", mec="tab:purple", mew=1.5, ms=7, ls="none", zorder=5)
SPRING_COIL = dict(color="tab:purple", lw=1.2, zorder=4)
LINK = dict(color="0.55", lw=5.0, alpha=0.45, solid_capstyle="round", zorder=0)
MASS = dict(marker="o", color="0.3", ms=11, ls="none", zorder=1)
LIMIT = dict(color="0.55", lw=0.8, ls=":")
RHO_BINDING = dict(marker="x", color="crimson", ms=10, mew=2.2, ls="none", zorder=7)
CONVEXITY_BINDING = dict(marker="D", mfc="none", mec="magenta", mew=1.8, ms=12, ls="none", zorder=6)


def save_figure(fig: Figure, path, dpi: int = DPI) -> None:
    """Write ``fig`` to ``path`` as a PNG, atomically (a complete file or none;
    :func:`cadcam.make.drawing.save_png`)."""
    save_png(fig, path, dpi)


# ------------------------------------------------------------------------------------ profiles
def _pose_indices(n: int, n_poses: int) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, max(1, min(n_poses, n))).round().astype(int))


def _curve(ev: Evaluation, p: int, max_points: int = 1500):
    """φ [rad], ρ [m] of profile ``p`` over its wrapped range [0, max α] (the evaluation's dense
    scan, thinned; computed when the evaluation skipped the scan)."""
    ps = ev.profiles[p]
    if ps.phi.size:
        idx = np.unique(np.r_[np.arange(0, ps.phi.size, max(1, ps.phi.size // max_points)), ps.phi.size - 1])
        return ps.phi[idx], ps.rho[idx]
    phi = np.linspace(0.0, float(np.nanmax(ps.alpha)), 600)
    rho = np.asarray(profile_function(ev.design.bases[p]).map(phi.size)(phi, ev.design.coefficients[p])[0]).ravel()
    return phi, rho


def _rho_at(ev: Evaluation, p: int, phi) -> np.ndarray:
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    f = profile_function(ev.design.bases[p]).map(phi.size)
    return np.asarray(f(phi, ev.design.coefficients[p])[0]).ravel()


def _profile_marks(ev: Evaluation, p: int) -> list[tuple[str, float, float]]:
    """(kind, φ, ρ) of the points of profile ``p`` where a limit binds (within
    :data:`cadcam.verify.binding.RTOL`): ρ at ρ_min or ρ_max, the convexity margin at its
    required minimum."""
    ps, lim = ev.profiles[p], ev.problem.profiles[p]
    if not ps.phi.size:
        return []
    out = []
    if limit_state(ps.rho_lo - lim.rho_min, lim.rho_min):
        k = int(np.argmin(ps.rho))
        out.append(("rho", ps.phi[k], ps.rho[k]))
    if limit_state(lim.rho_max - ps.rho_hi, lim.rho_max):
        k = int(np.argmax(ps.rho))
        out.append(("rho", ps.phi[k], ps.rho[k]))
    need = ev.problem.options.convexity_epsilon * lim.rho_min ** 2
    if np.isfinite(ps.convexity_min) and limit_state(ps.convexity_min - need, lim.rho_min ** 2):
        k = int(np.argmin(ps.convexity))
        out.append(("convexity", ps.phi[k], ps.rho[k]))
    return out


def _exit_point(lo, hi, a, b):
    """Where the segment from ``a`` (inside the box [lo, hi]) towards ``b`` leaves the box."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = b - a
    t = 1.0
    for i in range(2):
        if d[i] > 0:
            t = min(t, (hi[i] - a[i]) / d[i])
        elif d[i] < 0:
            t = min(t, (lo[i] - a[i]) / d[i])
    return a + max(t, 0.0) * d


def _edge_label(ax, lo, hi, a, b, text):
    """Label, at the edge of the view, a point ``b`` [mm] outside it seen from ``a``: the text
    just inside the edge it leaves by, an arrow to where it leaves."""
    e = _exit_point(lo, hi, a, b)
    span, mid = hi - lo, (lo + hi) / 2
    towards = np.sign(mid - e)  # into the view
    if abs(e[0] - lo[0]) < 1e-9 * span[0] or abs(e[0] - hi[0]) < 1e-9 * span[0]:  # a side
        ha = "left" if e[0] < mid[0] else "right"
        xy = (e[0] + towards[0] * 0.02 * span[0], e[1] + (towards[1] or 1.0) * 0.09 * span[1])
    else:  # the top or the bottom
        ha = "center"
        xy = (np.clip(e[0], lo[0] + 0.2 * span[0], hi[0] - 0.2 * span[0]), e[1] + towards[1] * 0.09 * span[1])
    ax.annotate(text, e, xytext=xy, fontsize=7, color="0.2", ha=ha, va="center",
                arrowprops=dict(arrowstyle="->", color="0.4", lw=0.8, shrinkA=2, shrinkB=0),
                bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="0.7", lw=0.5, alpha=0.9), zorder=8)


#: A spring is drawn as a zigzag of this many coils between its two ends, as wide as this
#: fraction of its drawn free length (at most this fraction of its mechanism's largest radius,
#: not to hide the profile), with a straight hook of this fraction of its length at each end:
#: stretched, its coils spread and its width stays.
COILS = 8
COIL_WIDTH = 0.16
COIL_WIDTH_RADII = 0.5
COIL_HOOK = 0.08
#: A spring with no free length given is drawn with one equal to its travel, shortened so that
#: at its longest it fills at most this fraction of the least room it has, and not below this
#: fraction of its travel.
COIL_FILL = 0.8
COIL_LEAST = 0.2


def coil(start, direction, length: float, width: float, coils: int = COILS) -> np.ndarray:
    """The zigzag of a spring (points, (2·coils + 3) × 2) from ``start`` along the unit vector
    ``direction`` over ``length``, ``width`` wide; in the units of ``start``."""
    start, direction = np.asarray(start, float), np.asarray(direction, float)
    normal = np.array([-direction[1], direction[0]])
    hook = COIL_HOOK * length
    t = np.r_[0.0, hook + (length - 2 * hook) * np.arange(2 * coils + 1) / (2 * coils), length]
    side = np.r_[0.0, 0.0, np.tile([1.0, -1.0], coils)[:-1], 0.0, 0.0] * width / 2
    return start + t[:, None] * direction + side[:, None] * normal


def _mechanism_springs(ev: Evaluation, u: int) -> list[tuple[int, object, np.ndarray]]:
    """(j, port, x) of each spring port on mechanism ``u``: the spring's index, the port, and
    its extension [m] over the mechanism's joint grid (other joints at their first angle)."""
    problem, tensor = ev.problem, ev.tensor
    joint = problem.mechanisms[u].joint
    line = tensor.line([0] * tensor.m, joint)
    return [(j, port, np.ravel(tensor.extension(j, line)) * np.ones(tensor.n))
            for j, spring in enumerate(problem.springs) for port in spring.ports if port.mechanism == u]


def _drawn_free_length(spring, x: np.ndarray, rooms: list[float]) -> float:
    """The free length [m] a spring is drawn with: its own, else its travel, shortened to fit
    (:data:`COIL_FILL`, :data:`COIL_LEAST`) at its longest extension ``x`` in its least room."""
    if spring.free_length is not None:
        return spring.free_length
    fit = COIL_FILL * min(rooms, default=np.inf) - float(np.max(x))
    return max(min(spring.travel, fit), COIL_LEAST * spring.travel)


def _coils(ev: Evaluation, u: int, mech, poses: list[tuple[int, float, np.ndarray, np.ndarray]],
           radius: float, fitted: list[tuple] | None = None) -> list[list]:
    """The springs of mechanism ``u`` (``mech``, its largest radius ``radius`` [m]) drawn at
    each of its ``poses`` (grid index, θ, z, c), each a zigzag [mm] from the mechanism's
    ``spring_line`` over its drawn free length plus its extension there (at most its room),
    and whether that free length is the spring's own; a free length drawn to fit fits the
    rooms at the poses ``fitted`` (default: those drawn)."""
    out: list[list] = [[] for _ in poses]
    for j, port, x in _mechanism_springs(ev, u):
        spring = ev.problem.springs[j]
        lines = [(i, k, mech.spring_line(th, z, c, port.name, port.sign)) for i, (k, th, z, c) in enumerate(poses)]
        drawn = [(i, k, line) for i, k, line in lines if line is not None]
        rooms = [line[2] for line in (mech.spring_line(th, z, c, port.name, port.sign) for _, th, z, c in fitted)
                 if line is not None] if fitted is not None and spring.free_length is None else \
            [room for _, _, (_, _, room) in drawn]
        free = _drawn_free_length(spring, x, rooms)
        width = MM * min(COIL_WIDTH * free, COIL_WIDTH_RADII * radius)
        for i, k, (start, direction, room) in drawn:
            length = min(free + float(x[k]), room)
            points = coil(MM * np.asarray(start, float), direction, MM * length, width)
            out[i].append((points, spring.free_length is not None))
    return out


def _cable_to_coils(spans: list, coils: list) -> list:
    """The free cable spans [mm], each that ends where a spring's coil starts (its fixed end)
    cut back to the coil's other end: the cable pulls the spring, it does not run through it."""
    out = []
    for a, b in spans:
        ends = [points[-1] for points, _ in coils if np.allclose(points[0], b, atol=1e-6)]
        out.append((a, ends[0] if ends else b))
    return out


def _inside(lo, hi, pt) -> bool:
    return bool(np.all(pt >= lo - 1e-9) and np.all(pt <= hi + 1e-9))


def _row(ev: Evaluation, u: int, n_poses: int):
    """What the profile view draws for mechanism ``u`` at each of its ``n_poses`` poses [mm],
    and the view's box (lo, hi) [mm]."""
    return mechanism_poses(ev, u, _pose_indices(ev.units[u].theta.size, n_poses))


def mechanism_poses(ev: Evaluation, u: int, indices, points: int = 1500,
                    fit_poses: int | None = None) -> tuple[list, np.ndarray, np.ndarray]:
    """What the profile view draws for mechanism ``u`` at the poses of its joint grid's
    ``indices`` [mm] (one tuple a pose: θ, the profiles of at most about ``points`` points, the
    free cable spans, the circles, the wrapped cable, the arms and the springs), and the box
    (lo, hi) [mm] that holds them: what a page draws of one pose (:mod:`cadcam.app.live`), and
    each figure's row. A spring without a free length is drawn with one that fits the poses
    drawn, or with ``fit_poses`` that many poses spread over the grid (a view of one pose at a
    time then draws it with one free length at every angle)."""
    problem = ev.problem
    mech, unit, sl = problem.mechanisms[u], ev.units[u], problem.profile_slices()[u]
    # the drawing hooks evaluate ρ in the mechanism's own bases: give it the design's (a
    # published design typed in as monomials is drawn in its own basis, not the spec's)
    mech = replace(mech, profiles=tuple(replace(pr, basis=b) for pr, b in zip(mech.profiles, ev.design.bases[sl])))
    c = np.concatenate([np.asarray(v, dtype=float) for v in ev.design.coefficients[sl]])
    curves = {p: _curve(ev, p, points) for p in range(sl.start, sl.stop)}
    marks = {p: _profile_marks(ev, p) for p in range(sl.start, sl.stop)}
    radius = max(float(np.nanmax(rho)) for _, rho in curves.values())
    panels = []
    poses = [(int(k), float(unit.theta[k]), unit.z[:, k], c) for k in indices]
    fitted = None if fit_poses is None else [(int(k), float(unit.theta[k]), unit.z[:, k], c)
                                             for k in _pose_indices(unit.theta.size, fit_poses)]
    coils = _coils(ev, u, mech, poses, radius, fitted) if problem.springs else [[] for _ in poses]
    for k, _, _, _ in poses:
        th, z = float(unit.theta[k]), unit.z[:, k]
        prof = []
        for p, (phi, rho) in curves.items():
            kk = p - sl.start
            alpha = float(z[kk])
            x, y = (MM * np.asarray(v) for v in mech.world_points(th, phi, rho, kk))
            dep = MM * np.array(mech.world_points(th, alpha, float(_rho_at(ev, p, alpha)[0]), kk), dtype=float)
            anchor = MM * np.array(mech.world_points(th, 0.0, float(rho[0]), kk), dtype=float)
            bind = [(kind, MM * np.array(mech.world_points(th, f, r, kk), dtype=float)) for kind, f, r in marks[p]]
            wound = phi <= alpha if mech.picture.wound else np.zeros(phi.shape, dtype=bool)
            prof.append((x, y, wound, dep, anchor, bind))
        spans = _cable_to_coils([(MM * np.asarray(a, float), MM * np.asarray(b, float))
                                 for a, b in mech.segments(th, z, c)], coils[len(panels)])
        circles = [(MM * np.asarray(ctr, float), MM * float(r)) for ctr, r in mech.circles(th, z, c)]
        wraps = [(MM * np.asarray(x, float), MM * np.asarray(y, float)) for x, y in mech.wraps(th, z, c)]
        arm = mech.arm(th, problem.joints[mech.joint].target)
        arms = [] if arm is None else [(MM * np.asarray(arm[0], float), arm[1])]
        panels.append((th, prof, spans, circles, wraps, arms, coils[len(panels)]))
    # the view: the profiles and springs at every drawn pose, and what lies near them
    pts = ([np.column_stack((x, y)) for _, prof, *_ in panels for x, y, *_ in prof] + [np.zeros((1, 2))]
           + [points for *_, springs in panels for points, _ in springs])
    near = REACH * MM * radius
    for _, prof, spans, circles, *_ in panels:
        extra = [d for _, _, _, d, _, _ in prof] + [v for s in spans for v in s] + [ctr for ctr, _ in circles]
        pts += [e[None, :] for e in extra if np.all(np.isfinite(e)) and np.hypot(*e) <= near]
    allp = np.vstack(pts)
    allp = allp[np.all(np.isfinite(allp), axis=1)]
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = 0.08 * max(hi - lo) + 0.05 * MM * radius
    return panels, lo - pad, hi + pad


def profile_figure(ev: Evaluation, n_poses: int = 3) -> Figure:
    """Each mechanism (a row) at ``n_poses`` joint angles (columns) in the world frame [mm].

    Drawn: each profile over its wrapped range (thin) and thick where the cable is wrapped at
    that angle, the anchor (■), the departure point (●), the free cable spans (the mechanism's
    ``segments``) and the cable lying on idlers (its ``wraps``), idler circles with their centres (+) and point idlers / spring ends (○)
    (``circles``), the joint axis, the ρ_min and ρ_max circles (dotted), and the points where
    ρ sits at a limit (✕) or the convexity margin at its required minimum (◇), within
    :data:`cadcam.verify.binding.RTOL`. The view is scaled to the profiles, not to the idler:
    what lies further than :data:`REACH` times the largest radius is named at the edge.
    """
    rows = [_row(ev, u, n_poses) for u in range(len(ev.problem.mechanisms))]
    return _poses_figure(ev, rows, [(i, None) for i in range(max(len(panels) for panels, _, _ in rows))])


def pose_frames(ev: Evaluation, n_frames: int = 24):
    """The frames of the mechanisms moving over their joints' range: ``(count, frame)``, where
    ``frame(i)`` is :func:`profile_figure`'s view of every mechanism (a row) at the ``i``-th of
    ``count`` joint angles spread over the grid, all in the one view that holds every frame."""
    rows = [_row(ev, u, n_frames) for u in range(len(ev.problem.mechanisms))]
    count = max(len(panels) for panels, _, _ in rows)
    return count, lambda i: _poses_figure(ev, rows, [(i, None)])


def pose_views(ev: Evaluation, boxes, pose: int = 0, n_poses: int = 1) -> Figure:
    """Every mechanism (a row) at the ``pose``-th of ``n_poses`` joint angles spread over its
    grid, drawn as :func:`profile_figure` draws it, once in each of the views ``boxes``
    (columns): each ((x_min, y_min), (x_max, y_max)) [mm], or None for the profile view's own;
    what lies outside a view is named at its edge. A whole mechanism beside a close-up of its
    profile, say."""
    rows = [_row(ev, u, n_poses) for u in range(len(ev.problem.mechanisms))]
    views = [None if box is None else tuple(np.asarray(corner, dtype=float) for corner in box) for box in boxes]
    return _poses_figure(ev, rows, [(pose, view) for view in views])


#: Least width of the profile view [in]: its title and legend fit above and below one pose.
POSES_MIN_WIDTH = 7.0


@matplotlib_defaults()
def _poses_figure(ev: Evaluation, rows: list, columns: list[tuple]) -> Figure:
    """The figure of :func:`profile_figure`: each mechanism's row of :func:`_row`, in the
    ``columns``: (index into each row's poses, view (lo, hi) [mm] or None for the row's own)."""
    problem = ev.problem
    mechs = problem.mechanisms
    ncols = len(columns)
    width = 3.9  # of a panel [in]
    heights = [width * max(_aspect(*(view or own)) for _, view in columns) + 0.6 for _, *own in rows]
    fig = Figure(figsize=(max(width * ncols + 0.4, POSES_MIN_WIDTH), sum(heights) + 1.2), layout="constrained")
    axes = fig.subplots(len(mechs), ncols, squeeze=False, gridspec_kw={"height_ratios": heights})
    seen = set()  # what the legend explains, beyond what every view draws
    for row, (mech, (panels, own_lo, own_hi)) in enumerate(zip(mechs, rows)):
        limits = sorted({(MM * pr.rho_min, "ρ_min") for pr in mech.profiles}
                        | {(MM * pr.rho_max, "ρ_max") for pr in mech.profiles})
        for col, (index, view) in enumerate(columns):
            ax = axes[row][col]
            if index >= len(panels):
                ax.set_axis_off()
                continue
            lo, hi = view or (own_lo, own_hi)
            reach = float(np.hypot(*np.maximum(np.abs(lo), np.abs(hi))))
            off = [f"{name} = {r:.4g} mm" for r, name in limits if r > reach]
            th, prof, spans, circles, wraps, arms, springs = panels[index]
            seen |= _draw_arms(ax, lo, hi, arms)
            seen |= _draw_springs(ax, springs)
            seen |= _draw_pose(ax, lo, hi, [r for r, _ in limits], prof, spans, circles, wraps)
            _label_off_view(ax, lo, hi, spans, circles, springs)
            angle = f"θ{mech.joint + 1}" if len(problem.joints) > 1 else "θ"
            ax.set_title(f"{mech.name}: {angle} = {np.degrees(th):.0f}°", fontsize=9)
            ax.tick_params(labelsize=7)
            ax.set_xlabel("x [mm]", fontsize=8)
            if col == 0:
                ax.set_ylabel("y [mm]", fontsize=8)
                if off:
                    ax.text(0.02, 0.02, "off view: " + ", ".join(off), transform=ax.transAxes,
                            fontsize=7, color="0.35", va="bottom")
    words = _words(mechs)
    handles = _profile_legend(max(len(mech.profiles) for mech in mechs), seen, words)
    fig.legend(handles=handles, loc="outside lower center", ncol=min(len(handles), 5 if ncols > 1 else 3), fontsize=8,
               frameon=False)
    angles = len({index for index, _ in columns})
    at = f"{angles} joint angles" if angles > 1 else "one joint angle"
    fig.suptitle(f"{problem.name}: {words.title} at {at} (+: joint axis)", fontsize=10)
    return fig


def _aspect(lo, hi) -> float:
    """The height of the view (``lo``, ``hi``) over its width, within what a panel is drawn at."""
    return float(np.clip((hi[1] - lo[1]) / (hi[0] - lo[0]), 0.45, 1.6))


def _draw_pose(ax, lo, hi, limits, prof, spans, circles, wraps) -> set[str]:
    """Draw one pose of a mechanism (a panel of :func:`_row`) on ``ax``, viewing the box
    (``lo``, ``hi``) [mm], with the circles of radii ``limits`` [mm] about the joint axis.

    Returns
    -------
    set of str
        The optional legend entries the panel shows: ``"idler"``, ``"end"`` (a spring end or
        point idler in view), ``"rho"`` and ``"convexity"`` (a binding limit).
    """
    seen = set()
    for r in limits:
        ax.add_patch(Circle((0, 0), r, fill=False, **LIMIT))
    for ctr, r in circles:
        if r > 0:
            seen.add("idler")
            ax.add_patch(Circle(tuple(ctr), r, fill=False, **IDLER))
            ax.plot(*ctr, marker="+", color="0.25", ms=8, ls="none")
        else:
            if _inside(lo, hi, ctr):
                seen.add("end")
            ax.plot(*ctr, **SPRING_END)
    for a, b in spans:
        ax.plot([a[0], b[0]], [a[1], b[1]], **CABLE)
    for wrap in wraps:
        ax.plot(*wrap, **CABLE)
    for i, (x, y, wrapped, dep, anchor, bind) in enumerate(prof):
        colour = PROFILE_COLOURS[i % len(PROFILE_COLOURS)]
        ax.plot(x, y, color=colour, lw=0.9, alpha=0.55)
        ax.plot(x[wrapped], y[wrapped], color=colour, lw=3.0, solid_capstyle="butt")
        ax.plot(*anchor, **ANCHOR)
        ax.plot(*dep, **DEPARTURE)
        for kind, pt in bind:
            seen.add(kind)
            ax.plot(*pt, **(RHO_BINDING if kind == "rho" else CONVEXITY_BINDING))
    ax.plot(0, 0, marker="+", color="black", ms=10, mew=1.2, ls="none")
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal", adjustable="box")
    return seen


def _draw_arms(ax, lo, hi, arms) -> set[str]:
    """The link from the joint axis to its mass [mm] (``arms``: point and words), under the
    mechanism; the mass drawn where it is in the view, else named at the edge."""
    for end, words in arms:
        ax.plot([0, end[0]], [0, end[1]], **LINK)
        if _inside(lo, hi, end):
            ax.plot(*end, **MASS)
            ax.annotate(words, end, xytext=(4, 4), textcoords="offset points", fontsize=7, color="0.2")
        else:
            _edge_label(ax, lo, hi, np.zeros(2), end, words)
    return {"arm"} if arms else set()


def _draw_springs(ax, springs) -> set[str]:
    """The springs' zigzags [mm] (``springs``: points and whether the free length drawn is the
    spring's own); returns the legend entries they need."""
    for points, _ in springs:
        ax.plot(*points.T, **SPRING_COIL)
    return {"coil" if own else "coil-nominal" for _, own in springs}


def _label_off_view(ax, lo, hi, spans, circles, springs) -> None:
    """Name at the edge of the view (``lo``, ``hi``) [mm] what lies off it: an idler once (not
    the cable's tangent points on it), a spring end where its cable leaves the view (with the
    spring's coil, ``springs``, when the cable pulls one: one label for both)."""
    away = [(ctr, r) for ctr, r in circles if not _inside(lo, hi, ctr)]
    named = []  # the fixed ends of springs named with the cable that pulls them
    for a, b in spans:
        on_idler = any(r > 0 and np.hypot(*(b - ctr)) <= 1.01 * r for ctr, r in away)
        if not _inside(lo, hi, b) and _inside(lo, hi, a) and not on_idler:
            fixed = [points[0] for points, _ in springs if np.allclose(points[-1], b, atol=1e-6)]
            named += fixed
            is_end = any(r == 0 and np.allclose(ctr, b) for ctr, r in circles)
            what = f"spring ({b[0]:.0f}, {b[1]:.0f}) to its end" if fixed else "spring end" if is_end else "cable end"
            at = fixed[0] if fixed else b
            _edge_label(ax, lo, hi, a, b, f"{what} ({at[0]:.0f}, {at[1]:.0f}) mm")
    for ctr, r in away:
        if r > 0:
            _edge_label(ax, lo, hi, np.zeros(2), ctr,
                        f"idler: centre ({ctr[0]:.0f}, {ctr[1]:.0f}) mm, r {r:.3g} mm")
        elif not any(np.allclose(ctr, b) for b in [b for _, b in spans] + named):
            _edge_label(ax, lo, hi, np.zeros(2), ctr, f"spring end ({ctr[0]:.0f}, {ctr[1]:.0f}) mm")


#: The optional entries of the profile view's legend, in their order: (key of what
#: :func:`_draw_pose` returns, its label (None: the mechanisms' word for their circles), style).
OPTIONAL_LEGEND = (("arm", "the link (to its mass)", LINK),
                   ("coil", "spring: free length + extension", SPRING_COIL),
                   ("coil-nominal", "spring: extension + a free length to fit (none given)", SPRING_COIL),
                   ("idler", None, IDLER),
                   ("end", "spring end / point idler", SPRING_END),
                   ("rho", "ρ at its limit", RHO_BINDING),
                   ("convexity", "convexity margin binding", CONVEXITY_BINDING))


def _words(mechs) -> Picture:
    """The words of the mechanisms' pictures, each joined with " / " where kinds differ."""
    pictures = list(dict.fromkeys(m.picture for m in mechs))
    return Picture(**{f.name: " / ".join(dict.fromkeys(w for w in (getattr(p, f.name) for p in pictures) if w))
                      for f in fields(Picture)})


def _profile_legend(pairs: int, seen: set[str], words: Picture) -> list[Line2D]:
    """The profile view's legend handles: the profiles (one colour, or one per profile of a
    mechanism with ``pairs`` of them), the marks every view draws, and those in ``seen``, in
    the mechanisms' ``words``."""
    if pairs == 1:
        handles = [Line2D([], [], color=PROFILE_COLOURS[0], lw=0.9, alpha=0.55, label="profile (designed range)")]
        if words.wound:
            handles.append(Line2D([], [], color=PROFILE_COLOURS[0], lw=3.0, label=words.wound))
    else:
        handles = [Line2D([], [], color=PROFILE_COLOURS[k], lw=3.0, label=f"profile {k + 1} (thick: wrapped)")
                   for k in range(pairs)]
    handles += [Line2D([], [], label=words.free, **CABLE),
                Line2D([], [], label=words.contact, **DEPARTURE),
                Line2D([], [], label=words.anchor, **ANCHOR),
                Line2D([], [], label="ρ_min, ρ_max", **LIMIT)]
    return handles + [Line2D([], [], label=label or words.circle, **style)
                      for key, label, style in OPTIONAL_LEGEND if key in seen]


# -------------------------------------------------------------------------------------- torque
@matplotlib_defaults()
def torque_figure(ev: Evaluation, band: Band | None = None, friction: FrictionBand | None = None) -> Figure:
    """Torque against target and the error [N·mm]: lines for one joint, with the tolerance
    ``band`` shaded around the torque (:mod:`cadcam.verify.tolerance`), the ``friction`` band
    [τ⁻, τ⁺] shaded between its edges (:mod:`cadcam.verify.friction`) and the error its
    acceptance's max_abs_error allows (when it has one) around the error, which stays at the
    design's own scale; error maps over the first two joints' angles for several (further joints
    at the first angle of their grid), the band's widest half-width in each title, and under
    them with friction a map of the friction band's width τ⁺ − τ⁻."""
    m = len(ev.tau)
    metrics = ev.metrics
    if m == 1:
        fig = Figure(figsize=(7, 6), layout="constrained")
        a1, a2 = fig.subplots(2, 1, sharex=True)
        th = np.degrees(ev.theta[0])
        a1.plot(th, MM * ev.tau_d[0], "k--", label="target τ_d")
        centre = ", band centre" if friction is not None and friction.friction.centre else ""
        a1.plot(th, MM * ev.tau[0], color="tab:blue", label=f"τ ({ev.problem.torque_model} model{centre})")
        if band is not None:
            w = MM * band.half_width[0]
            a1.fill_between(th, MM * ev.tau[0] - w, MM * ev.tau[0] + w, color="tab:blue", alpha=0.18, lw=0,
                            label=f"built part, to first order:\n{band.label()}")
        if friction is not None:
            a1.fill_between(th, MM * friction.minus[0], MM * friction.plus[0], facecolor="none", edgecolor="tab:orange",
                            hatch="////", lw=0.8, label="friction band: held still between\nτ⁻ (turning to −θ) and τ⁺ (to +θ)")
        a1.set_ylabel("torque [N·mm]")
        if friction is None:
            a1.legend(fontsize=8, loc="best")
        else:  # a wide band leaves no room inside the axes
            handles, labels = a1.get_legend_handles_labels()
            fig.legend(handles, ["\n".join(textwrap.fill(line, 44) for line in t.split("\n")) for t in labels], fontsize=8,
                       loc="outside upper center", ncols=2)
        accepted = ev.problem.joints[0].limits.get("max_abs_error")
        if accepted is not None:
            a2.axhspan(-MM * accepted, MM * accepted, color="tab:green", alpha=0.15, lw=0,
                       label=f"acceptance: |τ − τ_d| ≤ {MM * accepted:.3g} N·mm")
            a2.legend(fontsize=8)
        a2.plot(th, MM * (ev.tau[0] - ev.tau_d[0]), color="tab:red")
        a2.axhline(0, color="0.5", lw=0.6)
        a2.set_ylabel("τ − τ_d [N·mm]")
        a2.set_xlabel("θ [deg]")
        a1.set_title(f"{ev.problem.joints[0].name}: RMSE {MM * metrics.rmse[0]:.3g} N·mm, "
                     f"max |τ − τ_d| {MM * metrics.max_abs_error[0]:.3g} N·mm"
                     + ("" if friction is None else f"; friction band ≤ {MM * friction.width[0].max():.3g} N·mm wide"),
                     fontsize=10)
        return fig
    return _torque_maps(ev, band, friction)


def _torque_maps(ev: Evaluation, band: Band | None, friction: FrictionBand | None) -> Figure:
    """:func:`torque_figure` for several joints: each joint's error map over the first two joints'
    angles, and under it with ``friction`` its band's width τ⁺ − τ⁻."""
    m, n, metrics = len(ev.tau), ev.grid, ev.metrics
    rows = 1 if friction is None else 2
    fig = Figure(figsize=(5.4 * m, 4.6 * rows), layout="constrained")
    axes = fig.subplots(rows, m, squeeze=False)
    t1, t2 = (np.degrees(np.linspace(*ev.problem.joints[i].theta_range, n)) for i in (0, 1))
    first = lambda values: (MM * values).reshape((n,) * m)[(slice(None), slice(None)) + (0,) * (m - 2)]  # noqa: E731
    for i, ax in enumerate(axes[0]):
        err = first(ev.tau[i] - ev.tau_d[i])
        top = float(np.abs(err).max()) or 1.0
        im = ax.pcolormesh(t2, t1, err, shading="nearest", cmap="RdBu_r", vmin=-top, vmax=top)
        fig.colorbar(im, ax=ax, label="τ − τ_d [N·mm]")
        ax.set_title(f"{ev.problem.joints[i].name}: RMSE {MM * metrics.rmse[i]:.3g}, "
                     f"max {MM * metrics.max_abs_error[i]:.3g} N·mm"
                     + ("" if band is None else f"\nbuilt part: ± {MM * band.half_width[i].max():.3g} N·mm at most"),
                     fontsize=10)
    for i, ax in enumerate(axes[1] if friction is not None else []):
        im = ax.pcolormesh(t2, t1, first(friction.width[i]), shading="nearest", cmap="Oranges", vmin=0)
        fig.colorbar(im, ax=ax, label="τ⁺ − τ⁻ [N·mm]")
        ax.set_title(f"{ev.problem.joints[i].name}: friction band τ⁺ − τ⁻ ≤ {MM * friction.width[i].max():.3g} N·mm",
                     fontsize=10)
    for ax in axes.ravel():
        ax.set_xlabel("θ₂ [deg]")
        ax.set_ylabel("θ₁ [deg]")
    fig.suptitle(f"torque error ({ev.problem.torque_model} model)", fontsize=10)
    return fig


# -------------------------------------------------------------------------------------- output
@matplotlib_defaults()
def output_figure(ev: Evaluation, recheck: Evaluation | None = None) -> Figure:
    """Each mechanism's output x(θ) against its law x_d(θ) [mm] and the error [µm]: on the
    ``recheck`` evaluation's finer grid where given, the design grid's angles marked on it (the
    NLP meets the law at those angles; between them only the re-check shows the error)."""
    rows = [(u, mech) for u, mech in enumerate(ev.problem.mechanisms) if mech.output_target is not None]
    fig = Figure(figsize=(6.5 * max(len(rows), 1), 6), layout="constrained")
    axes = fig.subplots(2, max(len(rows), 1), sharex="col", squeeze=False)
    for k, (u, mech) in enumerate(rows):
        a1, a2 = axes[0][k], axes[1][k]
        coarse = ev.units[u]
        fine = coarse if recheck is None else recheck.units[u]
        th = np.degrees(fine.theta)
        x = fine.z[mech.unknowns.index(mech.output)]
        xd, err = output_law(mech, fine.theta), output_error(mech, fine)
        a1.plot(th, MM * xd, "k--", label=f"target {mech.output}_d")
        a1.plot(th, MM * x, color="tab:blue", label=f"{mech.output} (rootfinder)")
        a1.set_ylabel(f"{mech.output} [mm]")
        a1.legend(fontsize=8, loc="best")
        a2.plot(th, UM * err, color="tab:red", label=None if recheck is None else "re-check grid")
        if recheck is not None:
            a2.plot(np.degrees(coarse.theta), UM * output_error(mech, coarse), "o", ms=3, color="0.2",
                    label="design grid (the NLP's angles)")
            a2.legend(fontsize=8, loc="best")
        a1.set_title(f"{mech.name}: max |{mech.output} − {mech.output}_d| {MM * np.abs(err).max():.3g} mm "
                     f"({'design' if recheck is None else 're-check'} grid)", fontsize=9)
        a2.axhline(0, color="0.5", lw=0.6)
        a2.set_ylabel(f"{mech.output} − {mech.output}_d [µm]")
        a2.set_xlabel("θ [deg]")
    return fig


# ------------------------------------------------------------------------------------- springs
def _wrap(name: str, width: int = 26) -> str:
    return "\n".join(textwrap.wrap(name, width)) or name


#: Spring colours: the default cycle without its red, which marks limits reached.
SPRING_COLOURS = ("C0", "C1", "C2", "C4", "C5", "C6", "C7", "C8", "C9")


def _spring_colour(j: int) -> str:
    return SPRING_COLOURS[j % len(SPRING_COLOURS)]


def _short(name: str) -> str:
    """A spring's name without its parenthesised details: "spring 1 (McMaster…)" → "spring 1"."""
    return name.split(" (")[0] or name


@matplotlib_defaults()
def springs_figure(ev: Evaluation) -> Figure:
    """Every spring's extension against its travel [mm].

    Top: each spring's extension range over the grid (coloured bar) inside its allowed range
    [0, travel] (grey), the limits it sits at (within :data:`cadcam.verify.binding.RTOL` of the
    travel, or at zero) marked and named in red. Below: each extension over its joint's angle
    (one joint: all springs in one panel), or, for a spring joining two joints (Johnston2023's
    spring 2), a map over both angles with a contour at 99 % of its travel where it comes that
    close; a red cross where a limit binds.
    """
    problem = ev.problem
    springs, m, n = problem.springs, len(ev.tau), ev.grid
    grids = [np.degrees(j.grid(n)) for j in problem.joints]
    S = len(springs)
    detail = 1 if m == 1 else S
    fig = Figure(figsize=(max(8.0, 4.6 * detail), 1.4 + 0.5 * S + 3.6), layout="constrained")
    gs = fig.add_gridspec(2, detail, height_ratios=[0.6 + 0.5 * S, 3.6])
    _extension_ranges(fig.add_subplot(gs[0, :]), ev)
    if m == 1:
        ax = fig.add_subplot(gs[1, 0])
        for j, s in enumerate(springs):
            _extension_line(ax, grids[0], MM * ev.x[j], MM * s.travel, _spring_colour(j), _short(s.name))
            _mark_extremes(ax, grids[0], MM * ev.x[j], MM * s.travel)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_xlabel("θ [deg]")
        ax.set_ylabel("extension [mm] (dotted: travel)")
        ax.legend(fontsize=8)
        return fig
    net = problem.network()
    for j, s in enumerate(springs):
        ax = fig.add_subplot(gs[1, j])
        cams = net.joints_of(j)
        x = MM * ev.x[j].reshape((n,) * m)
        if len(cams) == 1:
            _spring_over_one_joint(ax, grids, x, cams[0], MM * s.travel, _spring_colour(j))
        else:
            _spring_over_two_joints(fig, ax, grids, x, cams[:2], MM * s.travel)
        ax.set_title(_wrap(s.name, 40), fontsize=8)
    return fig


def _extension_ranges(top, ev: Evaluation) -> None:
    """On ``top``, each spring's extension range over the grid inside [0, travel] [mm], the
    limits it reaches marked in red, and its range and limits named on the right."""
    springs, m, n = ev.problem.springs, len(ev.tau), ev.grid
    S = len(springs)
    xmin, xmax = MM * ev.x.min(axis=1), MM * ev.x.max(axis=1)
    notes_all = []
    for j, s in enumerate(springs):
        travel = MM * s.travel
        y = S - 1 - j
        top.barh(y, travel, left=0, height=0.6, color="0.9", edgecolor="0.6")
        top.barh(y, max(xmax[j] - xmin[j], 1e-3 * travel), left=xmin[j], height=0.36, color=_spring_colour(j))
        notes = []
        hi_state, lo_state = limit_state(travel - xmax[j], travel), limit_state(xmin[j], travel)
        if hi_state:
            top.plot(xmax[j], y, marker="|", color="red", ms=22, mew=2.5)
            notes.append("at its travel limit" if hi_state == "at" else "BEYOND its travel")
        if lo_state:
            top.plot(max(xmin[j], 0), y, marker="|", color="red", ms=22, mew=2.5)
            notes.append("at zero extension" if lo_state == "at" else "IN COMPRESSION")
        notes_all.append(f"{xmin[j]:.2f}–{xmax[j]:.2f} of {travel:.2f} mm" + (": " + ", ".join(notes) if notes else ""))
    top.set_yticks(range(S), [_wrap(s.name, 30) for s in reversed(springs)], fontsize=7)
    right = top.twinx()  # the ranges and binding limits, as labels on the right
    right.set_ylim(-0.6, S - 0.4)
    right.set_yticks(range(S), list(reversed(notes_all)), fontsize=8)
    for label, note in zip(right.get_yticklabels(), reversed(notes_all)):
        label.set_color("red" if ":" in note else "black")
    right.tick_params(length=0)
    hi = max(max(MM * s.travel for s in springs), float(xmax.max()))
    top.set_xlim(min(0.0, float(xmin.min())) - 0.02 * hi, 1.04 * hi)
    top.set_ylim(-0.6, S - 0.4)
    top.set_xlabel("extension [mm] (grey: allowed, 0 to travel; red: a limit reached)", fontsize=8)
    grid = " × ".join([str(n)] * m) if m > 1 else f"{n}-angle"
    top.set_title(f"spring extensions over the {grid} grid ({ev.problem.torque_model} model)", fontsize=10)


def _extension_line(ax, th, x, travel, colour, label=None) -> None:
    """A spring's extension ``x`` [mm] over the angles ``th`` [deg], its ``travel`` dotted."""
    ax.plot(th, x, color=colour, label=label)
    ax.axhline(travel, color=colour, ls=":", lw=1)


def _spring_over_one_joint(ax, grids, x, c: int, travel: float, colour) -> None:
    """The extension [mm] on the grid ``x`` of a spring that only joint ``c`` stretches, over
    that joint's angle (the others at the first angle of their grid)."""
    line = x[tuple(slice(None) if a == c else 0 for a in range(x.ndim))]
    _extension_line(ax, grids[c], line, travel, colour)
    ax.axhline(0, color="k", lw=0.5)
    _mark_extremes(ax, grids[c], line, travel)
    ax.set_xlabel(f"θ{c + 1} [deg]")
    ax.set_ylabel("extension [mm] (dotted: travel)")


def _spring_over_two_joints(fig, ax, grids, x, cams, travel: float) -> None:
    """The extension [mm] on the grid ``x`` of a spring joining joints ``cams`` = (a, b), as a
    map over their angles (further joints at the first angle of their grid), with a contour at
    99 % of its ``travel`` where it comes that close."""
    a, b = cams
    sl = x[tuple(slice(None) if k in (a, b) else 0 for k in range(x.ndim))]
    if a > b:
        sl = sl.T
    im = ax.pcolormesh(grids[b], grids[a], sl, shading="nearest", cmap="viridis")
    fig.colorbar(im, ax=ax, label="extension [mm]")
    if sl.max() >= 0.99 * travel:
        cs = ax.contour(grids[b], grids[a], sl, levels=[0.99 * travel], colors="r", linewidths=1.2)
        ax.clabel(cs, fmt=lambda v: "99 % of travel", fontsize=7)
    ia, ib = np.unravel_index(int(np.argmax(sl)), sl.shape)
    if limit_state(travel - sl.max(), travel):
        ax.plot(grids[b][ib], grids[a][ia], marker="X", color="red", ms=9, ls="none")
    ax.set_xlabel(f"θ{b + 1} [deg]")
    ax.set_ylabel(f"θ{a + 1} [deg]")


def _mark_extremes(ax, th, x, travel):
    """Red crosses where an extension curve sits at its travel or at zero."""
    k = int(np.argmax(x))
    if limit_state(travel - x[k], travel):
        ax.plot(th[k], x[k], marker="X", color="red", ms=9, ls="none")
    k = int(np.argmin(x))
    if limit_state(x[k], travel):
        ax.plot(th[k], x[k], marker="X", color="red", ms=9, ls="none")


# --------------------------------------------------------------------------------- convergence
#: Superscript forms of an exponent's characters (DejaVu Sans, matplotlib's font, has them).
SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def power_of_ten(value: float, _position=None) -> str:
    """A logarithmic axis's tick label as plain text, ``10⁻⁵`` or ``2×10⁻⁵``: matplotlib's own
    labels are mathtext, whose parser takes 0.3 s to build in each process that draws one."""
    if not value > 0:
        return ""
    exponent = math.floor(math.log10(value) + 1e-9)
    mantissa = value / 10.0**exponent
    power = "10" + str(exponent).translate(SUPERSCRIPT)
    return power if abs(mantissa - 1) < 1e-6 else f"{mantissa:.3g}×{power}"


#: The convergence figure's size [in] and its fixed layout: margins [in] (left: a logarithmic
#: axis's labels such as 10⁻¹³ and the axis's name; right: the step size's axis, 0–1, and its
#: name; bottom: the iterations; top: the title) and the gap [in] between its three axes. With
#: the objective on a logarithmic axis its contents are the same words and number formats for
#: every design, so it is laid out once here, as matplotlib's constrained layout lays it out,
#: and not by that layout at each draw, which costs most of the figure's drawing time. A linear
#: objective's labels are as wide as its digits: that figure keeps the constrained layout.
CONVERGENCE_SIZE = (7.0, 7.5)
CONVERGENCE_MARGINS = (0.75, 0.6, 0.48, 0.25)
CONVERGENCE_GAP = 0.16


def _stacked_axes(fig: Figure, rows: int, margins: tuple[float, float, float, float], gap: float):
    """``rows`` axes of ``fig`` one above the other sharing x, within ``margins`` [in] (left,
    right, bottom, top) and ``gap`` [in] apart."""
    width, height = fig.get_size_inches()
    left, right, bottom, top = margins
    each = (height - bottom - top - (rows - 1) * gap) / rows
    return fig.subplots(rows, 1, sharex=True, gridspec_kw=dict(
        left=left / width, right=1 - right / width, bottom=bottom / height, top=1 - top / height, hspace=gap / each))


@matplotlib_defaults()
def convergence_figure(history: dict) -> Figure:
    """IPOPT's iterations of the returned solve: the objective, the primal and dual
    infeasibilities (log scale, with the barrier parameter μ) and the step (‖d‖, log scale,
    and the primal step size α_pr) against the iteration.

    ``history`` holds equal-length lists ``iteration``, ``objective``, ``inf_pr``, ``inf_du``,
    ``mu``, ``d_norm``, ``alpha_pr`` (result.json's ``solver.history``).
    """
    it = np.asarray(history["iteration"], dtype=float)

    def col(key):
        v = history.get(key)
        return None if v is None else np.asarray([np.nan if x is None else x for x in v], dtype=float)

    obj = col("objective")
    finite = obj[np.isfinite(obj)] if obj is not None else np.zeros(0)
    positive = finite[finite > 0]
    log = bool(positive.size and positive.max() > 20 * positive.min())  # a wide range: logarithmic
    if log:  # every axis's labels of known widths: the fixed layout
        fig = Figure(figsize=CONVERGENCE_SIZE)
        a1, a2, a3 = _stacked_axes(fig, 3, CONVERGENCE_MARGINS, CONVERGENCE_GAP)
    else:  # the objective's linear labels (and their offset) as wide as its digits
        fig = Figure(figsize=CONVERGENCE_SIZE, layout="constrained")
        a1, a2, a3 = fig.subplots(3, 1, sharex=True)
    title = f"IPOPT: {len(it)} iterates"
    if obj is not None and obj.size:
        title += f"; last objective {obj[-1]:.6g}"
        if log:
            a1.set_yscale("log")
            if positive.size < finite.size:
                title += f" ({finite.size - positive.size} iterate(s) ≤ 0 not shown on the log scale)"
                obj = np.where(obj > 0, obj, np.nan)
        a1.plot(it, obj, color="tab:blue", marker=".", ms=3)
    a1.set_ylabel("objective (as IPOPT sees it)")
    a1.set_title(title, fontsize=10)
    for key, label, colour in (("inf_pr", "primal infeasibility", "tab:red"),
                               ("inf_du", "dual infeasibility", "tab:green"),
                               ("mu", "barrier μ", "0.5")):
        v = col(key)
        if v is not None:
            a2.semilogy(it, np.where(v > 0, v, np.nan), label=label, color=colour,
                        ls=":" if key == "mu" else "-", marker="." if key != "mu" else None, ms=3)
    a2.set_ylabel("infeasibility, μ")
    a2.legend(fontsize=8)
    d = col("d_norm")
    if d is not None:
        a3.semilogy(it, np.where(d > 0, d, np.nan), color="tab:purple", marker=".", ms=3)
    a3.set_ylabel("‖d‖ (step)", color="tab:purple")
    a3.set_xlabel("iteration")
    alpha = col("alpha_pr")
    if alpha is not None:
        b3 = a3.twinx()
        b3.plot(it, alpha, color="tab:orange", lw=0.9)
        b3.set_ylim(0, 1.05)
        b3.set_ylabel("α_pr (primal step size)", color="tab:orange")
    for ax in (a1, a2, a3):
        if ax.get_yscale() == "log":
            ax.yaxis.set_major_formatter(FuncFormatter(power_of_ten))
            _minor_marks(ax)
    return fig


def _minor_marks(ax) -> None:
    """Draw the minor ticks of ``ax``'s logarithmic y axis (eight a decade) as one line of tick
    marks, as matplotlib draws them, and no tick objects: a tick is five artists, and an axis
    over a few decades has dozens of them. Its limits are fixed at those its data give."""
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo, hi)
    axis = ax.yaxis
    values = [v for v in axis.get_minorticklocs() if lo <= v <= hi]
    axis.set_minor_locator(NullLocator())
    tick = {key: matplotlib.rcParams[f"ytick.minor.{key}"] for key in ("size", "width")}
    colour = matplotlib.rcParams["ytick.color"]
    marks = Line2D(np.zeros(len(values)), values, transform=ax.get_yaxis_transform("tick1"), ls="none",
                   marker=TICKLEFT if matplotlib.rcParams["ytick.direction"] == "out" else TICKRIGHT,
                   ms=tick["size"], mew=tick["width"], color=colour, mec=colour, clip_on=False)
    marks.set_figure(ax.figure)
    ax.add_artist(_Marks(marks))


class _Marks(Artist):
    """Tick marks drawn by a line of markers that is not one of the axes' data lines, after the
    axes' spines and ticks (as an axis draws its ticks)."""

    zorder = 2.51

    def __init__(self, line: Line2D):
        super().__init__()
        self.line = line

    def draw(self, renderer) -> None:
        self.line.draw(renderer)


# ------------------------------------------------------------------------------- all of a run
def figures(ev: Evaluation, history: dict | None = None, band: Band | None = None,
            recheck: Evaluation | None = None, friction: FrictionBand | None = None) -> dict[str, Figure]:
    """The figures of a design run by name: ``profile``; ``torque`` (with the tolerance
    ``band`` and the ``friction`` band where given) and ``springs`` (only with springs: without them there is no torque);
    ``output`` (only for mechanisms with an output law; its error on the ``recheck`` grid where
    given); ``convergence`` (only when IPOPT's ``history`` is given)."""
    return {name: make() for name, make in figure_makers(ev, history, band, recheck, friction).items()}


def figure_makers(ev: Evaluation, history: dict | None = None, band: Band | None = None,
                  recheck: Evaluation | None = None,
                  friction: FrictionBand | None = None) -> dict[str, Callable[[], Figure]]:
    """:func:`figures` by name, each not yet built: a function of no arguments that builds it
    (so that a drawing process builds the figure it draws)."""
    out = {"profile": partial(profile_figure, ev)}
    if ev.problem.springs:
        out["torque"] = partial(torque_figure, ev, band, friction)
        out["springs"] = partial(springs_figure, ev)
    if any(mech.output_target is not None for mech in ev.problem.mechanisms):
        out["output"] = partial(output_figure, ev, recheck)
    if history and history.get("iteration"):
        out["convergence"] = partial(convergence_figure, history)
    return out


def save_named(name: str, ev: Evaluation, history: dict | None, band: Band | None, recheck: Evaluation | None,
               friction: FrictionBand | None, path) -> None:
    """Build the figure ``name`` of :func:`figure_makers` and write it to ``path``
    (:func:`save_figure`)."""
    save_figure(figure_makers(ev, history, band, recheck, friction)[name](), path)


# --------------------------------------------------------------------------------------- study
def pareto_front(points: np.ndarray) -> np.ndarray:
    """Indices of the points no other point beats in both coordinates (minimising both)."""
    order = np.lexsort((points[:, 1], points[:, 0]))
    front, best = [], np.inf
    for k in order:
        if points[k, 1] < best:
            front.append(k)
            best = points[k, 1]
    return np.array(front, dtype=int)


#: How a quantity in SI is shown: (unit, factor from SI); a unit not listed is shown as it is.
SHOWN_AS = {"m": ("mm", MM), "rad": ("deg", 180 / np.pi), "N/m": ("N/mm", 1 / MM), "N": ("N", 1.0),
            "N·m": ("N·mm", MM), "m²": ("mm²", MM**2), "ratio": ("%", 100.0), "-": ("-", 1.0)}
#: Metric (:data:`cadcam.verify.evaluate.METRICS`) → (label, what its index counts, unit,
#: factor from SI to the unit drawn).
METRIC_LABELS = {name: (m.label, m.per, *SHOWN_AS.get(m.unit, (m.unit, 1.0))) for name, m in METRICS.items()}
#: Run facts of a study table (:func:`cadcam.sweep.runner.flat_table`).
RUN_LABELS = {
    "iterations": ("IPOPT iterations", "", 1.0), "solve_time_s": ("solve time", "s", 1.0),
    "build_time_s": ("build time", "s", 1.0), "wall_time_s": ("wall time", "s", 1.0),
    "recheck_violations": ("violations on the re-check", "", 1.0), "idx": ("case index", "", 1.0),
}
#: Last part of a spec key (its index stripped) → (unit, factor from SI).
SPEC_UNITS = {
    "rho_min": ("mm", MM), "rho_max": ("mm", MM),
    "travel": ("mm", MM), "preextension": ("mm", MM), "free_length": ("mm", MM),
    "min_curvature_radius": ("mm", MM),
    "length": ("mm", MM), "lengths": ("mm", MM), "com": ("mm", MM), "upper": ("mm", MM),
    "crank": ("mm", MM), "fore": ("mm", MM), "rate": ("N/mm", 1 / MM), "preload": ("N", 1.0),
    "mass": ("kg", 1.0), "masses": ("kg", 1.0), "g": ("m/s²", 1.0),
    "theta_range_deg": ("deg", 1.0), "reference_angle": ("deg", 180 / np.pi), "phase": ("deg", 180 / np.pi),
    "tracking_weight": ("-", 1.0), "sensitivity_weights": ("-", 1.0), "band_weight": ("N·m", 1.0),
    "order": ("", 1.0),
    "grid": ("", 1.0), "convexity_epsilon": ("-", 1.0), "limit_margin": ("-", 1.0),
}


def spec_unit(key: str) -> tuple[str, float]:
    """The unit a spec key is shown in and the factor from SI: the problem's own keys, then the
    keys the registered mechanisms declare; ("", 1) for a key no one declares."""
    if key in SPEC_UNITS:
        return SPEC_UNITS[key]
    for kind in mechanism_kinds():
        unit = mechanism_class(kind).spec_units.get(key)
        if unit is not None:
            return SHOWN_AS[unit]
    return "", 1.0


def _unit(unit: str) -> str:
    return f" [{unit}]" if unit else ""


def axis_label(key: str) -> tuple[str, float]:
    """A readable axis label with its unit for a study table column, and the factor that turns
    the column's SI values into that unit: ``rmse_1`` → ("RMSE, joint 1 [N·mm]", 1000),
    ``cams.1.idler.offset`` → ("cams 1 idler offset [mm]", 1000), ``springs.2.rate`` →
    ("springs 2 rate [N/mm]", 0.001). Unknown columns keep their name and SI values."""
    for name in sorted(METRIC_LABELS, key=len, reverse=True):
        hit = re.fullmatch(re.escape(name) + r"((?:_\d+)*)", key)
        if hit:
            label, counts, unit, factor = METRIC_LABELS[name]
            idx = [int(v) for v in hit.group(1).split("_")[1:]]
            if isinstance(counts, tuple):
                label += "".join(f", {c} {i}" for c, i in zip(counts, idx))
            elif counts and idx:
                label += f", {counts} {idx[0]}"
            return label + _unit(unit), factor
    if key in RUN_LABELS:
        label, unit, factor = RUN_LABELS[key]
        return label + _unit(unit), factor
    if "." in key:
        parts = key.split(".")
        leaf = re.sub(r"(_\d+)+$", "", parts[-1])
        suffix = parts[-1][len(leaf):]
        unit, factor = spec_unit(leaf)
        words = " ".join(p.replace("_", " ") for p in parts[:-1] + [leaf])
        if suffix:
            words += " " + " ".join(suffix.strip("_").split("_"))
        return words + _unit(unit), factor
    return key, 1.0


@matplotlib_defaults()
def study_figure(table: list[dict], x: str, y: str, color: str | None = None, pareto: bool = False,
                 title: str = "") -> Figure:
    """Scatter of column ``y`` against ``x`` over a study's successful cases, optionally
    coloured by ``color`` and with the Pareto front (both minimised) drawn; axes labelled with
    names and units (:func:`axis_label`), values drawn in those units."""
    rows = [r for r in table if r.get("status") == "success"
            and isinstance(r.get(x), (int, float)) and isinstance(r.get(y), (int, float))]
    (xl, fx), (yl, fy) = axis_label(x), axis_label(y)
    pts = np.array([[fx * r[x], fy * r[y]] for r in rows], dtype=float).reshape(-1, 2)
    fig = Figure(figsize=(7, 5), layout="constrained")
    ax = fig.add_subplot()
    if color:
        cl, fc = axis_label(color)
        c = [r.get(color) for r in rows]
        if all(isinstance(v, (int, float)) for v in c):
            sc = ax.scatter(pts[:, 0], pts[:, 1], c=fc * np.asarray(c, dtype=float),
                            cmap=matplotlib.colormaps["viridis"])
            fig.colorbar(sc, ax=ax, label=cl)
        else:
            for k, level in enumerate(dict.fromkeys(c)):
                mask = np.array([v == level for v in c])
                ax.scatter(pts[mask, 0], pts[mask, 1], color=f"C{k % 10}", label=str(level))
            ax.legend(fontsize=8, title=cl)
    else:
        ax.scatter(pts[:, 0], pts[:, 1])
    if pareto and len(pts):
        front = pts[pareto_front(pts)]
        ax.plot(front[:, 0], front[:, 1], "r-o", mfc="none", label="Pareto front (both minimised)")
        ax.legend(fontsize=8, title=axis_label(color)[0] if color else None)
    ax.set_xlabel(xl)
    ax.set_ylabel(yl)
    ax.set_title(f"{title + ': ' if title else ''}{len(rows)} successful cases of {len(table)}", fontsize=10)
    return fig


def plot_study(table: list[dict], x: str, y: str, color: str | None, pareto: bool, path,
               title: str) -> None:
    """:func:`study_figure` as a PNG."""
    save_figure(study_figure(table, x, y, color, pareto, title), path)


# ---------------------------------------------------------------------------------- catalogue
#: Marker of the best spring of a catalogue search (:func:`catalogue_figure`).
BEST_SPRING = dict(marker="o", mfc="none", mec="black", mew=1.6, ms=13, ls="none", zorder=6)


@matplotlib_defaults()
def catalogue_figure(rate, preload, verdicts: list[str], rmse, best: int | None, colours: dict[str, str],
                     title: str = "") -> Figure:
    """A catalogue searched for one spring slot (``cadcam springs``). Left: every spring by its
    rate [N/mm, log] and initial tension [N], coloured by its verdict (``colours``: verdict →
    colour, the first drawn on top); right: the designed springs' rmse [N·mm, log] against their
    rate (those ``rmse`` gives). The best spring (index ``best``) is ringed on both.

    Parameters
    ----------
    rate, preload : array_like
        Each spring's rate [N/m] and initial tension [N].
    verdicts : list of str
        Each spring's verdict, a key of ``colours``.
    rmse : array_like
        Each spring's design rmse [N·m], NaN where none is drawn.
    """
    k, f0, e = np.asarray(rate, float) / MM, np.asarray(preload, float), np.asarray(rmse, float) * MM
    words = np.asarray(verdicts)
    fig = Figure(figsize=(11, 4.6), layout="constrained")
    springs, errors = fig.subplots(1, 2)
    for word in reversed(list(colours)):
        mask = words == word
        if not mask.any():
            continue
        label = f"{word.replace('_', ' ')} ({int(mask.sum())})"
        springs.scatter(k[mask], f0[mask], s=9, color=colours[word], label=label, linewidths=0)
        shown = mask & np.isfinite(e)
        if shown.any():
            errors.scatter(k[shown], e[shown], s=12, color=colours[word], label=label, linewidths=0)
    if best is not None:
        springs.plot(k[best], f0[best], **BEST_SPRING, label="the best")
        errors.plot(k[best], e[best], **BEST_SPRING, label="the best")
    springs.set_xscale("log")
    springs.set(xlabel="rate [N/mm]", ylabel="initial tension [N]",
                title=f"{len(words)} springs by their verdict")
    errors.set(xscale="log", yscale="log", xlabel="rate [N/mm]", ylabel="design rmse [N·mm]",
               title="the designed springs' error")
    if not np.isfinite(e).any():
        errors.text(0.5, 0.5, "no design converged", ha="center", va="center", transform=errors.transAxes)
    for ax in (springs, errors):
        handles, labels = ax.get_legend_handles_labels()
        if handles:
            ax.legend(handles[::-1], labels[::-1], fontsize=8, loc="best")
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def plot_catalogue(rate, preload, verdicts: list[str], rmse, best: int | None, colours: dict[str, str], path,
                   title: str = "") -> None:
    """:func:`catalogue_figure` as a PNG."""
    save_figure(catalogue_figure(rate, preload, verdicts, rmse, best, colours, title), path)
