"""A spec's spring slot searched over a whole spring catalogue: what the slot asks of a spring
(:func:`slot_need`), the catalogue's screen for it (:func:`screen_slot`) before any solve, and
the survivors designed on a process pool (:func:`search`), each warm-started from the solved
spring nearest in rate, each given a verdict (:data:`VERDICTS`).
"""
from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..physics.catalogue import Catalogue, Need, Screen, screen
from ..problem import Problem

#: The (mechanism kind, port) pairs whose moment arm on their joint is at most the mechanism's
#: profiles' ``rho_max``: the cable of an anchored pulley leaves its profile tangentially, so its length
#: changes by the perpendicular distance of that line from the pivot, at most the largest
#: radius, per radian. Springs on other ports get no force or stroke test.
ARM_BOUNDED = {("anchored_pulley", "cable")}

#: Points of the joint's range the target's work and peak torque are taken on.
NEED_POINTS = 2001


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
    arms = [max(f.rho_max for f in problem.mechanisms[p.mechanism].profiles) for p in spring.ports
            if (problem.mechanisms[p.mechanism].kind, p.name) in ARM_BOUNDED]
    bounded = len(arms) == len(spring.ports) == 1
    return Need(energy=float(work.max() - work.min()), torque=float(np.abs(tau).max()),
                arm=float(arms[0]) if bounded else None,
                angle=float(np.ptp(theta)) if bounded else None)


def screen_slot(problem: Problem, j: int, catalogue: Catalogue) -> Screen:
    """``catalogue`` screened for spring ``j`` of ``problem`` (:func:`slot_need`, :func:`screen`)."""
    return screen(catalogue, slot_need(problem, j))


# -- the whole catalogue searched ---------------------------------------------------------------
#: The most IPOPT iterations a catalogue search spends on one spring (at most the spec's own
#: ``solver.max_iter``): a spring the design reaches converges in a few dozen from a
#: neighbour's design, and one that does not would otherwise hold a worker for the spec's
#: whole limit (measured: 40 s for the tutorial's 5108N509 at 500 iterations against 0.5 s
#: for a spring that fits).
SEARCH_MAX_ITER = 150

#: The orders ``cadcam springs --rank`` offers: within each verdict (feasible, near, then the
#: rest), rows by this key, ties by rmse.
RANKS = {
    "error": "the design's rmse [N·m]",
    "size": "the spring's outside diameter × free length [m²]",
    "cost": "the pack price [USD]",
}

#: A search row's verdicts, in the order the table lists them.
VERDICTS = {
    "feasible": "designed; the solve converged and the re-check passed, the body's limits included",
    "near": "designed and converged, but the re-check failed: the reason names the binding limit and by how much",
    "infeasible": "screened out (its reason), or the design failed (its status)",
    "not_designed": "passed the screen but beyond --limit",
}

#: The columns of ``springs.csv`` (SI units; the price in the catalogue's currency).
TABLE_COLUMNS = ("part_number", "verdict", "reason", "rmse", "relative_rmse", "peak_force", "max_length",
                 "od", "free_length", "pack_price")


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


