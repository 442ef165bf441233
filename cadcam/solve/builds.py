"""Built NLPs kept for reuse: a problem of the same structure (everything a build depends on
beyond its CasADi parameters and bounds) is solved through the NLP already built for it, as a
sweep's cases and a design session's edits are."""
from __future__ import annotations

import json
from collections import OrderedDict

from ..problem import Problem
from . import robust
from .rows import ANCHOR_ROWS_FIRST
from .stall import STALL_RULE
from .transcription import Transcription

#: How many built NLPs a process keeps, the least recently used dropped first (a 2-DOF build
#: holds some tens of MB).
KEPT_BUILDS = 8

_BUILDS: OrderedDict[str, Transcription] = OrderedDict()


def structure_key(problem: Problem) -> str:
    """What a built NLP depends on beyond its CasADi parameters and bounds."""
    o = problem.options
    return json.dumps([
        problem.torque_model, o.grid, o.quadrature_order, o.convexity_points, o.max_iter, o.tol,
        o.objective, o.functions, [list(x) for x in o.ipopt],
        [problem.curvature_limit(k) > 0 for k in range(len(problem.profiles))],
        [[list(c.theta_range), [w > 0 for w in c.sensitivity_weights], c.band_weight > 0] for c in problem.joints],
        [[m.kind, m.joint, [[b.name, b.order, list(b.domain)] for b in m.bases]]
         for m in problem.mechanisms],
        [[[p.mechanism, p.name, p.sign] for p in s.ports] for s in problem.springs],
        [s.free_length is not None for s in problem.springs],
        [sorted(m.placement_region()) for m in problem.mechanisms],
        sorted(problem.arm_scales().items()), robust.structure(problem), repr(STALL_RULE.get()),
        ANCHOR_ROWS_FIRST.get()])


def built_for(problem: Problem) -> tuple[Transcription, bool]:
    """The NLP of ``problem``'s structure, built now or kept from before; and whether it was
    built by this call. A kept build whose library has compiled in the background since
    solves through it from now on (:meth:`Transcription.adopt_compiled`)."""
    key = structure_key(problem)
    tr = _BUILDS.get(key)
    if tr is not None:
        _BUILDS.move_to_end(key)
        tr.adopt_compiled()
        return tr, False
    tr = _BUILDS[key] = Transcription(problem)
    while len(_BUILDS) > KEPT_BUILDS:
        _BUILDS.popitem(last=False)
    return tr, True


def forget_builds() -> None:
    """Drop every kept NLP (the next problem of each structure is built afresh)."""
    _BUILDS.clear()
