"""A spec names a catalogue spring by its part: the row fills rate, preload, free length and
travel (the least extension its length, load and stress allow), the spec may not give them too,
an unknown part names the nearest, the design reports the body's numbers and the re-check
fails a design that passes one of the body's limits."""
from __future__ import annotations

import copy
import math
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cadcam.optimize import optimize
from cadcam.physics.catalogue import load_catalogue, shipped
from cadcam.spec import SpecError, parse_spec
from cadcam.sweep.springs import screen_slot, slot_need
from cadcam.verify.evaluate import BODY_CHECKS, evaluate

ROOT = Path(__file__).resolve().parents[1]
TUTORIAL = tomllib.loads((ROOT / "docs" / "first_balancer.toml").read_text())
#: A part whose screen passes for the tutorial, its travel bound by its longest length.
PART = "9654K908"


def _with_part(part: str = PART, **spring) -> dict:
    data = copy.deepcopy(TUTORIAL)
    data["springs"] = [{"ports": ["cable:1"], "part": part, **spring}]
    return data


@pytest.mark.parametrize("part", ["5108N001", "5108N023", PART, "9654K901"])
def test_the_row_fills_the_spring(part):
    spring = parse_spec(_with_part(part)).springs[0]
    cat = shipped()
    i = cat.index(part)
    b = cat.spring_body(i)
    assert (spring.rate, spring.preload, spring.free_length) == (b.rate, b.preload, b.free_length)
    assert spring.travel == min(b.length_max - b.free_length, (b.load_max - b.preload) / b.rate,
                                b.extension_limits()["stress"])
    assert spring.travel == cat.travel()[0][i]
    assert spring.body == b and spring.part == part and spring.catalogue is None


def test_the_resolved_problem_keeps_the_part_and_reads_back_the_same():
    problem = parse_spec(_with_part())
    springs = problem.to_dict()["springs"]
    assert springs[0]["part"] == PART and springs[0]["rate"] == problem.springs[0].rate
    assert parse_spec(problem.to_dict()).springs == problem.springs


@pytest.mark.parametrize("key", ["rate", "preload", "free_length", "travel"])
def test_a_filled_key_given_beside_the_part_is_refused(key):
    with pytest.raises(SpecError, match=rf"springs\[1\]\.{key} = 0\.5: part '{PART}' sets {key} .*not both"):
        parse_spec(_with_part(**{key: 0.5}))


@pytest.mark.parametrize("part, words", [
    ("9654K9080", "no part '9654K9080' in the shipped catalogue (McMaster-Carr); the nearest: 9654K908"),
    ("", "expected a catalogue part number"),
])
def test_an_unknown_part_is_one_line(part, words):
    with pytest.raises(SpecError) as err:
        parse_spec(_with_part(part))
    assert words in str(err.value) and "\n" not in str(err.value)


def test_a_catalogue_is_read_relative_to_the_spec_and_only_for_a_part(tmp_path):
    (tmp_path / "mine.csv").write_text(
        "part_number,stiffness,load_min,length_natural,length_max,load_max,wire_dia,od,material\n"
        "A1,1000,2,0.05,0.11,62,0.0015,0.012,Music-Wire Steel\n")
    spring = parse_spec(_with_part("A1", catalogue="mine.csv"), base=tmp_path).springs[0]
    assert spring.rate == 1000 and spring.travel == pytest.approx(0.06)
    assert spring.catalogue == str((tmp_path / "mine.csv").resolve())
    assert load_catalogue(tmp_path / "mine.csv").parts == ("A1",)
    data = copy.deepcopy(TUTORIAL)
    data["springs"][0]["catalogue"] = "mine.csv"
    with pytest.raises(SpecError, match="a catalogue is read only for a part"):
        parse_spec(data, base=tmp_path)


def test_the_tutorial_screen_passes_the_part_and_finds_many():
    problem = parse_spec(TUTORIAL)
    need = slot_need(problem, 0)
    assert need.energy == pytest.approx(0.5 * 9.81 * 0.2 * math.cos(math.radians(20)), rel=1e-6)
    assert need.torque == pytest.approx(0.5 * 9.81 * 0.2) and need.arm == 0.06
    result = screen_slot(problem, 0, shipped())
    assert result.passed[shipped().index(PART)]
    assert result.passed.sum() >= 10


@pytest.fixture(scope="module")
def designed():
    problem = parse_spec(_with_part())
    return problem, optimize(problem)


def test_a_part_named_spring_designs_and_reports_its_body(designed):
    problem, result = designed
    assert result.status == "success", result.message
    out = result.to_dict()
    (body,) = out["spring_bodies"]
    x = out["recheck"]["extension_max"][0]
    b = problem.springs[0].body
    assert body["part"] == PART and body["travel_binding"] == "length"
    assert body["peak_force"] == pytest.approx(b.preload + b.rate * x)
    assert body["max_length"] == pytest.approx(b.free_length + x)
    d, D = b.wire_diameter, b.coil_diameter
    w = D / d
    assert body["peak_stress"] == pytest.approx(8 * D * body["peak_force"] * (w + 0.5) / (w - 0.75) / (math.pi * d**3))
    assert body["peak_force"] <= body["load_max"] and body["max_length"] <= body["length_max"]
    assert body["peak_stress"] <= body["allowed_stress"]


@pytest.mark.parametrize("limit, field, words", [
    ("load", "load_max", "spring force above its largest load"),
    ("length", "length_max", "spring longer than its largest length"),
    ("stress", "allowed_stress", "wire stress above its allowance"),
])
def test_the_recheck_fails_a_design_past_a_body_limit(designed, limit, field, words):
    problem, result = designed
    spring = problem.springs[0]
    x = float(np.max(result.recheck.metrics.extension_max))
    # the body as if its limit sat at 90 % of the extension the design reaches
    tighter = {"load_max": spring.body.force(0.9 * x), "length_max": spring.body.length(0.9 * x),
               "allowed_stress": spring.body.stress(0.9 * x)}
    body = replace(spring.body, **{field: tighter[field]})
    changed = replace(problem, springs=(replace(spring, body=body),))
    violations = evaluate(changed, result.design).metrics.violations
    body_words = [w for w, *_ in BODY_CHECKS.values()]
    assert [v.split(":")[0] for v in violations if v.split(":")[0] in body_words] == [words]
