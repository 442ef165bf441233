"""Builds, not corners: the build model against builds evaluated exactly, the draws, each
build's settings, the adjustment table and the payload range, on the tutorial's balancer with
a tensioning screw and a slot for its spring end, its cable over a fixed guide with friction."""
import copy
import csv
import re
import shlex
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import lsq_linear
from scipy.stats import norm

import cadcam
from cadcam.cli import _override
from cadcam.outputs.run_files import ADJUSTMENT_FILE, run_file_names
from cadcam.spec import SpecError, parse_spec, read_spec_data
from cadcam.verify import builds as B
from cadcam.verify.evaluate import evaluate
from cadcam.verify.friction import friction_band

#: A full design per module fixture and more: too heavy for make test's five minutes.
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
TUTORIAL = ROOT / "docs" / "first_balancer.toml"
#: A rope over a fixed steel pin: its effective friction coefficient (docs/physics.md: about 60 %
#: of the tension passes a 180° turn) and the pin's wrap [deg].
GUIDE = {"spring": 1, "mu": 0.16, "wrap_deg": 30.0}
#: docs/tutorial.md's "Build it, and set it back": the tutorial's arm with 44° of cable wound at
#: the range's start (its anchor turned back, so that its spring end may turn back along the
#: slot's arc without unwinding the cable), a screw, a slot, 0.3–0.8 kg to carry, and its cable
#: over :data:`GUIDE`, the friction band's centre tracked.
OVERRIDES = {"mechanisms.1.anchor_angle": 0.35, "adjustment.preload_travel": 0.0105, "adjustment.slot": "chi0",
             "adjustment.slot_travel": 0.12, "joints.1.target.mass_range": [0.3, 0.8], "friction.guides": [GUIDE],
             "friction.centre": True}


def tutorial() -> dict:
    """The tutorial's spec with :data:`OVERRIDES`, as data."""
    data = read_spec_data(TUTORIAL)
    data["mechanisms"][0]["anchor_angle"] = 0.35
    data["adjustment"] = {"preload_travel": 0.0105, "slot": "chi0", "slot_travel": 0.12}
    data["joints"][0]["target"]["mass_range"] = [0.3, 0.8]
    data["friction"] = {"guides": [GUIDE], "centre": True}
    return data


def test_the_tutorial_shows_these_overrides():
    """docs/tutorial.md's command of "Build it, and set it back" sets what this module designs."""
    text = (ROOT / "docs" / "tutorial.md").read_text(encoding="utf-8")
    (command,) = [line for line in text.splitlines() if line.startswith("cadcam design") and "out/adjusted" in line]
    words = shlex.split(command)
    given = dict(_override(words[i + 1]) for i, word in enumerate(words) if word == "--set")
    assert given == OVERRIDES
    assert re.search(r"tested-by tests/verify/test_builds.py::test_the_tutorial_meets_two_percent", text)


@pytest.fixture(scope="module")
def arm():
    result = cadcam.design(TUTORIAL, overrides=OVERRIDES)
    assert result.success
    assert result.problem.adjustment == {"preload_travel": 0.0105, "slot": "chi0", "slot_travel": 0.12}
    assert result.problem.friction.centre and len(result.problem.friction.guides) == 1
    return result


@pytest.fixture(scope="module")
def model(arm):
    ev, sens = arm.evaluation, arm.band.sensitivity
    chosen = B.settings(ev.problem, sens.layout)
    return B.build_model(ev, sens, B.mixed_function(sens.model), [s for s in chosen if not s.screw])[0], chosen


def _posed(ev, problem):
    """The evaluation ``ev`` with its problem replaced (its metrics kept): the same design
    under another [builds] or [adjustment]."""
    out = copy.copy(ev)
    out.problem = problem
    return out


def _exact(arm, step: np.ndarray) -> np.ndarray:
    """τ − τ_d of the build ``step`` evaluated exactly, on the design grid."""
    ev = arm.evaluation
    problem, design = B.built(ev.problem, ev.design, arm.band.sensitivity.layout, step)
    return (evaluate(problem, design, grid=ev.grid, profile=False).tau - ev.tau_d).ravel()


