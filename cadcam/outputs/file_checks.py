"""Every workshop file read back and checked against its own tolerance: the rows of
``verification.md``'s table of files (:mod:`cadcam.outputs.verification`).

A row names a file, its check (:data:`FILE_CHECKS`: unit, sense, meaning), what was measured
in the file as written and the limit it is held to. The DXF's rows restate its report (the torque
recomputed from it, its distance from the designed outline, its walls, convexity and the cable's
clearance); the others are measured here, each from its own file:

- ``camN.svg``: its arcs (the DXF's fit, printed to 1e-9 mm) from the designed outline, within
  the fit's tolerance and the printing's rounding, their ends on the DXF's; its circles against
  the DXF's holes;
- ``camN_points.csv``: its polygon from the designed outline, within its chordal tolerance, every
  vertex on the DXF's arcs within the fit; the torque (or x) recomputed from the polygons, by the
  same file models as the DXF's, within the design's requirement;
- ``camN.stl`` and ``camN.step``: a closed surface, the thickness, the face on z = 0 (its outer
  boundary from the designed outline and its vertices from the DXF's arcs, its holes against the
  DXF's circles) and the volume against the exact one, (area inside the DXF's arcs − the holes) ×
  thickness less the groove's band × its width, within what the file's polygons (or the kernel)
  can differ by.

Every vertex is checked, not samples only, so that a file changed in one place fails.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..make.biarc import arc_geometry, chain_measures, chain_segments, inward_band, signed_distance
from ..make.workshop import ROUNDING
from ..physics.outline import NOTCH, STRAIGHT, outline_from_chain
from ..verify.file_model import MILLIMETRES, read_svg
from ..verify.solid_files import read_step, read_stl
from .verification import WALLS, chain_distance, file_error, model_gap_limit

#: Each check of a file, declared once: name → (unit, sense of its limit, what is measured).
FILE_CHECKS = {
    "torque": ("N·m", "≤", "largest |file − design| of a joint's torque recomputed from the files, over the grid "
                           "(the table recomputed from the files; `where`: the joint): `required`"),
    "x": ("m", "≤", "largest |file − design| of a differential pair's output x recomputed from the files "
                    "(the table recomputed from the files; `where`: the mechanism): `required`"),
    "model_gap": ("N·m", "≤", "under a force model: the design's largest |τ_force − τ_energy| over the grid, the torque "
                               "the design claims against the one its part does (∂V/∂θ, which the files are checked "
                               "against; `where`: the joint): max(1 × design_max_abs_error, 1e-4 × peak), "
                               "cadcam.outputs.verification.MODEL_GAP_SHARE"),
    "read": ("-", "=", "the file reads back as its format (else its reader's message)"),
    "units": ("-", "=", "the file's length unit: millimetres (an SVG: its width in mm equal to its viewBox's, 1:1)"),
    "outline": ("m", "≤", "largest distance from the designed outline (a groove: the designed spiral), at 4096 "
                          "points, to the outline the file holds — its arcs, its polygon, its solid's face on z = 0 — "
                          "within the file's own tolerance"),
    "vertices": ("m", "≤", "largest distance from every vertex the file holds (an SVG's arcs' ends, a points CSV's "
                           "rows, an STL face's polygon; a STEP: points along its face's outer edges) to the DXF's "
                           "arcs: the vertices lie on the designed outline, which the DXF keeps within its fit, "
                           "and a file's rounding"),
    "walls": ("m", "≥", "the least of bore_wall_m, anchor_wall_m and holes_wall_m, measured with a sign from the DXF's "
                        "arcs: wall_rule_m less 1 nm of rounding"),
    "convex": ("m", "≤", "concavity_m: how far the DXF's arcs turn inwards (1 nm of rounding)"),
    "cable_clearance": ("m", "≥", "cable_clearance_m: the least distance of the cable's free span from the part, "
                                  "against its radius less 1 nm"),
    "holes_found": ("-", "=", "holes the file holds (an STL or STEP: the inner boundaries of its face on z = 0) "
                              "against the DXF's bore and anchor hole"),
    "holes_inside": ("m", "≤", "how far any hole's edge reaches inside its circle in the DXF (its centre's offset "
                               "less its inscribed radius's shortfall): a pin or shaft of the hole's diameter fits "
                               "where this is within the file's rounding"),
    "holes_outside": ("m", "≤", "how far any hole's edge lies outside its circle in the DXF (its centre's offset "
                                "and its circumscribed radius beyond it): within the file's tolerance"),
    "closed": ("-", "=", "edges of the mesh not shared by exactly two facets, once each way (0: watertight)"),
    "thickness": ("m", "≤", "|the solid's extent along z − the thickness|"),
    "volume": ("m³", "≤", "|the solid's volume − (area inside the DXF's arcs − the holes' circles) × thickness + "
                          "(the groove's band (cadcam.make.biarc.inward_band) − the holes' area within it) × its "
                          "width|, within what its polygons can differ by (perimeters × chordal tolerances × "
                          "thickness), its rounding and the error of a hole's share of the band where the band's "
                          "inner edge crosses the hole (integrated on the DXF's exact arcs)"),
}

#: How far [m] the SVG's arcs, rebuilt from ends and radii printed to 1e-9 mm (1e-12 m), may
#: move: ten of their last places.
SVG_ROUNDING = 1e-11
#: The last printed place [m] of the SVG's circles (1e-6 mm).
SVG_CIRCLE_PLACE = 1e-9
#: How far [m] a STEP's curves may lie from the arcs written (OpenCascade's confusion
#: tolerance, 1e-7 mm, times ten).
STEP_ROUNDING = 1e-9
#: Share of its volume by which a STEP's volume, integrated by the kernel on the file's own
#: arcs, may differ from the exact one.
STEP_VOLUME_SHARE = 1e-9


def row(file: str, check: str, measured, limit, where: str | None = None) -> dict:
    """One check of one file (:data:`FILE_CHECKS`), judged by its sense (a measure None:
    could not be made, failed)."""
    sense = FILE_CHECKS[check][1]
    if measured is None:
        ok = False
    elif sense == "≤":
        ok = measured <= limit
    elif sense == "≥":
        ok = measured >= limit
    else:
        ok = measured == limit
    return {"file": file, "check": check, **({"where": where} if where else {}), "measured": measured,
            "limit": limit, "passed": bool(ok)}


def quantity_rows(checks: list[dict]) -> list[dict]:
    """The torque and output checks recomputed from files (``files``: their names) as rows;
    those not recomputed are left to the checks table's note."""
    return [row(c["files"], c["quantity"] if c["quantity"] == "x" else "torque", c["file_max_abs_error"],
                c["required"], c["where"]) for c in checks if "passed" in c]


