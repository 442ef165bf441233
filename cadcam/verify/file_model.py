"""The torque (or a differential pair's output x) of a design recomputed from its written files.

What a workshop receives is the file, not the polynomial: this module reads ``camN.dxf`` back
with ezdxf, rebuilds the outline from its arcs and lines (or a helical groove's centre line
``camN_groove.csv``, an open chain of chords wound turn after turn, projected on the plane as
the design model projects it), and computes what that part does by plane geometry alone,
sharing nothing with the NLP's symbolic model but the spec's physical parameters (positions,
senses, windings, spring rates, preloads and the design's pre-extensions):

- the cable leaves a convex outline along the line n·X = h(ψ) with outward normal
  n = (cos ψ, sin ψ), h the outline's support function along the outline from the anchor (for
  an arc of centre C and radius R whose normals span ψ: h = n·C + R; at a corner, n·corner);
  the line through a point S (an anchored spring's end) is the root of n·S − h(ψ) = 0 in
  [χ − π, χ], χ the polar angle of S unwrapped from the anchor (as many turns round as the
  cable has gone), and the line tangent to an idler of radius q at P with the idler on the
  cable's left, like the outline, the root of n·P + q − h(ψ) = 0;
- the wrapped length is the arcs' length from the anchor (the first vertex) to the contact
  point, the free span the distance from it to S (or to the idler's contact P + q n);
- a follower circle of radius r pressed onto the cam along a line (a wire cam's idler riding
  its platform at height a₀, a roller follower on its stem) has its centre where that line
  meets the outline grown by r, on the side the line comes from, found by bisection; a wire
  cam's wire port is the wrapped length plus r γ, γ the idler's contact angle, its platform
  port the idler centre's x, a roller follower's port its centre's position on the line;
- a spring's extension is x_j = x₀_j + Σ_p P_jp (L_p(θ) − L_p(θ_ref)), L_p a port's length, and
  the joint torque τ = Σ_j (k_j x_j + F0_j) Σ_p P_jp dL_p/dθ, dL/dθ by a central difference;
- a differential pair's output x is the idler distance at which the two paths and the arc on
  the idler add up to the cable's length, found by bisection.

The files are in the profile's own frame: the cable anchored at the first vertex on +x and wound
counter-clockwise from it (the mechanism's ``winding`` = "cw" part is this outline mirrored); a
wire cam's frame turns by −θ in the world (a point at polar angle φ sits at world angle φ − θ).
"""
from __future__ import annotations


from dataclasses import dataclass, replace
from pathlib import Path

import ezdxf
import numpy as np

TWO_PI = 2 * np.pi
#: Millimetres per metre (the files' unit: the DXF's $INSUNITS = 4, a groove's columns ``_mm``).
MM = 1e3
#: DXF $INSUNITS code of millimetres (a groove's CSV, in millimetres, is read as such).
MILLIMETRES = 4
#: The columns of a groove's CSV the file model reads: its centre line's plane coordinates [mm].
GROOVE_COLUMNS = ("x_mm", "y_mm")
#: Bisection steps of a tangency (halving π rad: below 1e-15 rad) and of the slider (halving
#: the slider's range: below 1e-15 of it).
BISECTIONS = 52
#: Step [rad] of the central difference dL/dθ (its error is below 1e-9 of the moment arm).
STEP = 1e-5
#: Bulge below which a segment is straight (as the writer's :data:`cadcam.make.biarc.STRAIGHT`:
#: the sag of such an arc is below 1e-12 of its length).
STRAIGHT = 1e-12
#: How far [m] a target may sit inside the tangent at the outline's last point and still leave
#: there: a departure exactly at the end of the designed arc (the range's most-wound pose), seen
#: through the file's rounding.
END_SLACK = 1e-9
#: How far [m] the cable's length at a differential pair's x found may miss the cable's (the
#: bisection closes x to 1e-15 of the slider's range, where the length moves by about 1e-15 m;
#: a miss beyond this is a jump of the length, no root).
LENGTH_SLACK = 1e-9
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
    return _pieces(xyb[:, :2] / MM, xyb[:, 2], int(doc.header.get("$INSUNITS", 0)),
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
    with open(path, encoding="utf-8") as f:
        header = f.readline().strip().split(",")
    missing = [c for c in GROOVE_COLUMNS if c not in header]
    if missing:
        raise ValueError(f"{Path(path).name}: no column {', '.join(missing)}")
    xy = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)[:, [header.index(c) for c in GROOVE_COLUMNS]] / MM
    if len(xy) < 2:
        raise ValueError(f"{Path(path).name}: {len(xy)} rows, a groove needs at least 2")
    return _pieces(xy, np.zeros(len(xy)), MILLIMETRES, False, [], groove=True)