def test_the_build_model_is_the_exact_torque_of_thirty_builds(arm, model):
    """30 builds drawn over the tutorial's tolerances, evaluated exactly (the departure solved
    again, the springs' rates, preloads, pre-extensions, the spring end and the profile moved):
    the model is within 1e-5 of the target's peak as built (first order: 0.14 %) and 1e-3 at
    each build's best settings, a slot turned up to 6° and a screw a millimetre (first order:
    1.2 %)."""
    model, chosen = model
    D = np.concatenate(list(arm.band.sensitivity.directions.values()), axis=1)
    step = D @ B.draws(1, 30, D.shape[1], "uniform")
    adjusted = B.with_settings(step, chosen, B.best_settings(model, step, chosen))
    peak = np.abs(arm.evaluation.tau_d).max()
    for steps, bound, first_order in ((step, 1e-5, 1e-3), (adjusted, 1e-3, 1e-2)):
        exact = np.column_stack([_exact(arm, s) for s in steps.T])
        assert np.abs(exact - model.error(steps)).max() < bound * peak
        assert np.abs(exact - model.error0[:, None] - model.J @ steps).max() > first_order * peak


def test_a_builds_friction_coefficient_moves_its_torque_to_its_friction_bands_centre(arm, model):
    """The guide's μ 30 % off either way: the build's torque is the centre of the friction band
    the design has under that μ (cadcam.verify.friction, the tensions and arms the design's),
    to rounding; the declared μ moves nothing, its centre being tracked."""
    model, _ = model
    ev = arm.evaluation
    points = B.kept_points(ev.grid, 1)
    step = np.zeros((model.J.shape[1] + 1, 3))
    step[-1] = [-0.3, 0.0, 0.3]
    error = model.error(step)
    np.testing.assert_array_equal(error[:, 1], model.error(step[:-1, [1]])[:, 0])
    for b, factor in ((0, 0.7), (2, 1.3)):
        centre = friction_band(ev, ev.problem.friction.scaled(factor)).centre[0, points]
        np.testing.assert_allclose(error[:, b], centre - ev.tau_d[0, points], rtol=0, atol=1e-12)
        assert np.abs(error[:, b] - error[:, 1]).max() > 1e-3 * np.abs(ev.tau_d).max()


def test_the_friction_coefficients_are_drawn_after_the_other_parts(arm, model):
    """With the friction tolerance 0 the builds are those the model gives without friction from
    the same draws less their last row: the guide's draw comes last, so the other parts draw
    what they drew before friction was drawn; at ± 30 % they differ."""
    model, _ = model
    ev, sens = arm.evaluation, arm.band.sensitivity
    exact = replace(ev.problem, tolerances=(("friction", 0.0),), builds=(("count", 2000),))
    drawn = B.simulate_builds(_posed(ev, exact), sens)
    D = np.concatenate(list(sens.directions.values()), axis=1)
    xi = B.draws(0, 2000, D.shape[1] + 1, "uniform")
    frictionless = replace(model, friction=None)
    np.testing.assert_allclose(drawn.before, B.largest_errors(frictionless, D @ xi[:-1]), rtol=1e-12)
    rubbing = B.simulate_builds(_posed(ev, replace(exact, tolerances=())), sens)
    assert rubbing.sources[-1]["tolerance"] == "friction" and drawn.sources[-1]["tolerance"] != "friction"
    np.testing.assert_allclose(rubbing.before, B.largest_errors(model, B.with_friction(D, model.friction, 0.3) @ xi),
                               rtol=1e-12)
    assert not np.allclose(rubbing.before, drawn.before, rtol=1e-6)


def test_draws_are_reproducible_from_their_seed_and_as_declared():
    uniform = B.draws(7, 200_000, 2, "uniform")
    np.testing.assert_array_equal(uniform, B.draws(7, 200_000, 2, "uniform"))
    assert not np.array_equal(uniform, B.draws(8, 200_000, 2, "uniform"))
    assert np.abs(uniform).max() <= 1 and np.var(uniform) == pytest.approx(1 / 3, rel=0.01)
    normal = B.draws(7, 200_000, 2, "normal")
    assert np.abs(normal).max() <= 1  # cut at ±3σ
    cut = 1 - 2 * norm.cdf(-3)  # the share kept
    assert np.std(normal) == pytest.approx(np.sqrt(1 - 6 * norm.pdf(3) / cut) / 3, rel=0.005)  # σ of the cut normal
    assert np.mean(np.abs(normal) > 2 / 3) == pytest.approx(2 * (norm.cdf(-2) - norm.cdf(-3)) / cut, abs=0.002)