def model_gap_rows(checks: list[dict]) -> list[dict]:
    """Under a force model, each torque check's ``model_gap`` as a row of the files it is
    recomputed from (:func:`cadcam.outputs.verification.model_gap_limit`)."""
    return [row(c["files"], "model_gap", c["model_gap"], model_gap_limit(c), c["where"])
            for c in checks if "model_gap" in c]


def dxf_rows(name: str, cam: dict, units: int) -> list[dict]:
    """A DXF's (or a groove CSV's) own rows, from its report (:func:`cadcam.outputs.verification.cam_report`)."""
    rows = [row(name, "units", "mm" if units == MILLIMETRES else f"$INSUNITS {units}", "mm"),
            row(name, "outline", cam["file_error_m"], cam["fit_tolerance_m"])]
    if "concavity_m" in cam:
        walls = [cam[w] for w in WALLS if w in cam]
        rows += [row(name, "convex", cam["concavity_m"], NOTCH),
                 row(name, "walls", min(walls) if len(walls) == len(WALLS) else None, cam["wall_rule_m"] - ROUNDING)]
    if "cable_clearance_m" in cam:
        rows.append(row(name, "cable_clearance", cam["cable_clearance_m"], cam["cable_radius_m"] - NOTCH))
    return rows


def svg_rows(name: str, outline, svg, dxf, fit: float) -> list[dict]:
    """An SVG read back (``svg``) against the designed ``outline``, the fit's tolerance ``fit``
    [m] and the DXF read back (``dxf``): its arcs are the DXF's, printed."""
    rows = [row(name, "units", "mm" if svg.units == MILLIMETRES else "not 1:1 mm", "mm"),
            row(name, "outline", file_error(outline, svg), fit + SVG_ROUNDING),
            row(name, "vertices", float(chain_distance(svg.vertices, dxf).max()), SVG_ROUNDING)]
    holes = [(c, d / 2, d / 2) for c, d in svg.circles]
    return rows + hole_rows(name, holes, dxf.circles, 0.0, SVG_CIRCLE_PLACE)


