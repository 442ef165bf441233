"""A closed outline as a chain of circular arcs, tangent-continuous where the outline is: the
biarc fit that the DXF and SVG files carry.

Between two points of the outline with their tangents, a biarc is the pair of circular arcs,
meeting tangentially, that starts at the first point along the first tangent and ends at the
second along the second (Bolton 1975; the "equal tangent lengths" joint of Meek & Walton 1992,
Sec. 2). Its error falls as the cube of the interval, so a few hundred arcs carry a cam to a
few nanometres where a polygon would need tens of thousands of chords. The chain is stored as
LWPOLYLINE vertices with bulges: the bulge of a segment is tan(sweep/4), positive
counter-clockwise, zero for a straight segment.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..physics.outline import STRAIGHT

if TYPE_CHECKING:
    from .workshop import Outline

TWO_PI = 2 * np.pi

#: Intervals per radian of each arc (designed, closing) that the fit starts from.
START_DENSITY = 4.0
#: Points of the outline inside each interval at which the fit's distance is measured.
ERROR_SAMPLES = 24
#: Factor on a sampled largest distance for what falls between the samples (measured on the
#: Ludovico2021 pulleys against an exact point-to-arc distance: 0.6 % at 24 samples).
SAMPLE_SPARE = 1.05
#: Halvings of an interval the fit may make before it gives up (2⁻³⁰ of a turn: far below any
#: length a file holds).
MAX_ROUNDS = 30
#: 1 − cos of the angle between two tangents below which they are parallel (the joint of the
#: general formula loses its digits there).
PARALLEL = 1e-12


@dataclass(frozen=True)
class ArcChain:
    """A closed chain of circular arcs and straight segments [m].

    Attributes
    ----------
    vertices : ndarray, shape (N, 2)
        Start of each segment, counter-clockwise from the outline's anchor (φ = 0); segment i
        runs from vertex i to vertex i + 1 (the last back to vertex 0).
    bulges : ndarray, shape (N,)
        tan(sweep/4) of each segment (sweep > 0 counter-clockwise).
    error : float
        Largest distance [m] measured from the outline to the chain (the sampled largest,
        raised by :data:`SAMPLE_SPARE` for what the samples miss between them).
    """

    vertices: np.ndarray
    bulges: np.ndarray
    error: float

    def sample(self, per_segment: int = 8) -> np.ndarray:
        """Points [m] along the chain, ``per_segment`` per segment from its start (N·per_segment, 2)."""
        a = self.vertices
        b = np.roll(a, -1, axis=0)
        s = np.arange(per_segment) / per_segment
        return np.concatenate([arc_points(p, q, k, s) for p, q, k in zip(a, b, self.bulges)])


def arc_geometry(a, b, bulge):
    """Centre [m], signed radius [m] (> 0 counter-clockwise) and sweep [rad] of the arc from
    ``a`` to ``b`` with ``bulge`` (broadcast over leading axes; not for straight segments)."""
    chord = b - a
    length = np.linalg.norm(chord, axis=-1)
    sweep = 4 * np.arctan(bulge)
    left = np.stack([-chord[..., 1], chord[..., 0]], axis=-1) / length[..., None]
    centre = (a + b) / 2 + left * (length / (2 * np.tan(sweep / 2)))[..., None]
    return centre, length / (2 * np.sin(sweep / 2)), sweep


def arc_points(a, b, bulge: float, s) -> np.ndarray:
    """Points at fractions ``s`` of the arc (or segment) from ``a`` to ``b`` with ``bulge``."""
    s = np.asarray(s, dtype=float)
    if abs(bulge) < STRAIGHT:
        return a + s[:, None] * (b - a)
    centre, _, sweep = arc_geometry(a, b, bulge)
    start = a - centre
    ang = sweep * s
    c, si = np.cos(ang), np.sin(ang)
    return centre + np.column_stack([c * start[0] - si * start[1], si * start[0] + c * start[1]])


def arc_distance(points, a, b, bulge) -> np.ndarray:
    """Distance from ``points`` (..., k, 2) to the arcs from ``a`` to ``b`` (..., 1, 2) with
    ``bulge`` (..., 1): to the circle where the point projects inside the arc's sweep, to the
    nearer end otherwise; straight segments as segments."""
    ends = np.minimum(np.linalg.norm(points - a, axis=-1), np.linalg.norm(points - b, axis=-1))
    straight = np.abs(bulge) < STRAIGHT
    safe = np.where(straight, 1.0, bulge)
    centre, radius, sweep = arc_geometry(a, b, safe)
    to_p, to_a = points - centre, a - centre
    turn = np.arctan2(to_a[..., 0] * to_p[..., 1] - to_a[..., 1] * to_p[..., 0],
                      np.sum(to_a * to_p, axis=-1))  # from a to the point, about the centre
    within = np.mod(turn * np.sign(sweep), TWO_PI) <= np.abs(sweep)
    circle = np.abs(np.linalg.norm(to_p, axis=-1) - np.abs(radius))
    return np.where(straight, segment_distance(points, a, b), np.where(within, circle, ends))


def chain_segments(vertices, bulges):
    """Starts, ends (N, 2) and bulges (N,) of the closed chain ``vertices``/``bulges``: segment
    i runs from vertex i to vertex i + 1, the last back to vertex 0."""
    vertices = np.asarray(vertices, dtype=float)
    return vertices, np.roll(vertices, -1, axis=0), np.asarray(bulges, dtype=float)


def winding_number(points, vertices, bulges) -> np.ndarray:
    """How many times the closed chain ``vertices``/``bulges`` [m] winds counter-clockwise round
    each of ``points`` (k, 2) [m]: 1 inside a counter-clockwise outline, 0 outside.

    The chain's region is the polygon of its vertices with each arc's circular segment (the
    lens between the arc and its chord) added where the arc bulges out of it (turning
    counter-clockwise, to the right of its chord) and taken away where it bulges in: the
    polygon's winding number (Sunday's crossing rule) ± 1 inside each lens."""
    a, b, bulges = chain_segments(vertices, bulges)
    p = np.asarray(points, dtype=float).reshape(-1, 1, 2)
    side = (b - a)[None, :, 0] * (p - a)[..., 1] - (b - a)[None, :, 1] * (p - a)[..., 0]  # > 0: left
    y = p[..., 1]
    up = (a[None, :, 1] <= y) & (b[None, :, 1] > y) & (side > 0)
    down = (a[None, :, 1] > y) & (b[None, :, 1] <= y) & (side < 0)
    winding = up.sum(axis=1) - down.sum(axis=1)
    arc = np.abs(bulges) >= STRAIGHT
    if arc.any():
        centre, radius, sweep = arc_geometry(a[arc], b[arc], bulges[arc])
        lens = (np.linalg.norm(p - centre, axis=-1) < np.abs(radius)) & (-np.sign(sweep) * side[:, arc] > 0)
        winding = winding + np.sum(np.sign(sweep) * lens, axis=1).astype(int)
    return winding


def signed_distance(points, vertices, bulges) -> np.ndarray:
    """Distance [m] from each of ``points`` (k, 2) [m] to the closed chain ``vertices``/
    ``bulges``, measured to its exact arcs and lines: positive inside the region it bounds,
    negative outside (:func:`winding_number`)."""
    a, b, bulges = chain_segments(vertices, bulges)
    p = np.asarray(points, dtype=float).reshape(-1, 1, 2)
    distance = arc_distance(p, a[None], b[None], bulges[None]).min(axis=1)
    return np.where(winding_number(p[:, 0], vertices, bulges) != 0, distance, -distance)


def support(normals, vertices, bulges) -> np.ndarray:
    """The closed chain's support function h(n) = max n·x over its points x [m], at the unit
    ``normals`` (K, 2): the largest of n·v over its vertices and, for each arc whose angular
    span seen from its centre holds n, n·centre + radius (the arc's own point of normal n)."""
    a, b, bulges = chain_segments(vertices, bulges)
    n = np.asarray(normals, dtype=float).reshape(-1, 2)
    h = (n @ a.T).max(axis=1)
    arc = np.abs(bulges) >= STRAIGHT
    if arc.any():
        centre, radius, sweep = arc_geometry(a[arc], b[arc], bulges[arc])
        start = np.arctan2(*(a[arc] - centre).T[::-1])
        turn = np.mod((np.arctan2(n[:, 1:], n[:, :1]) - start) * np.sign(sweep), TWO_PI)
        reach = np.where(turn <= np.abs(sweep), n @ centre.T + np.abs(radius), -np.inf)
        h = np.maximum(h, reach.max(axis=1))
    return h


def tangent_angles(vertices, bulges) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Angles [rad] of the tangent of each segment of the closed chain ``vertices``/``bulges``
    where it leaves its start and where it arrives at its end, and its sweep (0 for a line):
    an arc's chord lies half its sweep from either."""
    a, b, bulges = chain_segments(vertices, bulges)
    chord = b - a
    sweep = 4 * np.arctan(bulges)
    angle = np.arctan2(chord[:, 1], chord[:, 0])
    return angle - sweep / 2, angle + sweep / 2, sweep


def concavity(vertices, bulges) -> float:
    """How far [m] the closed chain ``vertices``/``bulges`` turns inwards, from its exact arcs:
    0 for a convex outline, whose tangent turns counter-clockwise all the way round, once.

    At each place where it turns clockwise — a joint whose tangent turns clockwise, the middle
    of an arc that does — the distance by which the whole chain reaches beyond its tangent
    line there, h(n) − n·x (:func:`support`), the lesser of the two one-sided tangents at a
    joint. The distance from such a place to the chain's convex hull, the depth of the notch a
    cable or a straight edge laid on the part bridges, is the least of h(n) − n·x over every
    n, so this is never less than the deepest notch, and it is 0 exactly where the chain is
    convex (its tangent lines are its support lines). At a joint turning clockwise by δ onto
    an arc of radius R the chain dips beyond the tangent by about δ²R/2. A chain whose tangent
    turns other than once round is infinitely concave."""
    a, b, bulges = chain_segments(vertices, bulges)
    leave, arrive, sweep = tangent_angles(vertices, bulges)
    angle = leave + sweep / 2  # the chord's
    turn = np.angle(np.exp(1j * (np.roll(leave, -1) - arrive)))  # at the joint after segment i
    if abs(sweep.sum() + turn.sum() - TWO_PI) > np.pi:
        return float("inf")
    joint = turn < 0
    inward = sweep < 0
    places = np.concatenate([np.roll(a, -1, axis=0)[joint], np.roll(a, -1, axis=0)[joint],
                             np.array([arc_points(p, q, k, [0.5])[0] for p, q, k in
                                       zip(a[inward], b[inward], bulges[inward])]).reshape(-1, 2)])
    if not len(places):
        return 0.0
    tangents = np.concatenate([arrive[joint], np.roll(leave, -1)[joint], angle[inward]])
    normals = np.column_stack([np.sin(tangents), -np.cos(tangents)])  # the tangent turned by −90°
    depth = support(normals, vertices, bulges) - np.sum(normals * places, axis=1)
    count = int(joint.sum())
    return float(max(np.minimum(depth[:count], depth[count:2 * count]).max(initial=0.0),
                     depth[2 * count:].max(initial=0.0)))


def chain_measures(vertices, bulges) -> tuple[float, float]:
    """Area [m²] inside the closed chain ``vertices``/``bulges`` (counter-clockwise: positive)
    and its length [m], from its exact arcs: the polygon of its vertices (shoelace) with each
    arc's circular segment R²(θ − sin θ)/2 added (taken away where it turns clockwise)."""
    a, b, bulges = chain_segments(vertices, bulges)
    area = 0.5 * float(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]))
    length = np.linalg.norm(b - a, axis=1)
    arc = np.abs(bulges) >= STRAIGHT
    if arc.any():
        _, radius, sweep = arc_geometry(a[arc], b[arc], bulges[arc])
        area += float(np.sum(radius**2 * (sweep - np.sin(sweep)) / 2))
        length[arc] = np.abs(radius * sweep)
    return area, float(length.sum())


