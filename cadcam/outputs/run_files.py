"""The files of a design run: ``result.json``, the torque, profile and output tables, the
figures and the workshop files, as ``cadcam design`` (and :meth:`cadcam.result.Result.save`)
write them into a folder.

The figures (matplotlib) and the workshop files (ezdxf, manifold3d) are imported where they are
written, so that importing cadcam — in every sweep worker, for ``cadcam evaluate`` — does not
load them. Drawing the figures and the sheets is most of a small design's time; the writers
hand them on as drawings (the figures at once, the sheets as soon as they can
be drawn), which the drawing processes of :class:`cadcam.outputs.forked.Drawer` draw side by
side on the cores: each a
:class:`cadcam.outputs.forked.Call` that builds its figure where it is drawn, so that the
process making the files imports no matplotlib.
"""
from __future__ import annotations

import datetime
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..verify.builds import adjusts, table_rows
from ..verify.evaluate import cable_report, output_error, output_law
from ..files import write_csv, write_json
from ..problem import Workshop
from .forked import Call, Drawing


class WorkshopError(ValueError):
    """A cam's workshop files cannot be made: its outline cannot be closed, or a hole or the
    groove leaves too little material (the message names the cam and the size)."""


#: A planar part's drawing sheets (:func:`cadcam.make.drawing.part_sheets`), each name after
#: ``camN``: one PDF of both sheets, then a PNG of each, sheet 1 (the workshop drawing) first.
SHEET_FILES = ("_sheet.pdf", "_sheet.png", "_sheet2.png")
#: The sheets each of :data:`SHEET_FILES` holds.
SHEET_PAGES = {"_sheet.pdf": (1, 2), "_sheet.png": (1,), "_sheet2.png": (2,)}
#: The sheet files drawn together, each group by a drawing process of its own, which builds
#: the sheets they hold once: the workshop drawing's PNG (the longest to draw) alone, the PDF
#: with the checking sheet's PNG.
SHEET_DRAWINGS = (("_sheet.png",), ("_sheet.pdf", "_sheet2.png"))

#: Points of a tensor grid up to which a torque table holds every one of them.
TABLE_POINTS = 1_000_000
#: The adjustment table (:func:`cadcam.verify.builds.table_rows`): how the builder sets the
#: adjustment from the spring's measured rate (and, with a payload range, the mass).
ADJUSTMENT_FILE = "adjustment.csv"


def torque_table(ev) -> tuple[list[str], np.ndarray]:
    """θ [rad], τ, τ_d and τ − τ_d [N·m] per joint and the spring extensions [m] at grid points
    of the evaluation ``ev``: the column names and one row per point.

    A tensor grid of at most :data:`TABLE_POINTS` points is given whole, in C order of the
    joints' angles (one joint: every angle; two joints at the default fine grid: 451² =
    203 401 rows). A larger one (three joints at the default fine grid hold 451³ ≈ 9.2·10⁷
    points) is represented by the grid lines through each joint's worst point (largest
    |τ − τ_d|, ``ev.worst``): for joint 1, then joint 2, …, the line along joint 1's angle,
    then along joint 2's, … (m² lines of n rows, the worst point in each), all other angles
    held at the worst point's. Every row is a point of the grid, computed like every other;
    the columns are the same either way.
    """
    m, S = len(ev.problem.joints), len(ev.problem.springs)
    header = ([f"theta{i + 1}_rad" for i in range(m)]
              + [f"{k}{i + 1}_Nm" for i in range(m) for k in ("tau", "tau_d", "error")]
              + [f"x{j + 1}_m" for j in range(S)])
    if ev.tensor.points <= TABLE_POINTS:
        samples = [ev.tensor.sample(ev.tensor.whole())]
    else:
        samples = [ev.tensor.sample(ev.tensor.line(worst, axis)) for worst in ev.worst for axis in range(m)]
    rows = []
    for s in samples:
        cols = [*s["theta"]] + [v for i in range(m) for v in (s["tau"][i], s["tau_d"][i],
                                                               s["tau"][i] - s["tau_d"][i])]
        rows.append(np.column_stack(cols + [*s["x"]]))
    return header, np.vstack(rows)


