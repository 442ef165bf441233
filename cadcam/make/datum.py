"""The datum that fixes a part's angle on its shaft: a straight mark engraved on its face from
the bore outwards, pointing along one of the world's axes with the joint at θ = 0.

A mark is chosen over a keyway or a flat because it leaves the cut outline, the bore and the
anchor hole as designed and verified (a keyway would need a wall rule of its own, a flat a
shaft to match). The builder sets the joint at θ = 0 and turns the part on its shaft until the
mark points along that axis, then clamps or pins it.

Angles: the outline's frame is the drawing's (the DXF's), its +x axis the ray to the anchor
point φ = 0; a point at polar angle β of the outline lies at world angle ``zero`` + w β with
the joint at θ = 0, w = ±1 the profile's winding (−1: the drawing is the part seen from its
back, :attr:`cadcam.mechanisms.base.Mechanism.windings`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..problem import MIN_WALL
from .workshop import TWO_PI, Outline

#: World angles [rad] a mark may point along with the joint at θ = 0: the spec's four axis
#: directions (+x, +y, −x, −y), which a builder finds with a square or a level.
MARK_DIRECTIONS = (0.0, np.pi / 2, np.pi, 3 * np.pi / 2)


@dataclass(frozen=True)
class Datum:
    """A mark engraved on a part's face, along a ray from the axis (lengths [m], angles [rad]).

    Attributes
    ----------
    angle : float
        Polar angle of the mark in the outline's frame, counter-clockwise from its +x axis
        (the ray to the anchor point φ = 0), in (−π, π].
    world : float
        World angle the mark points along with the joint at θ = 0, one of
        :data:`MARK_DIRECTIONS`.
    inner, outer : float
        Radii where the mark starts (the bore's edge) and ends.
    anchor : float
        Polar angle of the anchor hole's centre in the outline's frame, in (−π, π].
    """

    angle: float
    world: float
    inner: float
    outer: float
    anchor: float

    @property
    def segment(self) -> np.ndarray:
        """The mark's ends [m], shape (2, 2), inner end first."""
        u = np.array([np.cos(self.angle), np.sin(self.angle)])
        return np.array([self.inner * u, self.outer * u])


def _wrapped(angle: float) -> float:
    """``angle`` [rad] in (−π, π]."""
    return float(np.pi - np.mod(np.pi - angle, TWO_PI))


def _mark_end(outline: Outline, angle: float, anchor: np.ndarray, anchor_diameter: float) -> float:
    """Radius [m] where a mark along ``angle`` ends: a wall MIN_WALL inside the outline, and
    short of the anchor hole (centre ``anchor`` [m]) by a wall where it would run into it."""
    u = np.array([np.cos(angle), np.sin(angle)])
    end = outline.radius_at(angle) - MIN_WALL
    along, across = float(anchor @ u), float(abs(anchor[0] * u[1] - anchor[1] * u[0]))
    keep = anchor_diameter / 2 + MIN_WALL  # the hole and a wall round it
    if along > 0 and across < keep:
        end = min(end, along - np.sqrt(keep**2 - across**2))
    return end


def datum_mark(outline: Outline, circles, zero: float, winding: float) -> Datum:
    """The longest mark from the bore's edge along one of :data:`MARK_DIRECTIONS`, a wall short
    of the outline and of the anchor hole (:func:`_mark_end`): the longer the mark, the closer
    a builder sets the part's angle by it.

    Parameters
    ----------
    outline : Outline
    circles : list of (centre, diameter)
        The bore and the anchor hole, [m] (:func:`cadcam.make.workshop.holes`).
    zero : float
        World angle [rad] of the outline's +x axis (φ = 0) with the joint at θ = 0.
    winding : float
        +1 or −1: the profile's winding (a point at polar angle β lies at world angle
        ``zero`` + ``winding`` β).
    """
    (_, bore), (anchor, hole) = circles
    at = _wrapped(np.arctan2(anchor[1], anchor[0]))
    marks = [Datum(angle, world, bore / 2, _mark_end(outline, angle, anchor, hole), at)
             for world, angle in ((w, _wrapped(winding * (w - zero))) for w in MARK_DIRECTIONS)]
    return max(marks, key=lambda mark: mark.outer)
