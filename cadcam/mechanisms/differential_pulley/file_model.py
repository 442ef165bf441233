"""A differential pair's output recomputed from its written files (the file model,
:meth:`cadcam.mechanisms.base.Mechanism.output_from_file`): the idler distance x at which the
two paths, each from its anchor round its outline read back
(:class:`cadcam.physics.outline.FileOutline`) to the line tangent to the idler, and the arc on
the idler add up to the cable's length, found by bisection.
"""
from __future__ import annotations

import numpy as np

from ...physics.outline import BISECTIONS, TWO_PI, rotate

#: How far [m] the cable's length at a differential pair's x found may miss the cable's (the
#: bisection closes x to 1e-15 of the slider's range, where the length moves by about 1e-15 m;
#: a miss beyond this is a jump of the length, no root).
LENGTH_SLACK = 1e-9


def _frame(mech, k: int, theta):
    """Rotation angle (n,) and mirror sign taking profile k's outline frame to the world."""
    return mech.anchor_angles[k] + mech.sense * theta, mech.windings[k]


def _to_world(v, angle, w):
    """Directions (n, 2) of an outline frame in the world."""
    return rotate(angle, v * np.array([1.0, w]))


def _from_world(v, angle, w):
    """World points (n, 2) in an outline frame."""
    return rotate(-angle, v) * np.array([1.0, w])


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
    omega = np.mod(mech.windings[0] * (np.arctan2(out[:, 1], out[:, 0]) - np.arctan2(into[:, 1], into[:, 0])), TWO_PI)
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
