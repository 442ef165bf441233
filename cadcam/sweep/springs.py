"""A spec's spring slot searched over a whole spring catalogue: what the slot asks of a spring
(:func:`slot_need`), the catalogue's screen for it (:func:`screen_slot`) before any solve, and
the survivors designed on a process pool or a Dask cluster (:func:`search`), each warm-started
from a solved spring near it in rate and initial tension, in an order and from starts fixed
before any is designed (:class:`StartTree`), each given a verdict (:data:`VERDICTS`).

Fast enough for a whole catalogue: each worker parses the spec once and swaps each part's
spring into it (:func:`with_part`: the NLP's numbers change, not its graph, so one build serves
every part); a spring starts from its neighbour's design with the spring's pre-extension
matched (:func:`force_matched`), its IPOPT multipliers and the margins it needed; a profile
that breaks its shape between the check points is mended by raising those margins in the same
NLP (:data:`SEARCH_REFINE`); only while no spring is solved does one start from the default
start.
"""
from __future__ import annotations

import contextlib
import copy
import heapq
import json
import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..designs import Design
from ..errors import SpecError
from ..physics.catalogue import Catalogue, Need, Screen, Slack, room_arms, screen
from ..physics.springs import Spring
from ..problem import Problem
from ..solve.blocks import LENGTH_SCALE
from ..solve.ipopt import IMPOSE_OPTIONS, SEARCH_IMPOSE_IPOPT, Multipliers
from ..solve.rows import ANCHOR_ROWS_FIRST
from ..solve.stall import STALL_STATUS, StallRule, stall_rule

#: Points of the joint's range the target's work and peak torque are taken on.
NEED_POINTS = 2001
#: Every how many of those points a window of the acceptance's slack starts and ends
#: (:func:`acceptance_slack`): 100 widths.
NEED_WINDOW = 20


def slot_need(problem: Problem, j: int) -> Need:
    """What spring ``j`` (0-based) of ``problem`` must at least do, for :func:`screen`.

    The tests apply to a spring on one joint that no other spring works on (its energy must
    then supply the target's whole work); a spring that shares its joint, or spans several,
    gets no test and every catalogue spring passes the screen.
    """
    spring = problem.springs[j]
    joints = {problem.mechanisms[p.mechanism].joint for p in spring.ports}
    if len(joints) != 1:
        return Need()
    (i,) = joints
    shared = [s for s in problem.springs if s is not spring
              and any(problem.mechanisms[p.mechanism].joint == i for p in s.ports)]
    if shared or len(problem.joints) != 1:
        return Need()
    joint = problem.joints[i]
    theta = np.linspace(*joint.theta_range, NEED_POINTS)
    tau = np.asarray(joint.target.function(1, 0).map(theta.size)(theta[None, :])).ravel()
    work = np.concatenate([[0.0], np.cumsum(0.5 * (tau[1:] + tau[:-1]) * np.diff(theta))])
    port = spring.ports[0]
    mechanism = problem.mechanisms[port.mechanism]
    arm = mechanism.largest_arm(port.name) if len(spring.ports) == 1 else None
    rooms = mechanism.mount_room(port.name, room_arms(arm)) if arm is not None else None
    return Need(energy=float(work.max() - work.min()), torque=float(np.abs(tau).max()), arm=arm,
                angle=float(np.ptp(theta)) if arm is not None else None,
                rooms=None if rooms is None else tuple(float(r) for r in rooms),
                slack=acceptance_slack(joint.limits, theta, tau))


