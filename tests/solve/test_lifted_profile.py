"""Convexity, ρ-bound and curvature rows written on lifted ρ, ρ′, ρ″ at the check points (issue 30,
item 1): the same optima as the rows written directly on the coefficients; and at fixed check
angles, over a range set from the start."""
import pytest

from cadcam import load_spec
from cadcam.optimize import optimize, start_design
from cadcam.solve import rows
from cadcam.solve.builds import forget_builds
from cadcam.solve.transcription import Transcription
from cadcam.verify.evaluate import start_samples

from ..conftest import SPEC_1DOF


def test_lifted_profile_rows_and_the_dense_rows_share_their_optima(monkeypatch):
    """The two writings of the rows are one NLP: each one's optimum, taken as the other's start,
    is the other's optimum (same objective and ρ). From the circle the two may reach different
    local optima of the 1-DOF cam: their iterates differ. On a grid of 12 angles: the lifted
    rows are at the check points, whatever the grid, and the cam meets ρ_min there too."""
    problem = load_spec(SPEC_1DOF).with_options(grid=12)
    dense_tr = Transcription(problem)
    dense = optimize(problem, transcription=dense_tr)
    monkeypatch.setattr(rows, "LIFTED_PROFILE_SIZE", 0)  # lift every profile
    lifted_tr = Transcription(problem)
    M = problem.options.convexity_points
    assert all(lifted_tr.v.blocks[name][1] == M for name in ("rho0", "drho0", "ddrho0"))
    lifted = optimize(problem, transcription=lifted_tr)
    for optimum, other in ((dense, lifted_tr), (lifted, dense_tr)):
        again = optimize(problem, transcription=other, start=optimum.design)
        assert optimum.status == again.status == "success"
        assert again.solve.objective == pytest.approx(optimum.solve.objective, rel=1e-6)
        assert again.recheck.metrics.rho_min == pytest.approx(optimum.recheck.metrics.rho_min, rel=1e-5)


@pytest.fixture
def fresh_builds():
    """No NLP kept from before or after: a test that changes how NLPs are built must not hand
    its builds to other tests (the banded solve builds its plain NLP through the kept ones)."""
    forget_builds()
    yield
    forget_builds()


def test_a_fixed_check_range_runs_a_grid_step_past_the_starts_wrap(monkeypatch, fresh_builds):
    """A profile checked at fixed angles (the cable robot's degree-30 pulleys are; here the
    1-DOF cam): the range's end is the start's most-wound departure plus one grid step of its
    wrap, and the optimum's wrap stays inside it on the fine re-check (to 1 µrad: IPOPT's
    tolerance on the row)."""
    monkeypatch.setattr(rows, "FIXED_RANGE_SIZE", 0)
    problem, start = start_design(load_spec(SPEC_1DOF))
    tr = Transcription(problem)
    samples = start_samples(problem, start, tr.n, tr.start_order())
    _, pv = tr.start_point(problem, start, samples)
    alpha = samples[0].z[0]  # the cam's contact angle on the grid: it winds on as θ grows
    end = tr.p.part(pv, "wc0")[0]
    assert end == pytest.approx(alpha[-1] + (alpha[-1] - alpha[0]) / (tr.n - 1), rel=1e-12)
    result = optimize(problem, transcription=tr)
    assert result.status == "success"
    # (here the row binds: the cam's optimum would wrap further than its circular start)
    assert 0.9 * end < result.recheck.metrics.alpha_max[0] <= end + 1e-6