def points_rows(name: str, outline, points, dxf, tolerance: float, fit: float) -> list[dict]:
    """A points CSV's polygon read back (``points``) against the designed ``outline`` and its
    chordal ``tolerance`` [m], its vertices against the DXF ``dxf`` and its ``fit`` [m]."""
    return [row(name, "outline", file_error(outline, points), tolerance),
            row(name, "vertices", float(chain_distance(points.vertices, dxf).max()), fit)]


def hole_rows(name: str, found: list, circles: list, tolerance: float, rounding: float) -> list[dict]:
    """The holes ``found`` in a file (centre [m], inscribed and circumscribed radius [m]) against
    the DXF's ``circles`` (centre, diameter), each matched with the nearest: how far any edge
    reaches inside its circle (within ``rounding``) and lies outside it (within ``tolerance`` +
    ``rounding``), and how many there are."""
    rows = [row(name, "holes_found", len(found), len(circles))]
    if len(found) != len(circles) or not circles:
        return rows + [row(name, "holes_inside", None, rounding), row(name, "holes_outside", None, tolerance + rounding)]
    inside, outside = [], []
    for centre, diameter in circles:
        c, inner, outer = min(found, key=lambda hole: np.hypot(*(hole[0] - centre)))
        offset, radius = float(np.hypot(*(c - centre))), diameter / 2
        inside.append(radius - inner + offset)
        outside.append(outer + offset - radius)
    return rows + [row(name, "holes_inside", max(inside), rounding),
                   row(name, "holes_outside", max(outside), tolerance + rounding)]


def solid_rows(name: str, solid, outline, dxf, thickness: float, groove: tuple[float, float],
               tolerance: float, fit: float) -> list[dict]:
    """An STL or STEP read back (``solid``: :class:`cadcam.verify.solid_files.Solid`) against
    the designed ``outline``, the DXF ``dxf``, the ``thickness`` [m], the groove (depth, width)
    [m], its polygons' chordal ``tolerance`` [m] (0: a STEP, the DXF's arcs) and the DXF's
    ``fit`` [m]."""
    rounding = solid.rounding if tolerance else STEP_ROUNDING
    face = solid.outline if len(solid.outline) > 2 else None
    vertices = float(chain_distance(face, dxf).max()) if face is not None else None
    if tolerance:  # a polygon: also the designed outline's distance from it
        error = file_error(outline, outline_from_chain(face, np.zeros(len(face)), MILLIMETRES, True, [])) \
            if face is not None else None
        shape = [row(name, "outline", error, tolerance + rounding), row(name, "vertices", vertices, fit + rounding)]
    else:
        shape = [row(name, "vertices", vertices, rounding)]
    return [row(name, "closed", solid.open_edges, 0),
            row(name, "thickness", abs(solid.z_range[1] - solid.z_range[0] - thickness), rounding), *shape,
            *hole_rows(name, solid.holes, dxf.circles, tolerance, rounding),
            _volume_row(name, solid, dxf, thickness, groove, tolerance, fit)]


def _volume_row(name: str, solid, dxf, thickness: float, groove: tuple[float, float], tolerance: float,
                fit: float) -> dict:
    """The solid's volume against the exact one, (area inside the DXF's arcs − the holes) ×
    thickness less the groove's band (less the holes' share of it) × its width: an STL's within
    what an inscribed polygon, circumscribed holes and a DXF within its fit of the design can
    differ by, the polygon's band from the exact one's and its rounding; a STEP's, of the DXF's
    own arcs, within :data:`STEP_VOLUME_SHARE`; either also within the error of the holes'
    share of the band where the band crosses a hole (:func:`_holes_in_band`)."""
    area, length = chain_measures(dxf.vertices, dxf.bulges)
    (depth, width), holes = groove, dxf.circles
    band = inward_band(dxf.vertices, dxf.bulges, depth) if depth else 0.0
    shared, error = _holes_in_band(dxf, depth) if depth else (0.0, 0.0)
    exact = (area - sum(np.pi * d**2 / 4 for _, d in holes)) * thickness - width * (band - shared)
    if not tolerance:
        return row(name, "volume", abs(solid.volume - exact), STEP_VOLUME_SHARE * abs(exact) + width * error)
    polygon = inward_band(solid.outline, np.zeros(len(solid.outline)), depth) if depth and len(solid.outline) > 2 \
        else band
    slack = (thickness * (length * (tolerance + fit) + sum(np.pi * d for _, d in holes) * tolerance)
             + width * (abs(polygon - band) + error) + solid.surface * solid.rounding)
    return row(name, "volume", abs(solid.volume - exact), slack)