def test_box_least_squares_is_scipys_bounded_least_squares():
    rng = np.random.default_rng(3)
    K, r = rng.normal(size=(40, 30, 3)), rng.normal(size=(40, 30))
    low, high = -rng.uniform(0.01, 0.3, (40, 3)), rng.uniform(0.01, 0.3, (40, 3))
    d = B.box_least_squares(np.einsum("bra,brc->bac", K, K), np.einsum("bra,br->ba", K, r), low, high)
    expected = np.array([lsq_linear(K[b], -r[b], bounds=(low[b], high[b]), tol=1e-14).x for b in range(40)])
    np.testing.assert_allclose(d, expected, atol=1e-9)
    assert np.any(np.isclose(d, low) | np.isclose(d, high))  # bounds bind for some


def test_the_best_settings_minimise_the_error_within_their_ranges(arm, model):
    """Each build's best settings against a dense scan of the screw and slot: none is lower."""
    model, chosen = model
    step = np.zeros((model.J.shape[1], 2))
    k = arm.band.sensitivity.layout.start["k"]
    step[k] = [100.0, -100.0]  # ± the rate's tolerance
    best = B.best_settings(model, step, chosen)

    def cost(step, a):
        return ((model.weights[:, None] * model.error(B.with_settings(step, chosen, a))) ** 2).sum(axis=0)
    grid = np.vstack([g.ravel() for g in np.meshgrid(*[np.linspace(-s.bound, s.bound, 161) for s in chosen])])
    for b in range(2):
        scanned = cost(np.repeat(step[:, [b]], grid.shape[1], axis=1), grid)
        assert cost(step[:, [b]], best[:, [b]])[0] <= scanned.min() * (1 + 1e-9)


def test_holding_still_nulls_the_error_at_the_stated_pose(arm, model):
    model, chosen = model
    builds = arm.builds
    pose = int(np.flatnonzero(np.isclose(arm.evaluation.theta[0, B.kept_points(arm.evaluation.grid, 1)],
                                         builds.pose[0]))[0])
    sens = arm.band.sensitivity
    D = np.concatenate(list(sens.directions.values()), axis=1)
    step = D @ B.draws(0, 50, D.shape[1], "uniform")
    a = B.as_set(model, step, chosen, builds.table, B.rates_of(step, sens.layout, 1), pose)
    error = model.error(B.with_settings(step, chosen, a))
    assert np.abs(error[pose]).max() < 1e-12
    assert np.abs(error).max() > 1e-3  # but not elsewhere


def test_the_tutorial_meets_two_percent_after_one_adjustment(arm):
    """Issue 52's goal: P95 of the largest torque error ≤ 2 % of the target's peak after the
    adjustment (10 000 builds, each part uniform within its tolerance); as built it is about
    the rate's tolerance, 10 %. Its guide's friction band, the target mid-band, is
    2 tanh(μβ) = 16.7 % of the torque wide at every angle (docs/tutorial.md), and the summary
    says so beside the P95 before and after adjusting."""
    builds, peak = arm.builds, np.abs(arm.evaluation.tau_d).max()
    before, best, set_ = (builds.percentiles(stage)[1, 0] / peak for stage in ("before", "best", "set"))
    assert 0.09 < before < 0.10
    assert set_ <= 0.02 and best <= 0.02
    assert builds.at_end == {"best": 0.0, "set": 0.0}
    assert not builds.limits
    band = arm.friction
    L = GUIDE["mu"] * np.radians(GUIDE["wrap_deg"])
    np.testing.assert_allclose(band.width, 2 * np.tanh(L) * band.centre, rtol=1e-9)
    np.testing.assert_allclose(band.centre, arm.evaluation.tau, rtol=1e-12)
    width = arm.to_dict()["friction_band"]["joints"][0]
    assert width["width_max_share"] == pytest.approx(2 * np.tanh(L), rel=1e-3) and width["outside_max"] == 0
    summary = arm.summary()
    assert f"friction band τ⁺ − τ⁻ (holds any payload still, its centre tracked) at its widest per joint: arm " \
           f"{1e3 * band.width.max():.4g} N·mm ({100 * width['width_max_share']:.3g} % of the target's peak), target " \
           "inside" in summary
    assert f"({100 * builds.percentiles('set')[0, 0] / peak:.2g} / {100 * set_:.2g} % of the target's peak)" in summary