def run_file_names(problem, figures: bool, workshop: Workshop | None) -> list[str]:
    """The name of every file a design run of ``problem`` may write (:func:`write_outputs` with
    ``figures``, :func:`write_workshop_files` with the sizes ``workshop``, none if None), known
    before the solve, so that a folder holding a file cadcam may not replace is refused before
    any work (:func:`cadcam.files.refuse_files_of_others`). A profile comes out as an outline or
    a helical groove, and IPOPT's iterates may be missing: the names of either are given."""
    output = any(mech.output_target is not None for mech in problem.mechanisms)
    names = ["result.json", "torque.csv", "torque_recheck.csv", "profile.csv", *(["output.csv"] if output else []),
             *([ADJUSTMENT_FILE] if adjusts(problem) else [])]
    if figures:
        names += [f"{name}.png" for name in figure_names(problem)]
    if workshop is None:
        return names
    kinds = (".dxf", ".svg", "_points.csv", "_groove.csv", *(SHEET_FILES if figures else ()),
             *((".stl", ".step") if workshop.stl is not None else ()))
    return names + [f"cam{i + 1}{kind}" for i in range(len(problem.profiles)) for kind in kinds] \
        + ["verification.json", "verification.md"]


def write_torque_csv(path: Path, ev) -> None:
    """The :func:`torque_table` of the evaluation ``ev`` as a CSV file."""
    write_csv(path, *torque_table(ev))


def write_outputs(result, out: Path, figures: bool = True, send: Callable[[list[Drawing]], None] | None = None,
                  workshop: dict | None = None) -> None:
    """``result.json``, ``torque.csv`` (design grid), ``torque_recheck.csv`` (the fine re-check
    grid), ``profile.csv``, for adjusted builds the adjustment table :data:`ADJUSTMENT_FILE`,
    with ``figures`` the PNG figures (torque and springs only if there are springs,
    ``convergence.png`` if the solver recorded IPOPT's iterates) and, for
    mechanisms with an output law (a differential pair's idler distance), ``output.csv`` (and
    ``output.png``) in ``out``. With ``send``, the figures (:func:`figure_drawings`) are given to
    it to be drawn by :class:`cadcam.outputs.forked.Drawer` (:func:`_hand_on`), not drawn
    here. ``workshop``: the workshop step's
    outcome (``status`` ``written`` with its ``files``, or ``failed`` with its ``message``),
    recorded in ``result.json`` beside the design's own status."""
    ev = result.evaluation
    write_json(out / "result.json", {**result.to_dict(), **({"workshop": workshop} if workshop else {})})
    write_torque_csv(out / "torque.csv", ev)
    write_torque_csv(out / "torque_recheck.csv", result.recheck)
    # one table of floats (write_csv's fast path: the same text as cell by cell, the cam 1.0, …)
    rows = np.vstack([np.column_stack([np.full(cs.phi.size, i + 1.0), cs.phi, cs.rho, cs.rho * np.cos(cs.phi),
                                       cs.rho * np.sin(cs.phi), cs.convexity]) for i, cs in enumerate(ev.profiles)]
                     or [np.zeros((0, 6))])
    write_csv(out / "profile.csv", ["cam", "phi_rad", "rho_m", "x_m", "y_m", "convexity_m2"], rows)
    if result.builds is not None and result.builds.chosen:
        write_csv(out / ADJUSTMENT_FILE, *table_rows(result.builds))
    outputs = [(u, mech) for u, mech in enumerate(ev.problem.mechanisms) if mech.output_target is not None]
    if outputs:  # x(θ) of mechanisms with an output law, against it
        header, cols = ["theta_rad"], [ev.units[outputs[0][0]].theta]
        for u, mech in outputs:
            xd = output_law(mech, ev.units[u].theta)
            header += [f"{mech.output}{u + 1}_m", f"{mech.output}{u + 1}_d_m", f"error{u + 1}_m"]
            cols += [ev.units[u].z[mech.unknowns.index(mech.output)], xd, output_error(mech, ev.units[u])]
        write_csv(out / "output.csv", header, np.column_stack(cols))
    if figures:
        _hand_on(figure_drawings(result, out), send)


def figure_names(problem, history: dict | None = None) -> list[str]:
    """The names of the PNG figures of a design of ``problem``
    (:func:`cadcam.outputs.plots.figure_makers`), the longest to draw first (the mechanism at
    three poses), so that workers drawing side by side end together: ``profile``,
    ``convergence`` where IPOPT's iterates are in ``history`` (None: where they may be),
    ``torque`` and ``springs`` where there are springs, ``output`` for mechanisms with an
    output law."""
    output = any(mech.output_target is not None for mech in problem.mechanisms)
    return ["profile", *(("convergence",) if history is None or history.get("iteration") else ()),
            *(("torque", "springs") if problem.springs else ()), *(("output",) if output else ())]


