"""A workshop sheet of a cam at true scale: A4 landscape, PNG or PDF, written atomically.

The sheet has a frame, a title block (part, spec, drawing number, scale, units, sheet size,
date, the cadcam version that made it) and the dimensions a machinist needs: the bore's and the
anchor hole's diameters, the anchor hole's position from the rotation axis, the largest radius
of the outline and the smallest radius of the designed (wrapped) arc. Built on
``matplotlib.figure.Figure`` (no pyplot). Views only: the outline, holes and their checks come
from :mod:`cadcam.make.workshop`.
"""
from __future__ import annotations

import datetime
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Rectangle

from ..files import atomic_path
from ..library_files import matplotlib_defaults
from ..mechanisms.base import Picture
from ..version import __version__
from .workshop import DEFAULT_TOLERANCE, MM, Outline, holes

SHEET = (297.0, 210.0)
"""A4 landscape [mm of paper]."""
MARGIN = 10.0
"""Blank border of the sheet, outside the frame [mm of paper]."""
NOTES = 30.0
"""Height of the band for the notes and the title block at the foot of the sheet [mm of paper]."""
TITLE_BLOCK = 120.0
"""Width of the title block at the lower right [mm of paper]."""
REDUCTIONS = (1, 2, 5, 10, 20, 50, 100)
"""Scales 1:n tried in turn until the cam fits the drawing area."""
DPI = 300
"""Resolution of a PNG sheet; printed at this resolution it is at true scale."""
INCH = 25.4
"""Millimetres per inch."""
LEADER = 9.0
"""Length of a dimension's leader beyond the outline [mm of paper]."""


def draw_sheet(path, outline: Outline, bore_diameter: float, anchor_diameter: float,
               rho_min: float, rho_max: float, title: str, *, spec: str = "", drawing: str = "",
               date: str | None = None) -> int:
    """Draw the cam on an A4 landscape sheet (:func:`sheet_figure`) and write it to ``path``
    (``.png`` at :data:`DPI` dots per inch, or ``.pdf``), atomically.

    Returns
    -------
    int
        n of the scale 1:n.
    """
    _sheet_format(path)
    fig, n = sheet_figure(outline, bore_diameter, anchor_diameter, rho_min, rho_max, title,
                          spec=spec, drawing=drawing or Path(path).stem, date=date)
    save_sheet(fig, path)
    return n


@matplotlib_defaults()
def save_sheet(fig: Figure, *paths) -> None:
    """Write a sheet of :func:`sheet_figure` to each of ``paths`` (``.png`` at :data:`DPI` dots
    per inch, or ``.pdf``), atomically."""
    for path in paths:
        fmt = _sheet_format(path)
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format=fmt, dpi=DPI)


def _sheet_format(path) -> str:
    """``png`` or ``pdf`` from ``path``'s suffix; ValueError naming the path otherwise."""
    fmt = Path(path).suffix.lower().lstrip(".")
    if fmt not in ("png", "pdf"):
        raise ValueError(f"path = {str(path)!r}: the sheet is written as .png or .pdf")
    return fmt