def acceptance_slack(limits: dict, theta: np.ndarray, tau: np.ndarray) -> Slack:
    """How far a design may miss the target ``tau`` [N·m] at the evenly spaced angles ``theta``
    [rad] and still meet the acceptance ``limits`` (a joint's): :class:`Slack`, its windows
    every :data:`NEED_WINDOW` points of the angles."""
    from ..problem import TORQUE_FLOOR

    span, inf = float(np.ptp(theta)), math.inf
    relative = limits.get("relative_rmse")
    size = np.abs(tau)
    total = np.concatenate([[0.0], np.cumsum(0.5 * (size[1:] + size[:-1]) * np.diff(theta))])[::NEED_WINDOW]
    ends = theta[::NEED_WINDOW]
    windows = tuple((math.sqrt(span / (ends[d] - ends[0])),
                     float(np.max((total[d:] - total[:-d]) / (ends[d:] - ends[:-d]))))
                    for d in range(1, ends.size))
    return Slack(span=span, rmse=inf if relative is None else relative * float(np.sqrt(np.mean(tau**2))),
                 per_joule=inf if relative is None else relative * TORQUE_FLOOR / span,
                 cap=limits.get("rmse") or inf, max_error=limits.get("max_abs_error") or inf, windows=windows)


def screen_slot(problem: Problem, j: int, catalogue: Catalogue) -> Screen:
    """``catalogue`` screened for spring ``j`` of ``problem`` (:func:`slot_need`, :func:`screen`)."""
    return screen(catalogue, slot_need(problem, j))


# -- the whole catalogue searched ---------------------------------------------------------------
#: The most IPOPT iterations a catalogue search spends on one spring in one solve (at most the
#: spec's own ``solver.max_iter``; a solve that imposes its deferred rows after the first may
#: spend as many again): a spring the design reaches converges in a few dozen from a
#: neighbour's design, and one that does not would otherwise hold a worker for the spec's
#: whole limit, costing more than dozens of springs that fit. A spring that reaches the cap is
#: reported undecided, not infeasible.
SEARCH_MAX_ITER = 100

#: The stall rule of a search's solves (:class:`cadcam.solve.stall.StallRule`): a run whose
#: primal infeasibility (IPOPT's inf_pr, in the NLP's scaled units, mm and mm²) has stayed at
#: least 3 through iterations 25 to 30 is stopped at the 30th, its spring undecided, where it
#: would otherwise hold a worker to :data:`SEARCH_MAX_ITER`: on the tutorial's catalogue nearly
#: every undecided spring sat that far from feasible for dozens of iterations, and a window
#: rather than one iteration spares the converging runs whose inf_pr rises and falls on the way
#: (a single test at iteration 40 with inf_pr ≥ 1 stopped feasible springs too).
SEARCH_STALL = StallRule(iteration=30, window=5, inf_pr=3.0)

#: How a search solves again a design whose profile broke its shape between the NLP's check
#: points (:data:`cadcam.optimize.REFINEMENTS`): its margins raised in the same NLP, warm, in a
#: fraction of a second, where ``cadcam design``'s four times the check points took 3–25 s a
#: spring on the tutorial (a third of its catalogue) and ended at the iteration limit for half.
SEARCH_REFINE = "margin"

#: The orders ``cadcam springs --rank`` offers: within each verdict (feasible, near, then the
#: rest), rows by this key, ties by rmse.
RANKS = {
    "error": "the design's rmse [N·m]",
    "band": "the design's first-order tolerance band, its largest half-width [N·m] (computed for every design "
            "with this rank, some 25 ms each)",
    "size": "the spring's outside diameter × free length [m²]",
    "cost": "the pack price [USD]",
}

#: A search row's verdicts, in the order the table lists them.
VERDICTS = {
    "feasible": "designed; the solve converged and the re-check passed, the body's limits included",
    "near": "designed and converged, but the re-check failed: the reason names the binding limit and by how much",
    "undecided": "passed the screen, but its design did not converge (its status; a search's within its budget, "
                 "SEARCH_MAX_ITER iterations from one start, or stopped by SEARCH_STALL, the stall rule): neither "
                 "found nor ruled out",
    "infeasible": "screened out (its reason: a test it cannot pass), or a part the spec cannot use",
    "not_designed": "passed the screen but beyond --limit",
}
#: Each verdict's colour (CSS), best first: the catalogue figure's (``catalogue.png``) and the
#: design page's lights (:data:`cadcam.app.parts.LIGHTS`).
VERDICT_COLOURS = {"feasible": "#2e7d32", "near": "#f9a825", "undecided": "#8d6e63", "infeasible": "#c62828",
                   "not_designed": "#90a4ae"}