def design_part(data: dict, origin: str, base: str, part: str, start: tuple | None) -> dict:
    """Design the spec ``data`` (read from ``origin``, relative paths from folder ``base``)
    whose spring names ``part``, warm from ``start`` = (design dict, objective, part) of a
    neighbour if given; a row for :func:`verdict`. Never raises: a failure is a row."""
    from ..designs import Design
    from ..optimize import warm_optimize
    from ..solve.builds import built_for
    from ..spec import parse_spec

    t0 = time.perf_counter()
    row = {"part": part}
    try:
        problem = parse_spec(data, origin, Path(base))
        problem = problem.with_options(max_iter=min(problem.options.max_iter, SEARCH_MAX_ITER))
        tr, _ = built_for(problem)
        design, objective, name = start or (None, None, None)
        result = warm_optimize(problem, tr, Design.from_dict(design, problem) if design else None,
                               objective, f"part {name}")
        d = result.to_dict()
        (body,) = [b for b in d["spring_bodies"] if b["part"] == part][:1]
        row.update(status=result.status, message=result.message, violations=d["violations"],
                   rmse=max(d["metrics"]["rmse"]), relative_rmse=_largest(d["metrics"]["relative_rmse"]),
                   objective=d["metrics"]["objective"], design=d["design"], body=body)
    except Exception as exc:  # noqa: BLE001 - any failure of one spring is its row, the search goes on
        row.update(status="error", message=f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}")
    row["wall_time_s"] = time.perf_counter() - t0
    return row


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
    """A designed spring's verdict and reason (:data:`VERDICTS`)."""
    if row["status"] == "error" or "body" not in row:
        return "infeasible", f"{row['status']}: {row['message']}"
    words, ratio = binding_limit(row["body"])
    if row["status"] == "success":
        return "feasible", f"binding: {words}, {100 * -ratio:.3g} % to spare"
    if row["status"] in ("recheck_failed", "target_missed"):
        if ratio > 0:
            return "near", f"{words} passed by {100 * ratio:.3g} %"
        first = row["violations"][0] if row["violations"] else row["message"]
        return "near", f"{row['status']}: {first}"
    return "infeasible", f"{row['status']}: {row['message']}"


def design_order(catalogue: Catalogue, passed, nominal_rate: float) -> list[int]:
    """The rows that passed the screen, nearest the nominal rate first (|log k/k_nominal|)."""
    rows = np.flatnonzero(passed)
    gap = np.abs(np.log(catalogue.body.rate[rows] / nominal_rate))
    return [int(i) for i in rows[np.argsort(gap, kind="stable")]]


def nearest_start(rate: float, solved: list[tuple[float, dict, float, str]]):
    """(design, objective, part) of the solved spring nearest in log rate to ``rate``, or None."""
    if not solved:
        return None
    return min(solved, key=lambda s: abs(math.log(s[0] / rate)))[1:]


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
                         body.get("max_length"), float(b.coil_diameter[i] + b.wire_diameter[i]),
                         float(b.free_length[i]), None if math.isnan(price) else price])
        order = list(VERDICTS)

        def key(row):
            value = {"error": row[3], "size": row[7] * row[8], "cost": row[9]}[rank]
            return (order.index(row[1]), value is None, value or 0.0, row[3] is None, row[3] or 0.0)
        return sorted(rows, key=key)

    def best(self) -> str | None:
        """The feasible part of the least rmse, or None."""
        ok = [(r["rmse"], p) for p, r in self.designed.items() if verdict(r)[0] == "feasible"]
        return min(ok)[1] if ok else None


def search(data: dict, origin: str, base: Path, j: int, catalogue: Catalogue, catalogue_path: str | None,
           workers: int, limit: int | None = None, report=None) -> Search:
    """Screen ``catalogue`` for spring ``j`` (0-based) of the spec ``data`` and design the
    survivors, at most ``limit`` of them (those nearest the spec's own rate), on ``workers``
    processes (0: in this process). ``catalogue_path`` is the file a part is read from (None:
    the shipped catalogue); ``report(row, search)`` is called as each spring is done.
    """
    from ..spec import parse_spec
    from .runner import _Local, _Serial

    problem = parse_spec(data, origin, base)
    screened = screen_slot(problem, j, catalogue)
    todo = design_order(catalogue, screened.passed, problem.springs[j].rate)[:limit]
    found = Search(catalogue, screened, {}, len(todo))
    executor = _Local(workers, design_part) if workers else _Serial(design_part)
    room, pending, solved = 2 * max(workers, 1) if workers else 1, {}, []
    interrupted = True
    try:
        while todo or pending:
            while todo and len(pending) < room:
                i = todo.pop(0)
                rate, part = float(catalogue.body.rate[i]), catalogue.parts[i]
                fut = executor.submit(part_spec(data, j, part, catalogue_path), origin, str(base), part,
                                      nearest_start(rate, solved))
                pending[fut] = rate
            for fut in executor.wait(list(pending)):
                rate, row = pending.pop(fut), fut.result()
                found.designed[row["part"]] = row
                if row["status"] == "success":
                    solved.append((rate, row["design"], row["objective"], row["part"]))
                if report is not None:
                    report(row, found)
        interrupted = False
    finally:
        executor.close(interrupted)
    return found