@matplotlib_defaults()
def sheet_figure(outline: Outline, bore_diameter: float, anchor_diameter: float, rho_min: float,
                 rho_max: float, title: str, *, spec: str = "", drawing: str = "",
                 date: str | None = None, words: Picture = Picture(),
                 cable: tuple[str, ...] = (), tolerance: float = DEFAULT_TOLERANCE) -> tuple[Figure, int]:
    """The workshop sheet of one cam as a Figure, 1 mm of paper per mm of cam when it fits.

    The designed (wrapped) arc is drawn thick and red, the closing arc thin and black; the bore,
    the anchor hole, centre lines, the radius limits ρ_min and ρ_max as dashed circles (each
    only if it fits on the sheet), the dimensions (Ø bore, Ø anchor hole with its centre's x
    and y from the axis, R of the largest radius, R of the smallest radius of the wrapped arc),
    a 10 mm scale bar, notes and the title block. A cam too large for A4 at 1:1 is drawn at the
    first of 1:2, 1:5, 1:10, … that fits; the title block states the scale.

    Parameters
    ----------
    outline : Outline
    bore_diameter, anchor_diameter : float
        [m], checked by :func:`cadcam.make.workshop.holes`.
    rho_min, rho_max : float
        Radius limits of the design [m].
    title : str
        The part's name.
    spec : str
        The spec (problem) the part was designed for.
    drawing : str
        The drawing number (``cam1``; the file's stem when written by :func:`draw_sheet`).
    date : str, optional
        ISO date on the title block; default today.
    words : Picture
        The mechanism's words: the notes call the red arc ``words.arc`` and say
        ``words.runs_on`` of it (a cable's by default).
    cable : tuple of str
        Lines of notes on the cable (:func:`cable_notes`); none without a ``[cable]``.
    tolerance : float
        The fit [m] of the arcs the part's files hold, against which the holes are placed
        (:func:`cadcam.make.workshop.holes`): the files' own, for the sheet to show their holes.

    Returns
    -------
    (Figure, int)
        The sheet and n of the scale 1:n.
    """
    circles = holes(outline, bore_diameter, anchor_diameter, tolerance)
    points = outline.points * MM
    lo, hi = points.min(axis=0), points.max(axis=0)
    area = np.array([SHEET[0] - 2 * MARGIN, SHEET[1] - 2 * MARGIN - NOTES])
    n = next((k for k in REDUCTIONS if np.all((hi - lo) / k <= area)), REDUCTIONS[-1])
    half = area * n / 2  # half the drawing area [mm of cam]
    centre = (lo + hi) / 2
    fig = Figure(figsize=(SHEET[0] / INCH, SHEET[1] / INCH))
    ax = fig.add_axes([MARGIN / SHEET[0], (MARGIN + NOTES) / SHEET[1],
                       area[0] / SHEET[0], area[1] / SHEET[1]])
    ax.set_xlim(centre[0] - half[0], centre[0] + half[0])
    ax.set_ylim(centre[1] - half[1], centre[1] + half[1])
    ax.set_axis_off()
    _draw_cam(ax, outline, circles)
    taken = _dimensions(ax, outline, circles, n)
    shown = _draw_limits(ax, centre, half, {"ρ_min": rho_min, "ρ_max": rho_max}, taken)
    _frame(fig)
    _notes(fig, outline, rho_min, rho_max, shown, words, cable)
    _title_block(fig, title, spec, drawing, n, date or datetime.date.today().isoformat())
    return fig, n


def _draw_cam(ax, outline, circles):
    """Designed arc, closing arc, holes and centre lines [mm of cam]."""
    on = outline.designed(outline.phi)
    closing = np.vstack((outline.points[~on], outline.points[:1]))  # back to φ = 0
    ax.plot(*(closing * MM).T, color="black", lw=0.8)
    ax.plot(*(outline.points[on] * MM).T, color="tab:red", lw=2.0)
    for centre, diameter in circles:
        ax.add_patch(_circle(centre * MM, diameter * MM / 2, lw=0.8, color="black"))
    reach = outline.rho_range[1] * MM + 5
    for line in ([[-reach, reach], [0, 0]], [[0, 0], [-reach, reach]]):
        ax.plot(*line, color="0.3", lw=0.4, ls="-.")


def _draw_limits(ax, centre, half, limits, taken=()) -> list[str]:
    """Dashed circles of the radius ``limits`` that fit the view, each named at an angle away
    from the dimensions' angles ``taken``; returns their names."""
    shown = [name for name, r in limits.items() if np.all(np.abs(centre) + r * MM <= half)]
    angle = _spread(list(taken), np.radians(np.arange(0, 360, 10)))
    for name in shown:
        r = limits[name] * MM
        ax.add_patch(_circle(np.zeros(2), r, ls="--", lw=0.5, color="0.45"))
        ax.text(r * np.cos(angle), r * np.sin(angle), f"{name} = {r:.2f}", fontsize=6, color="0.4",
                ha="left" if np.cos(angle) >= 0 else "right", va="bottom" if np.sin(angle) >= 0 else "top")
    return shown


def _circle(centre, radius, **style):
    """An unfilled circle patch."""
    return Circle(tuple(centre), radius, fill=False, **style)


def _outline_radius(outline, angle) -> float:
    """Radius of the outline [mm] along the ray at polar ``angle`` [rad]."""
    return outline.radius_at(angle) * MM


def _spread(taken, candidates) -> float:
    """The candidate angle [rad] farthest (in angle) from every angle in ``taken``."""
    def gap(a):
        return min(abs((a - t + np.pi) % (2 * np.pi) - np.pi) for t in taken) if taken else np.pi
    return max(candidates, key=gap)


def _radial(ax, outline, angle, radius, text, n, placed, colour="black"):
    """A radius dimension: an arrow from the axis to the outline at ``angle`` and its text on
    a leader beyond the outline, turned away from the centre lines when it would lie along one
    [mm of cam]."""
    u = np.array([np.cos(angle), np.sin(angle)])
    tip = radius * u
    ax.annotate("", xy=tip, xytext=(0, 0),
                arrowprops=dict(arrowstyle="-|>", lw=0.5, color=colour, mutation_scale=6, shrinkA=0, shrinkB=0))
    axis = np.round(angle / (np.pi / 2)) * np.pi / 2  # the nearest centre line
    turn = angle - axis
    if abs(turn) < np.radians(20):
        angle = axis + (np.radians(25) if turn >= 0 else -np.radians(25))
    _leader(ax, tip, angle, _outline_radius(outline, angle), text, n, placed, colour)