#: The columns of ``springs.csv`` (SI units; the price in the catalogue's currency; ``band``
#: only with ``--rank band``).
TABLE_COLUMNS = ("part_number", "verdict", "reason", "rmse", "relative_rmse", "peak_force", "max_length",
                 "band", "od", "free_length", "pack_price")


def part_spec(data: dict, j: int, part: str, catalogue: str | None) -> dict:
    """Spec data ``data`` with spring ``j`` (0-based) made catalogue part ``part`` (of the
    catalogue file ``catalogue``, None: the shipped one): the keys the part fills removed."""
    from ..spec import FILLED_BY_PART

    out = copy.deepcopy(data)
    spring = {k: v for k, v in out["springs"][j].items() if k not in (*FILLED_BY_PART, "catalogue")}
    spring["part"] = part
    if catalogue is not None:
        spring["catalogue"] = catalogue
    out["springs"][j] = spring
    return out


def with_part(problem: Problem, j: int, part: str, catalogue: str | None) -> Problem:
    """``problem`` with spring ``j`` (0-based) made catalogue part ``part`` (of the catalogue
    file ``catalogue``, None: the shipped one): the problem :func:`part_spec`'s data parses to,
    made without parsing the spec again.

    Raises
    ------
    SpecError
        An unknown part, one without travel, or a spring whose fixed pre-extension is beyond
        the part's travel (one line).
    """
    from ..physics.catalogue import load_catalogue
    from ..spec import part_values

    spring = problem.springs[j]
    try:
        body, filled = part_values(load_catalogue(catalogue), part)
    except (KeyError, ValueError) as exc:
        raise SpecError(f"part {part!r}: {exc.args[0]}") from None
    if spring.preextension is not None and spring.preextension > filled["travel"]:
        raise SpecError(f"part {part!r}: {spring.name}'s preextension {spring.preextension:g} m is beyond its "
                        f"travel {filled['travel']:.6g} m")
    where = None if catalogue is None else str(Path(catalogue).resolve())
    springs = list(problem.springs)
    springs[j] = replace(spring, **filled, part=part, catalogue=where, body=body)
    return replace(problem, springs=tuple(springs))


#: A worker's spec of the search under way, parsed once: (its key, the problem).
_PARSED: dict = {}


def _spec_problem(spec: tuple) -> Problem:
    """The problem of ``spec`` = (data, origin, base folder) with the search's iteration cap
    (:data:`SEARCH_MAX_ITER`), parsed once per worker and search."""
    from ..spec import parse_spec

    data, origin, base = spec
    key = json.dumps([data, origin, base], sort_keys=True, default=str)
    if _PARSED.get("key") != key:
        problem = parse_spec(data, origin, Path(base))
        _PARSED.update(key=key, problem=problem.with_options(max_iter=min(problem.options.max_iter,
                                                                           SEARCH_MAX_ITER)))
    return _PARSED["problem"]


@contextlib.contextmanager
def search_nlp():
    """Within the block, NLPs are built as a search builds them: the outline's rows at the
    anchor imposed from the first solve (:data:`cadcam.solve.rows.ANCHOR_ROWS_FIRST`)."""
    anchor = ANCHOR_ROWS_FIRST.set(True)
    try:
        yield
    finally:
        ANCHOR_ROWS_FIRST.reset(anchor)