def figure_drawings(result, out: Path) -> list[Drawing]:
    """The PNG figures of ``result`` in ``out`` (:func:`write_outputs`) as drawings, each
    building its figure where it is drawn (:func:`cadcam.outputs.plots.save_named`; named by
    module, so that this process need not import matplotlib)."""
    ev = result.evaluation
    return [Call("cadcam.outputs.plots", "save_named",
                 (name, ev, result.history, result.band, result.recheck, result.friction, out / f"{name}.png"))
            for name in figure_names(ev.problem, result.history or {})]


def write_workshop_files(result, out: Path, args: Workshop, sheets: bool = True,
                         send: Callable[[list[Drawing]], None] | None = None) -> list[str]:
    """Per profile: DXF, SVG, CSV points and, with ``sheets``, its drawing sheets (:data:`SHEET_FILES`); STL
    on request; then ``verification.json`` and ``verification.md``. A profile whose cable wraps
    a turn or more (a helical groove) gets the groove's centre line ``cam{i}_groove.csv``
    instead: no planar outline holds it. WorkshopError when a profile's files cannot be made.
    The sheets need only the outlines and their fit: once the DXFs are fitted they are given to
    ``send`` (:meth:`cadcam.outputs.forked.Drawer.send`), to be drawn (and built) by the
    drawing processes while this one writes and checks the other files; drawn here, then,
    without it.

    The outlines and grooves are written as accurately as the design claims (the tolerance of
    :func:`cadcam.outputs.verification.fit_tolerance`, at most ``args.tolerance``), read back
    from the written files and recomputed; files that miss their requirement are written tighter.
    """
    from ..make.workshop import TWO_PI

    ev = result.evaluation
    notes, outlines, grooves, datums = [], {}, {}, {}
    owners = [mech for mech in ev.problem.mechanisms for _ in mech.profiles]
    for i, cs in enumerate(ev.profiles):
        try:
            if cs.alpha.max() >= TWO_PI:
                grooves[i] = float(cs.alpha.max())
            else:
                outlines[i] = _outline(ev, i, args)
                datums[i] = _datum(ev.problem, i, outlines[i], args)
        except ValueError as exc:
            raise WorkshopError(f"cam{i + 1}: {exc}") from exc
    from .verification import design_reference

    reference = design_reference(result)
    tolerance, chains, checks = _fitted_files(result, out, args, outlines, grooves, datums, reference)
    if sheets:
        cable = cable_report(result.problem, result.recheck.metrics)
        drawings = [drawing for i, outline in outlines.items() for drawing in _sheet_drawings(
            ev, i, outline, out, args, _part_notes(ev.problem, i, args, tolerance, datums[i], cable,
                                                   result.installation), owners[i])]
        _hand_on(drawings, send)
    names = {i: f"cam{i + 1}{'_groove.csv' if i in grooves else '.dxf'}" for i in chains}
    checks = _from_files(checks, names)
    points, point_checks, counts = _points_files(result, out, outlines, chains, _polygon_tolerance(tolerance),
                                                 reference)
    point_checks = _from_files(point_checks, {**names, **{i: f"cam{i + 1}_points.csv" for i in outlines}})
    notes += [f"cam{i + 1}: helical groove centre line, {len(chains[i].vertices)} points within "
              f"{1e3 * tolerance:.3g} mm, {phi_max / TWO_PI:.2f} turns at {1e3 * args.groove_pitch:g} mm pitch"
              + (" (wound clockwise: the CSV is its mirror image, a helix of the other hand; mirror y)"
                 if _mirrored(ev.problem, i) else "")
              for i, phi_max in grooves.items()]
    for i, outline in outlines.items():
        try:
            notes.append(_write_outline_files(ev, i, outline, out, args, tolerance, counts[i]))
        except ValueError as exc:
            raise WorkshopError(f"cam{i + 1}: {exc}") from exc
    from .file_checks import dxf_rows, model_gap_rows, quantity_rows
    from .verification import cable_clearances, cam_report, groove_report, verdict, write_report

    clearance = cable_clearances(result, chains)
    cams = {i: cam_report(i + 1, outlines[i], chains[i], tolerance, _polygon_tolerance(tolerance), args.cable_radius,
                          clearance[i]) if i in outlines
            else groove_report(i + 1, ev.design.bases[i], ev.design.coefficients[i], grooves[i], chains[i],
                               tolerance, args.cable_radius)
            for i in sorted(chains)}
    files = quantity_rows(checks + point_checks) + model_gap_rows(checks)
    for i in sorted(chains):
        files += dxf_rows(names[i], cams[i], chains[i].units)
        if i in outlines:
            files += _outline_file_rows(out, i, outlines[i], chains[i], points[i], args, tolerance)
    unread = {f"cam{i + 1}{kind}": "a drawing for people, of the outline and holes camN.dxf holds (not read back)"
              for i in outlines for kind in (SHEET_FILES if sheets else ())}
    write_report(out, list(cams.values()), checks, files, unread, point_checks)
    notes.append(f"verification.md: {verdict(checks, list(cams.values()), files)}")
    return notes