def _leader(ax, start, angle, out_radius, text, n, placed, colour="black"):
    """A leader from ``start`` along ``angle`` to LEADER mm of paper beyond the outline radius
    ``out_radius``, then a short shoulder and the ``text`` [mm of cam]; moved further out until
    its text clears the boxes ``placed`` of the texts drawn before it (its own is added)."""
    u = np.array([np.cos(angle), np.sin(angle)])
    side = 1.0 if u[0] >= 0 else -1.0
    lines = text.split("\n")
    width, height = (max(map(len, lines)) * 1.45 + 2) * n, (len(lines) * 3.3 + 1) * n  # 7 pt text
    for extra in np.arange(0.0, 80.0, 3.0):
        end = (out_radius + (LEADER + extra) * n) * u
        shoulder = end + np.array([side * 3.0 * n, 0.0])
        x0 = shoulder[0] + side * 0.8 * n
        box = (min(x0, x0 + side * width), shoulder[1] - height / 2, max(x0, x0 + side * width), shoulder[1] + height / 2)
        if not any(box[0] < b[2] and b[0] < box[2] and box[1] < b[3] and b[1] < box[3] for b in placed):
            break
    placed.append(box)
    ax.plot([start[0], end[0], shoulder[0]], [start[1], end[1], shoulder[1]], color=colour, lw=0.4)
    ax.text(x0, shoulder[1], text, fontsize=7, color=colour, ha="left" if side > 0 else "right", va="center")


def _dimensions(ax, outline, circles, n):
    """Ø bore, Ø anchor hole with its centre's position, R max of the outline and R min of the
    wrapped arc [mm of cam; offsets in mm of paper × n]; returns the angles [rad] the
    dimensions and centre lines take."""
    (_, bore), (anchor, hole) = circles
    bore, hole, anchor = bore * MM, hole * MM, anchor * MM
    pts = outline.points * MM
    r = np.hypot(*pts.T)
    k_max = int(np.argmax(r))
    on = outline.designed(outline.phi)
    k_min = int(np.flatnonzero(on)[np.argmin(r[on])])
    a_max = float(np.arctan2(*pts[k_max][::-1]))
    a_min = float(np.arctan2(*pts[k_min][::-1]))
    a_anchor = float(np.arctan2(anchor[1], anchor[0]))
    placed = []  # the leaders' text boxes, kept apart
    _radial(ax, outline, a_max, r[k_max], f"R{r[k_max]:.2f} (largest radius)", n, placed)
    _radial(ax, outline, a_min, r[k_min], f"R{r[k_min]:.2f} (least radius of the red arc)", n,
            placed, colour="tab:red")
    candidates = np.radians(np.arange(0, 360, 15))
    below = [-np.pi / 4, -np.pi / 2, -3 * np.pi / 8, -np.pi / 8]  # the linear dimension's side
    a_bore = _spread([a_max, a_min, a_anchor, 0.0, np.pi / 2, np.pi] + below, candidates)
    start = bore / 2 * np.array([np.cos(a_bore), np.sin(a_bore)])
    _leader(ax, start, a_bore, _outline_radius(outline, a_bore), f"Ø{bore:.2f} bore, on the axis", n, placed)
    a_hole = _spread([a_max, a_min, a_bore, 0.0, np.pi / 2], np.radians(np.arange(15, 76, 10)))  # up, right
    start = anchor + hole / 2 * np.array([np.cos(a_hole), np.sin(a_hole)])
    _leader(ax, start, a_hole, _outline_radius(outline, a_hole),
            f"Ø{hole:.2f} anchor hole\ncentre x {anchor[0]:.2f}, y {anchor[1]:.2f}", n, placed)
    # the anchor hole's x from the axis as a linear dimension below the cam
    y = pts[:, 1].min() - 6.0 * n
    ax.plot([0, 0], [y - 1.0 * n, pts[:, 1].min()], color="0.3", lw=0.3)
    ax.plot([anchor[0]] * 2, [y - 1.0 * n, anchor[1] - hole / 2], color="0.3", lw=0.3)
    ax.annotate("", xy=(anchor[0], y), xytext=(0, y),
                arrowprops=dict(arrowstyle="<|-|>", lw=0.5, color="black", mutation_scale=6, shrinkA=0, shrinkB=0))
    ax.text(anchor[0] / 2, y - 0.8 * n, f"{abs(anchor[0]):.2f}", fontsize=7, ha="center", va="top")
    return [a_max, a_min, a_bore, a_hole, 0.0, np.pi / 2, np.pi] + below


