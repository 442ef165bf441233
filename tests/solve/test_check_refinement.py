"""A design whose profile breaks its shape between the NLP's convexity check points is solved
again from its optimum with more of them (cadcam.optimize._refined)."""
import types
from pathlib import Path

import pytest

import cadcam
from cadcam.optimize import CHECK_REFINEMENT, _broken_between_checks

PENDULUM = Path(__file__).resolve().parents[2] / "models" / "ludovico2021_pendulum.toml"
#: IPOPT's default largest barrier parameter (its option ``mu_max``).
IPOPT_MU_MAX = 1e5


@pytest.mark.slow  # seconds of designs: make test-slow
def test_a_profile_bent_between_two_check_points_is_designed_again_with_more():
    """Ludovico2021's pendulum with convexity held at 2 points only, under IPOPT's own cap on
    its barrier parameter (not cadcam's, whose first optimum happens to be convex): the first
    optimum is not convex between them on the fine re-check; solved again from it with 4× the
    points, every constraint holds, and the result says so and keeps both solves among its
    trials."""
    result = cadcam.design(PENDULUM, overrides={"solver.convexity_points": 2}, ipopt={"mu_max": IPOPT_MU_MAX})
    assert result.success, result.recheck.violations
    assert result.problem.options.convexity_points == 2 * CHECK_REFINEMENT
    assert "broke its shape between them" in result.message
    assert len(result.solve.trials) == 2
    assert min(result.recheck.metrics.convexity_min) >= 0


def _fine(**broken):
    """A re-check whose margins are all met but ``broken`` (name → margin)."""
    margins = {key: [broken.get(key, 1.0)] for key in
               ("travel", "extension_lower", "convexity", "rho_min", "rho_max", "tangency", "branch",
                "preextension", "curvature_radius")}
    margins["mechanism"] = [{}]
    problem = types.SimpleNamespace(mechanisms=[types.SimpleNamespace(limits=())])
    return types.SimpleNamespace(problem=problem, metrics=types.SimpleNamespace(margins=margins))


def test_only_a_broken_shape_asks_for_more_check_points():
    """Convexity or curvature broken alone: more check points can mend it; a spring beyond its
    travel (with or without a broken shape), or nothing broken, is not the check points' doing."""
    assert _broken_between_checks(_fine(convexity=-1e-9))
    assert _broken_between_checks(_fine(convexity=-1e-9, curvature_radius=-1e-3))
    assert not _broken_between_checks(_fine(travel=-1e-3, convexity=-1e-9))
    assert not _broken_between_checks(_fine())