def _from_files(checks: list[dict], names: dict[int, str]) -> list[dict]:
    """The torque and output ``checks`` with the names of the files they are recomputed from
    (profile index → file name) as their ``files``."""
    files = " ".join(names[i] for i in sorted(names))
    return [{**c, "files": files} for c in checks]


def _outline_file_rows(out: Path, i: int, outline, dxf, points, args: Workshop, tolerance: float) -> list[dict]:
    """The rows of profile ``i``'s SVG, points CSV (read back: ``points``) and, where written,
    STL and STEP (:mod:`cadcam.outputs.file_checks`), ``dxf`` its DXF read back."""
    from .file_checks import points_rows, solid_check, svg_check

    stem = out / f"cam{i + 1}"
    polygon = _polygon_tolerance(tolerance)
    rows = svg_check(stem.with_suffix(".svg"), outline, dxf, tolerance)
    rows += points_rows(f"cam{i + 1}_points.csv", outline, points, dxf, polygon, tolerance)
    for path, chordal in ((stem.with_suffix(".stl"), polygon), (stem.with_suffix(".step"), 0.0)):
        if args.stl is not None and path.exists():
            rows += solid_check(path, outline, dxf, args, chordal, tolerance)
    return rows


def _outline(ev, i: int, args: Workshop):
    """Profile ``i`` cut and closed into the planar outline a workshop cuts, round the hub and
    a cable's radius inside the designed arc, a smooth closure clear of the hub by the files'
    loosest tolerance (:func:`cadcam.make.workshop.cut_outline`)."""
    from ..make.workshop import cut_outline

    return cut_outline(ev.design.bases[i], ev.design.coefficients[i], float(ev.profiles[i].alpha.max()),
                       args.hub_radius, args.cable_radius, args.tolerance)


def _owner(problem, i: int) -> tuple[int, int]:
    """The mechanism profile ``i`` belongs to and its index among that mechanism's profiles."""
    u, sl = next((u, sl) for u, sl in enumerate(problem.profile_slices()) if sl.start <= i < sl.stop)
    return u, i - sl.start


def _datum(problem, i: int, outline, args: Workshop):
    """The datum mark of profile ``i``'s part (:func:`cadcam.make.datum.datum_mark`), from where
    its mechanism puts the outline's +x axis (φ = 0) in the world with the joint at θ = 0 and
    which way the profile winds."""
    from ..make.datum import datum_mark
    from ..make.workshop import holes

    u, k = _owner(problem, i)
    mech = problem.mechanisms[u]
    x, y = mech.world_points(0.0, 0.0, 1.0, k)
    return datum_mark(outline, holes(outline, args.bore_diameter, args.anchor_diameter), float(np.arctan2(y, x)),
                      mech.windings[k])


def _part_notes(problem, i: int, args: Workshop, tolerance: float, datum, cable: dict | None,
                installation: list[dict]):
    """What profile ``i``'s workshop sheet states beyond its outline, the fields of its
    :class:`cadcam.make.drawing.PartNotes` (built where the sheet is drawn: this process need
    not import matplotlib): the springs on its mechanism, each mounted spring's cable cut
    length on the mechanism's first profile only, where the cable is anchored
    (:func:`cadcam.verify.installation.spring_installation`)."""
    u, k = _owner(problem, i)
    springs = tuple({key: value for key, value in row.items() if key != "cable_length" or k == 0}
                    for row, spring in zip(installation, problem.springs)
                    if any(port.mechanism == u for port in spring.ports))
    return dict(thickness=args.with_solids().stl, thickness_given=args.stl is not None,
                profile_tolerance=problem.tolerance["profile"], fit_tolerance=tolerance, datum=datum,
                dxf=f"cam{i + 1}.dxf", mirrored=_mirrored(problem, i), springs=springs, cable=cable, profile=i,
                cable_diameter=args.cable_diameter)


