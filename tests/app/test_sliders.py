"""The design page's sliders without a browser: which fields a designer turns, each slider's span,
step and unit made from its key's declaration and the value now, and the tolerances as fields."""
import tomllib

import pytest

from cadcam import load_problem
from cadcam.app.form import SPAN, STEPS, Slider, slider_of, turned
from cadcam.app.state import DesignState
from cadcam.problem import TOLERANCES


@pytest.fixture(scope="module")
def pendulum():
    return DesignState.template("ludovico2021_pendulum")


@pytest.fixture(scope="module")
def wire_cam():
    return DesignState.template("johnston2023_1dof")


def test_the_quantities_a_designer_turns_have_sliders_and_the_others_none(pendulum, wire_cam):
    keys = {f.key for state in (pendulum, wire_cam) for f in state.fields if slider_of(f) is not None}
    assert {"joints.1.theta_range_deg", "cams.1.theta_range_deg", "springs.1.rate", "springs.2.preload",
            "springs.1.travel", "mechanisms.1.spring_end", "mechanisms.2.order", "cams.1.order",
            "tolerances.rate", "tolerances.profile"} <= keys
    assert not {"cams.1.tracking_weight", "solver.grid", "workshop.bore_diameter", "cams.1.target.expression",
                "mechanisms.1.rho_max", "springs.1.free_length"} & keys
    assert turned("joints.2.target.mass") and turned("cams.1.target.length") and not turned("joints.1.target.g")


def test_a_positive_value_turns_within_a_factor_its_keys_bounds_and_plausible_range(wire_cam, pendulum):
    rate = slider_of(wire_cam.field("springs.1.rate"))
    assert rate == Slider(1100 / SPAN, 1100 * SPAN, 1.0, "N/m", "number", ((1100 / SPAN, 1100 * SPAN),))
    assert (rate.end - rate.start) / rate.step >= STEPS
    # a rate of 30 kN/m: no further than the catalogue's stiffest spring (the key's plausible range)
    stiff = slider_of(pendulum.field("springs.1.rate"))
    plausible = pendulum.field("springs.1.rate").declaration.plausible()
    assert (stiff.start, stiff.end) == (15000.0, plausible.high) and stiff.step == 100.0


def test_a_key_that_allows_zero_turns_from_zero_and_a_zero_value_to_its_plausible_top(wire_cam):
    preload = wire_cam.field("springs.1.preload")
    assert preload.value == 0.0
    assert slider_of(preload)[:2] == (0.0, preload.declaration.plausible().high)
    assert slider_of(preload, 3.0)[:2] == (0.0, 3.0 * SPAN)  # preload ≥ 0: from 0
    assert slider_of(wire_cam.field("springs.1.travel"), 0.05)[:2] == (0.05 / SPAN, 0.05 * SPAN)  # travel > 0
    tolerance = slider_of(wire_cam.field("tolerances.rate"))
    assert (tolerance.start, tolerance.end, tolerance.unit) == (0.0, TOLERANCES["rate"].default * SPAN, "ratio")


def test_an_order_a_range_and_a_spring_end_have_sliders_of_their_own_kind(wire_cam, pendulum):
    order = slider_of(wire_cam.field("cams.1.order"))
    assert (order.kind, order.start, order.end, order.step) == ("integer", 1, 7, 1)
    assert slider_of(wire_cam.field("cams.1.order"), 35).end == 40  # the key's highest order
    span = slider_of(pendulum.field("joints.1.theta_range_deg"))
    assert (span.kind, span.start, span.end, span.step, span.unit) == ("range", -90.0, 270.0, 1.0, "deg")
    end = slider_of(pendulum.field("mechanisms.1.spring_end"))
    assert end.kind == "point" and end.spans == ((0.0, 0.5), (-0.25, 0.25)) and end.step == 0.001
    assert slider_of(pendulum.field("mechanisms.1.spring_end"), "x") is None  # no value a slider shows


def test_a_slider_value_keeps_the_decimals_of_its_step():
    assert Slider(0.0, 0.2, 0.001, "ratio", "number").snapped(0.1 + 0.02 + 0.0000000001) == 0.12
    assert Slider(500.0, 2000.0, 10.0, "N/m", "number").snapped(1234.5) == 1234.0


def test_the_tolerances_are_fields_at_their_defaults_and_an_edit_sets_the_table(tmp_path):
    state = DesignState.template("johnston2023_1dof")
    fields = {f.key: f for f in state.fields if f.group == "Tolerances"}
    assert {k: f.value for k, f in fields.items()} == {f"tolerances.{k}": t.default for k, t in TOLERANCES.items()}
    assert fields["tolerances.placement"].label == "placement [m]"
    assert state.edit("tolerances.rate", "0.05") is None and state.edit("tolerances.profile", "2e-5") is None
    assert dict(state.problem().tolerances) == {"rate": 0.05, "profile": 2e-5}
    written = tmp_path / "edited.toml"
    written.write_text(state.spec_toml())
    assert tomllib.loads(written.read_text())["tolerances"] == {"rate": 0.05, "profile": 2e-5}
    assert load_problem(written).to_dict() == state.problem().to_dict()