@contextlib.contextmanager
def search_solves():
    """Within the block, solves as a search's are (:func:`design_part`): their stalled runs
    stopped (:data:`SEARCH_STALL`, fixed into the builds made or kept for them), the
    deferred rows imposed with :data:`cadcam.solve.ipopt.SEARCH_IMPOSE_IPOPT`, a design whose
    solve did not converge not re-checked on the fine grid
    (:data:`cadcam.optimize.RECHECK_UNCONVERGED`: its spring is undecided from its status) and
    the profiles scanned by the fine re-check alone (:data:`cadcam.optimize.SCAN_DESIGN_GRID`:
    a row's rmse is the design grid's, its verdict the re-check's); the NLPs built there are
    the search's (:func:`search_nlp`)."""
    from ..optimize import RECHECK_UNCONVERGED, SCAN_DESIGN_GRID

    impose, unconverged = IMPOSE_OPTIONS.set(SEARCH_IMPOSE_IPOPT), RECHECK_UNCONVERGED.set(False)
    scan = SCAN_DESIGN_GRID.set(False)
    try:
        with stall_rule(SEARCH_STALL), search_nlp():
            yield
    finally:
        SCAN_DESIGN_GRID.reset(scan)
        RECHECK_UNCONVERGED.reset(unconverged)
        IMPOSE_OPTIONS.reset(impose)


def design_part(spec: tuple, j: int, part: str, catalogue: str | None, start: dict | None,
                band: bool = False) -> dict:
    """Design the spec ``spec`` = (data, origin, base folder) with spring ``j`` made catalogue
    part ``part`` (:func:`with_part`), warm from ``start`` if given (:func:`solved_start`: a solved
    neighbour's design, its multipliers and the margins it was solved with, its part, its
    spring's (k, F0) and middle extension for :func:`force_matched`); a row for
    :func:`verdict`, with the design's tolerance band where ``band``. Never raises: a failure
    is a row."""
    from ..optimize import warm_optimize
    from ..solve.builds import built_for

    t0 = time.perf_counter()
    row = {"part": part}
    try:
        problem = with_part(_spec_problem(spec), j, part, catalogue)
    except SpecError as exc:
        row.update(status="unusable", message=str(exc), wall_time_s=time.perf_counter() - t0)
        return row
    try:
        start = start or {}
        design = (force_matched(Design.from_dict(start["design"], problem), j, start["spring"], problem.springs[j],
                                start["extension"]) if start else None)
        with search_solves():
            tr, _ = built_for(problem)
            warm = matched_point(tr, start.get("multipliers"), design, j) if start else None
            # a warm start that fails is not tried again from the default start: on the tutorial's
            # catalogue that retry seldom converged and cost more than the springs that did
            result = warm_optimize(problem, tr, design, None, f"part {start.get('part')}", warm,
                                   refine=SEARCH_REFINE, margins=start.get("margins"), retry=False)
        row.update(status=result.status, message=result.message, iterations=result.solve.iterations,
                   violations=result.recheck.violations if not result.success else [],
                   rmse=max(result.evaluation.metrics.rmse),
                   relative_rmse=_largest(result.evaluation.metrics.relative_rmse),
                   objective=result.evaluation.metrics.objective, design=result.design.to_dict(),
                   multipliers=result.solve.multipliers, margins=result.solve.margins,
                   extension=float(np.mean([result.recheck.metrics.extension_min[j],
                                            result.recheck.metrics.extension_max[j]])),
                   body=problem.springs[j].body_report(result.recheck.metrics.extension_max[j]),
                   inf_pr=result.solve.history["inf_pr"][-1] if result.solve.history["inf_pr"] else None)
        if band and result.band is not None:
            row["band"] = float(result.band.half_width.max())
    except Exception as exc:  # noqa: BLE001 - any failure of one spring is its row, the search goes on
        row.update(status="error", message=f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}")
    row["wall_time_s"] = time.perf_counter() - t0
    return row


def designed_again(problem: Problem, row: dict):
    """The design of a search's ``row`` solved again for ``problem`` (the spec with the row's
    part, its own solver settings): warm from the row's answer (its multipliers and any
    margins it was solved with), the same design, re-checked, in a few iterations; from the
    default start where that fails (on another path, a fresh library, it may not pass). Both
    in the NLP as the search built it (:func:`search_nlp`): its rows in the order of the row's
    multipliers, its libraries the search's."""
    from ..optimize import optimize

    with search_nlp():
        result = optimize(problem, start=Design.from_dict(row["design"], problem), warm=row["multipliers"],
                          refine=SEARCH_REFINE, margins=row["margins"])
        return result if result.success else optimize(problem)


