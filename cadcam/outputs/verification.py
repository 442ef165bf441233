"""How accurate the written workshop files are: the fit tolerance a design's claimed accuracy
asks for, and ``verification.json`` / ``verification.md``, which read each DXF back and say
how far the part it describes is from the design, and list every file read back with each of
its checks against its own tolerance (:mod:`cadcam.outputs.file_checks`).

The requirement (issue 31): the torque of each joint, recomputed from the written files by
:mod:`cadcam.verify.file_model`, is within max(:data:`DESIGN_SHARE` × the design's own largest
|τ − τ_d| on the fine re-check grid, :data:`PEAK_SHARE` × the design's peak |τ|) of the design's
torque; for a differential pair, its output x within max(:data:`DESIGN_SHARE` × the design's own
largest |x − x_d|, :data:`PEAK_SHARE` × the span of x over the range). The files are fitted to
:data:`FIT_SHARE` of that requirement divided by how much torque (or x) a metre of outline
error moves (:func:`fit_tolerance`), then read back and checked; a fit that misses is refitted
tighter, up to :data:`REFITS` times. A helical groove's centre line (``camN_groove.csv``) is
sampled so that its chords sag no more than that tolerance, and checked the same way; so is
each points CSV's polygon, by the same file models. Under a paper's force model the files are
checked against the design's energy torque ∂V/∂θ (what a part does), and the force model's
departure from it is stated.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..files import write_json, write_text
from ..make.biarc import arc_distance, concavity, segment_distance
from ..make.workshop import ROUNDING, cut_points, hole_walls
from ..mechanisms.base import ENERGY
from ..physics.outline import NOTCH, FileOutline
from ..physics.profile import profile_function
from ..problem import MIN_WALL
from ..verify.evaluate import evaluate
from ..verify.file_model import MILLIMETRES, file_torque, outline_points, span_clearance

#: Share of the design's own largest error the file may add (issue 31).
DESIGN_SHARE = 0.1
#: Share of the design's own largest error a points CSV's polygon may add: its own tolerance
#: (issue 51). A polygon's straight chords turn only at its points, and a follower or a cable
#: leaving it takes its direction from the chord it presses on, so its torque errs as the
#: chords' turn, which only more points lessen (the DXF's arcs keep their tangent): held to the
#: DXF's tenth of the design's error it took ~93 000 points (3.4 MB) on the 1-DOF spec; held
#: to the design's own error, a part cut from it errs at most twice as much as the design.
POINTS_SHARE = 1.0
#: Share of the design's own largest error the force model's departure from the energy torque
#: (``model_gap``) may reach (issue 51). Under a force model the design claims the force
#: model's torque and its part does the energy torque ∂V/∂θ: within this the part misses its
#: target by at most twice what the design claims; beyond it the files fail, as a part that
#: does not do what its design says.
MODEL_GAP_SHARE = 1.0
#: Share of the peak torque (of the span of x) below which a file error never needs to go.
PEAK_SHARE = 1e-4
#: Share of the requirement the fit's distance is given (the rest is margin for how the
#: outline error reaches the torque).
FIT_SHARE = 0.25
#: Metres of output x moved per metre of outline error for a differential pair (each free
#: span tangent to an outline moves the idler by about the outline's error over the cosine of
#: its angle to the slider; the check measures what it really is).
OUTPUT_GAIN = 4.0
#: Tightest fit [m] (a few hundred times the rounding of a 100 mm coordinate in the file).
MIN_FIT = 1e-10
#: Refits at a tighter tolerance after a file misses its requirement.
REFITS = 3
#: Points of the designed outline at which the file's distance from it is measured.
DISTANCE_SAMPLES = 4096
#: Segments either side of the one round a point's polar angle that its distance to a file's
#: chain is measured to (:func:`_polar_neighbours`): a point within the fit's tolerance of a
#: chain lies nearest to its own segment or, by a corner, the next one.
NEIGHBOUR_SEGMENTS = 2

#: The fields of the report, declared once: name → (unit, description).
FIELDS = {
    "cam": ("-", "the cam's number (camN.dxf, or camN_groove.csv for a helical groove)"),
    "units": ("-", "the DXF's units ($INSUNITS 4: mm; a groove's columns are in mm)"),
    "closed": ("-", "the profile polyline is closed (a groove's centre line is open: it winds on, turn after turn)"),
    "convex": ("-", "concavity_m ≤ 1 nm: the cut outline turns counter-clockwise all the way round, once, to "
                    "rounding (a groove's centre line: no chord turns inwards more than 1 nm deep)"),
    "concavity_m": ("m", "how far the profile's exact arcs, read from the DXF, reach beyond their own tangent where "
                         "they turn inwards (cadcam.make.biarc.concavity: never less than the deepest notch, 0 for a "
                         "convex outline); blank for a groove"),
    "vertices": ("-", "vertices of the profile polyline (each segment an arc or a line); a groove's rows, "
                      "joined by straight chords"),
    "fit_tolerance_m": ("m", "the biarc fit's tolerance (a groove's: its chords' sag), from the design's accuracy"),
    "file_error_m": ("m", "largest distance from the designed outline (a groove: the designed spiral) to the "
                          "outline read back from the DXF (the chord of the groove's CSV across its polar angle)"),
    "points_csv_tolerance_m": ("m", "chordal tolerance of camN_points.csv (and camN.stl)"),
    "bore_wall_m": ("m", "material between the bore and the cut outline, measured with a sign from the DXF's exact "
                         "arcs: negative where the bore's edge lies outside the part"),
    "anchor_wall_m": ("m", "material between the anchor hole and the cut outline, measured with a sign from the DXF's "
                           "exact arcs: negative where the hole's edge lies outside the part (below minus its radius "
                           "where its centre does)"),
    "holes_wall_m": ("m", "material between the anchor hole and the bore, from the DXF"),
    "wall_rule_m": ("m", "the least material every hole must leave (cadcam.problem.MIN_WALL)"),
    "walls_hold": ("-", "bore_wall_m, anchor_wall_m and holes_wall_m ≥ wall_rule_m less 1 nm of rounding; a file "
                        "without its bore or its anchor hole fails"),
    "cable_radius_m": ("m", "the cable's radius: the clearance its free spans keep from the part"),
    "cable_clearance_m": ("m", "least distance from the centre line of the cable's free span to the cut outline "
                               "read from the DXF (its anchor and closure included) over the fine re-check grid; "
                               "negative where the span runs through the part; blank where the cable runs from "
                               "the part onto a follower or there is no cable, and for a helical groove (its file "
                               "holds the groove's centre line, not the drum between its turns that a span would "
                               "clear; in the plane a span crosses the other turns, which lie at other heights)"),
    "spans_clear": ("-", "cable_clearance_m ≥ cable_radius_m less 1 nm: no free span touches the part"),
    "quantity": ("-", "what is recomputed from the files: a joint's torque or a differential pair's output x"),
    "where": ("-", "the joint or mechanism it belongs to"),
    "file_max_abs_error": ("N·m or m", "largest |file − design| over the fine re-check grid (the design grid "
                                       "beyond 10⁶ points)"),
    "design_max_abs_error": ("N·m or m", "the design's own largest |τ − τ_d| (|x − x_d|) on that grid"),
    "peak": ("N·m or m", "the design's peak |τ| (span of x) on that grid"),
    "required": ("N·m or m", "max(0.1 × design_max_abs_error, 1e-4 × peak) from the DXFs and grooves, "
                             "max(1 × design_max_abs_error, 1e-4 × peak) from the points CSVs (their own tolerance, "
                             "cadcam.outputs.verification.POINTS_SHARE): what file_max_abs_error must not exceed"),
    "unresolved_points": ("-", "grid points where the cable's departure from the file's outline lies outside "
                          "the range a convex outline allows (the cable would wrap past its anchor, or leave "
                          "past a groove's end)"),
    "passed": ("-", "file_max_abs_error ≤ required at every grid point"),
    "files": ("-", "the files a quantity is recomputed from (the DXFs, or the points CSVs; a helical groove's CSV "
                   "in either set)"),
    "model_gap": ("N·m", "under a force model (torque_model not energy): the design's largest |τ_force − τ_energy| "
                         "on the grid. The files are checked against the design's energy torque ∂V/∂θ, what a part "
                         "does and the file model computes; the design's accuracy claims the force model's torque, "
                         "which differs from it by this, at most max(1 × design_max_abs_error, 1e-4 × peak) "
                         "(cadcam.outputs.verification.MODEL_GAP_SHARE; the Files read table's model_gap row)"),
    "note": ("-", "why a quantity is not recomputed"),
}


def _requirement(own: float, peak: float, share: float = DESIGN_SHARE) -> float:
    """What a file may add to a design's error: max(``share``·own, PEAK_SHARE·peak)."""
    return max(share * own, PEAK_SHARE * peak)


