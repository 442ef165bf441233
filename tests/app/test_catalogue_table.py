"""The design page's spring catalogue table without a browser: each spring lit by the catalogue's
screen for the spec as edited, by its design's verdict once the page has designed with it under
the same edits, and a row picked making the spring that part."""
import math
import tomllib

import numpy as np
import pytest

from cadcam import load_problem
from cadcam.app.parts import LIGHTS, NUMBERS, count_line, significant
from cadcam.app.state import DesignState
from cadcam.physics.catalogue import Need, shipped
from cadcam.sweep.springs import design_order, screen_slot

from ..conftest import ROOT

#: The tutorial's balancer: one spring alone on its joint, so that the screen tests it.
TUTORIAL = ROOT / "docs" / "first_balancer.toml"


def _screen(overrides=()):
    return screen_slot(load_problem(TUTORIAL, overrides=list(overrides)), 0, shipped())


def _lit_by_screen(rows, screened) -> bool:
    """Every row lit as ``screened`` says: untried where it passed, infeasible with its reason
    where not."""
    return (list(rows["verdict"]) == ["untried" if p else "infeasible" for p in screened.passed]
            and list(rows["reason"]) == list(screened.reasons))


@pytest.fixture(scope="module")
def designed():
    """The tutorial's spring made the catalogue part the catalogue search designs first (the
    nearest its rate among those the screen passes), designed once."""
    state = DesignState(TUTORIAL)
    screened = _screen()
    part = shipped().parts[design_order(shipped(), screened.passed, load_problem(TUTORIAL).springs[0].rate)[0]]
    state.pick_part(1, part)
    return state, part, state.design()


def test_before_any_design_every_spring_is_lit_by_the_screen_of_the_spec_as_edited():
    state = DesignState(TUTORIAL)
    rows = state.catalogue_view(1).rows
    screened = _screen()
    assert len(rows) == len(shipped()) and list(rows["part"]) == list(shipped().parts)
    assert _lit_by_screen(rows, screened)
    assert 0 < screened.passed.sum() < len(shipped())  # the screen tells springs apart here
    assert list(rows["light"]) == [list(LIGHTS).index(w) for w in rows["verdict"]]
    assert count_line(rows) == f"{screened.passed.sum()} untried, {(~screened.passed).sum()} infeasible"
    view = state.catalogue_view(1)
    assert view.need.energy > 0 and view.origin == shipped().origin

    # a heavier arm: the screen of the edited spec, which rejects more springs
    assert state.edit("joints.1.target.mass", "0.8") is None
    heavier = _screen([("joints.1.target.mass", 0.8)])
    assert heavier.passed.sum() < screened.passed.sum()
    assert _lit_by_screen(state.catalogue_view(1).rows, heavier)


def test_the_numbers_are_the_catalogues_in_the_units_shown():
    rows = DesignState(TUTORIAL).catalogue_view(1).rows
    cat = shipped()
    i = len(cat) // 2
    body = cat.spring_body(i)
    expected = {"rate": body.rate / 1e3, "initial_tension": body.preload, "free_length": 1e3 * body.free_length,
                "travel": 1e3 * cat.travel()[0][i], "length_max": 1e3 * body.length_max, "load_max": body.load_max,
                "od": 1e3 * (body.coil_diameter + body.wire_diameter), "price": cat.pack_price[i]}
    assert [c.name for c in NUMBERS] == list(expected)
    for name, value in expected.items():
        assert rows[name][i] == pytest.approx(value, rel=5e-4), name


def test_a_spring_sharing_its_joint_is_screened_for_nothing():
    state = DesignState.template("johnston2023_1dof")  # two springs on its cam's joint
    view = state.catalogue_view(2)
    assert view.need == Need() and set(view.rows["verdict"]) == {"untried"}


def test_numbers_are_shown_to_four_significant_digits():
    shown = significant([0.000700507086614173, 2184.4, 0.99822259, 0.0, math.nan, -12.3456])
    assert list(shown[:4]) == [0.0007005, 2184.0, 0.9982, 0.0]
    assert math.isnan(shown[4]) and shown[5] == -12.35


def test_a_part_picked_is_the_spring_designed_named_and_written(designed):
    state, part, outcome = designed
    spring = outcome.result.problem.springs[0]
    assert (spring.part, spring.name) == (part, f"part {part}")
    cat = shipped()
    assert spring.rate == cat.spring_body(cat.index(part)).rate
    assert state.set_by_part("springs.1.rate") == part and state.set_by_part("springs.1.preextension") is None
    assert state.value("springs.1.rate") == spring.rate and state.table_names()["springs.1"] == f"part {part}"
    written = tomllib.loads(state.spec_toml())["springs"][0]
    assert written == {"name": f"part {part}", "ports": ["cable:1"], "part": part}  # no rate, travel: the part's


def test_a_designed_part_is_lit_by_its_verdict_while_the_edits_stand(designed):
    state, part, outcome = designed
    assert outcome.result.success
    rows = state.catalogue_view(1).rows
    row = rows[rows["part"] == part].iloc[0]
    assert (row["verdict"], row["light"]) == ("feasible", 0) and row["reason"].startswith("binding: its ")
    others = rows["part"] != part
    assert rows[others].equals(DesignState(TUTORIAL).catalogue_view(1).rows[others])  # the screen's, as before

    # another target: the part has not been designed for it; the same target again: its verdict
    assert state.edit("joints.1.target.mass", "0.45") is None
    again = state.catalogue_view(1).rows
    assert again[again["part"] == part]["verdict"].iloc[0] == "untried"
    assert state.edit("joints.1.target.mass", "") is None
    assert state.catalogue_view(1).rows.equals(rows)


def test_a_part_the_design_refuses_is_infeasible_with_the_refusal_and_a_paper_spring_replaces_a_part():
    state = DesignState(TUTORIAL)
    screened = _screen()
    weak = shipped().parts[int(np.flatnonzero(~screened.passed)[0])]
    state.pick_part(1, weak)
    outcome = state.design()
    assert outcome.error is not None and outcome.result is None
    rows = state.catalogue_view(1).rows
    row = rows[rows["part"] == weak].iloc[0]
    assert (row["verdict"], row["reason"]) == ("infeasible", outcome.error)

    from cadcam.app.state import catalogue
    state.pick_spring(1, catalogue()[0]["name"])
    assert state.parts == {} and state.part(1) is None
    assert [k for k, _ in state.override_pairs()] == ["springs.1"]
    state.pick_part(1, weak)
    assert state.picks == {} and [k for k, _ in state.override_pairs()] == ["springs"]
    with pytest.raises(KeyError, match="no part 'X1'"):
        state.pick_part(1, "X1")