def inward_band(vertices, bulges, depth: float) -> float:
    """Area [m²] between the convex closed chain ``vertices``/``bulges`` and its inward offset
    by ``depth`` [m] (a groove's band): P·d − d²·(Σ θ/2 over its arcs' sweeps + Σ tan(θ/2) over
    its corners' turns), each arc of radius R and sweep θ giving its sector of the annulus
    R·θ·d − θd²/2, each corner's two lines meeting nearer the middle (exact while d is below
    every arc's radius and no segment vanishes; the turns add up to 2π, so a smooth outline's
    band is Steiner's P·d − π d²)."""
    leave, arrive, sweep = tangent_angles(vertices, bulges)
    corner = np.angle(np.exp(1j * (np.roll(leave, -1) - arrive)))  # at the joint after each segment
    _, length = chain_measures(vertices, bulges)
    return float(length * depth - depth**2 * (sweep.sum() / 2 + np.sum(np.tan(corner / 2))))


def segment_distance(points, a, b) -> np.ndarray:
    """Distance from ``points`` to the segments from ``a`` to ``b`` (broadcast, last axis x, y)."""
    ab = b - a
    t = np.clip(np.sum((points - a) * ab, axis=-1) / np.sum(ab * ab, axis=-1), 0.0, 1.0)
    return np.linalg.norm(points - a - t[..., None] * ab, axis=-1)