#: Most points of a grid the torque checks sample whole: the fine re-check grid up to it (one
#: or two joints), the design grid beyond (three joints' 451³).
GRID_POINTS = 1_000_000


def _grid(result):
    """The evaluation the torque checks are made on: the fine re-check's, or the design grid's
    where the fine grid has more than :data:`GRID_POINTS` points."""
    return result.recheck if result.recheck.tensor.points <= GRID_POINTS else result.evaluation


def model_gap_limit(check: dict) -> float:
    """What a torque ``check``'s ``model_gap`` [N·m] may reach: max(:data:`MODEL_GAP_SHARE` ×
    its design's own error, :data:`PEAK_SHARE` × its peak)."""
    return _requirement(check["design_max_abs_error"], check["peak"], MODEL_GAP_SHARE)


def _torque_checks(result, share: float = DESIGN_SHARE) -> list[dict]:
    """Per joint with a torque target: the design's torque on the fine grid, its own error,
    peak and requirement (``share`` of its own error: :func:`_requirement`; ``joint``: its
    index)."""
    fine = _grid(result)
    sample = fine.tensor.sample(fine.tensor.whole())
    out = []
    for i, joint in enumerate(fine.problem.joints):
        if joint.target.kind == "none":
            continue
        own, peak = float(fine.metrics.max_abs_error[i]), float(np.abs(sample["tau"][i]).max())
        out.append({"quantity": "torque", "where": joint.name, "joint": i, "design_max_abs_error": own,
                    "peak": peak, "required": _requirement(own, peak, share)})
    return out


