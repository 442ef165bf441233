"""An outline read back from a workshop file, and the plane geometry of a cable or follower on it.

What a workshop receives is the file, not the polynomial: :mod:`cadcam.verify.file_model` reads
``camN.dxf`` (or a helical groove's centre line ``camN_groove.csv``) back into a
:class:`FileOutline`, an open or closed chain of arcs and lines, and each mechanism computes what
its part does from it by plane geometry alone (its ``file_model`` module, behind
:meth:`cadcam.mechanisms.base.Mechanism.port_length_from_file`):

- the cable leaves a convex outline along the line n·X = h(ψ) with outward normal
  n = (cos ψ, sin ψ), h the outline's support function along the outline from the anchor (for
  an arc of centre C and radius R whose normals span ψ: h = n·C + R; at a corner, n·corner);
  the line through a point S (an anchored spring's end) is the root of n·S − h(ψ) = 0 in
  [χ − π, χ], χ the polar angle of S unwrapped from the anchor (as many turns round as the
  cable has gone), and the line tangent to an idler of radius q at P with the idler on the
  cable's left, like the outline, the root of n·P + q − h(ψ) = 0 (:meth:`FileOutline.tangent`);
- the wrapped length is the arcs' length from the anchor (the first vertex) to the contact
  point, the free span the distance from it to S (or to the idler's contact P + q n);
- a follower circle of radius r pressed onto the cam along a line (a wire cam's idler riding
  its platform, a roller follower on its stem) has its centre where that line meets the
  outline grown by r, on the side the line comes from, found by bisection
  (:func:`follower_contact`).

The chain is in the profile's own frame: the cable anchored at the first vertex on +x and wound
counter-clockwise from it (a part wound clockwise is this outline mirrored).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

TWO_PI = 2 * np.pi
#: Bisection steps of a tangency (halving π rad: below 1e-15 rad) and of the slider (halving
#: the slider's range: below 1e-15 of it).
BISECTIONS = 52
#: Bulge below which a segment is straight, for the files' writer (:mod:`cadcam.make.biarc`) and
#: their reader alike: the sag of such an arc is below 1e-12 of its length.
STRAIGHT = 1e-12
#: How far [m] a target may sit inside the tangent at the outline's last point and still leave
#: there: a departure exactly at the end of the designed arc (the range's most-wound pose), seen
#: through the file's rounding.
END_SLACK = 1e-9
#: Smallest turn [rad] between two segments that counts as a corner of the outline (below it,
#: a tangent-continuous joint seen through the file's rounding).
CORNER = 1e-9
#: Deepest notch [m] that counts as no notch: a joint turning inwards so little that the cable
#: bridging its two segments passes within this of the joint (as :data:`END_SLACK`, far below
#: any error the file is judged by). A hull closure's tangent that leaves the designed arc's end
#: along the arc's own tangent (an outline row met with equality) turns either way by the
#: design's rounding (the solver's tolerance on that row).
NOTCH = 1e-9


@dataclass(frozen=True)
class FileOutline:
    """An outline read from a file [m]: its segments and their turning pieces.

    Attributes
    ----------
    vertices, bulges : ndarray
        The closed LWPOLYLINE on layer PROFILE of a DXF, or the open chain of a helical
        groove's centre line (its rows, joined by straight chords), vertex 0 the anchor.
    units : int
        $INSUNITS of the file (4: millimetres).
    closed : bool
        The polyline's closed flag (False: an open chain, a groove's).
    circles : list of (ndarray, float)
        Centres [m] and diameters [m] of the CIRCLEs on layer HOLES.
    centre, radius, start, end, length_at : ndarray
        The turning pieces in order from the anchor up to the first corner (deeper than
        :data:`NOTCH`) or arc turning inwards (a notch, where no cable can lie): each an arc
        (radius > 0) or a corner (radius 0, centre the corner), its outward normal angle running from
        ``start`` to ``end`` [rad] (unwrapped, increasing), and the outline's length from the
        anchor to its start [m].
    reflex : int
        Corners and arcs turning inwards (0 for a convex outline).
    lift : float
        How far [m] the chain lies outside the file's outline: 0 as read, the cable's radius
        on its centre line (:meth:`centre_line`).
    groove : bool
        The chain is a helical groove's centre line: the cable's centre line itself, wound on it
        turn after turn, its pitch neglected (its normal angles run on across the turns).
    """

    vertices: np.ndarray
    bulges: np.ndarray
    units: int
    closed: bool
    circles: list
    centre: np.ndarray
    radius: np.ndarray
    start: np.ndarray
    end: np.ndarray
    length_at: np.ndarray
    reflex: int
    lift: float = 0.0
    groove: bool = False

    def centre_line(self, cable_radius: float) -> FileOutline:
        """The centre line of a cable of ``cable_radius`` [m] lying on this outline: its outward
        offset, the same pieces about the same centres with their radii grown by the cable's
        (a corner becomes an arc of that radius), each piece's start that much farther along
        (the offset of a convex chain is longer by the radius times the normal's turn). A
        groove's file is the cable's centre line already."""
        if not cable_radius or self.groove:
            return self
        out = replace(self, radius=self.radius + cable_radius, lift=self.lift + cable_radius,
                      length_at=self.length_at + cable_radius * (self.start - self.start[0]))
        object.__setattr__(out, "_length", self._length + cable_radius * (self.end[-1] - self.start[0]))
        return out

    @property
    def length(self) -> float:
        """Length [m] of the chain along it: a closed outline's perimeter, a groove's centre
        line from its anchor to its end."""
        return float(self._length)

    def support(self, psi):
        """h(ψ) [m], the contact point (n, 2) [m] and the wrapped length from the anchor [m] at
        outward normal angles ``psi`` unwrapped along the chain from the anchor's normal (h is
        −inf outside the chain's span)."""
        psi = np.asarray(psi, dtype=float)
        i = np.clip(np.searchsorted(self.start, psi, side="right") - 1, 0, self.start.size - 1)
        on = (psi >= self.start[0]) & (psi <= self.end[-1])
        angle = np.clip(psi, self.start[i], self.end[i])
        n = np.stack([np.cos(psi), np.sin(psi)], axis=-1)
        point = self.centre[i] + self.radius[i, None] * np.stack([np.cos(angle), np.sin(angle)], axis=-1)
        wrapped = self.length_at[i] + self.radius[i] * (angle - self.start[i])
        return np.where(on, np.sum(n * point, axis=-1), -np.inf), point, wrapped

    def tangent(self, target, around, offset: float = 0.0):
        """The cable from the anchor round the outline towards ``target`` (n, 2) [m], or tangent
        to a circle of radius ``offset`` about it, with outline and circle on its left: normal
        angle ψ (n,), contact point (n, 2) and wrapped length (n,) [m].

        ``around`` (n,) is the target's polar angle unwrapped from the anchor [rad] (how far
        round the cable has gone: a wrap of nearly a turn meets the same target twice). The
        cable leaves where g(ψ) = n·target + offset − h(ψ) turns positive in
        [around − π, around], the one root there on a convex outline, found by bisection; NaN
        where that bracket leaves the outline's span (but for :data:`END_SLACK` at its end).
        A target outside the tangent at the anchor is reached straight from the anchor, where
        the cable is tied and may leave at any angle (nothing is wound; ψ is then the normal of
        the line from the anchor, :meth:`from_anchor`).
        """
        lo = np.maximum(np.asarray(around, dtype=float) - np.pi, self.start[0])
        hi = np.minimum(np.asarray(around, dtype=float), self.end[-1])

        def g(psi):
            return np.cos(psi) * target[:, 0] + np.sin(psi) * target[:, 1] + offset - self.support(psi)[0]

        top, bottom = g(hi), g(lo)
        at_end = (hi == self.end[-1]) & (top <= 0) & (top > -END_SLACK)
        # a target outside the anchor's tangent: the cable runs straight from the anchor
        at_anchor = (lo == self.start[0]) & (bottom > 0)
        bracketed = (bottom <= 0) & (top > 0)
        for _ in range(BISECTIONS):
            mid = (lo + hi) / 2
            below = g(mid) <= 0
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        psi = np.where(bracketed, (lo + hi) / 2, np.where(at_end, self.end[-1], np.nan))
        _, point, wrapped = self.support(psi)
        return (np.where(at_anchor, self.from_anchor(target, offset), psi),
                np.where(at_anchor[:, None], self.anchor, point), np.where(at_anchor, 0.0, wrapped))

    @property
    def anchor(self) -> np.ndarray:
        """Where the cable is tied [m]: the first vertex, the cable's radius out along the
        outline's normal there on a centre line (:meth:`centre_line`)."""
        return self.vertices[0] + self.lift * np.array([np.cos(self.start[0]), np.sin(self.start[0])])

    def from_anchor(self, target, offset: float = 0.0):
        """Normal angle [rad] (n,) of the line from the anchor A to ``target`` P (n, 2) [m], or
        tangent to a circle of radius ``offset`` about it on the line's left: the root of
        g(ψ) = n·(P − A) + offset where it turns positive, ψ = β + acos(offset/|A − P|) with β
        the angle of A − P, taken in (ψ_A − 2π, ψ_A] below the anchor's normal ψ_A (NaN where
        A lies inside the circle)."""
        d = self.anchor - target
        psi = np.arctan2(d[:, 1], d[:, 0]) + np.arccos(offset / np.hypot(d[:, 0], d[:, 1]))
        return self.start[0] - np.mod(self.start[0] - psi, TWO_PI)


def outline_from_chain(vertices, bulges, units, closed, circles, groove=False) -> FileOutline:
    """The turning pieces of the chain ``vertices``/``bulges`` from the anchor up to its first
    reflex corner or inward arc, if any (see :class:`FileOutline`): a closed chain back round
    to its anchor, an open one (``closed`` False) to its last vertex, where it ends."""
    count = len(vertices) if closed else len(vertices) - 1  # segments
    ends = np.roll(vertices, -1, axis=0)[:count]
    chord = ends - vertices[:count]
    length = np.hypot(*chord.T)
    arc = np.abs(bulges[:count]) >= STRAIGHT
    sweep = np.where(arc, 4 * np.arctan(bulges[:count]), 0.0)
    heading = np.arctan2(chord[:, 1], chord[:, 0]) - sweep / 2  # tangent angle at each start
    radius = np.where(arc, length / (2 * np.abs(np.sin(np.where(arc, sweep, 1.0) / 2))), 0.0)
    seg_length = np.where(arc, radius * np.abs(sweep), length)
    nxt = (np.arange(count) + 1) % len(vertices)
    following = np.minimum(nxt, count - 1)  # an open chain's last segment has none
    # each joint's turn and notch at once, the loop below in plain floats (a points CSV's
    # polygon has 10⁵ joints)
    turns = np.angle(np.exp(1j * (heading[following] - (heading + sweep))))
    notched = (_notch_depths(turns, seg_length, seg_length[following]) > NOTCH).tolist()
    sweeps, lengths, arcs, turns, nxt = sweep.tolist(), seg_length.tolist(), arc.tolist(), turns.tolist(), nxt.tolist()
    pieces, start, stop, at, reflex = [], [], [], [], 0  # pieces: (segment, its arc's or its end's)
    psi, s = float(heading[0]) - np.pi / 2, 0.0
    for i in range(count):
        reflex += int(sweeps[i] < 0)
        if arcs[i] and not reflex:
            pieces.append((i, psi)), start.append(psi), stop.append(psi + sweeps[i]), at.append(s)
        psi, s = psi + sweeps[i], s + lengths[i]
        if nxt[i] == count:  # an open chain's end: a corner of no turn, where a cable along the last
            if not reflex:  # segment's line leaves it
                pieces.append((i, None)), start.append(psi), stop.append(psi), at.append(s)
            break
        turn, notch = turns[i], notched[i]
        if nxt[i] == 0 and not reflex:  # back at the anchor: the normals close a full turn
            turn = start[0] + TWO_PI - psi
            notch = _notch_depth(turn, lengths[i], lengths[0]) > NOTCH
        if notch:
            reflex += 1
        elif not reflex and turn > 0 and (turn > CORNER or nxt[i] == 0):
            pieces.append((i, None)), start.append(psi), stop.append(psi + turn), at.append(s)
        psi = psi + turn
    index = np.array([i for i, _ in pieces], dtype=int)
    corner = np.array([normal is None for _, normal in pieces], dtype=bool)
    normal = np.array([0.0 if n is None else n for _, n in pieces])
    r = np.where(corner, 0.0, radius[index])
    centre = np.where(corner[:, None], ends[index], vertices[index] - r[:, None] * np.column_stack(
        [np.cos(normal), np.sin(normal)]))
    out = FileOutline(vertices, bulges, units, closed, circles, centre.reshape(-1, 2), r,
                      np.array(start), np.array(stop), np.array(at), reflex, groove=groove)
    object.__setattr__(out, "_length", s)
    return out


def _notch_depths(turn, before, after) -> np.ndarray:
    """:func:`_notch_depth` of each joint (arrays)."""
    with np.errstate(divide="ignore", invalid="ignore"):  # a joint turning outwards has none
        depth = np.sin(-turn) * before * after / np.hypot(before + after * np.cos(turn), after * np.sin(turn))
    return np.where(turn < 0, depth, 0.0)


def _notch_depth(turn: float, before: float, after: float) -> float:
    """How far [m] a joint turning inwards by −``turn`` [rad] between segments of lengths
    ``before`` and ``after`` [m] lies inside the chord over both, taken straight: sin(−turn)·ab/c,
    c that chord's length (0 for a joint turning outwards). Where a segment is an arc turning
    outwards the cable bridging the joint passes nearer it: this bounds the notch's depth."""
    if turn >= 0:
        return 0.0
    return float(np.sin(-turn) * before * after / np.hypot(before + after * np.cos(turn), after * np.sin(turn)))


def rotate(angle, v):
    """Points ``v`` (n, 2) turned by ``angle`` (n,) [rad] counter-clockwise."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]], axis=1)


def follower_contact(outline: FileOutline, rotation, direction: float, offset: float, radius: float):
    """A circle of ``radius`` [m] (an idler, a roller) whose centre slides along the line
    s û + e v̂ (û at world angle ``direction`` β, v̂ a quarter turn on, e = ``offset`` [m]),
    pressed onto the outline turned by ``rotation`` (n,) [rad] in the world: its outline-frame
    normal angle ψ (n,), the wrapped length from the anchor to the contact (n,) [m], the centre's
    position s (n,) [m] and the pressure angle φ_p (n,) [rad], the normal's world angle less β
    (NaN where the contact lies outside the outline's chain).

    The centre is R(rotation)·P(ψ) + r n, P the outline's point of normal ψ: a point of the
    outline grown by r, whose height along v̂ grows with φ_p over (−π/2, π/2) on a convex
    outline, so the height e is met by bisection in φ_p.
    """
    rotation = np.atleast_1d(np.asarray(rotation, dtype=float))
    u, v = np.array([np.cos(direction), np.sin(direction)]), np.array([-np.sin(direction), np.cos(direction)])

    def centre(lean):
        psi = direction + lean - rotation
        _, point, wrapped = outline.support(psi)
        world = rotate(rotation, point)
        return world @ u + radius * np.cos(lean), world @ v + radius * np.sin(lean), wrapped, psi

    lo, hi = np.full(rotation.shape, -np.pi / 2), np.full(rotation.shape, np.pi / 2)
    for _ in range(BISECTIONS):
        mid = (lo + hi) / 2
        below = centre(mid)[1] <= offset
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    lean = (lo + hi) / 2
    # on a straight segment (a polygon's chord) the normal stands still while the contact runs
    # along it: the bracket's ends are the segment's ends, and the centre lies between them on
    # its offset, where its height meets e (on an arc the ends are one point to rounding)
    below_at, above_at = centre(lo), centre(hi)
    rise = above_at[1] - below_at[1]
    share = np.clip(np.where(rise > 0, (offset - below_at[1]) / np.where(rise > 0, rise, 1.0), 0.5), 0.0, 1.0)
    position, wrapped = (a + share * (b - a) for a, b in ((below_at[0], above_at[0]), (below_at[2], above_at[2])))
    psi = direction + lean - rotation
    on = (psi >= outline.start[0]) & (psi <= outline.end[-1])
    return tuple(np.where(on, value, np.nan) for value in (psi, wrapped, position, lean))
