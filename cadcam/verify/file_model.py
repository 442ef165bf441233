"""The torque (or a differential pair's output x) of a design recomputed from its written files.

What a workshop receives is the file, not the polynomial: this module reads ``camN.dxf`` back
with ezdxf, rebuilds the outline from its arcs and lines (or a helical groove's centre line
``camN_groove.csv``, an open chain of chords wound turn after turn, projected on the plane as
the design model projects it) into a :class:`cadcam.physics.outline.FileOutline`, and computes
what that part does by plane geometry alone, sharing nothing with the NLP's symbolic model but
the spec's physical parameters (positions, senses, windings, spring rates, preloads and the
design's pre-extensions):

- each port's length L_p(θ) comes from its mechanism's file model
  (:meth:`cadcam.mechanisms.base.Mechanism.port_length_from_file`, in the mechanism's folder);
- a spring's extension is x_j = x₀_j + Σ_p P_jp (L_p(θ) − L_p(θ_ref)), and the joint torque
  τ = Σ_j (k_j x_j + F0_j) Σ_p P_jp dL_p/dθ, dL/dθ by a central difference;
- a differential pair's output x comes from its file model
  (:meth:`cadcam.mechanisms.base.Mechanism.output_from_file`).

The files are in the profile's own frame (:mod:`cadcam.physics.outline`): the cable anchored at
the first vertex on +x and wound counter-clockwise from it.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..library_files import libraries_imported
from ..physics.outline import STRAIGHT, FileOutline, outline_from_chain
from ..units import MM

with libraries_imported():  # ezdxf's ezdxf.ini: not from the working folder
    import ezdxf

#: DXF $INSUNITS code of millimetres (a groove's CSV, in millimetres, is read as such).
MILLIMETRES = 4
#: The columns of a groove's CSV the file model reads: its centre line's plane coordinates [mm].
GROOVE_COLUMNS = ("x_mm", "y_mm")
#: Step [rad] of the central difference dL/dθ: far below the turn of a points CSV's chords (a
#: follower's torque on a polygon jumps from chord to chord, and a wider step would average the
#: jumps away), far above the lengths' rounding (1e-17 m over it: 1e-10 of a moment arm).
STEP = 1e-7


def read_dxf(path) -> FileOutline:
    """The outline of a cadcam DXF: its PROFILE polyline (arcs as bulges) and HOLES circles.

    Raises
    ------
    ValueError
        If the file holds no single LWPOLYLINE on layer PROFILE.
    """
    doc = ezdxf.readfile(str(path))
    msp = doc.modelspace()
    lines = [e for e in msp.query("LWPOLYLINE") if e.dxf.layer == "PROFILE"]
    if len(lines) != 1:
        raise ValueError(f"{Path(path).name}: {len(lines)} LWPOLYLINEs on layer PROFILE, expected 1")
    xyb = np.array(list(lines[0].get_points(format="xyb")), dtype=float)
    circles = [(np.array([c.dxf.center.x, c.dxf.center.y]) / MM, 2 * c.dxf.radius / MM)
               for c in msp.query("CIRCLE") if c.dxf.layer == "HOLES"]
    return outline_from_chain(xyb[:, :2] / MM, xyb[:, 2], int(doc.header.get("$INSUNITS", 0)),
                              bool(lines[0].closed), circles)


def read_groove(path) -> FileOutline:
    """The centre line of a helical groove from ``camN_groove.csv`` (its columns
    :data:`GROOVE_COLUMNS` among others): the rows projected on the drum's plane (the pitch
    neglected, as the design model neglects it), joined by straight chords into an open chain
    from the anchor (the first row) that winds on turn after turn to the last row and does not
    close.

    Raises
    ------
    ValueError
        If the file lacks a column of :data:`GROOVE_COLUMNS` or has fewer than two rows.
    """
    xy = _columns(path, GROOVE_COLUMNS)
    return outline_from_chain(xy, np.zeros(len(xy)), MILLIMETRES, False, [], groove=True)


def _columns(path, columns: tuple[str, ...]) -> np.ndarray:
    """The ``columns`` of the CSV at ``path`` [mm] as metres (rows, len(columns)).

    Raises
    ------
    ValueError
        If the file lacks one of the columns or has fewer than two rows.
    """
    with open(path, encoding="utf-8") as f:
        header = f.readline().strip().split(",")
    missing = [c for c in columns if c not in header]
    if missing:
        raise ValueError(f"{Path(path).name}: no column {', '.join(missing)}")
    xy = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)[:, [header.index(c) for c in columns]] / MM
    if len(xy) < 2:
        raise ValueError(f"{Path(path).name}: {len(xy)} rows, at least 2 expected")
    return xy


def read_points(path) -> FileOutline:
    """The closed polygon of ``camN_points.csv`` (its columns :data:`GROOVE_COLUMNS`, the
    vertices counter-clockwise from the anchor): the outline a workshop joining the points by
    straight lines cuts. ValueError as :func:`read_groove`."""
    xy = _columns(path, GROOVE_COLUMNS)
    return outline_from_chain(xy, np.zeros(len(xy)), MILLIMETRES, True, [])


#: The commands of an SVG path that :func:`read_svg` reads (absolute moves, arcs, lines, close),
#: the ones ``cadcam.make.workshop.write_svg`` writes.
SVG_COMMANDS = "MALZ"


def read_svg(path) -> FileOutline:
    """The outline of a cadcam SVG: its one path (M, then an A arc or L line per segment, Z)
    and its circles, y negated back (SVG's y axis points down); ``units`` 4 where the drawing is
    at 1:1 in millimetres (its width in mm equal to its viewBox's), else 0.

    Raises
    ------
    ValueError
        If the file holds other than one path, or a command other than :data:`SVG_COMMANDS`.
    """
    import xml.etree.ElementTree as ET

    root = ET.parse(path).getroot()
    ns = {"svg": "http://www.w3.org/2000/svg"}
    paths = root.findall(".//svg:path", ns)
    if len(paths) != 1:
        raise ValueError(f"{Path(path).name}: {len(paths)} paths, expected 1")
    words = re.findall(r"[A-Za-z]|[-+0-9.eE]+", paths[0].get("d").replace(",", " "))
    if set(w for w in words if w.isalpha()) - set(SVG_COMMANDS) or words[0] != "M":
        raise ValueError(f"{Path(path).name}: a path of commands other than {', '.join(SVG_COMMANDS)}")
    flip = np.array([1.0, -1.0]) / MM
    points, bulges, i = [np.array(words[1:3], dtype=float) * flip], [], 3
    while words[i] != "Z":
        if words[i] == "L":
            end, bulge, i = np.array(words[i + 1:i + 3], dtype=float) * flip, 0.0, i + 3
        else:  # A rx ry rotation large-arc sweep x y
            radius, large, positive = float(words[i + 1]) / MM, words[i + 4] == "1", words[i + 5] == "1"
            end, i = np.array(words[i + 6:i + 8], dtype=float) * flip, i + 8
            half = np.arcsin(min(1.0, np.hypot(*(end - points[-1])) / (2 * radius)))
            bulge = np.tan((np.pi - half if large else half) / 2) * (1 if positive else -1)
        points.append(end)
        bulges.append(bulge)
    width, box = root.get("width", ""), [float(v) for v in root.get("viewBox", "0 0 0 0").split()]
    units = MILLIMETRES if width.endswith("mm") and abs(float(width[:-2]) - box[2]) <= 1e-6 * box[2] else 0
    circles = [(np.array([float(c.get("cx")), float(c.get("cy"))]) * flip, 2 * float(c.get("r")) / MM)
               for c in root.findall(".//svg:circle", ns)]
    return outline_from_chain(np.array(points[:-1]), np.array(bulges), units, True, circles)


def file_torque(problem, design, outlines: dict, thetas) -> np.ndarray:
    """Joint torques [N·m] (m, P) at the points ``thetas`` (m, P) of a problem whose mechanisms
    all have a file model (:meth:`cadcam.mechanisms.base.Mechanism.has_file_model`), from their
    file outlines (mechanism index → its profiles' FileOutlines).

    τ_i = Σ_j (k_j x_j + F0_j) Σ_p W_jp dL_p/dθ_i, x_j = x₀_j + Σ_p P_jp (L_p(θ) − L_p(θ_ref))
    (the energy V = Σ ½k x² + F0 x differentiated, Johnston2023 Eq. 14, 36; W = P unless the
    friction band's centre is tracked, :attr:`cadcam.physics.springs.Network.W`).
    """
    network = problem.network()
    P = thetas.shape[1]
    d, dd = np.zeros((network.P.shape[1], P)), np.zeros((network.P.shape[1], P))
    for g, (u, port) in enumerate(problem.ports):
        mech = problem.mechanisms[u]
        th, at = np.unique(thetas[mech.joint], return_inverse=True)  # a tensor grid repeats each angle
        # one call at every angle the port is needed at: the file model's cost is per call
        at_th, at_ref, ahead, behind = np.split(mech.port_length_from_file(
            outlines[u], port, np.r_[th, mech.reference_angle, th + STEP, th - STEP]), np.cumsum([th.size, 1, th.size]))
        d[g] = (at_th - at_ref)[at]
        dd[g] = ((ahead - behind) / (2 * STEP))[at]
    springs = problem.spring_parameters()
    k, preload = springs.rate, springs.preload
    force = k[:, None] * (np.asarray(design.preextension)[:, None] + network.P @ d) + preload[:, None]
    tau = np.zeros(thetas.shape)
    for i in range(thetas.shape[0]):
        on = network.port_joint == i
        tau[i] = np.sum(force * (network.W[:, on] @ dd[on]), axis=0)
    return tau


#: Largest gap [m] between the outline's arcs and the chords through their sampled points (the
#: samples' sagitta): how far a clearance may be read long.
SAGITTA = 1e-9
#: Spans by outline points measured at once (memory: some eight arrays of that many floats).
CLEARANCE_BLOCK = 500_000


def outline_points(outline: FileOutline) -> np.ndarray:
    """Points (K, 2) [m] of the whole closed outline, the anchor and every vertex among them,
    each arc sampled so finely that its chords stay within :data:`SAGITTA` of it."""
    a, b = outline.vertices, np.roll(outline.vertices, -1, axis=0)
    out = []
    for p, q, bulge in zip(a, b, outline.bulges):
        sweep = 4 * np.arctan(bulge)
        chord = q - p
        half = np.hypot(*chord) / 2
        if abs(bulge) < STRAIGHT or half == 0:
            out.append(p[None])
            continue
        radius = half / abs(np.sin(sweep / 2))
        n = int(np.ceil(abs(sweep) / (2 * np.arccos(max(-1.0, 1 - SAGITTA / radius))))) + 1
        # the centre lies off the chord's midpoint, to the left of a counter-clockwise arc
        centre = (p + q) / 2 + np.array([-chord[1], chord[0]]) / 2 / np.tan(sweep / 2)
        turn = np.linspace(0.0, sweep, n, endpoint=False)
        start = p - centre
        out.append(centre + np.stack([np.cos(turn) * start[0] - np.sin(turn) * start[1],
                                      np.sin(turn) * start[0] + np.cos(turn) * start[1]], axis=1))
    return np.concatenate(out)


def span_clearance(points: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Least signed distance [m] (n,) from the outline ``points`` (K, 2) to each free span from
    ``start`` to ``end`` (n, 2), the outline on the span's left: a point beside the span counts
    its distance from the span's line, positive on the left, negative on the right (the span
    runs through the part); a point beyond either end its distance from that end. NaN where a
    span is."""
    d = end - start
    length = np.hypot(*d.T)
    u = d / length[:, None]
    out = np.full(len(start), np.inf)
    px, py = points[:, 0], points[:, 1]
    for rows in np.array_split(np.arange(len(start)), max(1, len(start) * len(points) // CLEARANCE_BLOCK)):
        rx, ry = px[None] - start[rows, 0, None], py[None] - start[rows, 1, None]
        ux, uy = u[rows, 0, None], u[rows, 1, None]
        along = rx * ux + ry * uy
        beside = (along > 0) & (along < length[rows, None])
        side = np.where(beside, ux * ry - uy * rx, np.inf).min(axis=1)
        ex, ey = px[None] - end[rows, 0, None], py[None] - end[rows, 1, None]
        # the nearer end's squared distance, its root taken once per span after the least
        ends = np.where(beside, np.inf, np.minimum(rx * rx + ry * ry, ex * ex + ey * ey)).min(axis=1)
        out[rows] = np.minimum(side, np.sqrt(ends))
    return np.where(np.isfinite(length), out, np.nan)
