"""The planar two-cable robot of Fedorov2018 Sec. 4.1: an end effector hung from two frame
anchors by cables whose lengths one motor sets through differential pulley pairs.

Coordinates (metres): x to the right, y up, in the frame's plane. The pick-and-place path
rises from ``start`` by ``lift``, moves across by ``span`` and comes down by ``lift`` (up,
across, down, Fedorov2018 Sec. 4.1, Fig. 6–7). Each move follows the minimum-jerk step
s(u) = 10u³ − 15u⁴ + 6u⁵ of its own share of the input; the across move begins ``overlap``
(a share of the input) before the rise ends and ends as long before the descent begins, which
rounds the two corners (the paper's "smooth transitions"; the velocity and acceleration are
continuous everywhere, which a motor turning at constant speed needs).

Every function takes CasADi or NumPy values alike.
"""
from __future__ import annotations

import casadi as ca
import numpy as np


def smooth_step(u):
    """The minimum-jerk step 10u³ − 15u⁴ + 6u⁵ of u clipped to [0, 1]: 0 before, 1 after."""
    u = ca.fmin(ca.fmax(u, 0), 1) if isinstance(u, (ca.SX, ca.MX)) else np.clip(u, 0.0, 1.0)
    return u**3 * (10 - 15 * u + 6 * u**2)


def pick_and_place(tau, start, lift: float, span: float, lift_share: float, overlap: float):
    """The end effector's position [m] at input share τ ∈ [0, 1] (Fedorov2018 Sec. 4.1).

    Parameters
    ----------
    tau : float, array or casadi.SX
        Share of the input rotation, 0 at the start of the path and 1 at its end.
    start : (float, float)
        The pick point [m]; the place point is ``start + (span, 0)``.
    lift, span : float
        Height of the two vertical moves and width of the horizontal one [m].
    lift_share : float
        Share of the input each vertical move takes, in (0, 0.5).
    overlap : float
        Share of the input during which the horizontal move overlaps each vertical one,
        in [0, lift_share).

    Returns
    -------
    (x, y) [m]
    """
    across = 1 - 2 * (lift_share - overlap)
    y = start[1] + lift * (smooth_step(tau / lift_share) - smooth_step((tau - 1 + lift_share) / lift_share))
    x = start[0] + span * smooth_step((tau - lift_share + overlap) / across)
    return x, y


def cable_length(x, y, anchor):
    """The straight cable from the frame anchor to the end effector at (x, y) [m]."""
    dx, dy = x - anchor[0], y - anchor[1]
    return (dx**2 + dy**2) ** 0.5


def end_effector(l1, l2, anchor1, anchor2):
    """The end effector [m] hung from two anchors by cables of lengths ``l1`` and ``l2`` [m]:
    the intersection of the two circles below the line through the anchors, where gravity
    holds it (NumPy arrays; NaN where the circles do not meet)."""
    a1, a2 = np.asarray(anchor1, dtype=float), np.asarray(anchor2, dtype=float)
    d_vec = a2 - a1
    d = np.hypot(*d_vec)
    along = (np.asarray(l1) ** 2 - np.asarray(l2) ** 2 + d**2) / (2 * d)
    with np.errstate(invalid="ignore"):
        across = np.sqrt(np.asarray(l1) ** 2 - along**2)
    e = d_vec / d
    n = np.array([e[1], -e[0]]) * (-1 if e[0] < 0 else 1)  # the normal that points down
    return a1[0] + along * e[0] + across * n[0], a1[1] + along * e[1] + across * n[1]
