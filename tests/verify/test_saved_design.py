"""A saved design re-evaluates to the run that made it: result.json keeps the poses the design
was checked at (design.poses), and the rootfinder starts there."""
import json

import numpy as np
import pytest

import cadcam
from cadcam.designs import Design, DesignError
from cadcam.optimize import optimize

from ..conftest import ROOT

#: The five-bar arm's design: too slow for make test's five minutes (make test-slow).
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def five_bar(tmp_path_factory):
    """Endo2010's five-bar arm designed and saved: re-evaluated from the closed-form guess
    alone, its second pulley's departure lands on other roots (α < 0 and α ≈ 1.39 rad against
    the run's α ≤ 0.46 rad: a torque error of 8.6e4 N·m on the design grid)."""
    result = optimize(cadcam.load_problem(ROOT / "models" / "endo2010_five_bar.toml"))
    out = tmp_path_factory.mktemp("five_bar")
    result.save(out, workshop=None, figures=False)
    return result, out / "result.json"


def _same(again, run):
    """The re-evaluation ``again`` has the run's poses, torques and metrics."""
    for u, v in zip(again.units, run.units):
        np.testing.assert_allclose(u.z, v.z, rtol=0, atol=1e-9)
    scale = np.abs(run.tau).max()
    assert np.abs(again.tau - run.tau).max() <= 1e-9 * scale
    assert again.violations == run.violations
    np.testing.assert_allclose(again.metrics.max_abs_error, run.metrics.max_abs_error, rtol=1e-6)


def test_a_saved_design_re_evaluates_to_the_run(five_bar):
    result, path = five_bar
    assert result.success, result.message
    _same(cadcam.evaluate(path, path), result.evaluation)
    problem = result.problem
    _same(cadcam.evaluate(path, path, grid=problem.options.recheck_grid), result.recheck)


def test_malformed_poses_get_one_line_errors(five_bar):
    result, path = five_bar
    data = json.loads(path.read_text())
    problem = cadcam.load_problem(path)
    poses = data["design"]["poses"]
    for bad, words in [(poses[:1], "one entry per mechanism"),
                       ([poses[0], {**poses[1], "theta": poses[1]["theta"][::-1]}], "must increase"),
                       ([poses[0], {**poses[1], "z": [row[:-1] for row in poses[1]["z"]]}], "as many as theta")]:
        with pytest.raises(DesignError) as err:
            Design.from_dict({**data["design"], "poses": bad}, problem, "result.json")
        assert words in str(err.value) and "\n" not in str(err.value)