def _holes_in_band(dxf, depth: float) -> tuple[float, float]:
    """The area [m²] of the DXF's holes within a groove's band ``depth`` [m] deep (the groove
    cuts no material there, so the band's area counts it once, not twice), and how far it may
    be off [m²]: a hole wholly within the band (its far edge no deeper than it below the exact
    arcs) counts whole; one wholly deeper, not at all; one the band's inner edge crosses, its
    share by :func:`band_in_hole`, exact but for rounding, or the whole hole's area off where
    that cannot say (the volume then fails unless that little)."""
    shared = error = 0.0
    for centre, diameter in dxf.circles:
        radius = diameter / 2
        deep = float(signed_distance(np.asarray(centre, dtype=float)[None], dxf.vertices, dxf.bulges)[0])
        if deep + radius <= depth:
            shared += np.pi * radius**2
        elif deep - radius < depth:
            area = band_in_hole(dxf, centre, radius, depth)
            shared += np.pi * radius**2 / 2 if area is None else area
            error += np.pi * radius**2 / 2 if area is None else BAND_ROUNDING * np.pi * radius**2
    return float(shared), float(error)


#: Share of a hole's area by which :func:`band_in_hole`'s closed form may be off (rounding).
BAND_ROUNDING = 1e-12
#: Gap [m] between the offsets of two segments' common end below which they join (rounding).
JOINED = 1e-12


def band_in_hole(dxf, centre, radius: float, depth: float) -> float | None:
    """Area [m²] of the hole (``centre``, ``radius`` [m]) within the groove's band ``depth`` [m]
    deep below the DXF's exact arcs, in closed form: the hole's area less that of its part
    deeper than the band, whose boundary is the chain offset inwards by ``depth`` (each arc's
    concentric arc, each line moved along its normal) where it runs inside the hole, and the
    hole's circle where it runs deeper than the band; its area is Green's ∮ (x dy − y dx)/2
    over those arcs and lines, each in closed form. None where the offset within the hole is no
    chain of such pieces (an arc there of radius ≤ ``depth``, or a corner whose offsets part),
    for which this has no closed form."""
    c = np.asarray(centre, dtype=float)
    a, b, bulges = chain_segments(dxf.vertices - c, dxf.bulges)  # the hole's centre at the origin
    arc = np.abs(bulges) >= STRAIGHT
    pieces, cuts = [], []  # the offset's pieces inside the hole; the hole's angles where it crosses it
    ends = np.zeros((len(a), 2, 2))  # each segment's offset start and end
    for k in range(len(a)):
        if arc[k]:
            middle, bent, sweep = arc_geometry(a[k], b[k], bulges[k])
            rho = bent - depth  # a counter-clockwise arc's centre lies inside: its offset is concentric
            if rho <= 0:
                if _near(a[k], b[k], middle, abs(bent), radius + depth):
                    return None
                ends[k] = np.nan
                continue
            start = np.arctan2(*(a[k] - middle)[::-1])
            ends[k] = middle + rho * np.array([[np.cos(start), np.sin(start)],
                                               [np.cos(start + sweep), np.sin(start + sweep)]])
            for lo, hi in _arc_inside(middle, rho, start, sweep, radius):
                pieces.append((rho**2 * (hi - lo) + rho * (middle[0] * (np.sin(hi) - np.sin(lo))
                                                           - middle[1] * (np.cos(hi) - np.cos(lo)))) / 2)
                cuts += [np.arctan2(*(middle + rho * np.array([np.cos(t), np.sin(t)]))[::-1])
                         for t, crossed in ((lo, lo > start), (hi, hi < start + sweep)) if crossed]
        else:
            d = b[k] - a[k]
            inward = np.array([-d[1], d[0]]) / np.hypot(*d) * depth
            p, q = a[k] + inward, b[k] + inward
            ends[k] = p, q
            for lo, hi in _line_inside(p, q, radius):
                u, v = p + lo * (q - p), p + hi * (q - p)
                pieces.append((u[0] * v[1] - u[1] * v[0]) / 2)
                cuts += [np.arctan2(*w[::-1]) for w, crossed in ((u, lo > 0), (v, hi < 1)) if crossed]
    parted = np.hypot(*(ends[:, 1] - np.roll(ends[:, 0], -1, axis=0)).T)
    near = np.minimum(np.hypot(*ends[:, 1].T), np.hypot(*np.roll(ends[:, 0], -1, axis=0).T)) < radius + depth
    if np.any((~(parted <= JOINED)) & near):  # a corner (or a vanished arc) by the hole
        return None
    cuts = np.sort(np.mod(cuts, 2 * np.pi))
    if cuts.size:
        spans = np.diff(np.append(cuts, cuts[0] + 2 * np.pi))
        middles = cuts + spans / 2
        deeper = signed_distance(c + radius * np.column_stack([np.cos(middles), np.sin(middles)]), dxf.vertices,
                                 dxf.bulges) > depth
        pieces.append(radius**2 * np.sum(spans[deeper]) / 2)
    elif signed_distance(c[None] + [[radius, 0.0]], dxf.vertices, dxf.bulges)[0] > depth:
        pieces.append(np.pi * radius**2)  # the hole's circle deeper than the band all round
    return float(np.pi * radius**2 - sum(pieces))


