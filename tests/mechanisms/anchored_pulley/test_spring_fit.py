"""A spring with a free length hangs from the anchored pulley's spring end along the free span:
it must fit there at every pose (a row of the NLP, and a check of the re-check), and the design
states where it is mounted and how long to cut the cable, which the written outline confirms."""
from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import numpy as np
import pytest

from cadcam.optimize import optimize
from cadcam.spec import parse_spec
from cadcam.verify.evaluate import evaluate
from cadcam.verify.file_model import read_dxf
from cadcam.mechanisms.anchored_pulley.file_model import anchored_path

ROOT = Path(__file__).resolve().parents[3]
TUTORIAL = tomllib.loads((ROOT / "docs" / "first_balancer.toml").read_text())
#: A free length [m] long enough that the tutorial's spring, hung 0.2 m from the joint, only
#: just fits where the arm leans furthest: the fit binds.
LONG = 0.17


def _tutorial(free_length: float | None) -> dict:
    data = copy.deepcopy(TUTORIAL)
    if free_length is not None:
        data["springs"][0]["free_length"] = free_length
    return data


@pytest.fixture(scope="module")
def bound(tmp_path_factory):
    """The tutorial with a long spring: its result and the folder its files are in."""
    result = optimize(parse_spec(_tutorial(LONG)))
    out = tmp_path_factory.mktemp("fit")
    result.save(out, figures=False)
    return result, out


def test_the_fit_binds_and_holds_on_the_fine_grid(bound):
    result, _ = bound
    assert result.status == "success"
    (row,) = result.installation
    limit = result.problem.options.limit_margin * LONG
    assert -1e-9 <= row["least_free_cable"] <= limit + 1e-6  # at its limit: the row is active


@pytest.mark.slow
def test_without_the_row_the_design_would_not_fit():
    free = optimize(parse_spec(_tutorial(None)))
    judged = evaluate(parse_spec(_tutorial(LONG)), free.design, grid=free.problem.options.recheck_grid)
    assert any(v.startswith("spring longer than its room: spring 1") for v in judged.violations)


def test_installation_ranges_follow_the_spring(bound):
    result, _ = bound
    (row,) = result.installation
    spring = result.problem.springs[0]
    x = result.recheck.x[0]
    assert row["extension"] == pytest.approx([x.min(), x.max()], abs=1e-12)
    assert row["force"] == pytest.approx([spring.preload + spring.rate * x.min(), spring.preload + spring.rate * x.max()])
    assert row["installed_length"] == pytest.approx([LONG + x.min(), LONG + x.max()])
    assert row["mount"] == pytest.approx([0.0, -0.2], abs=1e-12)


def test_the_cable_length_is_the_written_outline_path_less_the_spring(bound):
    """The path from the anchor round the written DXF to the spring end, less the spring's length
    at each re-check angle, is the cable length the design states (constant, as it must be)."""
    result, out = bound
    (row,) = result.installation
    recheck = np.genfromtxt(out / "torque_recheck.csv", delimiter=",", names=True)
    theta, x = recheck[recheck.dtype.names[0]], recheck[[n for n in recheck.dtype.names if n.startswith("x")][0]]
    centre_line = read_dxf(out / "cam1.dxf").centre_line(result.problem.workshop.cable_radius)
    path = anchored_path(centre_line, result.problem.mechanisms[0], theta)
    cable = path - LONG - x
    assert np.ptp(cable) < 2 * result.problem.workshop.tolerance
    assert np.abs(cable - row["cable_length"]).max() < 2 * result.problem.workshop.tolerance
    assert "cable_length" in result.to_dict()["spring_installation"][0]
    assert f"cable {1e3 * row['cable_length']:.1f} mm" in result.summary()


# -- the mount placed by the design within a region ------------------------------------------
#: A spring too long for the tutorial's spring end 0.2 m from the joint: hung there it would
#: reach past the pulley, so the design must move its mount further out.
TOO_LONG = 0.2


def _placed_spec(**region) -> dict:
    data = _tutorial(TOO_LONG)
    data["mechanisms"][0].update(region)
    return data


@pytest.fixture(scope="module")
def placed():
    return optimize(parse_spec(_placed_spec(mount_distance=[0.1, 0.35])))


@pytest.mark.slow
def test_the_mount_moves_out_until_the_spring_fits(placed):
    assert placed.status == "success", placed.message
    mech = placed.problem.mechanisms[0]
    (row,) = placed.installation
    assert 0.1 <= mech.ell <= 0.35 and mech.ell > 0.2 + 1e-3  # moved out, within its range
    assert mech.spring_end_x == pytest.approx(0.0, abs=1e-12)  # only its distance was free
    assert row["mount"] == pytest.approx([mech.spring_end_x, mech.spring_end_y])
    assert row["least_free_cable"] >= 0


@pytest.mark.slow
def test_the_placed_mount_is_the_spec_the_result_reads_back(placed):
    """result.json's problem holds the placed spring end: evaluated from it, the design gives
    the torque the result states."""
    again = parse_spec(placed.to_dict()["problem"])
    fine = evaluate(again, placed.design, grid=again.options.recheck_grid)
    assert np.abs(fine.tau - placed.recheck.tau).max() < 1e-9
    assert again.mechanisms[0].mount_distance == (0.1, 0.35)


@pytest.mark.parametrize("region, words", [
    ({"mount_distance": [0.25, 0.35]}, r"mount_distance = \[0\.25, 0\.35\]: expected .*own distance \(0\.2\)"),
    ({"mount_distance": [0.05, 0.35]}, r"least above rho_max = 0\.06 m"),
    ({"mount_angle": [0.0, 1.0]}, r"mount_angle = \[0\.0, 1\.0\]: expected .*own angle"),
    ({"mount_distance": [0.1]}, r"mount_distance"),
])
def test_a_region_that_does_not_hold_the_spring_end_is_refused(region, words):
    from cadcam.spec import SpecError
    with pytest.raises(SpecError, match=words):
        parse_spec(_placed_spec(**region))


@pytest.mark.parametrize("region, ell", [({}, 0.2), ({"mount_distance": [0.1, 0.35]}, 0.35)])
def test_the_mount_room_is_the_longest_line_at_each_arm(region, ell):
    """The room the spring screen gives a spring at moment arm h, against a brute-force longest
    line from a spring end at the spec's (or its region's largest) distance to a point within
    rho_max, the two on a line h from the joint: one a side of its foot, one the other."""
    mech = parse_spec(_placed_spec(**region)).mechanisms[0]
    r = mech.largest_arm("cable")
    assert r == 0.06 and mech.largest_arm("nope") is None and mech.mount_room("nope", [0.01]) is None
    arms = np.array([1e-4, 0.01, 0.03, 0.059])
    t = np.linspace(0.0, 1.0, 20_001)
    brute = [np.max(np.sqrt(ell**2 - h**2) + t * np.sqrt(r**2 - h**2)) for h in arms]
    np.testing.assert_allclose(mech.mount_room("cable", arms), brute, rtol=1e-12)
    assert np.all(np.diff(mech.mount_room("cable", np.linspace(0.0, r, 50))) < 0)  # falls as h grows
