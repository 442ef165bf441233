"""The tolerance band: its derivatives against finite differences of the re-check's own path,
its tolerances read from a spec, and its worst corner re-checked."""
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import cadcam
from cadcam.designs import Design
from cadcam.spec import SpecError, parse_spec, read_spec_data
from cadcam.verify.evaluate import evaluate
from cadcam.variation import Layout
from cadcam.verify.tolerance import _unknowns, tolerance_band
from cadcam.verify.model import parameter_model

MODELS = Path(__file__).resolve().parents[2] / "models"
SPEC = MODELS / "ludovico2021_pendulum.toml"  # an antagonistic pair of anchored pulleys
H = 1e-6  # relative step of the finite differences


@pytest.fixture(scope="module")
def pair(pendulum_result):
    assert pendulum_result.success
    return pendulum_result


def test_the_bands_model_gives_the_evaluations_torque_at_its_poses(pair):
    ev = pair.evaluation
    layout = Layout(ev.problem, ev.design)
    model = parameter_model(ev.problem, ev.design.bases).map(ev.theta.shape[1])
    tau, residual, _, _ = model(ev.theta, *layout.split(layout.nominal), _unknowns(ev))
    np.testing.assert_allclose(np.asarray(tau), ev.tau, rtol=1e-9, atol=1e-12)
    assert np.abs(np.asarray(residual)).max() < 1e-9


def test_the_rate_and_profile_parts_are_the_re_checks_finite_differences(pair):
    """Each part of the band is |∂τ/∂p| Δp; here ∂τ/∂p comes from evaluating perturbed
    designs by the re-check's own path (cadcam.verify.evaluate), not from the band's model."""
    ev, band = pair.evaluation, pair.band
    problem, design = ev.problem, ev.design
    rate = sum(np.abs(evaluate(problem.with_spring_rates(1 + H, [j]), design).tau - ev.tau) / H * 0.10
               for j in range(len(problem.springs)))
    np.testing.assert_allclose(band.parts["rate"], rate, rtol=1e-6)
    profile = 0
    for k, basis in enumerate(design.bases):
        grown = [c.copy() for c in design.coefficients]
        grown[k] += basis.from_monomial(np.eye(basis.size)[0] * H * 1e-3)  # ρ + 1 nm
        profile = profile + np.abs(evaluate(problem, Design(design.bases, grown, design.preextension)).tau
                                   - ev.tau) / (H * 1e-3) * 0.05e-3
    np.testing.assert_allclose(band.parts["profile"], profile, rtol=1e-6)


def test_the_worst_corner_re_checked_agrees_with_the_first_order_band(pair):
    corner = pair.band.corners[0]
    assert corner["residual"] < 1e-10  # the poses were re-solved at the corner
    assert corner["recomputed"] == pytest.approx(corner["predicted"], rel=0.1)
    assert corner["predicted"] == pytest.approx(pair.band.half_width[0].max())


def test_a_specs_tolerances_scale_their_parts_of_the_band(pair):
    data = read_spec_data(SPEC)
    data["tolerances"] = {"rate": 0.2, "profile": 0.0}
    problem = parse_spec(data, str(SPEC))
    assert problem.tolerance == {"rate": 0.2, "preload": 0.10, "placement": 0.5e-3, "profile": 0.0, "friction": 0.3}
    band = tolerance_band(replace(pair.evaluation, problem=problem))
    assert band.tolerance == {"rate": 0.2, "preload": 0.10, "placement": 0.5e-3, "profile": 0.0}  # no friction
    np.testing.assert_allclose(band.parts["rate"], 2 * pair.band.parts["rate"], rtol=1e-9)
    assert not band.parts["profile"].any()
    np.testing.assert_allclose(band.parts["placement"], pair.band.parts["placement"], rtol=1e-9)
    data["tolerances"] = {"rate": -0.1}
    with pytest.raises(SpecError, match=r"tolerances.rate.*a number ≥ 0 \[ratio\]"):
        parse_spec(data, str(SPEC))
    data["tolerances"] = {"rates": 0.1}
    with pytest.raises(SpecError, match="rates"):
        parse_spec(data, str(SPEC))


def test_the_band_is_in_result_json_the_summary_and_the_figure(pair, tmp_path):
    out = pair.to_dict()["tolerance_band"]
    assert out["tolerances"] == {"rate": 0.1, "preload": 0.1, "placement": 0.0005, "profile": 5e-05}
    assert out["joints"][0]["half_width_max"] == pytest.approx(pair.band.half_width[0].max())
    assert sum(out["joints"][0]["parts_at_max"].values()) == pytest.approx(out["joints"][0]["half_width_max"])
    assert "tolerance band (rate ± 10 %, preload ± 10 %, placement ± 0.5 mm, profile ± 0.05 mm)" in pair.summary()
    axes = pair.plot("torque").axes[0]
    assert any("built part" in t.get_text() for t in axes.get_legend().get_texts())


@pytest.mark.slow  # seconds of designs: make test-slow
def test_a_problem_without_springs_has_no_band():
    """The cable robot's envelope design (no springs), on a 21-angle grid: whether a band is
    given does not depend on the grid, and the spec's 61 angles re-check for 13 s."""
    problem = cadcam.load_problem(MODELS / "fedorov2018_cable_robot.toml", variant="envelope",
                                  overrides={"solver.grid": 21})
    assert not problem.springs
    result = replace(cadcam.design(problem), problem=problem)
    assert result.band is None and "tolerance_band" not in result.to_dict()


def test_the_worst_corners_newton_steps_never_throw_the_pose_away():
    """R(z) = atan(z) from z = 1.5: a full Newton step overshoots to a larger residual, and
    repeated it diverges (|z| grows each step past 1.39); each damped step lowers the residual
    and the steps reach the root."""
    from cadcam.verify.tolerance import CORNER_NEWTON_STEPS, _damped

    z = full = np.array([1.5])
    for _ in range(CORNER_NEWTON_STEPS):
        full = full - np.arctan(full) * (1 + full**2)
        step = np.arctan(z) * (1 + z**2)
        before = np.abs(np.arctan(z)).max()
        z = _damped(z, step, before, np.arctan)
        assert np.abs(np.arctan(z)).max() <= before
    assert abs(full[0]) > 1e3 and abs(z[0]) < 1e-12