def force_matched(design: Design, j: int, was: tuple[float, float], spring: Spring, extension: float) -> Design:
    """``design``, a neighbour's solved with spring ``j`` of rate and initial tension ``was`` =
    (k [N/m], F0 [N]) and extended by ``extension`` [m] in the middle of its range, with that
    spring's pre-extension moved so that ``spring`` pulls as hard there: the design's torque
    then starts close to the target the neighbour's met, where a neighbour of another initial
    tension would start it off by the difference times the moment arm (measured on the
    tutorial: from a neighbour of the same rate, 3 iterations instead of 11). Unchanged where
    that would take a pre-extension below zero, or the spring's is fixed."""
    k, f0 = was
    moved = (f0 + k * extension - spring.preload) / spring.rate - (extension - design.preextension[j])
    if spring.preextension is not None or not moved > 0:
        return design
    pre = np.array(design.preextension, dtype=float)
    pre[j] = moved
    return replace(design, preextension=pre)


def matched_point(tr, warm: Multipliers | None, design: Design, j: int) -> Multipliers | None:
    """``warm``, a neighbour's multipliers and NLP point, with spring ``j``'s pre-extension in
    that point made ``design``'s (:func:`force_matched`'s, in the build ``tr``): a warm start
    starts IPOPT at the answer's own NLP point where it holds one
    (:meth:`cadcam.solve.transcription.Transcription.solve`), not at the design given beside
    it, so the matched pre-extension is put where the solve reads it."""
    if warm is None or warm.x is None:
        return warm
    x = np.array(warm.x, dtype=float)
    pre = tr.v.part(x, "x0").copy()
    if pre[j] * LENGTH_SCALE == design.preextension[j]:
        return warm
    pre[j] = design.preextension[j] / LENGTH_SCALE
    tr.v.put(x, "x0", pre)
    return replace(warm, x=x)


def _largest(values) -> float | None:
    known = [v for v in values if v is not None]
    return max(known) if known else None


#: A body's quantity and limit per :data:`~cadcam.physics.springs.BODY_LIMITS` name, as
#: ``spring_bodies`` in result.json reports them, and the limit's words.
BODY_FIELDS = {"length": ("max_length", "length_max", "its largest length"),
               "load": ("peak_force", "load_max", "its largest load"),
               "stress": ("peak_stress", "allowed_stress", "its wire's stress allowance")}


def binding_limit(body: dict) -> tuple[str, float]:
    """The body limit nearest to (or furthest past) its bound at the design's largest extension
    and how far: (words, value / limit − 1)."""
    ratios = {k: body[q] / body[lim] - 1.0 for k, (q, lim, _) in BODY_FIELDS.items()}
    k = max(ratios, key=ratios.get)
    return BODY_FIELDS[k][2], ratios[k]


def verdict(row: dict) -> tuple[str, str]:
    """A designed spring's verdict and reason (:data:`VERDICTS`): a design that did not
    converge proves nothing, so it is ``undecided``; only a part the spec cannot use
    (:func:`with_part`) is ``infeasible`` here."""
    if row["status"] == "unusable":
        return "infeasible", f"unusable: {row['message']}"
    if row["status"] == STALL_STATUS:
        return "undecided", (f"stopped by the stall rule: {SEARCH_STALL.words()} (its inf_pr {row['inf_pr']:.3g}); "
                             "neither found nor ruled out")
    if row["status"] == "error" or "body" not in row:
        return "undecided", f"not finished: {row['status']}: {row['message']}"
    words, ratio = binding_limit(row["body"])
    if row["status"] == "success":
        raised = row.get("margins") or {}
        mended = (f"; solved with its shape margins raised (convexity ε = {raised['convexity_epsilon']:.3g} ρ_min², "
                  f"limit margin {raised['limit_margin']:.3g})" if raised else "")
        return "feasible", f"binding: {words}, {100 * -ratio:.3g} % to spare{mended}"
    if row["status"] in ("recheck_failed", "target_missed"):
        if ratio > 0:
            return "near", f"{words} passed by {100 * ratio:.3g} %"
        first = row["violations"][0] if row["violations"] else row["message"]
        return "near", f"{row['status']}: {first}"
    return "undecided", f"not finished: {row['status']}: {row['message']}"