def _fitted_files(result, out: Path, args: Workshop, outlines: dict, grooves: dict, datums: dict, reference: dict):
    """Write every outline's DXF (with its datum mark, profile index → Datum) and every groove's
    centre line (profile index → its most-wound
    departure [rad]) at the tolerance the design asks for, read them back and recompute; write
    them tighter while a check misses (at most ``REFITS`` times). Returns the tolerance [m], the
    files read back (profile index → FileOutline) and the checks (the torque against
    ``reference``: :func:`cadcam.outputs.verification.design_reference`)."""
    from ..make.workshop import helical_groove, write_dxf, write_groove_csv
    from ..verify.file_model import read_dxf, read_groove
    from .verification import MIN_FIT, REFITS, fit_tolerance, recompute

    design = result.evaluation.design
    tolerance = fit_tolerance(result, args.tolerance)
    for attempt in range(REFITS + 1):
        chains = {}
        for i, outline in outlines.items():
            try:
                write_dxf(out / f"cam{i + 1}.dxf", outline, args.bore_diameter, args.anchor_diameter, tolerance,
                          _mirrored(result.evaluation.problem, i), datums[i].segment)
            except ValueError as exc:
                raise WorkshopError(f"cam{i + 1}: {exc}") from exc
            chains[i] = read_dxf(out / f"cam{i + 1}.dxf")
        for i, phi_max in grooves.items():
            write_groove_csv(out / f"cam{i + 1}_groove.csv", helical_groove(
                design.bases[i], design.coefficients[i], phi_max, args.groove_pitch, tolerance))
            chains[i] = read_groove(out / f"cam{i + 1}_groove.csv")
        checks = recompute(result, chains, reference)
        miss = _miss(checks)
        if miss <= 1 or tolerance <= MIN_FIT or attempt == REFITS or not np.isfinite(miss):
            return tolerance, chains, checks
        tolerance = max(MIN_FIT, tolerance / (2 * miss))
    raise AssertionError("unreachable")


def _miss(checks: list[dict]) -> float:
    """The largest file error of the recomputed ``checks`` over its requirement."""
    return max((c["file_max_abs_error"] / c["required"] for c in checks if "passed" in c), default=0.0)


#: Factor beyond a points CSV's miss by which the turn of its chords is cut for the next try
#: (:func:`_points_files`): the torque of a follower pressed on a polygon errs as the turn of
#: the chord it presses on, a cable's on it as their sag, the turn squared. From the chords'
#: mean turn first: where they turn more than the mean the next try has margin, where less
#: one more try cuts them again.
DENSER = 1.25


def _points_files(result, out: Path, outlines: dict, chains: dict, polygon: float, reference: dict):
    """Write every outline's ``camN_points.csv`` (its polygon within ``polygon`` [m]), read them
    back and recompute the torque (or x) from them, with any helical groove's centre line of
    ``chains``, against their own tolerance (:data:`cadcam.outputs.verification.POINTS_SHARE`
    of the design's error); while a check misses, write them again with the designed arc's chords turning
    less (:func:`cadcam.make.workshop.polyline_knots`: a follower takes its direction from the
    chord it presses on), at most ``REFITS`` times. Returns the polygons read back (profile
    index → FileOutline), their checks and each file's number of points."""
    from ..make.workshop import chord_turn, polyline_knots, write_points_csv
    from ..verify.file_model import read_points
    from .verification import POINTS_SHARE, REFITS, recompute

    turn = None
    for attempt in range(REFITS + 1):
        points, counts = {}, {}
        for i, outline in outlines.items():
            counts[i] = write_points_csv(out / f"cam{i + 1}_points.csv", outline, polygon, turn)
            points[i] = read_points(out / f"cam{i + 1}_points.csv")
        checks = recompute(result, {**chains, **points}, reference, POINTS_SHARE) if outlines else []
        miss = _miss(checks)
        if miss <= 1 or attempt == REFITS or not np.isfinite(miss):
            return points, checks, counts
        if turn is None:  # the sag's polygon: its chords' mean turn on the designed arcs
            turns = []
            for outline in outlines.values():
                knots = polyline_knots(outline, polygon)
                turns.append(chord_turn(outline, knots)[knots[1:] <= outline.phi_end])
            turn = float(np.mean(np.concatenate(turns)))
        turn /= DENSER * miss
    raise AssertionError("unreachable")


