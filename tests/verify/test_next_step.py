"""A design that fails its re-check says what to change and by how much: the check points or
the design grid that would have seen the stretch the fine re-check found broken between the
NLP's samples (cadcam.verify.remedy.next_step), computed from that stretch."""
import contextlib
import io
import json
import re
import types

import numpy as np
import pytest

from cadcam import Design
from cadcam.cli import main
from cadcam.physics.profile import Basis, profile_function
from cadcam.verify.evaluate import LENGTH_TOL, evaluate
from cadcam.verify.remedy import PER_STRETCH, next_step

from ..conftest import SPEC_1DOF, circle_design

#: Hand-made profiles broken over a stretch strictly inside their wrap (tests/verify/
#: test_verdict_detectors.py): 20 mm + 11 mm·(φ − 0.75)², not convex for |φ − 0.75| ≲ 0.18;
#: 9.5 mm + 2 mm·(φ − 1)², below ρ_min = 10 mm around φ = 1.
SHAPES = {"not convex": ([0.02 + 0.011 * 0.75**2, -2 * 0.011 * 0.75, 0.011], "profile not convex"),
          "below rho_min": ([0.0095 + 0.002, -0.004, 0.002], "radius below rho_min")}
#: Convexity check points so few that the broken stretch falls between them: the wrap's ends.
FEW = 2


def _broken(problem, m, phi):
    """Flags along ``phi`` [rad] where ρ = Σ m_k φ^k breaks convexity or ρ_min, by its own
    evaluation."""
    basis = Basis("monomial", len(m) - 1, problem.profiles[0].basis.domain)
    rho, _, _, conv = (np.asarray(v).ravel() for v in profile_function(basis).map(phi.size)(phi, np.array(m)))
    return (conv < 0) | (rho < problem.profiles[0].rho_min - LENGTH_TOL)


@pytest.mark.parametrize("shape", SHAPES)
def test_a_shape_broken_between_check_points_asks_for_the_points_that_see_it(problem_1dof, shape):
    m, words = SHAPES[shape]
    problem = problem_1dof.with_options(grid=3, convexity_points=FEW)
    basis = Basis("monomial", len(m) - 1, problem.profiles[0].basis.domain)
    ev = evaluate(problem, Design([basis], [np.array(m)], np.array([0.005, 0.01])))
    step = next_step(ev)
    points = int(re.match(r"--set solver\.convexity_points=(\d+): ", step)[1])
    assert f"{words}: 'cam' over " in step and "\n" not in step
    span = ev.profiles[0].phi[-1]  # the wrapped range the NLP's check points spread over
    dense = np.linspace(0.0, span, 200_001)
    bad = dense[_broken(problem, m, dense)]
    lo, hi = bad.min(), bad.max()
    assert hi < span and lo > 0  # premise: a stretch inside the wrap
    assert not np.any(_broken(problem, m, np.linspace(0.0, span, FEW)))  # premise: the NLP's points miss it
    asked = np.linspace(0.0, span, points)
    assert np.count_nonzero((asked >= lo) & (asked <= hi)) >= PER_STRETCH
    assert points <= 4 * PER_STRETCH * span / (hi - lo)  # not more than the stretch asks for


def test_the_step_asks_for_more_than_a_solve_was_given_and_says_where_the_cap_stops_it(problem_1dof, monkeypatch):
    m, _ = SHAPES["not convex"]
    problem = problem_1dof.with_options(grid=3, convexity_points=FEW)
    basis = Basis("monomial", len(m) - 1, problem.profiles[0].basis.domain)
    ev = evaluate(problem, Design([basis], [np.array(m)], np.array([0.005, 0.01])))
    assert next_step(ev, tried=400).startswith("--set solver.convexity_points=800: ")
    monkeypatch.setenv("CADCAM_CAP_CONVEXITY_POINTS", "500")
    step = next_step(ev, tried=400)
    assert step.startswith("a lower order for 'cam', or a cap above 800 (CADCAM_CAP_CONVEXITY_POINTS)")
    assert "beyond the cap 500" in step and "--set" not in step


def test_a_design_method_that_is_not_the_nlp_is_told_to_use_it():
    fine = types.SimpleNamespace(problem=types.SimpleNamespace(options=types.SimpleNamespace(method="moment_arm")))
    assert next_step(fine).startswith("--set solver.method=nlp: the moment_arm design is re-checked as it is made, ")


def test_nothing_broken_asks_nothing(problem_1dof):
    ev = evaluate(problem_1dof, circle_design(problem_1dof, 0.02, [0.005, 0.02]))
    assert ev.violations == [] and next_step(ev) is None


def test_a_spring_just_beyond_its_travel_may_keep_a_larger_reserve_instead(problem_1dof):
    """A circle wound from a pre-extension that takes spring 1 1 mm beyond its travel: besides a
    finer grid, a limit margin whose reserve, beyond the one kept now, holds twice that."""
    spring = problem_1dof.springs[0]
    sweep = 0.02 * np.ptp(problem_1dof.joints[0].theta_range)  # the circle winds ρ·Δθ of cable
    ev = evaluate(problem_1dof, circle_design(problem_1dof, 0.02, [spring.travel + 1e-3 - sweep, 0.01]))
    overshoot = -ev.metrics.margins["travel"][0]
    assert overshoot == pytest.approx(1e-3, rel=0.05)  # premise
    step = next_step(ev)
    assert step.startswith("--grid ") and "spring above its travel: spring 1" in step
    margin = float(re.search(r"; or --set solver\.limit_margin=([0-9.e-]+): a reserve of 2× the overshoot", step)[1])
    kept = problem_1dof.options.limit_margin
    assert PER_STRETCH * overshoot <= (margin - kept) * spring.travel <= 1.1 * PER_STRETCH * overshoot


def _column(path, name):
    lines = path.read_text().splitlines()
    k = lines[0].split(",").index(name)
    return np.array([float(line.split(",")[k]) for line in lines[1:]])


def test_a_spring_compressed_between_grid_angles_fails_with_the_grid_that_sees_it(tmp_path):
    """On a design grid of 3 angles with spring 2's pre-extension fixed at 0, the converged
    design's spring 2 is compressed between grid angles (tests/verify/test_verdict_detectors.py):
    the message ends with the grid whose angles fall inside the compressed stretch the re-check
    found, where the 3 angles had none."""
    out = tmp_path / "o"
    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(io.StringIO()):
        code = main(["design", str(SPEC_1DOF), "-o", str(out), "--no-figures", "--grid", "3",
                     "--set", "springs.2.preextension=0.0"])
    assert code == 1
    first = stdout.getvalue().splitlines()[0]
    written = json.loads((out / "result.json").read_text())
    assert first == f"recheck_failed: {written['message']}"
    grid = int(re.search(r"; next: --grid (\d+) \(or --set solver\.grid=\1\): spring in compression: spring 2", first)[1])
    theta, x2 = _column(out / "torque_recheck.csv", "theta1_rad"), _column(out / "torque_recheck.csv", "x2_m")
    compressed = theta[x2 < -LENGTH_TOL]
    assert compressed.size >= 2  # premise: a stretch, seen on the fine grid
    assert np.all(_column(out / "torque.csv", "x2_m") >= -LENGTH_TOL)  # premise: the 3 angles miss it
    asked = np.linspace(theta[0], theta[-1], grid)
    assert np.any((asked >= compressed.min()) & (asked <= compressed.max()))
