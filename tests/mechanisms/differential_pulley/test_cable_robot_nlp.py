"""Fedorov2018's one-motor cable robot (Sec. 4.1) designed: Fedorov's envelope pulleys and
cadcam's NLP started from them, each re-checked on the spec's fine grid, and the NLP design's
helical grooves as written. (The path, the kinematics, the idler law, the spec's errors and the
envelope design by the command line are tests/mechanisms/differential_pulley/test_cable_robot.py.)"""
import json

import numpy as np
import pytest

from cadcam.mechanisms.differential_pulley.robot_path import robot_path
from cadcam.optimize import start_design
from cadcam.spec import load_spec
from cadcam.verify.evaluate import evaluate

from .test_cable_robot import ROBOT

#: The cable robot designed by its NLP takes minutes on two cores: the slow lane.
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def robot():
    return load_spec(ROBOT)


@pytest.fixture(scope="module")
def envelope(robot):
    """Fedorov's envelope pulleys (the NLP's start): the completed problem, the design and its
    evaluation on the spec's fine re-check grid, the grid the NLP's design is re-checked on."""
    problem, design = start_design(robot)
    return problem, design, evaluate(problem, design, grid=robot.options.recheck_grid)


def test_envelope_pulleys_trace_the_path_within_a_millimetre(envelope):
    """Fedorov's envelope pulleys (the baseline) fitted at the spec's degree, re-checked by the
    rootfinder on the spec's fine grid (301 angles): convex, every limit met, and the end
    effector within 1 mm of its path."""
    _, design, ev = envelope
    assert ev.grid == 301
    assert ev.violations == []
    path = robot_path(ev)
    assert path.error.max() < 1e-3
    assert min(ev.metrics.alpha_max) > 4 * np.pi  # helical: more than two turns each
    # the path is symmetric about the frame's middle: the right cable's pulleys are the left's
    left, right = design.coefficients[:2], design.coefficients[2:]
    assert np.abs(left[0] - right[1]).max() < 1e-9 and np.abs(left[1] - right[0]).max() < 1e-9


@pytest.fixture(scope="module")
def nlp_result(robot):
    """The spec's design by cadcam's NLP (about 80 s)."""
    from cadcam.optimize import optimize
    assert robot.options.method == "nlp"
    return optimize(robot)


def test_the_nlp_from_the_envelope_traces_the_path_closer_than_the_envelope(nlp_result, envelope):
    """The spec's design: cadcam's NLP on both degree-30 pairs, started from Fedorov's envelope
    pulleys, converges and passes the fine re-check with the end effector nearer its path than
    the envelope pulleys put it on the same fine grid."""
    result = nlp_result
    assert result.status == "success" and result.solve.iterations > 0
    on_same_grid = envelope[2]
    assert on_same_grid.grid == result.recheck.grid
    nlp_error, envelope_error = robot_path(result.recheck).error.max(), robot_path(on_same_grid).error.max()
    assert nlp_error < envelope_error < 0.35e-3
    assert min(result.recheck.metrics.alpha_max) > 4 * np.pi


def test_the_nlp_designs_grooves_give_its_x(nlp_result, tmp_path):
    """The grooves' centre lines as written (each chord within the fit tolerance the design's
    accuracy asks for, at most GROOVE_ROWS rows), read back as open chains wound 2.5 turns: the
    idlers' x recomputed from them by plane geometry meets the design's within its requirement
    at every point of the fine grid, none unresolved."""
    from cadcam.make.workshop import GROOVE_ROWS
    from cadcam.outputs.run_files import write_workshop_files
    write_workshop_files(nlp_result, tmp_path, nlp_result.problem.workshop, sheets=False)
    report = json.loads((tmp_path / "verification.json").read_text())
    assert [c["quantity"] for c in report["checks"]] == ["x", "x"]
    for check in report["checks"]:
        assert check["passed"] and check["unresolved_points"] == 0, check
    assert report["passed"] and [cam["cam"] for cam in report["cams"]] == [1, 2, 3, 4]
    for cam in report["cams"]:
        rows = np.loadtxt(tmp_path / f"cam{cam['cam']}_groove.csv", delimiter=",", skiprows=1)
        assert cam["vertices"] == len(rows) <= GROOVE_ROWS
        assert not cam["closed"] and cam["convex"] and cam["units"] == "mm"
        assert cam["file_error_m"] <= cam["fit_tolerance_m"]
        assert "cable_clearance_m" not in cam  # the file holds no drum between the turns


def _grooves(result, tmp_path, grow=0.0, rows=slice(None)):
    """Each profile's groove (its spiral ``grow`` [m] larger, ``rows`` of it) written at the
    design's fit tolerance and read back."""
    from cadcam.make.workshop import helical_groove, write_groove_csv
    from cadcam.outputs.verification import fit_tolerance
    from cadcam.verify.file_model import read_groove
    tolerance, chains = fit_tolerance(result, result.problem.workshop.tolerance), {}
    for i, (b, c) in enumerate(zip(result.design.bases, result.design.coefficients)):
        grown = c + b.from_monomial(np.eye(b.size)[0] * grow)
        groove = helical_groove(b, grown, float(result.evaluation.profiles[i].alpha.max()), 0.004, tolerance)
        write_groove_csv(tmp_path / f"cam{i + 1}_groove.csv", groove[rows])
        chains[i] = read_groove(tmp_path / f"cam{i + 1}_groove.csv")
    return chains


def test_grooves_of_spirals_20_um_larger_fail_the_check(nlp_result, tmp_path):
    """Grooves of spirals 20 µm larger than designed hold more cable per turn: the idlers move in
    as the symbolic model says the larger pulleys move them (to 5 %), and the check fails by
    far."""
    from dataclasses import replace as replaced
    from cadcam.outputs.verification import recompute
    chains = _grooves(nlp_result, tmp_path, grow=2e-5)
    ev = nlp_result.evaluation
    grown = replaced(ev.design, coefficients=[c + b.from_monomial(np.eye(b.size)[0] * 2e-5)
                                              for b, c in zip(ev.design.bases, ev.design.coefficients)])
    larger = evaluate(nlp_result.problem, grown, grid=ev.grid)
    for u, mech in enumerate(nlp_result.problem.mechanisms):
        x = mech.output_from_file([chains[2 * u], chains[2 * u + 1]], ev.units[u].theta)
        by_model = larger.units[u].z[2] - ev.units[u].z[2]
        np.testing.assert_allclose(x - ev.units[u].z[2], by_model, rtol=0, atol=0.05 * np.abs(by_model).max())
    for check in recompute(nlp_result, chains):
        assert not check["passed"] and check["file_max_abs_error"] > 10 * check["required"]


def test_a_groove_ending_at_the_most_wound_departure_leaves_it_unresolved(nlp_result, tmp_path):
    """Without the step the groove runs past the range, its last chord turns half a step short of
    the cable's tangent at the most-wound pose: the cable would leave past the groove's end, so
    at each end of the range (where one pulley of each pair is most wound) x is not found."""
    from cadcam.outputs.verification import recompute
    for check in recompute(nlp_result, _grooves(nlp_result, tmp_path, rows=slice(None, -1))):
        assert check["unresolved_points"] == 2 and not check["passed"]
