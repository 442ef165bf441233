"""A workshop sheet of a cam at true scale: A4 landscape, PNG or PDF, written atomically.

Views only: the outline, holes and their checks come from :mod:`cadcam.views.workshop`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle

from ..files import atomic_path
from .workshop import MM, Outline, holes

SHEET = (297.0, 210.0)
"""A4 landscape [mm of paper]."""
MARGIN = 10.0
"""Blank border of the sheet [mm of paper]."""
NOTES = 30.0
"""Height of the band for title and notes at the foot of the sheet [mm of paper]."""
REDUCTIONS = (1, 2, 5, 10, 20, 50, 100)
"""Scales 1:n tried in turn until the cam fits the drawing area."""
DPI = 300
"""Resolution of a PNG sheet; printed at this resolution it is at true scale."""
INCH = 25.4
"""Millimetres per inch."""


def draw_sheet(path, outline: Outline, bore_diameter: float, anchor_diameter: float,
               rho_min: float, rho_max: float, title: str) -> int:
    """Draw the cam on an A4 landscape sheet, 1 mm of paper per mm of cam when it fits.

    The designed (wrapped) arc is drawn thick and red, the closing arc thin and black; the bore,
    the anchor hole, centre lines, the radius limits ρ_min and ρ_max as dashed circles (each
    only if it fits on the sheet), a 10 mm scale bar and notes with the sizes in millimetres.
    A cam too large for A4 at 1:1 is drawn at the first of 1:2, 1:5, 1:10, … that fits; the
    title always states the scale.

    Parameters
    ----------
    path : path-like
        ``.png`` (at DPI dots per inch) or ``.pdf``.
    outline : Outline
    bore_diameter, anchor_diameter : float
        [m], checked by :func:`cadcam.views.workshop.holes`.
    rho_min, rho_max : float
        Radius limits of the design [m].
    title : str

    Returns
    -------
    int
        n of the scale 1:n.
    """
    fmt = Path(path).suffix.lower().lstrip(".")
    if fmt not in ("png", "pdf"):
        raise ValueError(f"path = {str(path)!r}: the sheet is written as .png or .pdf")
    circles = holes(outline, bore_diameter, anchor_diameter)
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
    shown = _draw_limits(ax, centre, half, {"ρ_min": rho_min, "ρ_max": rho_max})
    _notes(fig, outline, circles, title, n, rho_min, rho_max, shown)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=fmt, dpi=DPI)
    return n


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


def _draw_limits(ax, centre, half, limits) -> list[str]:
    """Dashed circles of the radius ``limits`` that fit the view; returns their names."""
    shown = [name for name, r in limits.items() if np.all(np.abs(centre) + r * MM <= half)]
    for name in shown:
        r = limits[name] * MM
        ax.add_patch(_circle(np.zeros(2), r, ls="--", lw=0.5, color="0.45"))
        ax.annotate(f"{name} = {r:.2f}", (r / np.sqrt(2), r / np.sqrt(2)), fontsize=7,
                    color="0.35")
    return shown


def _circle(centre, radius, **style):
    """An unfilled circle patch."""
    return Circle(tuple(centre), radius, fill=False, **style)


def _notes(fig, outline, circles, title, n, rho_min, rho_max, shown):
    """Title, sizes and a 10 mm scale bar in the band at the foot of the sheet."""
    (_, bore), (anchor, hole) = circles
    lo, hi = outline.rho_range
    limits = f"radius limits ρ_min = {rho_min * MM:.2f}, ρ_max = {rho_max * MM:.2f}"
    off = [name for name in ("ρ_min", "ρ_max") if name not in shown]
    lines = [
        f"Bore Ø{bore * MM:.2f} on the rotation axis (origin); anchor hole Ø{hole * MM:.2f} "
        f"at x = {anchor[0] * MM:.2f}, y = {anchor[1] * MM:.2f}.",
        f"Outline radius {lo * MM:.2f} to {hi * MM:.2f}. Red: designed (wrapped) arc, "
        f"φ = 0° to {np.degrees(outline.phi_end):.1f}° from the anchor point; black: closing arc.",
        f"Dashed: {limits}" + (f" ({', '.join(off)} off the sheet)." if off else "."),
    ]
    x0, y0 = MARGIN / SHEET[0], (MARGIN + NOTES) / SHEET[1]
    fig.text(x0, y0 - 0.035, f"{title} — scale 1:{n}", fontsize=12, weight="bold")
    fig.text(x0, y0 - 0.06, "Dimensions in mm.\n" + "\n".join(lines), fontsize=8, va="top",
             linespacing=1.5)
    bar = 10 / n / SHEET[0]  # 10 mm of cam as a fraction of the sheet width
    right, foot = 1 - MARGIN / SHEET[0], MARGIN / SHEET[1] + 0.01
    fig.add_artist(Line2D([right - bar, right], [foot, foot], color="black", lw=2))
    fig.text(right - bar / 2, foot + 0.01, "10 mm", ha="center", fontsize=8)