def test_a_table_row_set_on_a_build_evaluated_exactly_brings_it_back(arm, model):
    """The stiffest spring in tolerance (1100 N/m), set as adjustment.csv says and evaluated
    exactly: within 1.5 % of the target's peak (as built: 10 %), as the model says."""
    header, rows = B.table_rows(arm.builds)
    assert header == ["mass_kg", "rate1_N_per_m", "slot1_mm", "screw1_mm"]
    row = rows[B.TABLE_ROWS - 1]
    assert row[:2] == [0.5, pytest.approx(1100.0)]
    sens = arm.band.sensitivity
    step = np.zeros(sens.layout.size)
    step[sens.layout.start["k"]] = 100.0
    peak = np.abs(arm.evaluation.tau_d).max()
    assert np.abs(_exact(arm, step)).max() > 0.09 * peak
    slot, screw = arm.builds.chosen[1], arm.builds.chosen[0]
    step[slot.index] = row[2] * 1e-3 * slot.per_metre
    step[screw.index] = row[3] * 1e-3
    exact = _exact(arm, step)
    assert np.abs(exact).max() < 0.015 * peak
    np.testing.assert_allclose(exact, model[0].error(step[:, None])[:, 0], atol=1e-3 * peak)


def test_every_payload_is_met_within_five_percent_and_its_row_is_a_best_setting(arm):
    """0.3–0.8 kg on the tutorial's arm, the screw and the slot set per mass: every mass
    within 5 % RMS of its target (the goal of issue 52), each setting re-evaluated exactly
    giving its reported error, and no nearby slot setting better."""
    payloads = arm.builds.payloads
    assert [p["mass"] for p in payloads] == pytest.approx([0.3, 0.4, 0.5, 0.6, 0.7, 0.8])
    assert all(p["relative_rmse"] <= 0.05 and not p["violations"] for p in payloads)
    assert payloads[2]["relative_rmse"] < 1e-5  # the design's own mass needs no setting
    ev, sens = arm.evaluation, arm.band.sensitivity
    light = payloads[0]
    a = np.array([light["settings"][s.name] for s in arm.builds.chosen])
    rmse = []
    for nudge in (0.0, 0.01, -0.01):
        at = B.payload_evaluation(B.with_mass(ev.problem, 0, 0.3), ev, sens.layout, arm.builds.chosen,
                                   a + [0.0, nudge])
        rmse.append(at.metrics.rmse[0])
    assert rmse[0] == pytest.approx(light["rmse"], rel=1e-9)
    assert rmse[0] < min(rmse[1:])


def test_the_ranges_are_limits_of_the_design(arm):
    """A screw whose travel slackens the spring and stretches it beyond its travel, and a slot
    that turns the spring end back beyond the cable wound at the range's start, are told."""
    problem = replace(arm.problem, adjustments=(("preload_travel", 0.02), ("slot", "chi0"), ("slot_travel", 0.2)),
                      builds=(("count", 10),))
    builds = B.simulate_builds(_posed(arm.evaluation, problem), arm.band.sensitivity)
    assert any("spring 1 goes slack" in v for v in builds.limits)
    assert any("beyond its 60 mm" in v for v in builds.limits)
    assert any(v.startswith("slot 1 at -200 mm: cable on the wrong departure branch") for v in builds.limits)