def design_order(catalogue: Catalogue, passed, nominal_rate: float) -> list[int]:
    """The rows that passed the screen, nearest the nominal rate first (|log k/k_nominal|)."""
    rows = np.flatnonzero(passed)
    gap = np.abs(np.log(catalogue.body.rate[rows] / nominal_rate))
    return [int(i) for i in rows[np.argsort(gap, kind="stable")]]


def spring_scales(catalogue: Catalogue, rows) -> tuple[float, float]:
    """The spans of log rate and of initial tension [N] over catalogue ``rows`` (those that
    passed the screen; 1 where one is zero): the scales of :func:`spring_gaps`."""
    b = catalogue.body
    spans = (float(np.ptp(np.log(b.rate[rows]))), float(np.ptp(b.preload[rows]))) if len(rows) else (0.0, 0.0)
    return tuple(v or 1.0 for v in spans)


#: The weight of initial tension against rate in :func:`spring_gaps`: a neighbour's design starts
#: a spring with its pre-extension moved so that it pulls as hard in the middle of its range
#: (:func:`force_matched`), which makes up for most of a difference in initial tension and none
#: of one in rate. Chosen where the searches of the tutorial's catalogue, the 1-DOF wire cam's
#: and Endo2010's pulley's took fewer IPOPT iterations than at 1 and found as many feasible
#: springs or more (``bench_springs.py`` measures the tutorial's).
TENSION_WEIGHT = 0.3


def spring_gaps(springs: np.ndarray, spring: tuple[float, float], scales: tuple[float, float]) -> np.ndarray:
    """Distances from each of ``springs`` (m, 2) = (rate k [N/m], initial tension F0 [N]) to
    ``spring``: in log k and F0, each over its span ``scales`` (:func:`spring_scales`), F0's
    weighted by :data:`TENSION_WEIGHT`."""
    (k, f0), (sk, sf) = spring, scales
    return np.hypot(np.log(springs[:, 0] / k) / sk, TENSION_WEIGHT * (springs[:, 1] - f0) / sf)


def solved_start(row: dict, spring: tuple[float, float]) -> dict | None:
    """The start a designed ``row`` (:func:`design_part`'s) gives the springs after it: its
    design, multipliers, margins and part, its spring ``spring`` = (k [N/m], F0 [N]) and its
    middle extension (for :func:`force_matched`); None where its design failed."""
    if row["status"] != "success":
        return None
    return {"design": row["design"], "multipliers": row["multipliers"], "margins": row["margins"],
            "part": row["part"], "spring": spring, "extension": row["extension"]}


class StartTree:
    """The order a search designs its springs in and the spring each starts from, fixed before
    any is designed, so that a search's rows are the same on any number of workers or a Dask
    cluster and however long each design takes: the springs joined by Prim's tree over their
    gaps (:func:`spring_gaps`), grown from the first given (the spring nearest the spec's
    rate, :func:`design_order`), so that each spring's parent is the nearest of those before it
    in :attr:`order`. A spring is designed once its parent is, warm from its nearest ancestor
    that was solved (:meth:`start_of`): even a distant neighbour's design, its multipliers and
    its active set start a spring nearer its optimum than the default start, from which a spring
    of the tutorial's catalogue more often ends undecided.

    Parameters
    ----------
    springs : ndarray (m, 2)
        The springs to design, (rate k [N/m], initial tension F0 [N]), in the order given.
    scales : tuple
        :func:`spring_scales` of the springs searched.
    """

    def __init__(self, springs: np.ndarray, scales: tuple[float, float]):
        springs = np.asarray(springs, dtype=float)
        m = len(springs)
        self.parent, self.order = np.full(m, -1), []
        gap, nearest, left = np.full(m, np.inf), np.zeros(m, dtype=int), np.ones(m, dtype=bool)
        for _ in range(m):
            free = np.flatnonzero(left)
            i = int(free[np.argmin(gap[free])])  # on a tie (the first, all at no gap yet), the first given
            if self.order:
                self.parent[i] = nearest[i]
            self.order.append(i)
            left[i] = False
            to_i = spring_gaps(springs, springs[i], scales)
            closer = to_i < gap
            gap[closer], nearest[closer] = to_i[closer], i
        self.rank = np.empty(m, dtype=int)
        self.rank[self.order] = np.arange(m)
        self.children: list[list[int]] = [[] for _ in range(m)]
        for i in self.order[1:]:
            self.children[self.parent[i]].append(i)

    def start_of(self, i: int, starts: dict) -> dict | None:
        """The start of spring ``i``: that of its nearest ancestor solved, from ``starts``
        (spring → its start, None where its design failed), where every ancestor of ``i`` is
        done; None (the default start) where none was solved."""
        p = int(self.parent[i])
        while p >= 0 and starts[p] is None:
            p = int(self.parent[p])
        return starts[p] if p >= 0 else None