def biarcs(p0, t0, p1, t1):
    """The biarc from ``p0`` along unit tangent ``t0`` to ``p1`` along ``t1`` (each (n, 2)):
    its joint (n, 2) and the bulges (n, 2) of its two arcs.

    The joint is J = (p0 + d t0 + p1 − d t1)/2 with d the root of |p1 − d t1 − p0 − d t0| = 2d
    (equal tangent lengths: Meek & Walton 1992, Eq. 2):
    d = (−v·t + √((v·t)² + 2(1 − t0·t1) v·v)) / (2(1 − t0·t1)), v = p1 − p0, t = t0 + t1, and
    d = v·v / (4 v·t1) for parallel tangents. Each arc's sweep is twice the angle from its
    start tangent to its chord.
    """
    v, t = p1 - p0, t0 + t1
    vt, vv = np.sum(v * t, axis=1), np.sum(v * v, axis=1)
    c = 1 - np.sum(t0 * t1, axis=1)
    parallel = c < PARALLEL
    safe = np.where(parallel, 1.0, c)
    d = np.where(parallel, vv / (4 * np.sum(v * t1, axis=1)),
                 (-vt + np.sqrt(vt**2 + 2 * safe * vv)) / (2 * safe))
    joint = (p0 + d[:, None] * t0 + p1 - d[:, None] * t1) / 2
    tj = joint - p0 - d[:, None] * t0  # the joint's tangent, along J − (p0 + d t0)
    tj /= np.linalg.norm(tj, axis=1, keepdims=True)
    return joint, np.column_stack([_bulge(p0, joint, t0), _bulge(joint, p1, tj)])