def _frame(fig):
    """The drawing's frame along the margin."""
    fig.add_artist(Rectangle((MARGIN / SHEET[0], MARGIN / SHEET[1]), 1 - 2 * MARGIN / SHEET[0],
                             1 - 2 * MARGIN / SHEET[1], transform=fig.transFigure, fill=False, lw=0.8))


def cable_notes(report: dict, k: int) -> tuple[str, ...]:
    """The sheet's lines on the cable of profile ``k``, from its report
    (:func:`cadcam.verify.evaluate.cable_report`): its data, its least bend radius against the
    red arc's (the cut outline's) least radius of curvature, and its peak tension against its
    working load [mm, N]."""
    d = report["diameter"] * MM
    arc = report["curvature_radius_min"][k] * MM - d / 2
    return (f"Cable: {report.get('name') or 'given in full'}, Ø{d:.2f} {report['kind']}; peak tension "
            f"{report['peak_tension']:.4g} N, working load {report['working_load']:.4g} N "
            f"({report['breaking_load']:.4g} N / {report['safety_factor']:g}).",
            f"The red arc's least radius of curvature {arc:.2f}; the cable's least bend radius "
            f"{report['min_bend_radius'] * MM:.2f}.")


def _notes(fig, outline, rho_min, rho_max, shown, words, cable=()):
    """Notes and a 10 mm scale bar in the band at the foot of the sheet, left of the title
    block; ``words`` names the red arc and says what runs on it, ``cable`` the cable's lines."""
    lo, hi = outline.rho_range
    off = [name for name in ("ρ_min", "ρ_max") if name not in shown]
    lines = [
        f"Dimensions in mm. Red: {words.arc}, "
        f"φ = 0° to {np.degrees(outline.phi_end):.1f}° from the anchor point; black: closing arc.",
        f"Outline radius {lo * MM:.2f} to {hi * MM:.2f}; {words.runs_on}.",
        *([f"The cable's centre line lies {outline.offset * MM:.2f} mm (its radius) outside this cut outline."]
          if outline.offset else []),
        f"Dashed: radius limits ρ_min = {rho_min * MM:.2f}, ρ_max = {rho_max * MM:.2f}"
        + (f" ({', '.join(off)} off the sheet)." if off else "."),
        *cable,
        "The outline's full definition: camN_points.csv / camN.dxf (this sheet is for checking).",
    ]
    x0 = (MARGIN + 3) / SHEET[0]
    fig.text(x0, (MARGIN + NOTES - 4) / SHEET[1], "\n".join(lines), fontsize=7, va="top", linespacing=1.5)
    left = 1 - (MARGIN + TITLE_BLOCK + 16) / SHEET[0]
    foot = (MARGIN + 5) / SHEET[1]
    fig.add_artist(Line2D([left, left + 10 / SHEET[0]], [foot, foot], color="black", lw=2))  # 10 mm of paper
    fig.text(left + 5 / SHEET[0], foot + 0.008, "10 mm of paper", ha="center", fontsize=6)


def _title_block(fig, title, spec, drawing, n, date):
    """The title block at the lower right, inside the frame: part, spec, drawing number, scale,
    units, sheet, date and the cadcam version [mm of paper]."""
    w, h = TITLE_BLOCK, NOTES - 2
    x0, y0 = SHEET[0] - MARGIN - w, MARGIN

    def box(x, y, bw, bh, label, value, size=7.5, weight="normal"):
        fig.add_artist(Rectangle((x / SHEET[0], y / SHEET[1]), bw / SHEET[0], bh / SHEET[1],
                                 transform=fig.transFigure, fill=False, lw=0.6))
        fig.text((x + 1.2) / SHEET[0], (y + bh - 1.0) / SHEET[1], label, fontsize=4.5, color="0.35", va="top")
        fig.text((x + 1.5) / SHEET[0], (y + 1.2) / SHEET[1], value, fontsize=size, va="bottom", weight=weight)

    row = h / 4
    box(x0, y0 + 3 * row, w, row, "PART", title, size=9, weight="bold")
    box(x0, y0 + 2 * row, w * 0.7, row, "SPEC", spec or "—")
    box(x0 + w * 0.7, y0 + 2 * row, w * 0.3, row, "DRAWING No.", drawing or "—")
    box(x0, y0 + row, w * 0.3, row, "SCALE", f"1:{n}", weight="bold")
    box(x0 + w * 0.3, y0 + row, w * 0.2, row, "UNITS", "mm")
    box(x0 + w * 0.5, y0 + row, w * 0.2, row, "SHEET", "A4")
    box(x0 + w * 0.7, y0 + row, w * 0.3, row, "DATE", date)
    box(x0, y0, w, row, "MADE BY", f"cadcam {__version__}")