@dataclass
class Search:
    """A catalogue searched for one spring slot: every row's verdict and numbers.

    Attributes
    ----------
    catalogue : Catalogue
    screened : Screen
    designed : dict
        Part → its row from :func:`design_part`, for every spring designed.
    planned : int
        How many springs are to be designed.
    """

    catalogue: Catalogue
    screened: Screen
    designed: dict
    planned: int
    #: Part → (its designed row, that row's verdict word), judged once (:meth:`best` is asked after every
    #: spring designed; judging every row each time grew with the square of their number).
    _words: dict = field(default_factory=dict, repr=False, compare=False)

    def verdicts(self) -> list[tuple[str, str]]:
        """(verdict, reason) of every catalogue row, in catalogue order."""
        out = []
        for part, reason in zip(self.catalogue.parts, self.screened.reasons):
            if part in self.designed:
                out.append(verdict(self.designed[part]))
            elif reason:
                out.append(("infeasible", f"screen: {reason}"))
            else:
                out.append(("not_designed", "passed the screen; not designed (beyond --limit)"))
        return out

    def table(self, rank: str) -> list[list]:
        """The rows of ``springs.csv`` (:data:`TABLE_COLUMNS`), ranked by ``rank`` (:data:`RANKS`)."""
        cat, b = self.catalogue, self.catalogue.body
        rows = []
        for i, (part, (word, reason)) in enumerate(zip(cat.parts, self.verdicts())):
            d = self.designed.get(part, {})
            body = d.get("body") or {}
            price = float(cat.pack_price[i])
            rows.append([part, word, reason, d.get("rmse"), d.get("relative_rmse"), body.get("peak_force"),
                         body.get("max_length"), d.get("band"), float(b.coil_diameter[i] + b.wire_diameter[i]),
                         float(b.free_length[i]), None if math.isnan(price) else price])
        order, col = list(VERDICTS), {name: k for k, name in enumerate(TABLE_COLUMNS)}
        rmse = col["rmse"]

        def key(row):
            value = (row[col["od"]] * row[col["free_length"]] if rank == "size"
                     else row[col[{"error": "rmse", "band": "band", "cost": "pack_price"}[rank]]])
            return (order.index(row[1]), value is None, value or 0.0, row[rmse] is None, row[rmse] or 0.0)
        return sorted(rows, key=key)

    def best(self) -> str | None:
        """The feasible part of the least rmse, or None."""
        for p, r in self.designed.items():
            if p not in self._words or self._words[p][0] is not r:  # a row replaced is judged again
                self._words[p] = (r, verdict(r)[0])
        ok = [(r["rmse"], p) for p, r in self.designed.items() if self._words[p][1] == "feasible"]
        return min(ok)[1] if ok else None


#: The fewest springs a search designs for it to compile the NLP's functions before it starts
#: (:func:`prepare_functions`; with ``solver.functions = "compiled"`` it always does, rather
#: than have each worker compile them at the same time): the compile takes some 3–13 s on 2
#: cores, and compiled functions design a spring about 0.25 s faster than expanded ones (the
#: tutorial: 0.16 s against 0.42 s for its solve).
COMPILE_FIRST = 40