def _output_checks(result, share: float = DESIGN_SHARE) -> list[dict]:
    """Per mechanism with an output law (a differential pair): its output x on the fine grid,
    its own error, span, requirement (``share`` of its own error)."""
    fine, out = result.recheck, []
    for u, mech in enumerate(fine.problem.mechanisms):
        if mech.output_target is None:
            continue
        x = fine.units[u].z[mech.unknowns.index(mech.output)]
        own = float(fine.metrics.output_max_abs_error[u])
        out.append({"quantity": "x", "where": mech.name, "mechanism": u, "design_max_abs_error": own,
                    "peak": float(np.ptp(x)), "required": _requirement(own, float(np.ptp(x)), share)})
    return out


def _force_gain(result) -> float:
    """Σ_j max |k_j x_j + F0_j| [N] over the fine grid: the torque a metre of moment arm error
    can move."""
    fine = result.recheck
    springs = fine.problem.springs
    lo_hi = [fine.tensor.extension_range(j) for j in range(len(springs))]
    return float(sum(max(abs(s.rate * x + s.preload) for x in ends) for s, ends in zip(springs, lo_hi)))


def fit_tolerance(result, loosest: float) -> float:
    """The tolerance [m] of ``result``'s files (the biarc fit's; a groove's chords' sag):
    :data:`FIT_SHARE` of the tightest requirement over the torque and output checks, divided by
    the torque (N per metre of arm) or output (:data:`OUTPUT_GAIN`) a metre of outline error
    moves; at most ``loosest`` (the
    spec's workshop tolerance), at least :data:`MIN_FIT`. Every mechanism's files are fitted so,
    also those :func:`recompute` has no file model for (their accuracy is then not checked)."""
    gain = _force_gain(result)
    candidates = [loosest] + [FIT_SHARE * c["required"] / gain for c in _torque_checks(result) if gain > 0]
    candidates += [FIT_SHARE * c["required"] / OUTPUT_GAIN for c in _output_checks(result)]
    return float(max(MIN_FIT, min(candidates)))


def _segments(chain: FileOutline):
    """Starts, ends (1, K, 2) and bulges (1, K) of the chain's segments: a closed chain's back
    round to its first vertex, an open one's to its last."""
    ends = np.roll(chain.vertices, -1, axis=0)
    count = len(ends) if chain.closed else len(ends) - 1
    return chain.vertices[None, :count], ends[None, :count], chain.bulges[None, :count]


