"""Which constraints of a design bind: the limits an evaluation sits at (or beyond), each as one
short sentence with the value and the limit in millimetres.

A limit *binds* when the design's margin to it is at most :data:`RTOL` times the limit's own
size (its scale, below); a margin more negative than that is a limit *exceeded* (it is also
among the evaluation's ``violations``, which name it without the numbers). The tolerance is
relative so that it means the same for a 10 mm cam and a 200 mm one; 1e-3 is ten times the
reserve the NLP keeps from every limit (``limit_margin`` = 1e-4 of it), so an optimum pressed
against a limit is flagged on the fine re-check while a limit missed by 0.1 % is not.

The scale of each limit: a spring's travel for both its travel limit and its zero extension
(x ≥ 0), ρ_min and ρ_max for themselves, ρ_min² for the convexity margin (which binds within
the tolerance of the NLP's required ``convexity_epsilon``·ρ_min² and is exceeded only below zero,
where the profile stops being convex), the minimum radius of curvature for
itself, and for a mechanism's own limits (moment arm, free span, slider travel) the larger of
the limit and the mechanism's ρ_min (a limit of zero has no size of its own).
"""
from __future__ import annotations

import math
from collections.abc import Mapping
import numbers

from ..mechanisms.base import LIMIT_UNITS
from ..units import MM

#: Relative tolerance: a margin ≤ RTOL × the limit's scale binds.
RTOL = 1e-3

def _finite(v) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, bool) and math.isfinite(v)


def limit_state(margin: float, scale: float, rtol: float = RTOL) -> str | None:
    """"at" (|margin| ≤ rtol·scale), "beyond" (margin < −rtol·scale) or None (slack)."""
    if margin > rtol * scale:
        return None
    return "at" if margin >= -rtol * scale else "beyond"


def binding_constraints(metrics: Mapping, problem, rtol: float = RTOL) -> list[str]:
    """The constraints of ``problem`` that bind in an evaluation's ``metrics``.

    Parameters
    ----------
    metrics : dict
        :attr:`cadcam.verify.evaluate.Evaluation.metrics` (or ``result.json``'s ``metrics`` /
        ``recheck``): ``extension_min``/``extension_max`` per spring, ``rho_min``/``rho_max``,
        ``convexity_min``, ``curvature_radius_min`` per profile, ``margins["mechanism"]``.
    problem : cadcam.problem.Problem
        The problem whose limits the metrics are measured against.
    rtol : float
        Relative tolerance (:data:`RTOL`).

    Returns
    -------
    list of str
        One sentence per binding or exceeded limit, e.g. ``"spring 2 at its travel limit:
        32.00 mm of 32.00 mm"``; springs first, then profiles, then mechanisms. Values that are
        not finite are left to the evaluation's violations.
    """
    out = _spring_sentences(metrics, problem, rtol)
    out += _profile_sentences(metrics, problem, rtol)
    own = metrics.get("margins", {}).get("mechanism", [])
    for mech, margins in zip(problem.mechanisms, own):
        out += _mechanism_sentences(mech, margins, rtol)
    return out


def _measured(values: list, i: int) -> bool:
    """Whether ``values`` holds a finite measurement at index ``i``."""
    return i < len(values) and _finite(values[i])


def _spring_sentences(metrics: Mapping, problem, rtol: float) -> list[str]:
    """The binding sentences of each spring: its largest extension (its travel, or its
    cable's working load where that comes first), then its zero extension."""
    out = []
    xmin, xmax = metrics.get("extension_min", []), metrics.get("extension_max", [])
    for j, s in enumerate(problem.springs):
        largest = problem.extension_limit(j)
        if _measured(xmax, j):
            state = limit_state(largest - xmax[j], largest, rtol)
            if state and largest < s.travel:
                cable, tension = problem.cable, s.rate * xmax[j] + s.preload
                out.append(f"{s.name} {state} its cable's working load: tension {tension:.4g} N of "
                           f"{cable.working_load:.4g} N ({cable.breaking_load:.4g} N breaking / {cable.safety_factor:g})")
            elif state:
                out.append(f"{s.name} {state} its travel limit: {MM * xmax[j]:.2f} mm of "
                           f"{MM * s.travel:.2f} mm")
        if _measured(xmin, j):
            state = limit_state(xmin[j], s.travel, rtol)
            if state == "at":
                out.append(f"{s.name} at zero extension: least extension {MM * xmin[j]:.3f} mm "
                           f"(travel {MM * s.travel:.2f} mm)")
            elif state:
                out.append(f"{s.name} in compression: {MM * xmin[j]:.3f} mm (must stay ≥ 0)")
    return out