def prepare_functions(problem: Problem, j: int, part: str, catalogue: str | None) -> None:
    """Compile the functions of ``problem``'s NLP with spring ``j`` made ``part`` (of the
    catalogue file ``catalogue``; :func:`with_part`: a catalogue part may give the NLP more
    than the spec's own spring), and of that NLP with its deferred outline rows (a design
    that breaks one of them is solved again with them all), into the cache now, as the
    search's designs build them (:func:`search_nlp`), where its ``solver.functions``
    would otherwise solve with expanded ones until a background compile is done (``auto``)
    or have each worker compile them at once (``compiled``). A machine without a C compiler keeps expanded functions; a
    part that cannot be used or a compile that fails leaves the workers to build their own
    (each row of theirs then says why it failed, if it does)."""
    from ..solve import compiled
    from ..solve.transcription import Transcription

    if problem.options.functions in ("auto", "compiled") and compiled.available():
        try:
            with search_nlp():  # the NLP as the search's designs build it
                Transcription.graph_of(with_part(problem, j, part, catalogue)).compile_libraries()
        except (compiled.CompileError, SpecError):
            pass


def search(spec: tuple, j: int, catalogue: Catalogue, catalogue_path: str | None, workers: int,
           limit: int | None = None, report=None, dask: str | None = None, band: bool = False) -> Search:
    """Screen ``catalogue`` for spring ``j`` (0-based) of the spec ``spec`` = (data, origin,
    base folder) and design the survivors, at most ``limit`` of them (those nearest the spec's
    own rate), on ``workers`` processes (0: in this process) or the Dask cluster ``dask``
    (``local`` or a scheduler address), in the order of their :class:`StartTree`, each warm from
    its nearest ancestor there that was solved (the same rows on any workers); with each
    design's tolerance band where ``band``.
    ``catalogue_path`` is the file a part is read from (None: the shipped catalogue);
    ``report(row, search)`` is called as each spring is done.
    """
    from .runner import _Dask, _Local, _Serial

    problem = _spec_problem(spec)
    screened = screen_slot(problem, j, catalogue)
    todo = design_order(catalogue, screened.passed, problem.springs[j].rate)
    scales, body = spring_scales(catalogue, todo), catalogue.body
    todo = todo[:limit]
    found = Search(catalogue, screened, {}, len(todo))
    if not todo:
        return found
    # started first: a local pool's workers start up while the functions compile
    executor = (_Dask(dask, max(workers, 1), design_part) if dask else
                _Local(workers, design_part) if workers else _Serial(design_part))
    # a ready spring is sent when a worker is free, one per worker, so that the workers take
    # the ready springs in the tree's order (a round trip to the worker is a small part of a design)
    room, pending = max(workers, 1), {}
    interrupted = True
    try:
        if len(todo) >= COMPILE_FIRST or problem.options.functions == "compiled":
            prepare_functions(problem, j, catalogue.parts[todo[0]], catalogue_path)
        tree, starts = StartTree(np.c_[body.rate[todo], body.preload[todo]], scales), {}
        ready = [(0, tree.order[0])]  # (rank in the tree's order, spring) of the springs whose parent is done
        while ready or pending:
            while ready and len(pending) < room:  # the ready spring first in the tree's order
                k = heapq.heappop(ready)[1]
                fut = executor.submit(spec, j, catalogue.parts[todo[k]], catalogue_path, tree.start_of(k, starts), band)
                pending[fut] = k
            for fut in executor.wait(list(pending)):
                k, row = pending.pop(fut), fut.result()
                found.designed[row["part"]] = row
                starts[k] = solved_start(row, (float(body.rate[todo[k]]), float(body.preload[todo[k]])))
                for child in tree.children[k]:
                    heapq.heappush(ready, (int(tree.rank[child]), child))
                if report is not None:
                    report(row, found)
        interrupted = False
    finally:
        executor.close(interrupted)
    return found