def file_error(outline, chain: FileOutline) -> float:
    """Largest distance [m] from the designed outline, at :data:`DISTANCE_SAMPLES` points, to
    the chain read back from the file (:func:`chain_distance`)."""
    return float(chain_distance(outline.xy(np.linspace(0.0, 2 * np.pi, DISTANCE_SAMPLES, endpoint=False)),
                                chain).max())


def chain_distance(points, chain: FileOutline) -> np.ndarray:
    """Distance [m] from each of ``points`` (N, 2) [m] to the chain: to the segments round its
    polar angle (:func:`_polar_neighbours`) where the chain winds once round the axis, else to
    every segment."""
    a, b, bulges = _segments(chain)
    near = _polar_neighbours(points, chain)
    if near is not None:
        return arc_distance(points[:, None], a[0][near], b[0][near], bulges[0][near]).min(axis=1)
    best = np.full(len(points), np.inf)
    for rows in np.array_split(np.arange(len(points)), max(1, len(points) * len(a[0]) // 2_000_000)):
        best[rows] = arc_distance(points[rows, None], a, b, bulges).min(axis=1)
    return best


def _polar_neighbours(points, chain: FileOutline) -> np.ndarray | None:
    """Indices (N, 2·:data:`NEIGHBOUR_SEGMENTS` + 1) of the closed chain's segments round the
    polar angle of each of ``points`` [m]: the segment whose vertices' polar angles bracket
    the point's and :data:`NEIGHBOUR_SEGMENTS` either side. None unless the vertices' polar
    angles about the axis run one way once round (a chain that winds once round the axis, as
    every outline of a part on its bore does): only then does a point lie near the segments of
    its own polar angle. The distance to a subset of the segments is never less than to the
    nearest, so the error measured with them is never smaller than the file's."""
    if not chain.closed:
        return None
    polar = np.unwrap(np.arctan2(chain.vertices[:, 1], chain.vertices[:, 0]))
    steps = np.diff(np.append(polar, polar[0] + np.sign(polar[-1] - polar[0]) * 2 * np.pi))
    if not (np.all(steps > 0) or np.all(steps < 0)):  # the steps add up to one turn
        return None
    sense = np.sign(steps[0])
    start = sense * polar  # increasing, from start[0] round to start[0] + 2π
    angle = start[0] + np.mod(sense * np.arctan2(points[:, 1], points[:, 0]) - start[0], 2 * np.pi)
    k = np.searchsorted(start, angle, side="right") - 1  # the segment from vertex k to k + 1
    offsets = np.arange(-NEIGHBOUR_SEGMENTS, NEIGHBOUR_SEGMENTS + 1)
    return np.mod(k[:, None] + offsets, len(start))


def _groove_error(basis, coefficients, phi_max: float, chain: FileOutline) -> float:
    """Largest distance [m] from the designed spiral ρ(φ), φ ∈ [0, ``phi_max``], to the groove's
    chord across each point's polar angle (not to the nearest chord: in the plane the spiral's
    turns may cross), at :data:`DISTANCE_SAMPLES` points a turn."""
    phi = np.linspace(0.0, phi_max, int(np.ceil(DISTANCE_SAMPLES * phi_max / (2 * np.pi))) + 1)
    points = cut_points(profile_function(basis), coefficients, phi, 0.0)
    polar = np.unwrap(np.arctan2(chain.vertices[:, 1], chain.vertices[:, 0]))
    k = np.clip(np.searchsorted(polar, phi, side="right") - 1, 0, len(polar) - 2)
    return float(segment_distance(points, chain.vertices[k], chain.vertices[k + 1]).max())


#: The walls of :data:`FIELDS` that ``walls_hold`` judges, each printed to six digits.
WALLS = ("bore_wall_m", "anchor_wall_m", "holes_wall_m")


def _walls(chain: FileOutline) -> dict:
    """The walls of the file's holes (its bore: the circle about the axis; its anchor hole: the
    other) measured with a sign against its exact arcs (:func:`cadcam.make.workshop.hole_walls`),
    and whether each keeps the rule: a file without its one bore and one anchor hole (whose
    walls are then left out) fails."""
    bores = [d for c, d in chain.circles if np.hypot(*c) <= ROUNDING]
    anchors = [(c, d) for c, d in chain.circles if np.hypot(*c) > ROUNDING]
    walls = {}
    if bores:
        walls["bore_wall_m"] = hole_walls(chain, np.zeros(2), bores[0], 0.0)[0]
    if bores and anchors:
        walls["anchor_wall_m"], walls["holes_wall_m"] = hole_walls(chain, anchors[0][0], anchors[0][1], bores[0])
    whole = len(bores) == len(anchors) == 1
    return {**walls, "wall_rule_m": MIN_WALL,
            "walls_hold": whole and all(w >= MIN_WALL - ROUNDING for w in walls.values())}


def _chain_fields(cam: int, chain: FileOutline, tolerance: float, cable_radius: float) -> dict:
    """The fields every file read back has (see :data:`FIELDS`)."""
    return {"cam": cam, "units": "mm" if chain.units == MILLIMETRES else f"$INSUNITS {chain.units}",
            "closed": chain.closed, "vertices": len(chain.vertices), "fit_tolerance_m": tolerance,
            "cable_radius_m": cable_radius}


def groove_report(cam: int, basis, coefficients, phi_max: float, chain: FileOutline, tolerance: float,
                  cable_radius: float) -> dict:
    """The file fields of one helical groove's centre line read back (see :data:`FIELDS`):
    those of :func:`cam_report` that a groove has (no holes, no polygon files, no clearance);
    it is convex where no chord turns inwards more than :data:`NOTCH` deep (its chords are
    straight: the depth of each joint is exact)."""
    return {**_chain_fields(cam, chain, tolerance, cable_radius), "convex": chain.reflex == 0,
            "file_error_m": _groove_error(basis, coefficients, phi_max, chain)}


def cam_report(cam: int, outline, chain: FileOutline, tolerance: float, polygon_tolerance: float,
               cable_radius: float, cable_clearance: float | None) -> dict:
    """The file fields of one cam's DXF read back (see :data:`FIELDS`); ``cable_clearance``
    from :func:`cable_clearances`."""
    spans = {} if cable_clearance is None else {
        "cable_clearance_m": cable_clearance, "spans_clear": bool(cable_clearance >= cable_radius - NOTCH)}
    inwards = concavity(chain.vertices, chain.bulges)
    return {**_chain_fields(cam, chain, tolerance, cable_radius), "convex": bool(inwards <= NOTCH),
            "concavity_m": inwards, "file_error_m": file_error(outline, chain),
            "points_csv_tolerance_m": polygon_tolerance, **_walls(chain), **spans}


def _profiles_of(problem) -> list[list[int]]:
    """Per mechanism, the indices of its profiles in the problem's profile order (camN − 1)."""
    first = np.cumsum([0] + [mech.n_profiles for mech in problem.mechanisms])
    return [list(range(a, b)) for a, b in zip(first[:-1], first[1:])]


def cable_clearances(result, chains: dict[int, FileOutline]) -> dict[int, float | None]:
    """Per profile read back (index → its cut outline): the least distance [m] from its cable's
    free span, over the fine re-check's angles, to the whole cut outline (the span's centre
    line found about the outline's centre line); None where no free span leaves it, and on a
    helical groove (its file holds the centre line only, not the drum between its turns)."""
    problem, fine = result.problem, result.recheck
    centre = {i: c.centre_line(problem.workshop.cable_radius) for i, c in chains.items()}
    out: dict[int, float | None] = {i: None for i in chains}
    for u, (mech, profiles) in enumerate(zip(problem.mechanisms, _profiles_of(problem))):
        if any(chains[i].groove for i in profiles):
            continue
        spans = mech.free_spans_from_file([centre[i] for i in profiles], fine.units[u].theta)
        for i, (start, end) in zip(profiles, spans or []):
            out[i] = float(np.nanmin(span_clearance(outline_points(chains[i]), start, end)))
    return out


def design_reference(result) -> dict:
    """What the files' torque is checked against, on the grid of :func:`_grid`: its points
    (``sample``), the design's torque there (``tau``) — its own under the energy model; under
    a force model its energy torque ∂V/∂θ, which a part does and the file model computes, and
    the force model's largest departure from it (``model_gap``)."""
    fine = _grid(result)
    sample = fine.tensor.sample(fine.tensor.whole())
    if fine.problem.torque_model == ENERGY:
        return {"sample": sample, "tau": sample["tau"]}
    energy = evaluate(fine.problem.with_torque_model(ENERGY), fine.design, grid=fine.grid, profile=False)
    tau = energy.tensor.sample(energy.tensor.whole())["tau"]
    return {"sample": sample, "tau": tau, "model_gap": np.max(np.abs(tau - sample["tau"]), axis=1)}


def recompute(result, chains: dict[int, FileOutline], reference: dict | None = None,
              share: float = DESIGN_SHARE) -> list[dict]:
    """The torque and output checks with the values recomputed from the files (profile index →
    outline or groove read back), or a note where no file model covers a mechanism. The torque
    is checked against :func:`design_reference` (``reference``, computed here if None); the
    files may add ``share`` of the design's own error (:data:`POINTS_SHARE` for the points
    CSVs)."""
    problem, fine = result.problem, _grid(result)
    # the DXFs hold the cut outlines; the cable's centre line, on which the design is, lies its
    # radius outside them (a groove's file is that centre line)
    chains = {i: c.centre_line(problem.workshop.cable_radius) for i, c in chains.items()}
    profiles_of = _profiles_of(problem)
    checks = []
    torque = _torque_checks(result, share)
    missing = sorted({mech.kind for mech in problem.mechanisms if not mech.has_file_model()})
    if torque and not missing:  # a file torque only against a target
        reference = reference or design_reference(result)
        outlines = {u: [chains[i] for i in profiles] for u, profiles in enumerate(profiles_of)}
        tau = file_torque(problem, fine.design, outlines, reference["sample"]["theta"])
        for check in torque:
            i = check.pop("joint")
            found = np.isfinite(tau[i])
            gap = {"model_gap": float(reference["model_gap"][i])} if "model_gap" in reference else {}
            checks.append(_judged({**check, **gap},
                                  float(np.max(np.abs(tau[i] - reference["tau"][i])[found], initial=0.0)),
                                  int(np.sum(~found))))
    else:
        checks += [{**{k: v for k, v in c.items() if k != "joint"},
                    "note": f"not recomputed from the files: no file model of {', '.join(missing)}"} for c in torque]
    for check in _output_checks(result, share):
        u = check.pop("mechanism")
        mech = problem.mechanisms[u]
        if not mech.has_file_model():
            checks.append({**check, "note": f"not recomputed from the files: no file model of {mech.kind}"})
            continue
        x = mech.output_from_file([chains[i] for i in profiles_of[u]], fine.units[u].theta)
        xd = fine.units[u].z[mech.unknowns.index(mech.output)]
        found = np.isfinite(x)
        checks.append(_judged(check, float(np.max(np.abs(x - xd)[found], initial=0.0)), int(np.sum(~found))))
    return checks


def _judged(check: dict, error: float, unresolved: int) -> dict:
    """``check`` with its file error over the points the file model resolved, their shortfall
    and the verdict (every point resolved and within the requirement)."""
    return {**check, "file_max_abs_error": error, "unresolved_points": unresolved,
            "passed": bool(error <= check["required"] and unresolved == 0)}


def passed(checks: list[dict], cams: list[dict], files: list[dict] = ()) -> bool | None:
    """Every file keeps the rules of its own — convex, its holes' walls, its free spans' clearance,
    each check of the files' rows (:mod:`cadcam.outputs.file_checks`) — and every recomputed
    check met its requirement (those not recomputed do not count); None when none could be
    recomputed and no file broke a rule of its own (False where one did)."""
    if not all(c["convex"] and c.get("walls_hold", True) and c.get("spans_clear", True) for c in cams):
        return False
    if not all(r["passed"] for r in files):
        return False
    judged = [c["passed"] for c in checks if "passed" in c]
    return all(judged) if judged else None


def verdict(checks: list[dict], cams: list[dict], files: list[dict] = ()) -> str:
    """The report's one word: PASSED, FAILED or NOT CHECKED (no file model covers the design)."""
    return {True: "PASSED", False: "FAILED", None: "NOT CHECKED"}[passed(checks, cams, files)]


def write_report(out: Path, cams: list[dict], checks: list[dict], files: list[dict] = (),
                 unread: dict[str, str] | None = None, points: list[dict] = ()) -> None:
    """``verification.json`` (the fields; ``files``: each check of each file read, and
    ``file_checks`` their meanings; ``not_read``: the files written but not read, with why; the
    cams' DXFs; ``checks``: the quantities recomputed from the DXFs (and grooves), and
    ``points_checks`` from the points CSVs) and ``verification.md``."""
    from .file_checks import FILE_CHECKS

    unread = unread or {}
    write_json(out / "verification.json", {
        "fields": {k: {"unit": u, "description": d} for k, (u, d) in FIELDS.items()},
        "file_checks": {k: {"unit": u, "sense": sense, "description": d} for k, (u, sense, d) in FILE_CHECKS.items()},
        "files": list(files), "not_read": unread, "cams": cams, "checks": checks, "points_checks": list(points),
        "passed": passed(checks, cams, files)})
    write_text(out / "verification.md", _markdown(cams, checks + list(points), list(files), unread))


def _table(rows: list[dict], names: list[str]) -> list[str]:
    """A markdown table of ``rows`` over the fields ``names`` (their units in the header)."""
    def cell(name, v):
        return (f"{v:.6g}" if name in WALLS else f"{v:.3g}") if isinstance(v, float) else str(v)
    head = [f"{n} [{FIELDS[n][0]}]" if FIELDS[n][0] != "-" else n for n in names]
    return (["| " + " | ".join(head) + " |", "|" + "---|" * len(names)]
            + ["| " + " | ".join(cell(n, r.get(n, "")) for n in names) + " |" for r in rows])


def _markdown(cams: list[dict], checks: list[dict], files: list[dict], unread: dict[str, str]) -> str:
    """The report as markdown: the verdict, every file read with its checks, the quantities
    recomputed, the DXFs' details, the files not read, then the fields' meanings."""
    from .file_checks import FILE_CHECKS

    lines = [f"# Workshop files against the design: {verdict(checks, cams, files)}", "",
             "Every file a workshop receives is read back as written and checked against its own tolerance: "
             "`measured` against `limit` (each check's meaning under Checks of the files). The number to read "
             "first is `file_max_abs_error` against `required`: the torque (or a differential pair's x) "
             "recomputed from the written DXF outlines (and helical grooves' centre lines), and again from the "
             "points CSVs' polygons, by plane geometry, against the design's; and, under Files, each hole's wall "
             "against `wall_rule_m`, measured with a sign (negative: outside the part), whether the outline is "
             "convex, and `cable_clearance_m` against `cable_radius_m`: how near the free cable comes to the part.",
             "", "## Files read", ""]
    shown = [{**r, "check": r["check"] + (f" ({r['where']})" if r.get("where") else ""),
              "limit": f"{FILE_CHECKS[r['check']][1]} {_cell(r['limit'])}", "unit": FILE_CHECKS[r["check"]][0]}
             for r in files]
    lines += _rows(shown, ["file", "check", "measured", "limit", "unit", "passed"])
    lines += ["", "## Recomputed from the files", ""]
    lines += _table(checks, ["quantity", "where", "files", "file_max_abs_error", "required", "passed",
                             "unresolved_points", "design_max_abs_error", "peak", "model_gap", "note"])
    lines += ["", "## Files", ""]
    lines += _table(cams, ["cam", "units", "closed", "convex", "concavity_m", "vertices", "fit_tolerance_m",
                           "file_error_m", "points_csv_tolerance_m", *WALLS, "wall_rule_m", "walls_hold",
                           "cable_radius_m", "cable_clearance_m", "spans_clear"])
    if unread:
        lines += ["", "## Written, not read", ""] + [f"- `{name}`: {why}" for name, why in unread.items()]
    lines += ["", "## Checks of the files", ""] + [f"- `{k}` [{u}, {sense} limit]: {d}"
                                                   for k, (u, sense, d) in FILE_CHECKS.items()]
    lines += ["", "## Fields", ""] + [f"- `{k}` [{u}]: {d}" for k, (u, d) in FIELDS.items()] + [""]
    return "\n".join(lines)


def _cell(v) -> str:
    """A value of a row as printed: floats to three digits."""
    return f"{v:.3g}" if isinstance(v, float) else str(v)


def _rows(rows: list[dict], names: list[str]) -> list[str]:
    """A markdown table of ``rows`` over the columns ``names``, as :func:`_cell` prints them."""
    return (["| " + " | ".join(names) + " |", "|" + "---|" * len(names)]
            + ["| " + " | ".join(_cell(r.get(n, "")) for n in names) + " |" for r in rows])