def _pieces(vertices, bulges, units, closed, circles, groove=False) -> FileOutline:
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
    centre, r, start, stop, at, reflex = [], [], [], [], [], 0
    psi, s = heading[0] - np.pi / 2, 0.0
    for i in range(count):
        reflex += int(sweep[i] < 0)
        if arc[i] and not reflex:
            centre.append(vertices[i] - radius[i] * np.array([np.cos(psi), np.sin(psi)]))
            r.append(radius[i]), start.append(psi), stop.append(psi + sweep[i]), at.append(s)
        psi, s = psi + sweep[i], s + seg_length[i]
        nxt = (i + 1) % len(vertices)
        if nxt == count:  # an open chain's end: a corner of no turn, where a cable along the last
            if not reflex:  # segment's line leaves it
                centre.append(ends[i]), r.append(0.0), start.append(psi), stop.append(psi), at.append(s)
            break
        turn = np.angle(np.exp(1j * (heading[nxt] - (heading[i] + sweep[i]))))
        if nxt == 0 and not reflex:  # back at the anchor: the normals close a full turn
            turn = start[0] + TWO_PI - psi
        if _notch_depth(turn, seg_length[i], seg_length[nxt]) > NOTCH:
            reflex += 1
        elif not reflex and turn > 0 and (turn > CORNER or nxt == 0):
            centre.append(ends[i]), r.append(0.0), start.append(psi), stop.append(psi + turn)
            at.append(s)
        psi = psi + turn
    out = FileOutline(vertices, bulges, units, closed, circles, np.array(centre), np.array(r),
                      np.array(start), np.array(stop), np.array(at), reflex, groove=groove)
    object.__setattr__(out, "_length", s)
    return out


def _notch_depth(turn: float, before: float, after: float) -> float:
    """How far [m] a joint turning inwards by −``turn`` [rad] between segments of lengths
    ``before`` and ``after`` [m] lies inside the chord over both, taken straight: sin(−turn)·ab/c,
    c that chord's length (0 for a joint turning outwards). Where a segment is an arc turning
    outwards the cable bridging the joint passes nearer it: this bounds the notch's depth."""
    if turn >= 0:
        return 0.0
    return float(np.sin(-turn) * before * after / np.hypot(before + after * np.cos(turn), after * np.sin(turn)))


# ------------------------------------------------------------------------------- anchored pulley