def _near(a, b, middle, bent: float, reach: float) -> bool:
    """Whether an arc (ends ``a``, ``b``, centre ``middle``, radius ``bent``) comes within
    ``reach`` [m] of the origin (its circle does, and so might the arc)."""
    return bool(abs(np.hypot(*middle) - bent) < reach or min(np.hypot(*a), np.hypot(*b)) < reach)


def _arc_inside(middle, rho: float, start: float, sweep: float, radius: float) -> list[tuple[float, float]]:
    """The angles [rad] (from ``start`` over ``sweep`` > 0) of the arc about ``middle`` of radius
    ``rho`` that lie inside the circle of ``radius`` about the origin, as (from, to) pairs."""
    s = np.hypot(*middle)
    if s >= rho + radius:  # apart
        return []
    if s + rho <= radius:  # the whole circle inside the hole
        return [(start, start + sweep)]
    if rho >= s + radius:  # the hole inside the arc's circle: no crossing
        return []
    towards = np.arctan2(-middle[1], -middle[0])  # the direction from the arc's centre to the hole's
    half = np.arccos(np.clip((rho**2 + s**2 - radius**2) / (2 * rho * s), -1.0, 1.0))
    lo = start + np.mod(towards - half - start, 2 * np.pi)
    out = []
    for first in (lo - 2 * np.pi, lo):  # the window about the direction, and its turn before
        a, b = max(first, start), min(first + 2 * half, start + sweep)
        if a < b:
            out.append((a, b))
    return out


def _line_inside(p, q, radius: float) -> list[tuple[float, float]]:
    """The fractions (from, to) of the segment from ``p`` to ``q`` inside the circle of
    ``radius`` about the origin."""
    d = q - p
    aa, bb, cc = d @ d, 2 * p @ d, p @ p - radius**2
    disc = bb**2 - 4 * aa * cc
    if disc <= 0:
        return []
    root = np.sqrt(disc)
    lo, hi = max((-bb - root) / (2 * aa), 0.0), min((-bb + root) / (2 * aa), 1.0)
    return [(lo, hi)] if lo < hi else []


def read_back(reader, path: Path, checks) -> list[dict]:
    """The rows ``checks(file)`` gives of the file at ``path`` read by ``reader``; a file that
    does not read back (ValueError) fails with the reader's message."""
    try:
        file = reader(path)
    except ValueError as exc:
        return [row(path.name, "read", str(exc), "read")]
    return checks(file)


def svg_check(path: Path, outline, dxf, fit: float) -> list[dict]:
    """The rows of the SVG at ``path`` (:func:`svg_rows`)."""
    return read_back(read_svg, path, lambda svg: svg_rows(path.name, outline, svg, dxf, fit))


def solid_check(path: Path, outline, dxf, workshop, tolerance: float, fit: float) -> list[dict]:
    """The rows of the STL (``tolerance`` [m]: its polygons' chordal tolerance) or STEP
    (``tolerance`` 0) at ``path`` (:func:`solid_rows`), the ``workshop``'s thickness and groove."""
    return read_back(read_stl if tolerance else read_step, path, lambda solid: solid_rows(
        path.name, solid, outline, dxf, workshop.stl, (workshop.groove_depth, workshop.groove_width), tolerance, fit))
