"""A provisional design's profiles are scanned coarser (:data:`cadcam.verify.evaluate.MOVING_SCAN`)
than every other evaluation's, to the same extremes."""
import numpy as np
import pytest

import cadcam
from cadcam.verify.evaluate import FULL_SCAN, MOVING_SCAN, SCAN

from ..conftest import SPEC_1DOF

#: The design grid of these designs [angles]: small, so that the scans' own sizes count.
GRID = 12


@pytest.fixture(scope="module")
def designs():
    """A design session's 1-DOF design, then a provisional one after a 1 % step of spring 1's
    rate."""
    session = cadcam.Session()
    first = session.design(SPEC_1DOF, grid=GRID)
    edit = {"springs.1.rate": 1.01 * cadcam.load_spec(SPEC_1DOF).springs[0].rate}
    return first, session.design(SPEC_1DOF, grid=GRID, overrides=edit, recheck=False)


def test_a_provisional_design_is_scanned_coarser_and_the_context_restored(designs):
    first, moving = designs
    assert first.success and moving.success and moving.provisional
    assert [p.phi.size for p in first.evaluation.profiles] == [max(20 * GRID, FULL_SCAN.points)]
    assert [p.phi.size for p in moving.evaluation.profiles] == [max(20 * GRID, MOVING_SCAN.points)]
    assert MOVING_SCAN.points < FULL_SCAN.points and MOVING_SCAN.levels < FULL_SCAN.levels
    assert SCAN.get() is FULL_SCAN


def test_the_coarse_scan_finds_the_full_scans_extremes(designs):
    """The provisional design evaluated again with the full scan: the same least and largest ρ
    and least convexity margin (refined minima), to 1e-9."""
    _, moving = designs
    full = cadcam.evaluate(moving.problem, moving.design)
    for name in ("rho_min", "rho_max", "convexity_min"):
        np.testing.assert_allclose(getattr(moving.evaluation.metrics, name), getattr(full.metrics, name), rtol=1e-9)