def _rotate(angle, v):
    """Points ``v`` (n, 2) turned by ``angle`` (n,) [rad] counter-clockwise."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]], axis=1)


def spring_end_in_outline_frame(mech, theta) -> np.ndarray:
    """An anchored pulley's spring end at joint angles ``theta`` in its outline's frame [m]:
    the world turned back by the anchor's angle (and the pulley's turn when the pulley turns),
    mirrored for a clockwise winding."""
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    turn = mech.sense * theta
    still = np.zeros_like(theta)
    end = np.tile([mech.spring_end_x, mech.spring_end_y], (theta.size, 1))
    world = _rotate(turn if mech.turning == "spring_end" else still, end)
    own = _rotate(-(mech.anchor_angle + (turn if mech.turning == "pulley" else still)), world)
    own[:, 1] *= _winding(mech)
    return own


def _winding(mech, k: int = 0) -> float:
    """+1 where profile ``k`` of ``mech`` is wound counter-clockwise from its anchor, else −1
    (a differential pair's second profile the other way round)."""
    return (1.0 if mech.winding == "ccw" else -1.0) * (1.0 if k == 0 else -1.0)


def spring_end_turns(mech, theta) -> np.ndarray:
    """The spring end's polar angle in the outline's frame [rad], unwrapped from the anchor:
    its world angle at θ = 0 less the anchor's, plus the turn of the body that turns (the
    spring end's, or less the pulley's), mirrored for a clockwise winding."""
    turn = mech.sense * np.atleast_1d(np.asarray(theta, dtype=float))
    turn = turn if mech.turning == "spring_end" else -turn
    return _winding(mech) * (np.arctan2(mech.spring_end_y, mech.spring_end_x) - mech.anchor_angle + turn)


def anchored_span(outline: FileOutline, mech, theta):
    """The free span of an anchored pulley's cable at ``theta`` (n,) in its outline's frame:
    where it leaves the outline and the spring end (both (n, 2) [m]), and the length wrapped
    from the anchor (n,) [m]."""
    end = spring_end_in_outline_frame(mech, theta)
    _, point, wrapped = outline.tangent(end, spring_end_turns(mech, theta))
    return point, end, wrapped


def anchored_path(outline: FileOutline, mech, theta) -> np.ndarray:
    """Length [m] of the cable from the anchor round the outline to the spring end at ``theta``."""
    point, end, wrapped = anchored_span(outline, mech, theta)
    return wrapped + np.hypot(*(end - point).T)


# ------------------------------------------------------------------- followers: wire cam, roller

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
        world = _rotate(rotation, point)
        return world @ u + radius * np.cos(lean), world @ v + radius * np.sin(lean), wrapped, psi

    lo, hi = np.full(rotation.shape, -np.pi / 2), np.full(rotation.shape, np.pi / 2)
    for _ in range(BISECTIONS):
        mid = (lo + hi) / 2
        below = centre(mid)[1] <= offset
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    lean = (lo + hi) / 2
    position, _, wrapped, psi = centre(lean)
    on = (psi >= outline.start[0]) & (psi <= outline.end[-1])
    return tuple(np.where(on, value, np.nan) for value in (psi, wrapped, position, lean))


def wire_cam_port(outline: FileOutline, mech, port: str, theta) -> np.ndarray:
    """Length [m] of a wire cam's port at ``theta``: its follower idler rides the platform at
    height a₀, the cam turned by −θ (Johnston2023 Eq. 7); ``wire`` is the wrapped length plus the
    wire on the idler r γ, γ = φ_p + π the contact's angle on the idler (Eq. 6, 14);
    ``platform`` the idler centre's x (Eq. 15, 16)."""
    theta = np.asarray(theta, dtype=float)
    _, wrapped, qx, lean = follower_contact(outline, -theta, 0.0, mech.idler_offset, mech.idler_radius)
    return wrapped + mech.idler_radius * (lean + np.pi) if port == "wire" else qx


def roller_follower_port(outline: FileOutline, mech, theta) -> np.ndarray:
    """Position s [m] of a roller follower's centre along its line at ``theta``, the cam turned
    by γ₀ − θ (Norton2009; :mod:`cadcam.mechanisms.roller_follower`)."""
    rotation = mech.axis_angle - np.asarray(theta, dtype=float)
    return follower_contact(outline, rotation, mech.follower_angle, mech.offset, mech.roller_radius)[2]


def port_length(outlines: list, mech, port: str, theta) -> np.ndarray:
    """Length [m] of port ``port`` of ``mech`` at joint angles ``theta`` from its profiles' file
    outlines (a differential pair's port is its output x)."""
    if mech.kind == "wire_cam":
        return wire_cam_port(outlines[0], mech, port, theta)
    if mech.kind == "roller_follower":
        return roller_follower_port(outlines[0], mech, theta)
    if mech.kind == "differential_pulley":
        return differential_output(outlines, mech, np.atleast_1d(np.asarray(theta, dtype=float)))
    return anchored_path(outlines[0], mech, theta)


#: Mechanisms whose joint torque :func:`file_torque` recomputes from their files.
TORQUE_KINDS = ("anchored_pulley", "wire_cam", "roller_follower", "differential_pulley")


def file_torque(problem, design, outlines: dict, thetas) -> np.ndarray:
    """Joint torques [N·m] (m, P) at the points ``thetas`` (m, P) of a problem whose mechanisms
    are all of :data:`TORQUE_KINDS`, from their file outlines (mechanism index → its profiles'
    FileOutlines).

    τ_i = Σ_j (k_j x_j + F0_j) Σ_p P_jp dL_p/dθ_i, x_j = x₀_j + Σ_p P_jp (L_p(θ) − L_p(θ_ref))
    (the energy V = Σ ½k x² + F0 x differentiated, Johnston2023 Eq. 14, 36).
    """
    network = problem.network()
    P = thetas.shape[1]
    d, dd = np.zeros((network.P.shape[1], P)), np.zeros((network.P.shape[1], P))
    for g, (u, port) in enumerate(problem.ports):
        mech = problem.mechanisms[u]
        th, at = np.unique(thetas[mech.joint], return_inverse=True)  # a tensor grid repeats each angle
        path = lambda t: port_length(outlines[u], mech, port, t)  # noqa: E731
        d[g] = (path(th) - path(mech.reference_angle))[at]
        dd[g] = ((path(th + STEP) - path(th - STEP)) / (2 * STEP))[at]
    k = np.array([s.rate for s in problem.springs])
    preload = np.array([s.preload for s in problem.springs])
    force = k[:, None] * (np.asarray(design.preextension)[:, None] + network.P @ d) + preload[:, None]
    tau = np.zeros(thetas.shape)
    for i in range(thetas.shape[0]):
        on = network.port_joint == i
        tau[i] = np.sum(force * (network.P[:, on] @ dd[on]), axis=0)
    return tau


# --------------------------------------------------------------------------- differential pair

def _frame(mech, k: int, theta):
    """Rotation angle (n,) and mirror sign taking profile k's outline frame to the world."""
    return mech.anchor_angles[k] + mech.sense * theta, _winding(mech, k)


def _to_world(v, angle, w):
    """Directions (n, 2) of an outline frame in the world."""
    return _rotate(angle, v * np.array([1.0, w]))


def _from_world(v, angle, w):
    """World points (n, 2) in an outline frame."""
    return _rotate(-angle, v) * np.array([1.0, w])


def differential_spans(outlines, mech, theta, x):
    """Both free spans of a differential pair at joint angles ``theta`` with the idler's centre
    at distance ``x`` along the slider (both (n,)), each in its outline's frame: where the cable
    leaves the outline and where it meets the idler (both (n, 2) [m]), the length wrapped from
    the anchor (n,) [m] and the span's heading in the world (n, 2)."""
    slider = np.stack([np.cos(mech.slider_angle), np.sin(mech.slider_angle)])
    q, spans = mech.idler_radius, []
    for k in (0, 1):
        angle, w = _frame(mech, k, theta)
        idler = _from_world(x[:, None] * slider, angle, w)
        # the slider's angle seen from profile k's anchor, unwrapped: turned back by the shaft
        around = w * (mech.slider_angle - angle)
        psi, point, wrapped = outlines[k].tangent(idler, around, q)
        n = np.stack([np.cos(psi), np.sin(psi)], axis=1)
        spans.append((point, idler + q * n, wrapped, _to_world(np.stack([-n[:, 1], n[:, 0]], axis=1), angle, w)))
    return spans


def differential_length(outlines, mech, theta, x) -> np.ndarray:
    """Cable length [m] from anchor to anchor of a differential pair at joint angles ``theta``
    with the idler's centre at distance ``x`` along the slider (both (n,)): both paths round
    their outlines to the idler and the arc q·ω the cable turns on the idler."""
    spans = differential_spans(outlines, mech, theta, x)
    total = sum(wrapped + np.hypot(*(far - point).T) for point, far, wrapped, _ in spans)
    # in: along the cable from profile 1; out: from the idler back to profile 2
    into, out = spans[0][3], -spans[1][3]
    omega = np.mod(_winding(mech) * (np.arctan2(out[:, 1], out[:, 0]) - np.arctan2(into[:, 1], into[:, 0])), TWO_PI)
    return total + mech.idler_radius * omega


def differential_output(outlines, mech, theta) -> np.ndarray:
    """The idler distance x [m] at joint angles ``theta`` (n,) for which the cable has its
    length: bisection of the (increasing) length over the slider's range. Where the idler is so
    near that a cable would wrap past the end of an outline the length is undefined and counts
    as too short; NaN where no x in the range gives the cable its length (also where the
    bisection closes on the edge of that undefined stretch, the length jumping past the cable's
    there: a groove too short for the cable wound on it)."""
    theta = np.asarray(theta, dtype=float)
    lo = np.full(theta.shape, float(mech.slider_range[0]))
    hi = np.full(theta.shape, float(min(mech.slider_range[1], 10.0)))

    def short(x):
        return ~(differential_length(outlines, mech, theta, x) >= mech.cable_length)

    inside = short(lo) & ~short(hi)
    for _ in range(BISECTIONS):
        mid = (lo + hi) / 2
        below = short(mid)
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    x = (lo + hi) / 2
    found = inside & (np.abs(differential_length(outlines, mech, theta, x) - mech.cable_length) <= LENGTH_SLACK)
    return np.where(found, x, np.nan)


# ------------------------------------------------------------------------------------ clearance

def free_spans(outlines: list, mech, theta) -> list | None:
    """Each profile's free span of ``mech`` at joint angles ``theta`` (n,) from its centre-line
    outlines: (where the cable leaves the outline, where it ends) (both (n, 2) [m], the
    outline's frame) per profile; None for a follower, onto which the cable runs without a span
    (a wire cam's idler) or which carries none (a roller)."""
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    if mech.kind == "anchored_pulley":
        return [anchored_span(outlines[0], mech, theta)[:2]]
    if mech.kind == "differential_pulley":
        spans = differential_spans(outlines, mech, theta, differential_output(outlines, mech, theta))
        return [(point, far) for point, far, _, _ in spans]
    return None


#: Largest gap [m] between the outline's arcs and the chords through their sampled points (the
#: samples' sagitta): how far a clearance may be read long.
SAGITTA = 1e-9
#: Spans by outline points measured at once (memory: three arrays of that many floats).
CLEARANCE_BLOCK = 4_000_000


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
    for rows in np.array_split(np.arange(len(start)), max(1, len(start) * len(points) // CLEARANCE_BLOCK)):
        rel = points[None] - start[rows, None]
        along = rel[..., 0] * u[rows, None, 0] + rel[..., 1] * u[rows, None, 1]
        side = u[rows, None, 0] * rel[..., 1] - u[rows, None, 1] * rel[..., 0]
        beyond = np.minimum(np.hypot(rel[..., 0], rel[..., 1]),
                            np.hypot(*(points[None] - end[rows, None]).transpose(2, 0, 1)))
        beside = (along > 0) & (along < length[rows, None])
        out[rows] = np.where(beside, side, beyond).min(axis=1)
    return np.where(np.isfinite(length), out, np.nan)
