"""The cable as a part of a design: a spec's [cable] read from the table or given in full, a
diameter alone keeping today's limits, the cables no design can carry refused before any
solve in one line, and a small knee assist whose least radius of curvature and peak tension
are both held at the cable's limits, with the cable's checks in result.json, the summary and
the drawing sheet."""
from __future__ import annotations

import json
import tomllib
from dataclasses import replace
from importlib.resources import files
from pathlib import Path

import pytest
from jsonschema import Draft202012Validator

import cadcam
from cadcam.cli import main
from cadcam.errors import SpecError
from cadcam.make.drawing import cable_notes
from cadcam.physics.cables import Cable, shipped_cables
from cadcam.spec import load_spec, parse_spec
from cadcam.verify.binding import RTOL
from cadcam.verify.evaluate import LENGTH_TOL, evaluate
from cadcam.verify.reachable import unreachable

ROOT = Path(__file__).resolve().parents[1]
#: The knee assist of the docs: a torque table to 8 N·m, one spring, a 1.5 mm 7x19 wire rope.
KNEE = ROOT / "docs" / "knee_assist.toml"
#: A cable given in full that both binds in the knee's stiff variant (:func:`designed`): it bends
#: round no less than 18 mm and its working load, 1540 N / 5 = 308 N, is just above what the
#: target's energy needs of a 6000 N/m spring (a 304 N peak at the least).
BINDING = {"diameter": 0.0015, "min_bend_radius": 0.018, "breaking_load": 1540.0, "kind": "wire rope"}


def knee(cable: dict | None = None, grid: int = 16, rho_max: float | None = None, **spring):
    """The knee assist on a design grid of ``grid``, its spring and cable changed as given."""
    data = tomllib.loads(KNEE.read_text(encoding="utf-8"))
    data["solver"] = {"grid": grid}
    data["springs"][0].update(spring)
    if cable is not None:
        data["cable"] = cable
    if rho_max is not None:
        data["mechanisms"][0]["rho_max"] = rho_max
    return parse_spec(data, "knee.toml")


@pytest.fixture(scope="module")
def designed():
    """The knee with a stiff spring and the :data:`BINDING` cable, designed once (a few s)."""
    return cadcam.design(knee(BINDING, rate=6000.0, travel=0.08))


def test_a_named_cable_fills_its_part_and_the_workshop_diameter():
    problem = knee()
    row = shipped_cables().cable("stainless 7x19 1.5 mm")
    assert problem.cable == row and problem.workshop.cable_diameter == 0.0015
    assert problem.curvature_limit(0) == pytest.approx(0.018 + 0.00075)
    # 3000 N/m from 10 N reaches the working load 262 N at 84 mm: the 80 mm travel comes first
    assert problem.extension_limit(0) == 0.08
    stiff = knee(rate=6000.0)
    assert stiff.extension_limit(0) == pytest.approx((262.0 - 10.0) / 6000.0)


def test_the_resolved_problem_reads_back_with_its_cable():
    for problem in (knee(), knee(BINDING)):
        again = parse_spec(json.loads(json.dumps(problem.to_dict())), "result.json")
        assert again.cable == problem.cable and again.workshop == problem.workshop


@pytest.mark.parametrize("cable, workshop, words", [
    ({"name": "stainless 7x19 1.6 mm"}, None,
     "cable.name = 'stainless 7x19 1.6 mm': no cable 'stainless 7x19 1.6 mm' in the shipped cable table; "
     "the nearest: stainless 7x19 1.5 mm"),
    ({"name": "stainless 7x19 1.5 mm", "diameter": 0.002}, None,
     "cable.diameter = 0.002: cable 'stainless 7x19 1.5 mm' sets diameter (0.0015 m from its row); give the name "
     "or diameter, not both"),
    ({"diameter": 0.0015, "min_bend_radius": 0.005}, None, "missing key 'cable.breaking_load'"),
    ({**BINDING, "kind": "chain"}, None, "cable.kind = 'chain': expected the cable's kind"),
    ({**BINDING, "colour": "red"}, None, "unknown key 'cable.colour'"),
    (BINDING, {"cable_diameter": 0.002},
     "workshop.cable_diameter = 0.002: the [cable] sets the diameter (0.0015 m, a 1.5 mm wire rope); remove "
     "workshop.cable_diameter"),
])
def test_a_cable_the_spec_gets_wrong_is_one_line(cable, workshop, words):
    data = tomllib.loads(KNEE.read_text(encoding="utf-8"))
    data["cable"] = cable
    if workshop is not None:
        data["workshop"] = workshop
    with pytest.raises(SpecError) as err:
        parse_spec(data, "knee.toml")
    assert words in str(err.value) and "\n" not in str(err.value)


def test_a_diameter_alone_keeps_todays_limits():
    """Every shipped spec gives its cable as a diameter: no cable part, so every profile's
    curvature limit is its own and every spring's largest extension its travel."""
    for path in sorted((ROOT / "models").glob("*.toml")) + [ROOT / "docs" / "first_balancer.toml"]:
        problem = load_spec(path)
        assert problem.cable is None and "cable" not in problem.to_dict(), path.name
        assert [problem.curvature_limit(k) for k in range(len(problem.profiles))] == [
            p.min_curvature_radius for p in problem.profiles], path.name
        assert [problem.extension_limit(j) for j in range(len(problem.springs))] == [
            s.travel for s in problem.springs], path.name


