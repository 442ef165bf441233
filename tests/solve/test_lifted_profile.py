"""Convexity, ρ-bound and curvature rows written on lifted ρ, ρ′, ρ″ at the check points (issue 30,
item 1): the same optimum as the rows written directly on the coefficients."""
import pytest

from cadcam import load_spec
from cadcam.optimize import optimize
from cadcam.solve import transcription
from cadcam.solve.transcription import Transcription

from ..conftest import SPEC_1DOF


def test_lifted_profile_rows_reach_the_dense_rows_optimum(monkeypatch):
    problem = load_spec(SPEC_1DOF)
    dense = optimize(problem)
    monkeypatch.setattr(transcription, "LIFTED_PROFILE_SIZE", 0)  # lift every profile
    tr = Transcription(problem)
    M = problem.options.convexity_points
    assert all(tr.v.blocks[name][1] == M for name in ("rho0", "drho0", "ddrho0"))
    lifted = optimize(problem, transcription=tr)
    assert dense.status == lifted.status == "success"
    assert lifted.solve.objective == pytest.approx(dense.solve.objective, rel=1e-6)
    assert lifted.recheck.metrics.rho_min == pytest.approx(dense.recheck.metrics.rho_min, rel=1e-5)