def _bulge(a, b, t) -> np.ndarray:
    """tan(sweep/4) of the arc from ``a`` to ``b`` leaving ``a`` along ``t``."""
    chord = b - a
    half = np.arctan2(t[:, 0] * chord[:, 1] - t[:, 1] * chord[:, 0], np.sum(t * chord, axis=1))
    return np.tan(half / 2)


def _fit_piece(outline: Outline, start: float, stop: float, closing: bool, tolerance: float):
    """Knots, joints, bulges and errors of the biarcs over [start, stop], intervals halved
    until each is within ``tolerance``."""
    knots = np.linspace(start, stop, max(2, int(np.ceil(START_DENSITY * (stop - start)))) + 1)
    s = np.arange(1, ERROR_SAMPLES + 1) / (ERROR_SAMPLES + 1)
    for _ in range(MAX_ROUNDS):
        a, b = knots[:-1], knots[1:]
        p0, p1 = outline.xy(a), outline.xy(b)
        joint, bulge = biarcs(p0, outline.unit_tangents(a, closing), p1,
                              outline.unit_tangents(b, closing))
        inner = outline.xy((a[:, None] + (b - a)[:, None] * s).ravel()).reshape(a.size, s.size, 2)
        error = np.minimum(arc_distance(inner, p0[:, None], joint[:, None], bulge[:, :1]),
                           arc_distance(inner, joint[:, None], p1[:, None], bulge[:, 1:])).max(axis=1)
        error *= SAMPLE_SPARE
        # two arcs turning opposite ways (an S) fit a convex stretch whose ends lean unevenly on
        # its chord; halving evens them out
        s_shaped = (bulge[:, 0] * bulge[:, 1] < 0) & (np.abs(bulge).min(axis=1) >= STRAIGHT)
        wide = (error > tolerance) | s_shaped
        if not wide.any():
            return p0, joint, bulge, error
        knots = np.sort(np.concatenate([knots, (a[wide] + b[wide]) / 2]))
    raise ValueError(f"the biarc fit did not reach the tolerance {tolerance:.3g} m in "
                     f"{MAX_ROUNDS} halvings of an interval")


def biarc_fit(outline: Outline, tolerance: float) -> ArcChain:
    """The closed outline as biarcs within ``tolerance`` [m] of it, from φ = 0 counter-clockwise.

    The designed arc [0, φ_end] and each piece of the closing arc [φ_end, 2π] (a hull
    closure's lines and the hub's arc between them, :attr:`Outline.closing_joints`) are fitted
    on their own, so that both ends of the designed arc are vertices, a corner of a hull
    closure stays a corner, and its lines and the hub's arc are written exactly (a biarc
    between two points of a circle along its tangents is that circle): the bore's wall is the
    hub's, not the hub's less the fit's tolerance. Intervals start at :data:`START_DENSITY` per
    radian and are halved until the largest distance from the outline, measured at
    :data:`ERROR_SAMPLES` points of each, is within ``tolerance`` and no biarc is S-shaped, so
    that a convex outline stays convex.
    """
    if not (np.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"tolerance must be a positive length [m], got {tolerance!r}")
    ends = np.concatenate([[outline.phi_end], outline.closing_joints, [TWO_PI]])
    pieces = [_fit_piece(outline, 0.0, outline.phi_end, False, tolerance)] + [
        _fit_piece(outline, start, stop, True, tolerance) for start, stop in zip(ends[:-1], ends[1:])]
    vertices = np.concatenate([np.stack([p0, joint], axis=1).reshape(-1, 2) for p0, joint, _, _ in pieces])
    bulges = np.concatenate([bulge.ravel() for _, _, bulge, _ in pieces])
    bulges[np.abs(bulges) < STRAIGHT] = 0.0  # a straight stretch (a hull closure's) as lines
    return ArcChain(vertices, bulges, float(max(error.max() for *_, error in pieces)))