def test_builds_are_in_result_json_the_summary_and_the_adjustment_table(arm, tmp_path):
    out = arm.to_dict()["builds"]
    assert out["count"] == 10_000 and out["seed"] == 0 and out["distribution"] == "uniform"
    assert {s["what"] for s in out["sources"]} == {"spring 1's rate", "spring 1's pre-extension", "pulley's ell",
                                                   "pulley's chi0", "cam 1's offset",
                                                   "spring 1's guide on cable:1: its mu"}  # its preload is 0
    assert out["sources"][-1]["tolerance"] == "friction" and out["sources"][-1]["plus_minus"] == 0.3
    assert out["joints"][0]["set"]["p95"] == pytest.approx(arm.builds.percentiles("set")[1, 0])
    summary = arm.summary()
    assert "builds: 10000 (seed 0, each part uniform within ± its tolerance; a friction coefficient among them)" \
        in summary
    assert f"as {ADJUSTMENT_FILE} says; then the screw until the arm holds still at" in summary
    assert ADJUSTMENT_FILE in run_file_names(arm.problem, False, None)
    arm.save(tmp_path, workshop=None, figures=False)
    with open(tmp_path / ADJUSTMENT_FILE, newline="") as f:
        rows = list(csv.reader(f))
    assert rows[0] == B.table_rows(arm.builds)[0]
    assert len(rows) == 1 + B.TABLE_ROWS + B.MASS_ROWS


def test_the_design_page_shows_the_friction_band_and_the_builds_before_and_after_adjusting(arm):
    """The page's details (made in the worker, as the page makes them) hold the summary's friction
    band and its builds' P95 as built, as set by the table and at best, beside the design's error;
    the live view's frame carries the friction band's edges."""
    pytest.importorskip("panel", reason="Panel is the app extra's (make test installs it)")
    from cadcam.app.page import DesignPage
    from cadcam.app.state import Outcome

    frame, details = DesignPage._drawn(Outcome(result=arm, seconds=1.0), 0, set())
    summary = arm.summary().splitlines()
    builds = next(line for line in summary if line.lstrip().startswith("builds:"))
    adjusted = next(line for line in summary if line.lstrip().startswith("adjusted ("))
    rubbing = arm.friction.summary_line([j.name for j in arm.problem.joints])
    for line in (builds, adjusted, rubbing):
        assert line in details.splitlines()
    assert "P50 / P95" in builds and "; at best " in adjusted
    assert frame.friction is True


def test_the_same_seed_gives_the_same_numbers_and_count_zero_none(arm):
    """Without an adjustment the model keeps the rates' products alone (those of the
    pre-extensions' and preloads' tolerances with the geometry are below 1e-4 of the peak)."""
    ev, peak = arm.evaluation, np.abs(arm.evaluation.tau_d).max()
    plain = _posed(ev, replace(ev.problem, adjustments=()))
    again = B.simulate_builds(plain, arm.band.sensitivity)
    np.testing.assert_array_equal(again.before, B.simulate_builds(plain, arm.band.sensitivity).before)
    np.testing.assert_allclose(again.before, arm.builds.before, atol=1e-4 * peak)
    assert again.best is None and "adjustment" not in again.to_dict()
    other = B.simulate_builds(_posed(ev, replace(ev.problem, adjustments=(), builds=(("seed", 1),))),
                              arm.band.sensitivity)
    assert not np.array_equal(other.before, again.before)
    assert B.simulate_builds(_posed(ev, replace(ev.problem, builds=(("count", 0),))), arm.band.sensitivity) is None


@pytest.mark.parametrize("change,message", [
    ({"adjustment": {"slot": "phi"}}, "adjustment.slot = 'phi': expected a parameter the problem's mechanisms place "
                                      "and can move, one of 'ell', 'chi0'"),
    ({"adjustment": {"slot_travel": 0.01}}, "adjustment.slot_travel = 0.01: expected 0 without a slot"),
    ({"builds": {"distribution": "gauss"}}, "builds.distribution = 'gauss': expected"),
    ({"mass_range": [0.6, 0.8]}, r"target.mass_range = \[0.6, 0.8\]: expected a range holding mass = 0.5"),
])
def test_a_wrong_builds_or_adjustment_key_is_one_line_naming_it(change, message):
    data = tutorial()
    if "mass_range" in change:
        data["joints"][0]["target"]["mass_range"] = change["mass_range"]
    else:
        data.update(change)
    with pytest.raises(SpecError, match=message) as err:
        parse_spec(data, str(TUTORIAL))
    assert "\n" not in str(err.value)
