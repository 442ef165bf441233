"""The next step after a failed re-check: what to change, and by how much.

The NLP holds a profile's shape at its convexity check points (``solver.convexity_points``,
spread evenly over the wrapped range) and the springs' travel and each mechanism's own limits at
the design grid's angles (``solver.grid``); the fine re-check scans between them. A limit it
finds broken over a stretch narrower than the samples' spacing was never seen by the NLP;
samples that put :data:`PER_STRETCH` inside a stretch of its width would have seen it:
:func:`next_step` says how many, from the stretch the re-check found, as the ``--set`` (or
flag) that asks for them.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..physics.profile import profile_function
from ..problem import SOLVER, cap, size_error
from .evaluate import LENGTH_TOL, LIMIT_TOL, MARGINS, Evaluation

#: Margins of a profile's shape that the NLP holds at its convexity check points only, so that
#: a profile may break them between those points, where the fine re-check looks.
SHAPE_MARGINS = ("convexity", "curvature_radius", "rho_min", "rho_max")
#: Margins of a spring that the NLP holds at the design grid's angles only.
SPRING_MARGINS = ("travel", "extension_lower")
#: Samples the step puts in the narrowest broken stretch: two, so that they see a stretch of
#: its width wherever it falls between them.
PER_STRETCH = 2


def next_step(fine: Evaluation, tried: int = 0) -> str | None:
    """What to change so that the NLP sees the limits the fine re-check ``fine`` found broken,
    and by how much, in words starting with the flag or ``--set`` that does it; None where
    nothing broken is a matter of samples (a departure not solved, a negative pre-extension).

    ``tried``: the most convexity check points a solve of this design was already given (the
    step asks for at least twice as many).
    """
    problem = fine.problem
    if problem.options.method != "nlp":  # no NLP held anything: it is the one to hold it
        return (f"--set solver.method=nlp: the {problem.options.method} design is re-checked as it is made, and "
                "the NLP holds every limit at its samples")
    steps = [step for step in (_check_points(fine, tried), _grid(fine)) if step is not None]
    return "; and ".join(steps) or None


def _runs(broken: np.ndarray) -> np.ndarray:
    """Lengths of the runs of True in ``broken`` (a flag per sample)."""
    edges = np.diff(np.concatenate([[0], broken.astype(int), [0]]))
    return np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)


def _narrowest(broken: np.ndarray, step: float) -> float:
    """Width of the narrowest broken stretch of samples ``step`` apart: its samples × the step
    (one step where a refined minimum alone, between samples, found it)."""
    runs = _runs(broken)
    return step * (int(runs.min()) if runs.size else 1)


def _samples_for(span: float, width: float) -> int:
    """Samples spread evenly over ``span`` that put :data:`PER_STRETCH` in any stretch of
    ``width``."""
    return math.ceil(PER_STRETCH * span / width) + 1


def _shape_broken(fine: Evaluation, k: int) -> np.ndarray:
    """Per sample of profile ``k``'s scan, whether a shape margin (:data:`SHAPE_MARGINS`) is
    broken there beyond its tolerance."""
    prof, limits = fine.profiles[k], fine.problem.profiles[k]
    n = prof.phi.size
    rho, drho, _, conv = (np.asarray(v).ravel() for v in
                          profile_function(fine.design.bases[k]).map(n)(prof.phi, fine.design.coefficients[k]))
    broken = (conv < -MARGINS["convexity"][1]) | (rho < limits.rho_min - LENGTH_TOL) | (rho > limits.rho_max + LENGTH_TOL)
    if limits.min_curvature_radius > 0:
        with np.errstate(divide="ignore", invalid="ignore"):
            radius = np.where(conv > 0, (rho**2 + drho**2) ** 1.5 / conv, 0.0)
        broken |= radius < limits.min_curvature_radius - LENGTH_TOL
    return broken


def _check_points(fine: Evaluation, tried: int) -> str | None:
    """The convexity check points that see the narrowest stretch of a profile whose shape the
    re-check found broken, or None where no profile's is."""
    problem, margins = fine.problem, fine.metrics.margins
    held = max(problem.options.convexity_points, tried)
    asks = []
    for k in range(len(problem.profiles)):
        key = next((key for key in SHAPE_MARGINS if not margins[key][k] >= -MARGINS[key][1]), None)
        if key is None:
            continue
        prof = fine.profiles[k]
        span = float(prof.phi[-1])
        width = _narrowest(_shape_broken(fine, k), span / (prof.phi.size - 1))
        asks.append((max(_samples_for(span, width), 2 * held), k, key, width, span))
    if not asks:
        return None
    points, k, key, width, span = max(asks, key=lambda a: a[0])
    name = problem.profiles[k].name
    what = (f"{MARGINS[key][2]}: {name!r} over {width:.2g} rad of its {span:.3g} rad wrap, between its {held} "
            f"check points {span / (held - 1):.2g} rad apart")
    if points > cap("convexity_points"):
        return (f"a lower order for {name!r}, or a cap above {points} (CADCAM_CAP_CONVEXITY_POINTS): {what}; "
                f"{PER_STRETCH} check points in it take {points}, beyond the cap {cap('convexity_points')}")
    return f"--set solver.convexity_points={points}: {what}; {points} put them {span / (points - 1):.2g} rad apart"