@pytest.mark.parametrize("problem, words", [
    (lambda: knee({"name": "stainless 1x19 1.5 mm"}),
     "cable 'stainless 1x19 1.5 mm' bends round no less than 55.5 mm, so its centre line, the designed profile, no "
     "tighter than 56.2 mm: above profile 'cam''s rho_max = 50 mm, which no profile within rho_max can wrap: a "
     "rho_max above 56.2 mm or a cable that bends tighter, e.g. 'stainless 7x7 2 mm' or 'stainless 7x19 2 mm'"),
    (lambda: knee({"name": "polyester braid 1.5 mm"}, preload=60.0),
     "spring 'spring 1': its initial tension pulls 60 N on cable 'polyester braid 1.5 mm', whose working load is "
     "57.14 N (400 N breaking / 7): a spring of less initial tension or a stronger cable"),
    (lambda: knee({"name": "Dyneema braid 1 mm"}, rate=6000.0, preextension=0.03),
     "its initial tension and fixed pre-extension 30 mm pull 190 N on cable 'Dyneema braid 1 mm', whose working "
     "load is 142.9 N"),
    (lambda: (lambda p: replace(p, workshop=replace(p.workshop, cable_diameter=0.002)))(knee()),
     "workshop.cable_diameter = 0.002 m is not the diameter of the cable 'stainless 7x19 1.5 mm' (0.0015 m): drop "
     "--cable-diameter"),
    (lambda: knee(rate=6000.0, travel=0.06),
     "its springs store at most 5.712 J within their travel and their cable's working load, so no design comes "
     "within 25.9 % of the target's RMS (accepted: 5 %, [joints.acceptance] relative_rmse): give a stronger cable "
     "(its working load 262 N stops 'spring 1' short of the travel)"),
])
def test_a_cable_no_design_can_carry_is_refused_before_solving(problem, words):
    assert words in unreachable(problem())


def test_the_cli_refuses_it_in_one_line_and_writes_nothing(tmp_path, capsys):
    spec = tmp_path / "knee.toml"
    spec.write_text(KNEE.read_text(encoding="utf-8").replace("stainless 7x19 1.5 mm", "stainless 1x19 1.5 mm"))
    assert main(["design", str(spec), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cadcam: error: knee: cable 'stainless 1x19 1.5 mm' bends round") and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_the_design_bends_its_cable_no_tighter_than_its_least_radius(designed):
    problem, fine = designed.problem, designed.recheck.metrics
    need = problem.cable.least_profile_radius
    assert designed.success, designed.summary()
    # the NLP's row holds on the fine re-check, and binds: the cable's radius is the active limit
    assert need - LENGTH_TOL <= fine.curvature_radius_min[0] <= need * (1 + RTOL)
    assert any("cam at its cable's least bend radius: radius of curvature 18.75 mm of 18.75 mm" in b
               for b in designed.binding)


def test_the_design_keeps_its_peak_tension_within_the_working_load(designed):
    problem, fine = designed.problem, designed.recheck.metrics
    spring, cable = problem.springs[0], problem.cable
    tension = spring.preload + spring.rate * fine.extension_max[0]
    assert cable.working_load == pytest.approx(308.0)
    assert cable.working_load * (1 - RTOL) <= tension <= cable.working_load + spring.rate * LENGTH_TOL
    assert any(b.startswith("spring 1 at its cable's working load: tension 308 N of 308 N") for b in designed.binding)


def test_a_weaker_cable_is_a_violation_of_the_same_design(designed):
    """Re-checked with a cable 2 mm stiffer and 10 % weaker, the design breaks both limits."""
    weaker = Cable(0.0015, 0.020, 1400.0, "wire rope")
    ev = evaluate(replace(designed.problem, cable=weaker), designed.design)
    assert any(v.startswith("cable tension above its working load: spring 1 pulls 308 N on a 1.5 mm wire rope "
                            "(working load 280 N") for v in ev.violations)
    assert any(v.startswith("radius of curvature below its minimum: cam (margin -0.002") for v in ev.violations)


def test_result_json_the_summary_and_the_sheet_carry_the_cable(designed, tmp_path):
    designed.save(tmp_path, figures=False)
    data = json.loads((tmp_path / "result.json").read_text())
    schema = json.loads((files("cadcam") / "result.schema.json").read_text(encoding="utf-8"))
    assert not list(Draft202012Validator(schema).iter_errors(data))
    cable = data["cable"]
    assert cable["least_profile_radius"] == pytest.approx(0.01875)
    assert cable["curvature_radius_min"] == designed.recheck.metrics.curvature_radius_min
    assert cable["peak_tension"] == pytest.approx(308.0, rel=RTOL) and cable["working_load"] == pytest.approx(308.0)
    assert (cable["safety_factor"], cable["breaking_load"], cable["kind"]) == (5.0, 1540.0, "wire rope")
    assert data["problem"]["cable"] == BINDING
    assert ("  cable given in full (Ø1.5 mm wire rope): least radius of curvature 18.75 mm, its bend asks ≥ 18.75 mm "
            "(18 mm to the cut outline); peak tension 308 N, working load 308 N (1540 N breaking / 5)"
            in designed.summary().split("\n"))
    tension, bend = cable_notes(cable, 0)
    assert tension == "Cable: given in full, Ø1.50 wire rope; peak tension 308 N, working load 308 N (1540 N / 5)."
    assert bend == "The red arc's least radius of curvature 18.00; the cable's least bend radius 18.00."


@pytest.mark.slow
def test_the_knee_assist_ends_with_a_part_that_respects_its_cable(tmp_path):
    """docs/knee_assist.toml as shipped: a success whose cable's limits hold on the re-check."""
    assert main(["design", str(KNEE), "-o", str(tmp_path), "--no-figures"]) == 0
    cable = json.loads((tmp_path / "result.json").read_text())["cable"]
    assert min(cable["curvature_radius_min"]) >= cable["least_profile_radius"] - LENGTH_TOL
    assert cable["peak_tension"] <= cable["working_load"]
