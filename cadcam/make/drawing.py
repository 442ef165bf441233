"""A part's two drawing sheets, A4 landscape, PNG or PDF, written atomically.

Sheet 1, the workshop drawing (:func:`workshop_figure`, at the largest scale that fits, a small
part enlarged): the part's front view with its bore
(Ø and its ISO 286 fit), its anchor hole (Ø and its centre from the bore's), its overall size
and its datum mark (:mod:`cadcam.make.datum`), an edge view with its thickness, the notes that
make it a part (general tolerances, the profile's tolerance, thickness, material, how the mark
sets the part's angle on its shaft), a table of the cable and the springs, and a title block.
Sheet 2, the checking sheet (:func:`sheet_figure`, at true scale or the first reduction that
fits): the outline with the designed (wrapped) arc in red, the radius limits and the dimensions
that check it against the design. Both carry a
title block (part, spec, drawing number, scale, units, sheet n of 2, date, the cadcam version
that made it). Built on ``matplotlib.figure.Figure`` (no pyplot). Views only: the outline,
holes and their checks come from :mod:`cadcam.make.workshop`.
"""
from __future__ import annotations

import datetime
import textwrap
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Rectangle

from ..files import atomic_path
from ..library_files import matplotlib_defaults
from ..mechanisms.base import Picture
from ..version import __version__
from .datum import Datum
from .png import save_png
from .fits import BORE_FIT, GENERAL_CLASS, angular_tolerance, bore_limits
from .workshop import DEFAULT_TOLERANCE, MIRRORED_NOTE, Outline, holes
from ..units import MM

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
ENLARGEMENTS = (5, 2)
"""Scales n:1 the workshop drawing tries before :data:`REDUCTIONS`: a small part is drawn large
enough to read (ISO 5455)."""
DPI = 300
"""Resolution of a PNG sheet; printed at this resolution it is at true scale."""
INCH = 25.4
"""Millimetres per inch."""
LEADER = 9.0
"""Length of a dimension's leader beyond the outline [mm of paper]."""
CHAR = 1.45
"""Width of a character of 7 pt text [mm of paper], generous (DejaVu Sans averages 1.3): for
keeping texts apart."""
LINE = 3.3
"""Height of a line of 7 pt text [mm of paper]."""


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
        if _sheet_format(path) == "png":
            save_png(fig, path, DPI)
        else:
            with atomic_path(path) as tmp:
                fig.savefig(tmp, format="pdf", dpi=DPI)


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
                 cable: tuple[str, ...] = (), sheet: str = "A4",
                 tolerance: float = DEFAULT_TOLERANCE) -> tuple[Figure, int]:
    """The checking sheet of one cam as a Figure, 1 mm of paper per mm of cam when it fits.

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
    sheet : str
        The title block's SHEET (which of a set, and the paper).
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
    _title_block(fig, _title_rows(title, spec, drawing, _scale(n), date or datetime.date.today().isoformat(), sheet),
                 NOTES - 2)
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
    width, height = (max(map(len, lines)) * CHAR + 2) * n, (len(lines) * LINE + 1) * n  # 7 pt text
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


def _title_block(fig, rows, height: float, w: float = TITLE_BLOCK) -> None:
    """The title block at the lower right, inside the frame, ``w`` wide and ``height`` high:
    ``rows`` from the top, each a list of boxes (label, value, share of the block's width,
    value's font size, weight) [mm of paper]."""
    x0, y0 = SHEET[0] - MARGIN - w, MARGIN
    row = height / len(rows)
    for r, boxes in enumerate(rows):
        y, x = y0 + (len(rows) - 1 - r) * row, x0
        for label, value, share, size, weight in boxes:
            bw = share * w
            fig.add_artist(Rectangle((x / SHEET[0], y / SHEET[1]), bw / SHEET[0], row / SHEET[1],
                                     transform=fig.transFigure, fill=False, lw=0.6))
            fig.text((x + 1.2) / SHEET[0], (y + row - 0.6) / SHEET[1], label, fontsize=4.5, color="0.35", va="top")
            fig.text((x + 1.5) / SHEET[0], (y + 0.6) / SHEET[1], value or "—", fontsize=size, va="bottom",
                     weight=weight)
            x += bw


def _scale(n: float) -> str:
    """The scale of ``n`` mm of part per mm of paper: 1:n, or 1/n:1 for an enlargement."""
    return f"1:{n:g}" if n >= 1 else f"{1 / n:g}:1"


def _title_rows(title, spec, drawing, scale, date, sheet, *middle) -> list:
    """The title block's rows: the part; the spec and drawing number; the rows ``middle``;
    ``scale``, units, ``sheet`` and date; the cadcam version that made it."""
    return [[("PART", title, 1.0, 9, "bold")],
            [("SPEC", spec, 0.7, 7.5, "normal"), ("DRAWING No.", drawing, 0.3, 7.5, "normal")],
            *middle,
            [("SCALE", scale, 0.3, 7.5, "bold"), ("UNITS", "mm", 0.2, 7.5, "normal"),
             ("SHEET", sheet, 0.2, 7.5, "normal"), ("DATE", date, 0.3, 7.5, "normal")],
            [("MADE BY", f"cadcam {__version__}", 1.0, 7.5, "normal")]]


# ----------------------------------------------------------------------------- workshop drawing

#: Width [mm of paper] of the column at the right of the workshop sheet: its notes, its cable
#: and spring table and its title block.
COLUMN = 100.0
#: Height [mm of paper] of the workshop sheet's title block (five rows).
WORKSHOP_TITLE = 35.0
#: Distance [mm of paper] of a linear dimension's line from the part.
DIM_OFFSET = 7.0
#: Room [mm of paper] between the front view and the edge view.
VIEW_GAP = 18.0
#: Room [mm of paper] the dimensions and the leaders' texts take round the views, across and up.
VIEW_ROOM = (60.0, 40.0)
#: |cos| of a leader's direction below which its text may stand on either side of it.
STEEP = 0.75
#: Least angle [rad] between a leader and a line it starts beside (a centre line, the mark).
LEADER_CLEAR = np.radians(12)
#: Font size [pt] of the notes and the table in the column at the right of the workshop sheet.
COLUMN_FONT = 6.5
#: Characters of a line of the notes, and of the table's second column.
NOTE_WIDTH, CELL_WIDTH = 70, 50
#: Width [mm of paper] of the table's first column, and its characters.
LABEL_COLUMN, LABEL_WIDTH = 30.0, 20
#: The sheets a part has: the workshop drawing and the checking sheet.
SHEETS = 2
#: World axis names of the mark's directions (:data:`cadcam.make.datum.MARK_DIRECTIONS`) [degrees].
AXIS_WORDS = {0: "+x", 90: "+y", 180: "−x", 270: "−y"}


@dataclass(frozen=True)
class PartNotes:
    """What the workshop sheet states of a part beyond its outline and holes (SI units).

    Attributes
    ----------
    thickness : float
        The plate's thickness [m].
    thickness_given : bool
        Whether the spec gives it (``[workshop] stl``), or it is cadcam's default plate.
    profile_tolerance : float
        ± [m] the cut outline may be from its DXF: the spec's ``[tolerances] profile``, which
        the design's tolerance band assumes.
    fit_tolerance : float
        [m] the DXF's arcs are within of the design.
    datum : Datum
        The mark that sets the part's angle on its shaft.
    dxf : str
        The DXF's file name.
    mirrored : bool
        Whether the drawing is the part seen from its back (a clockwise-wound part).
    springs : tuple of dict
        The installation of the springs on the part's mechanism
        (:func:`cadcam.verify.installation.spring_installation`), a cable's cut length only on
        the part it is anchored on.
    cable : dict or None
        The cable's report (:func:`cadcam.verify.evaluate.cable_report`); None without a
        ``[cable]``.
    profile : int
        The part's index among the design's profiles (its entry of the cable report).
    cable_diameter : float
        The cable's diameter [m] (``[workshop] cable_diameter``; 0: an ideal thread).
    material : str
        The part's material.
    """

    thickness: float
    thickness_given: bool
    profile_tolerance: float
    fit_tolerance: float
    datum: Datum
    dxf: str
    mirrored: bool = False
    springs: tuple = ()
    cable: dict | None = None
    profile: int = 0
    cable_diameter: float = 0.0
    material: str = "as ordered"


def part_sheets(outline: Outline, bore_diameter: float, anchor_diameter: float, rho_min: float,
                rho_max: float, title: str, part: PartNotes, *, spec: str = "", drawing: str = "",
                date: str | None = None, words: Picture = Picture()) -> tuple[Figure, Figure]:
    """A part's two sheets: the workshop drawing (:func:`workshop_figure`, sheet 1) and the
    checking sheet (:func:`sheet_figure`, sheet 2), the same date on both."""
    date = date or datetime.date.today().isoformat()
    return tuple(part_sheet(page, outline, bore_diameter, anchor_diameter, rho_min, rho_max, title, part, spec=spec,
                            drawing=drawing, date=date, words=words) for page in range(1, SHEETS + 1))


def part_sheet(page: int, outline: Outline, bore_diameter: float, anchor_diameter: float, rho_min: float,
               rho_max: float, title: str, part: PartNotes, *, spec: str = "", drawing: str = "",
               date: str | None = None, words: Picture = Picture()) -> Figure:
    """Sheet ``page`` (1 or 2) of :func:`part_sheets`."""
    if page == 1:
        return workshop_figure(outline, bore_diameter, anchor_diameter, title, part, spec=spec, drawing=drawing,
                               date=date)[0]
    return sheet_figure(outline, bore_diameter, anchor_diameter, rho_min, rho_max, title, spec=spec,
                        drawing=drawing, date=date, words=words,
                        cable=cable_notes(part.cable, part.profile) if part.cable else (),
                        sheet=f"2 of {SHEETS} · A4", tolerance=part.fit_tolerance)[0]


def save_part_sheets(files: dict, outline: Outline, bore_diameter: float, anchor_diameter: float, rho_min: float,
                     rho_max: float, title: str, part: dict, words: dict) -> None:
    """Write a part's sheets (:func:`part_sheet`; ``part``, the fields of its
    :class:`PartNotes`; ``words``, its keyword arguments, the date among them) to files: path →
    the pages it holds, a PDF of them or a PNG of one. The sheets the files hold are built
    once, and no other, so that a drawing process builds only those it writes."""
    notes = PartNotes(**part)
    built = {page: part_sheet(page, outline, bore_diameter, anchor_diameter, rho_min, rho_max, title, notes, **words)
             for page in sorted({page for pages in files.values() for page in pages})}
    for path, pages in files.items():
        if _sheet_format(path) == "pdf":
            save_pdf([built[page] for page in pages], path)
        else:
            save_sheet(*(built[page] for page in pages), path)


@matplotlib_defaults()
def save_pdf(figures, path) -> None:
    """Write ``figures`` as the pages of one PDF at ``path``, atomically."""
    from matplotlib.backends.backend_pdf import PdfPages

    with atomic_path(path) as tmp, PdfPages(tmp) as pdf:
        for fig in figures:
            pdf.savefig(fig)


@matplotlib_defaults()
def workshop_figure(outline: Outline, bore_diameter: float, anchor_diameter: float, title: str,
                    part: PartNotes, *, spec: str = "", drawing: str = "",
                    date: str | None = None) -> tuple[Figure, float]:
    """The workshop drawing of one part as a Figure, at the largest scale that fits.

    The front view (the outline, the bore and the anchor hole, centre lines, the datum mark
    and its angle from the +x axis, the bore's Ø and fit, the anchor hole's Ø and centre, the
    overall size, the profile's file and tolerance) and, to its right, the edge view with the
    thickness; at the right of the sheet the notes, the cable and spring table and the title
    block. A part is drawn at the largest of 5:1, 2:1, 1:1, 1:2, 1:5, … that fits the drawing
    area; the title block states the scale.

    Returns
    -------
    (Figure, float)
        The sheet and n of the scale 1:n (below 1 for an enlargement 1/n:1).
    """
    circles = holes(outline, bore_diameter, anchor_diameter, part.fit_tolerance)
    pts = outline.points * MM
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    t = part.thickness * MM
    view = np.array([[MARGIN, MARGIN], [SHEET[0] - MARGIN - COLUMN, SHEET[1] - MARGIN]])  # [mm of paper]
    room = view[1] - view[0] - np.array(VIEW_ROOM)
    scales = [1 / k for k in ENLARGEMENTS] + list(REDUCTIONS)  # mm of part per mm of paper
    n = next((k for k in scales if (hi[0] - lo[0] + t) / k + VIEW_GAP <= room[0] and (hi[1] - lo[1]) / k <= room[1]),
             scales[-1])
    # the part's origin on the paper: the front view and the edge view centred across, the part up
    left = view[0, 0] + (view[1, 0] - view[0, 0] - (hi[0] - lo[0] + t) / n - VIEW_GAP) / 2
    origin = np.array([left - lo[0] / n, view[:, 1].mean() - (lo[1] + hi[1]) / 2 / n])
    fig = Figure(figsize=(SHEET[0] / INCH, SHEET[1] / INCH))
    size = (view[1] - view[0]) / np.array(SHEET)
    ax = fig.add_axes([*(view[0] / np.array(SHEET)), *size])
    bounds = (view - origin) * n  # the view area [mm of part]
    ax.set_xlim(*bounds[:, 0])
    ax.set_ylim(*bounds[:, 1])
    ax.set_axis_off()
    edge = hi[0] + VIEW_GAP * n  # the edge view's left side [mm of part]
    taken = _Taken([_box(lo, hi, 2.0 * n)], [])
    _front_view(ax, outline, circles, part.datum, n)
    _edge_view(ax, edge, t, lo, hi, circles, n, taken)
    _overall_size(ax, pts, n, taken)
    _anchor_x(ax, circles, pts, n, taken)
    _mark_angle(ax, part.datum, circles, n)
    _callouts(ax, outline, circles, part, n, taken, bounds)
    _frame(fig)
    _column(fig, part, circles)
    middle = [[("MATERIAL", part.material, 0.5, 7.5, "normal"), ("THICKNESS", f"{t:.2f}", 0.2, 7.5, "bold"),
               ("TOLERANCES", GENERAL_CLASS, 0.3, 7.5, "normal")]]
    _title_block(fig, _title_rows(title, spec, drawing, _scale(n), date or datetime.date.today().isoformat(),
                                  f"1 of {SHEETS} · A4", *middle), WORKSHOP_TITLE, COLUMN)
    return fig, n


@dataclass
class _Taken:
    """Where a text of the view may not go [mm of part]: ``regions`` (the part, the dimensions
    and their extension lines) and the boxes of the ``texts`` drawn and of the edge view, which
    no leader may cross either."""

    regions: list
    texts: list


def _box(lo, hi, pad: float = 0.0) -> tuple[float, float, float, float]:
    """The box (x0, y0, x1, y1) from the corners ``lo``, ``hi``, grown by ``pad``."""
    return (lo[0] - pad, lo[1] - pad, hi[0] + pad, hi[1] + pad)


def _overlaps(box, boxes) -> bool:
    """Whether ``box`` overlaps any of ``boxes`` (x0, y0, x1, y1)."""
    return any(box[0] < b[2] and b[0] < box[2] and box[1] < b[3] and b[1] < box[3] for b in boxes)


def _gap(a, b):
    """The angle [rad] between the directions ``a`` and ``b`` [rad] (numbers or arrays), in [0, π]."""
    return abs((a - b + np.pi) % (2 * np.pi) - np.pi)


def _crosses(a, b, boxes) -> bool:
    """Whether the segment from ``a`` to ``b`` passes through any of ``boxes``."""
    points = a + np.linspace(0.0, 1.0, 24)[:, None] * (b - a)
    return any(np.any((points[:, 0] > x0) & (points[:, 0] < x1) & (points[:, 1] > y0) & (points[:, 1] < y1))
               for x0, y0, x1, y1 in boxes)


def _text_size(text: str, n: float, size: float = 7.0) -> np.ndarray:
    """Width and height [mm of part at 1:n] a ``size``-pt ``text`` takes, generous."""
    lines = text.split("\n")
    scale = size / 7.0
    return np.array([max(map(len, lines)) * CHAR * scale + 1.0, len(lines) * LINE * scale + 0.6]) * n


def _front_view(ax, outline, circles, datum, n):
    """The outline, the holes, their centre lines and the datum mark [mm of part]."""
    ax.plot(*np.vstack((outline.points, outline.points[:1])).T * MM, color="black", lw=0.9)
    for centre, diameter in circles:
        ax.add_patch(_circle(centre * MM, diameter * MM / 2, lw=0.9, color="black"))
    reach = outline.rho_range[1] * MM + 3 * n
    for line in ([[-reach, reach], [0, 0]], [[0, 0], [-reach, reach]]):
        ax.plot(*line, color="0.3", lw=0.35, ls="-.")
    (centre, hole), = circles[1:]
    c, r = centre * MM, hole * MM / 2 + 1.5 * n  # the anchor hole's centre lines
    ax.plot([c[0] - r, c[0] + r], [c[1]] * 2, color="0.3", lw=0.35, ls="-.")
    ax.plot([c[0]] * 2, [c[1] - r, c[1] + r], color="0.3", lw=0.35, ls="-.")
    ax.plot(*datum.segment.T * MM, color="tab:blue", lw=1.2, solid_capstyle="butt")


def _edge_view(ax, x, t, lo, hi, circles, n, taken):
    """The edge view at ``x`` [mm of part]: the plate ``t`` thick, the holes through it as
    hidden lines with their centre lines, its thickness dimensioned above it."""
    ax.add_patch(Rectangle((x, lo[1]), t, hi[1] - lo[1], fill=False, lw=0.9, color="black"))
    drawn = []  # the centre lines' heights: one where two would lie on each other
    for centre, diameter in circles:
        y, r = centre[1] * MM, diameter * MM / 2
        if not lo[1] < y < hi[1]:
            continue  # no hole through the plate
        for edge in (y - r, y + r):
            if lo[1] < edge < hi[1]:  # a hole's wall, seen through the plate
                ax.plot([x, x + t], [edge, edge], color="black", lw=0.5, ls=(0, (3, 1.5)))
        if all(abs(y - other) > n for other in drawn):
            ax.plot([x - 1.5 * n, x + t + 1.5 * n], [y, y], color="0.3", lw=0.35, ls="-.")
            drawn.append(y)
    y = hi[1] + DIM_OFFSET * n
    for side in (x, x + t):
        ax.plot([side, side], [hi[1] + 0.8 * n, y + 1.5 * n], color="0.3", lw=0.3)
    _arrows(ax, (x, y), (x + t, y), n)
    text = f"{t:.2f}"
    ax.text(x + t / 2, y + 0.8 * n, text, fontsize=7, ha="center", va="bottom")
    ax.text(x + t / 2, lo[1] - 2.0 * n, "edge view", fontsize=6, ha="center", va="top", color="0.3")
    w, h = _text_size(text, n)
    label = _text_size("edge view", n, 6)
    half = max(w, label[0]) / 2
    # the view with its dimension and its name, which no leader crosses
    taken.texts.append((min(x - 1.5 * n, x + t / 2 - half), lo[1] - 2.0 * n - label[1],
                        max(x + t + 1.5 * n, x + t / 2 + half), y + 0.8 * n + h))


def _arrows(ax, a, b, n):
    """A dimension line from ``a`` to ``b`` with its arrowheads, drawn outside pointing in where
    the line is too short for them [mm of part]."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    style = dict(lw=0.5, color="black", mutation_scale=6, shrinkA=0, shrinkB=0)
    if np.hypot(*(b - a)) >= 6.0 * n:
        ax.annotate("", xy=b, xytext=a, arrowprops=dict(arrowstyle="<|-|>", **style))
        return
    u = (b - a) / np.hypot(*(b - a))
    for tip, back in ((a, a - 3.0 * n * u), (b, b + 3.0 * n * u)):
        ax.annotate("", xy=tip, xytext=back, arrowprops=dict(arrowstyle="-|>", **style))
    ax.plot(*np.array([a, b]).T, color="black", lw=0.5)


def _overall_size(ax, pts, n, taken):
    """The part's width above it and its height at its left, between its extreme points
    [mm of part]."""
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    west, east = pts[np.argmin(pts[:, 0])], pts[np.argmax(pts[:, 0])]
    south, north = pts[np.argmin(pts[:, 1])], pts[np.argmax(pts[:, 1])]
    y = hi[1] + DIM_OFFSET * n
    for p in (west, east):
        ax.plot([p[0], p[0]], [p[1] + 0.8 * n, y + 1.5 * n], color="0.3", lw=0.3)
    _arrows(ax, (lo[0], y), (hi[0], y), n)
    width = f"{hi[0] - lo[0]:.2f}"
    ax.text((lo[0] + hi[0]) / 2, y + 0.8 * n, width, fontsize=7, ha="center", va="bottom")
    x = lo[0] - DIM_OFFSET * n
    for p in (south, north):
        ax.plot([p[0] - 0.8 * n, x - 1.5 * n], [p[1], p[1]], color="0.3", lw=0.3)
    _arrows(ax, (x, lo[1]), (x, hi[1]), n)
    height = f"{hi[1] - lo[1]:.2f}"
    ax.text(x - 0.8 * n, (lo[1] + hi[1]) / 2, height, fontsize=7, ha="right", va="center", rotation=90)
    w, h = _text_size(width, n)
    taken.texts.append(((lo[0] + hi[0] - w) / 2, y, (lo[0] + hi[0] + w) / 2, y + 0.8 * n + h))
    w, h = _text_size(height, n)
    taken.texts.append((x - 0.8 * n - h, (lo[1] + hi[1] - w) / 2, x, (lo[1] + hi[1] + w) / 2))
    taken.regions += [(lo[0], hi[1], hi[0], y + 0.8 * n + h), (x - 0.8 * n - h, lo[1], lo[0], hi[1])]


def _anchor_x(ax, circles, pts, n, taken):
    """The anchor hole's centre x from the bore's, below the part [mm of part]."""
    (centre, hole), = circles[1:]
    c = centre * MM
    y = pts[:, 1].min() - DIM_OFFSET * n
    ax.plot([0, 0], [y - 1.5 * n, pts[:, 1].min() - 0.8 * n], color="0.3", lw=0.3)
    ax.plot([c[0]] * 2, [y - 1.5 * n, c[1] - hole * MM / 2], color="0.3", lw=0.3)
    _arrows(ax, (0.0, y), (c[0], y), n)
    text = f"{abs(c[0]):.2f}"
    ax.text(c[0] / 2, y - 0.8 * n, text, fontsize=7, ha="center", va="top")
    w, h = _text_size(text, n)
    taken.texts.append((c[0] / 2 - w / 2, y - 0.8 * n - h, c[0] / 2 + w / 2, y))
    taken.regions.append((min(0, c[0]), y - 1.5 * n, max(0, c[0]), pts[:, 1].min()))


def _mark_angle(ax, datum, circles, n):
    """The datum mark's angle from the +x axis: an arc with its arrowhead inside the part
    between the bore and the anchor hole [mm of part]."""
    if abs(datum.angle) < np.radians(1):
        return  # along the +x axis: no arc
    (centre, hole), = circles[1:]
    reach = min(datum.outer, np.hypot(*centre) - hole / 2) * MM
    radius = datum.inner * MM + 0.55 * (reach - datum.inner * MM)
    a = np.linspace(0.0, datum.angle, 64)
    arc = radius * np.column_stack((np.cos(a), np.sin(a)))
    ax.plot(*arc[:-1].T, color="tab:blue", lw=0.5)
    ax.annotate("", xy=arc[-1], xytext=arc[-4],
                arrowprops=dict(arrowstyle="-|>", lw=0.5, color="tab:blue", mutation_scale=5, shrinkA=0, shrinkB=0))


def _callouts(ax, outline, circles, part, n, taken, bounds):
    """The datum mark's name and angle, the anchor hole's Ø and centre, the bore's Ø and fit and
    the profile's file and tolerance, each on a leader to a free place in the view [mm of part]."""
    (_, bore), (anchor, hole) = circles
    d, lower, upper = bore * MM, *bore_limits(bore * MM)
    c = anchor * MM
    a_anchor = float(np.arctan2(c[1], c[0]))
    a_profile = _spread([a_anchor, part.datum.angle, np.pi / 2, np.pi, -np.pi / 2],
                        np.radians(np.arange(-165, 180, 30)))
    at, normal = _outline_normal(outline, a_profile)
    datum, notes = part.datum, _part_notes(part, circles)
    lines = [0.0, np.pi / 2, np.pi, -np.pi / 2, datum.angle]  # the centre lines and the mark
    items = [  # (the point the leader starts from as a function of its direction, text, the directions
        # it may take: towards ``prefer`` ± ``spread`` [rad], and those along which it may not run)
        (lambda a: datum.segment[1] * MM, f"M {np.degrees(datum.angle):.1f}° {_note(notes, 'datum')}", datum.angle,
         np.radians(75), [datum.angle]),
        (lambda a: c + hole * MM / 2 * np.array([np.cos(a), np.sin(a)]),
         f"Ø{hole * MM:.2f} anchor hole\ncentre x {c[0]:.2f}, y {c[1]:.2f}", a_anchor, np.pi / 2, [0.0, np.pi]),
        (lambda a: d / 2 * np.array([np.cos(a), np.sin(a)]),
         f"Ø{d:.2f} {BORE_FIT} bore\n{d + lower:.3f} to {d + upper:.3f}", np.radians(135), np.pi, lines),
        (lambda a: at, f"profile: {part.dxf}\n±{part.profile_tolerance * MM:.3g} {_note(notes, 'profile')}", normal,
         np.radians(75), []),
    ]
    for k, (start, text, prefer, spread, along) in enumerate(items):
        _callout(ax, start, text, (prefer, spread, along), n, taken, bounds, "tab:blue" if k == 0 else "black")


def _outline_normal(outline, angle) -> tuple[np.ndarray, float]:
    """The outline's sample point [mm] nearest the ray at polar ``angle`` [rad] and the angle
    [rad] of its outward normal (the tangent turned clockwise: the outline runs
    counter-clockwise)."""
    pts = outline.points
    k = int(np.argmin(_gap(np.arctan2(pts[:, 1], pts[:, 0]), angle)))
    tx, ty = pts[(k + 1) % len(pts)] - pts[k - 1]
    return pts[k] * MM, float(np.arctan2(-tx, ty))


def _callout(ax, start, text, directions, n, taken, bounds, colour="black"):
    """``text`` on a leader from ``start(direction)`` [mm of part]: of the directions every 15°
    within ``spread`` of ``prefer`` and at least :data:`LEADER_CLEAR` from every angle of
    ``along`` (``directions`` = (prefer, spread, along) [rad]), and the distances beyond it,
    the nearest place (ties: nearest ``prefer``) whose text box, on the side the leader leans
    to (either side of a steep one), clears what is ``taken`` (and its leader the texts) inside
    ``bounds``; failing any, the farthest inside them; failing that, ``prefer`` at the least
    distance. Its box is added to the texts."""
    w, h = _text_size(text, n)
    (x0, y0), (x1, y1) = bounds
    prefer, spread, along = directions
    best = None
    for a in np.radians(np.arange(0, 360, 15)):
        turn = _gap(a, prefer)
        if turn > spread + 1e-9 or any(_gap(a, line) < LEADER_CLEAR for line in along):
            continue
        u = np.array([np.cos(a), np.sin(a)])
        for side in ((1.0, -1.0) if abs(u[0]) < STEEP else (np.sign(u[0]),)):
            for dist in np.arange(LEADER, 100.0, 2.0) * n:
                place = _leader_place(start(a), u, dist, side, w, h, n)
                box = place[-1]
                if box[0] < x0 or box[2] > x1 or box[1] < y0 or box[3] > y1:
                    break  # further out leaves the view too
                blocked = _overlaps(box, taken.regions + taken.texts) or _crosses(place[0], place[1], taken.texts)
                key = (blocked, -dist if blocked else dist, turn)
                if best is None or key < best[0]:
                    best = (key, place)
                if not blocked:
                    break
    u = np.array([np.cos(prefer), np.sin(prefer)])
    p, end, side, tx, box = best[1] if best else _leader_place(start(prefer), u, LEADER * n, np.sign(u[0]) or 1.0,
                                                               w, h, n)
    taken.texts.append(box)
    shoulder = end + np.array([side * 3.0 * n, 0.0])
    ax.plot([p[0], end[0], shoulder[0]], [p[1], end[1], shoulder[1]], color=colour, lw=0.4)
    ax.text(tx, end[1], text, fontsize=7, ha="left" if side > 0 else "right", va="center", color=colour)


def _leader_place(p, u, dist, side, w, h, n):
    """A leader from ``p`` along ``u`` for ``dist``, its shoulder and text to ``side`` (±1) for
    a text ``w`` by ``h``: its start, its end, ``side``, the text's x and box [mm of part]."""
    end = p + dist * u
    tx = end[0] + side * 3.8 * n
    return p, end, side, tx, (min(tx, tx + side * w), end[1] - h / 2, max(tx, tx + side * w), end[1] + h / 2)


def _part_notes(part: PartNotes, circles) -> dict[str, str]:
    """The workshop sheet's notes by name, in their order: dimensions and general tolerances,
    the bore's fit, the profile's file and tolerance, thickness and material, the datum mark
    and how it sets the part's angle on its shaft, a mirrored part's turn, the checking sheet
    [mm]."""
    (_, bore), _ = circles
    datum = part.datum
    beta, hole = np.degrees(datum.angle), np.degrees(datum.anchor)
    length = (datum.outer - datum.inner) * MM
    world = int(round(np.degrees(datum.world))) % 360
    notes = {
        "units": f"Dimensions in mm; general tolerances {GENERAL_CLASS} unless stated.",
        "bore": f"Bore Ø{bore * MM:.2f} {BORE_FIT} (ISO 286-1), on the axis: the origin of every position here.",
        "profile": f"Profile: cut to {part.dxf} (its arcs within {part.fit_tolerance * MM:.3g} mm of the design), the cut "
        f"outline within ±{part.profile_tolerance * MM:.3g} mm of it: the profile tolerance the design's "
        "tolerance band assumes ([tolerances] profile).",
        "plate": f"Thickness {part.thickness * MM:.2f} mm" + (" ([workshop] stl)." if part.thickness_given else
                                                     " (no [workshop] stl: cadcam's default plate)."
                                                     ) + f" Material: {part.material}.",
        "datum": f"Datum mark M (layer MARK of {part.dxf}): a line engraved on the face as drawn, from the bore's edge "
        f"R{datum.inner * MM:.2f} to "
        f"R{datum.outer * MM:.2f}, at {beta:.1f}° ±{angular_tolerance(length):.2g}° from the +x axis (the ray "
        f"to the anchor point φ = 0; positive counter-clockwise as drawn; the anchor hole's centre at "
        f"{hole:.1f}°). Fit the part with the joint at θ = 0 and M pointing along the world's "
        f"{AXIS_WORDS[world]} axis ({world}°, the spec's frame), then fix it to its shaft.",
        **({"mirrored": MIRRORED_NOTE + "."} if part.mirrored else {}),
        "sheet 2": "Sheet 2: the design's radii and the cable's arc, for checking.",
    }
    return {name: f"{k}. {line}" for k, (name, line) in enumerate(notes.items(), 1)}


def _note(notes: dict, name: str) -> str:
    """``(note k)``: the reference to note ``name`` of ``notes`` (:func:`_part_notes`)."""
    return f"(note {list(notes).index(name) + 1})"


def part_table(part: PartNotes) -> list[tuple[str, str]]:
    """The cable and spring table's rows (label, text): the cable, then each spring on the
    part's mechanism: its force range, its installed length, where it is mounted and how long
    its cable is cut (mm, N)."""
    rows = _cable_rows(part)
    for row in part.springs:
        rows.append((row["name"], f"force {row['force'][0]:.4g} to {row['force'][1]:.4g} N over the joint range"))
        if row["part"] and row["part"] not in row["name"]:
            rows.append(("", f"catalogue part {row['part']}"))
        if "installed_length" in row:
            lo, hi = (v * MM for v in row["installed_length"])
            rows.append(("", f"installed length {lo:.1f} to {hi:.1f}"))
        if "mount" in row:
            x, y = (v * MM for v in row["mount"])
            rows.append(("", f"mount at ({x:.1f}, {y:.1f}), joint at {np.degrees(row['mount_angle']):.4g}°"))
        if "cable_length" in row:
            rows.append(("", f"cable cut length {row['cable_length'] * MM:.1f}, anchor hole to hook"))
    # an adjustment (a preload tensioning, when the design has one) adds its rows here: what
    # is set, its range and its setting for the design
    return rows


def _cable_rows(part: PartNotes) -> list[tuple[str, str]]:
    """The table's rows on the cable: from its report, or its diameter alone without one."""
    report = part.cable
    if report is None:
        d = part.cable_diameter * MM
        return [("Cable", f"Ø{d:.2f}; no [cable]: its load and bend are not checked" if d > 0 else
                 "an ideal thread (no diameter); no [cable]: not checked")]
    bend = report["curvature_radius_min"][part.profile] * MM
    return [("Cable", f"{report.get('name') or 'given in full'}, Ø{report['diameter'] * MM:.2f} {report['kind']}"),
            ("", f"peak tension {report['peak_tension']:.4g} N, working load {report['working_load']:.4g} N "
                 f"({report['breaking_load']:.4g} N / {report['safety_factor']:g})"),
            ("", f"least bend radius {report['min_bend_radius'] * MM:.2f}; the profile's least radius of "
                 f"curvature {bend:.2f}")]


def _column(fig, part: PartNotes, circles) -> None:
    """The notes, and under them the cable and spring table, in the column above the title
    block at the right of the sheet [mm of paper]."""
    x0, x1 = SHEET[0] - MARGIN - COLUMN, SHEET[0] - MARGIN
    line = LINE * COLUMN_FONT / 7.0
    fig.add_artist(Line2D([x0 / SHEET[0]] * 2, [(MARGIN + WORKSHOP_TITLE) / SHEET[1], 1 - MARGIN / SHEET[1]],
                          transform=fig.transFigure, color="black", lw=0.6))
    y = SHEET[1] - MARGIN - 3.0
    fig.text((x0 + 2) / SHEET[0], y / SHEET[1], "NOTES", fontsize=7, weight="bold", va="top")
    y -= line + 1.5
    for note in _part_notes(part, circles).values():
        text = textwrap.fill(note, NOTE_WIDTH, subsequent_indent="   ")
        fig.text((x0 + 2) / SHEET[0], y / SHEET[1], text, fontsize=COLUMN_FONT, va="top", linespacing=1.2)
        y -= (text.count("\n") + 1) * line + 1.0
    y -= 3.0
    fig.text((x0 + 2) / SHEET[0], y / SHEET[1], "CABLE AND SPRINGS (mm, N)", fontsize=7, weight="bold", va="top")
    y -= line + 1.5
    split = x0 + LABEL_COLUMN
    rows = part_table(part)
    for k, (label, value) in enumerate(rows):
        text, label = textwrap.fill(value, CELL_WIDTH), textwrap.fill(label, LABEL_WIDTH)
        height = (max(text.count("\n"), label.count("\n")) + 1) * line + 0.6
        if y - height - line < MARGIN + WORKSHOP_TITLE:  # the rest would run into the title block
            fig.text((x0 + 2) / SHEET[0], y / SHEET[1], f"… {len(rows) - k} rows more in result.json "
                     "(spring_installation, cable)", fontsize=COLUMN_FONT, va="top")
            break
        if label:
            fig.add_artist(Line2D([x0 / SHEET[0], x1 / SHEET[0]], [(y + 0.8) / SHEET[1]] * 2,
                                  transform=fig.transFigure, color="0.5", lw=0.4))
        fig.text((x0 + 2) / SHEET[0], y / SHEET[1], label, fontsize=COLUMN_FONT, va="top", weight="bold",
                 linespacing=1.2)
        fig.text((split + 1) / SHEET[0], y / SHEET[1], text, fontsize=COLUMN_FONT, va="top", linespacing=1.2)
        y -= height