def _grid_broken(fine: Evaluation) -> list[tuple[str, int, np.ndarray | None, float | None]]:
    """What the re-check found broken of the limits the NLP holds at the design grid's angles
    only, one per spring or mechanism limit: the violation's words, its joint, a flag per angle
    of that joint's fine grid (None where the flags span several joints), and for a spring
    whose bound ``solver.limit_margin`` keeps a reserve from, the reserve [share of its travel]
    that holds :data:`PER_STRETCH` times the overshoot (else None)."""
    problem, margins = fine.problem, fine.metrics.margins
    network = problem.network()
    out = []
    for key in SPRING_MARGINS:
        for j, v in enumerate(margins[key]):
            if v >= -MARGINS[key][1]:
                continue
            spring = problem.springs[j]
            reserve = PER_STRETCH * -v / spring.travel
            # a fixed pre-extension below the reserve pins the lower bound at it
            held = key == "travel" or spring.preextension is None or spring.preextension >= reserve * spring.travel
            flags = None
            if len(problem.joints) == 1:  # its fine grid is the joint's: every extension is one angle's
                x = fine.x[j]
                flags = x > spring.travel + LENGTH_TOL if key == "travel" else x < -LENGTH_TOL
            joints = sorted(network.joints_of(j))
            out.append((f"{MARGINS[key][2]}: {spring.name}", joints[0] if joints else 0, flags,
                        reserve if held else None))
    for mech, unit, own in zip(problem.mechanisms, fine.units, margins["mechanism"]):
        for row, lim in zip(unit.margins, mech.limits):
            if not own[lim.name] >= -LIMIT_TOL[lim.unit]:
                out.append((f"{lim.name.replace('_', ' ')} below its limit: {mech.name}", mech.joint,
                            row < -LIMIT_TOL[lim.unit], None))
    return out


def _rounded_up(x: float, digits: int = 2) -> float:
    """``x`` > 0 rounded up to ``digits`` significant digits."""
    scale = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
    return math.ceil(x / scale - 1e-9) * scale


def _grid(fine: Evaluation) -> str | None:
    """The design grid that sees the narrowest stretch over which a spring or a mechanism's own
    limit is broken on the re-check (and, where only springs' bounds are, the limit margin that
    keeps their overshoot inside), or None where none is."""
    problem = fine.problem
    grid = problem.options.grid
    broken = _grid_broken(fine)
    if not broken:
        return None
    asks = []
    for what, i, flags, _ in broken:
        lo, hi = problem.joints[i].theta_range
        span = hi - lo
        width = None if flags is None else _narrowest(flags, span / (fine.grid - 1))
        ask = 2 * (grid - 1) + 1 if width is None else _samples_for(span, width)
        asks.append((max(ask, 2 * (grid - 1) + 1), i, what, width, span))
    points, i, what, width, span = max(asks, key=lambda a: a[0])
    joint = problem.joints[i].name
    where = f" over {math.degrees(width):.2g}° of the range of joint {joint!r}" if width is not None else ""
    said = f"{what}{where}, between its {grid} design-grid angles {math.degrees(span / (grid - 1)):.3g}° apart"
    too_big = size_error(replace(problem.options, grid=points), len(problem.joints))
    step = (f"fewer joints or narrower ranges: {said}; a grid of {points} angles: {too_big[1]}" if too_big is not None
            else f"--grid {points} (or --set solver.grid={points}): {said}; {points} put them "
                 f"{math.degrees(span / (points - 1)):.3g}° apart")
    return step + _reserve([b[3] for b in broken], problem.options.limit_margin)


def _reserve(reserves: list, margin: float) -> str:
    """The alternative of a larger ``solver.limit_margin`` (now ``margin``) that keeps every
    spring's overshoot inside its bound, where it can (``reserves``, each broken limit's: a
    share of the travel, or None where the margin keeps none from it); else ""."""
    if any(r is None for r in reserves):
        return ""
    needed = _rounded_up(margin + max(reserves))
    if not SOLVER["limit_margin"].ok(needed):
        return ""
    return (f"; or --set solver.limit_margin={needed:g}: a reserve of {PER_STRETCH}× the overshoot, "
            f"{100 * max(reserves) / PER_STRETCH:.2g} % of the travel, beyond the {margin:g} kept now")