def _mirrored(problem, i: int) -> bool:
    """Whether profile ``i``'s outline, drawn in its own frame, is its part seen from the back
    (its cable winds clockwise: :attr:`cadcam.mechanisms.base.Mechanism.windings`)."""
    windings = [w for mech in problem.mechanisms for w in mech.windings]
    return windings[i] < 0


def _polygon_tolerance(tolerance: float) -> float:
    """Chordal tolerance [m] of the polygon files (CSV, STL): the fit's, but not below the
    workshop tolerance's least value, where polygons grow without bound."""
    from ..problem import WORKSHOP_LIMITS

    return max(tolerance, WORKSHOP_LIMITS["tolerance"][0])


def _sheet_drawings(ev, i: int, outline, out: Path, args: Workshop, part: dict, mech) -> list[Drawing]:
    """The drawing sheets (:data:`SHEET_FILES`) of profile ``i`` of mechanism ``mech`` stating
    ``part`` (the fields of a :class:`cadcam.make.drawing.PartNotes`), as the drawings of
    :data:`SHEET_DRAWINGS`, each building the sheets it writes where it is drawn (this process
    need not import matplotlib), the same date on all."""
    cam = ev.problem.profiles[i]
    words = dict(spec=ev.problem.name, drawing=f"cam{i + 1}", date=datetime.date.today().isoformat(),
                 words=mech.picture)
    return [Call("cadcam.make.drawing", "save_part_sheets", (
        {out / f"cam{i + 1}{kind}": SHEET_PAGES[kind] for kind in kinds}, outline, args.bore_diameter,
        args.anchor_diameter, cam.rho_min, cam.rho_max, cam.name, part, words)) for kinds in SHEET_DRAWINGS]


def _write_outline_files(ev, i: int, outline, out: Path, args: Workshop, tolerance: float, points: int) -> str:
    """The SVG and STL of profile ``i`` (its DXF is written by :func:`_fitted_files`, its
    ``points`` points by :func:`_points_files`, its sheets drawn from :func:`_sheet_drawings`);
    returns its line of the summary."""
    from ..make.workshop import holes, write_stl, write_svg

    stem = out / f"cam{i + 1}"
    polygon = _polygon_tolerance(tolerance)
    write_svg(stem.with_suffix(".svg"), outline, args.bore_diameter, args.anchor_diameter, tolerance,
              _mirrored(ev.problem, i))
    note = f"cam{i + 1}: DXF arcs within {1e3 * tolerance:.3g} mm, {points} points at {1e3 * polygon:.3g} mm"
    if args.stl is not None:
        circles = holes(outline, args.bore_diameter, args.anchor_diameter, tolerance)  # as the DXF's
        volume = write_stl(stem.with_suffix(".stl"), outline, args.stl, circles, args.groove_depth,
                           args.groove_width, polygon)
        note += f", STL {volume * 1e9:.0f} mm³"
        note += _write_step(stem.with_suffix(".step"), outline, args, tolerance, circles)
    return note


def _write_step(path: Path, outline, args: Workshop, tolerance: float, circles: list) -> str:
    """``camN.step`` (the biarc outline extruded, the holes ``circles`` through it, the groove
    cut) where the extra ``step`` is installed; the summary's words either way."""
    from ..make import step

    if not step.available():
        return ", no STEP (pip install -e '.[step]')"
    volume = step.write_step(path, outline.arcs(tolerance), circles, args.stl, args.groove_depth,
                             args.groove_width)
    return f", STEP {volume * 1e9:.0f} mm³"


def _hand_on(drawings: list[Drawing], send: Callable[[list[Drawing]], None] | None) -> None:
    """Give ``drawings`` to ``send`` (:meth:`cadcam.outputs.forked.Drawer.send`), to be drawn by
    the drawing processes; without ``send``, draw them here."""
    if send is None:
        for drawing in drawings:
            drawing()
    else:
        send(drawings)
