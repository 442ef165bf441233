"""CasADi functions mapped over many points, each map built once."""
from __future__ import annotations

from functools import lru_cache

import casadi as ca

#: How many maps are kept (a function and a count of points each): the re-check's and a design
#: page's, whose designs evaluate the same functions on the same grids edit after edit.
KEPT_MAPS = 512


@lru_cache(maxsize=KEPT_MAPS)
def mapped(f: ca.Function, n: int) -> ca.Function:
    """``f.map(n)``, built once per function and count (a function is its own key: the cached
    functions of a structure, :func:`cadcam.mechanisms.base.pose_function` and the like). A map
    takes about half a millisecond to build, as long as evaluating a small one: a warm design of
    the 1-DOF spec built fourteen, 7 ms of its 70."""
    return f.map(n)
