"""The tolerances a workshop drawing states: the bore's fit (ISO 286-1) and the general
tolerances of every other length and angle (ISO 2768-1), looked up by nominal size.

Tables hold (largest nominal size [mm] of the range, value) pairs in increasing size; a size
belongs to the first range whose largest size it does not pass (ISO's "over … up to and
including").
"""
from __future__ import annotations

import bisect

#: The bore's fit: a hole of basis H (lower deviation 0) and grade IT7, the usual fit of a part
#: keyed, pinned or clamped on a ground shaft (h6/g6 a sliding fit, k6 a transition fit).
BORE_FIT = "H7"

#: ISO 286-1:2010 Table 1, grade IT7 [µm] by nominal size [mm], up to 1000 mm (the largest bore
#: ``[workshop] bore_diameter`` allows).
IT7 = ((3, 10), (6, 12), (10, 15), (18, 18), (30, 21), (50, 25), (80, 30), (120, 35), (180, 40),
       (250, 46), (315, 52), (400, 57), (500, 63), (630, 70), (800, 80), (1000, 90))

#: The general tolerance class of every length and angle not toleranced on its own.
GENERAL_CLASS = "ISO 2768-m"

#: ISO 2768-1:1989 Table 1, class m (medium): permissible deviation ± [mm] of a linear size by
#: nominal size [mm]. The standard starts at 0.5 mm; a smaller size (a coordinate near 0) is
#: given the first range's ±0.1 here.
LINEAR_M = ((3, 0.1), (6, 0.1), (30, 0.2), (120, 0.3), (400, 0.5), (1000, 0.8), (2000, 1.2), (4000, 2.0))

#: ISO 2768-1:1989 Table 3, class m: permissible deviation ± [degrees] of an angle by the
#: length [mm] of its shorter leg (beyond 400 mm: ±5′).
ANGULAR_M = ((10, 1.0), (50, 0.5), (120, 1 / 3), (400, 1 / 6), (float("inf"), 1 / 12))


def _lookup(table, size: float):
    """The value of the range of ``table`` that nominal ``size`` [mm] falls in; ValueError
    beyond its last range."""
    k = bisect.bisect_left([top for top, _ in table], abs(size))
    if k == len(table):
        raise ValueError(f"nominal size {size:g} mm is beyond the table's {table[-1][0]:g} mm")
    return table[k][1]


def bore_limits(diameter: float) -> tuple[float, float]:
    """Lower and upper deviation [mm] of an H7 hole of nominal ``diameter`` [mm]: 0 and IT7."""
    return 0.0, _lookup(IT7, diameter) * 1e-3


def linear_tolerance(size: float) -> float:
    """± [mm] of a length or coordinate of nominal ``size`` [mm] under :data:`GENERAL_CLASS`."""
    return _lookup(LINEAR_M, size)


def angular_tolerance(leg: float) -> float:
    """± [degrees] of an angle whose shorter leg is ``leg`` [mm] long under :data:`GENERAL_CLASS`."""
    return _lookup(ANGULAR_M, leg)