def _profile_sentences(metrics: Mapping, problem, rtol: float) -> list[str]:
    """The binding sentences of each profile: ρ_min, ρ_max, the convexity margin (the NLP
    asks ≥ ``convexity_epsilon``·ρ_min²) and the minimum radius of curvature (its own or its
    cable's, :meth:`cadcam.problem.Problem.curvature_limit`)."""
    out = []
    eps = problem.options.convexity_epsilon
    lo, hi = metrics.get("rho_min", []), metrics.get("rho_max", [])
    conv, curv = metrics.get("convexity_min", []), metrics.get("curvature_radius_min", [])
    for k, p in enumerate(problem.profiles):
        if _measured(lo, k):
            state = limit_state(lo[k] - p.rho_min, p.rho_min, rtol)
            if state:
                out.append(f"{p.name} {state} ρ_min: ρ down to {MM * lo[k]:.2f} mm, "
                           f"ρ_min {MM * p.rho_min:.2f} mm")
        if _measured(hi, k):
            state = limit_state(p.rho_max - hi[k], p.rho_max, rtol)
            if state:
                out.append(f"{p.name} {state} ρ_max: ρ up to {MM * hi[k]:.2f} mm, "
                           f"ρ_max {MM * p.rho_max:.2f} mm")
        if _measured(conv, k):
            out += _convexity_sentences(p, conv[k], eps * p.rho_min ** 2, rtol)
        least = problem.curvature_limit(k)
        if least > 0 and _measured(curv, k):
            state = limit_state(curv[k] - least, least, rtol)
            if state and least > p.min_curvature_radius:
                out.append(f"{p.name} {state} its cable's least bend radius: radius of curvature "
                           f"{MM * curv[k]:.2f} mm of {MM * least:.2f} mm ({MM * problem.cable.min_bend_radius:.2f} mm "
                           "to the cut outline, plus the cable's radius)")
            elif state:
                out.append(f"{p.name} {state} its minimum radius of curvature: {MM * curv[k]:.2f} mm "
                           f"of {MM * least:.2f} mm")
    return out


def _convexity_sentences(p, conv: float, need: float, rtol: float) -> list[str]:
    """The binding sentence, if any, of profile ``p``'s least convexity margin ``conv`` [m²]:
    near the NLP's required ``need`` [m²] (convexity itself only needs > 0), or below zero."""
    state = "beyond" if limit_state(conv, p.rho_min ** 2, rtol) == "beyond" else (
        "at" if limit_state(conv - need, p.rho_min ** 2, rtol) else None)
    if not state:
        return []
    word = "convexity margin near zero" if state == "at" else "not convex"
    return [f"{p.name} {word}: ρ² + 2ρ′² − ρρ″ down to {MM**2 * conv:.3g} mm² "
            f"(the NLP asks ≥ {MM**2 * need:.3g} mm², ρ_min² = {MM**2 * p.rho_min**2:.3g} mm²)"]


def _mechanism_sentences(mech, margins: dict, rtol: float) -> list[str]:
    """The binding sentences of one mechanism's own limits (:attr:`Mechanism.limits`)."""
    out = []
    size = min(p.rho_min for p in mech.profiles) if mech.profiles else 0.0
    for lim in mech.limits:
        margin = margins.get(lim.name)
        limit = lim.value(mech)
        if not _finite(margin) or not math.isfinite(limit):  # not computed, or no limit (an unbounded slider)
            continue
        state = limit_state(margin, max(abs(limit), size if lim.unit == "m" else 0.0), rtol)
        if not state:
            continue
        factor, unit, _ = LIMIT_UNITS[lim.unit]
        value = limit + lim.sense * margin
        side = "lower" if lim.sense > 0 else "upper"
        label = f"{mech.name} {lim.what}" + (f" (profile {lim.profile})" if lim.profile else "")
        space = " " if unit.isalpha() else ""
        out.append(f"{label} {state} its {side} limit: {factor * value:.2f}{space}{unit} of "
                   f"{factor * limit:.2f}{space}{unit}")
    return out
