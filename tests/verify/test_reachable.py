"""Targets no design can meet are told before any solve, and the bounds that tell them are
true lower bounds: a design solved anyway keeps at least that much error."""
import subprocess
import sys
from pathlib import Path

import pytest

import cadcam
from cadcam.optimize import optimize
from cadcam.spec import parse_spec, read_spec_data
from cadcam.verify import reachable

MODELS = Path(__file__).resolve().parents[2] / "models"
SPEC = MODELS / "endo2010_inverted.toml"


def _endo(accept=None, **changes):
    """Endo2010's inverted pendulum with ``changes`` to its spring and pulley (the spec's
    tables as dicts), and an acceptance that lets any design through if ``accept``."""
    data = read_spec_data(SPEC)
    data["springs"][0].update(changes.get("spring", {}))
    data["mechanisms"][0].update(changes.get("pulley", {}))
    if accept is not None:
        data["joints"][0]["acceptance"] = {"relative_rmse": accept}
    return parse_spec(data, str(SPEC))


@pytest.mark.parametrize("spec", sorted(MODELS.glob("*.toml")), ids=lambda p: p.stem)
def test_every_shipped_spec_is_reachable(spec):
    assert reachable.unreachable(cadcam.load_problem(spec)) is None


@pytest.mark.slow  # seconds of designs: make test-slow
def test_a_spring_too_weak_for_the_load_is_refused_and_its_bound_holds():
    weak = {"spring": {"rate": 250.0}}
    message = reachable.unreachable(_endo(**weak))
    assert message.startswith("joint 'arm': its target needs ") and "J of spring energy" in message
    assert "stiffer springs, more travel or more preload" in message and "\n" not in message
    # at grid 21 (the spec's is 46): the bound is of the problem solved, whatever its grid
    problem = _endo(accept=1.0, **weak).with_options(grid=21)
    rmse_bound, target_rms = reachable._energy_bound(problem, 0)[:2]
    assert rmse_bound > 0.05 * target_rms
    result = optimize(problem)
    assert result.solve.status == "converged" and not any("travel" in v for v in result.recheck.violations)
    assert result.recheck.metrics.rmse[0] >= rmse_bound  # within its travel, no design does better


@pytest.mark.slow  # seconds of designs: make test-slow
def test_a_cable_wound_the_wrong_way_is_refused_naming_the_keys_that_reverse_it():
    problem = _endo(pulley={"winding": "ccw"})
    message = reachable.unreachable(problem)
    assert "can only give it a negative torque" in message and "positive over 100 % of the range" in message
    assert "set the winding or sense of mechanism 'pulley' the other way" in message
    loose = _endo(accept=2.0, pulley={"winding": "ccw"})
    rmse_bound = reachable._sign_bound(loose, 0, reachable._CircularStart(loose))[0]
    result = optimize(loose)
    assert result.recheck.metrics.rmse[0] >= rmse_bound * (1 - 1e-9)


def test_cadcam_design_refuses_before_work_and_writes_nothing(tmp_path):
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, "-m", "cadcam", "design", str(SPEC), "--set", "springs.1.rate=100",
                          "-o", str(out)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.startswith("cadcam: error: endo2010_inverted: joint 'arm': its target needs")
    assert run.stderr.count("\n") == 1 and not out.exists()


def test_a_range_below_endo2010s_convexity_bound_is_noted_before_the_solve():
    """F0² ≤ 2k·m·g·l·(1 − cos θ0): with Endo's spring (k = 1150 N/m, F0 = 14.71 N) and arm
    (m g l = 2.4525 N·m), θ0 ≥ 15.9°; the spec's own 18° is above it, its variant 'low' (5°) below."""
    assert reachable.advice(cadcam.load_problem(SPEC)) == []
    (note,) = reachable.advice(cadcam.load_problem(SPEC, variant="low"))
    assert "starts at 5°, below Endo2010's convexity bound θ0 ≥ 15.9°" in note and "\n" not in note


def test_a_bore_with_no_room_inside_the_radius_limit_is_refused_before_solving(capsys, tmp_path):
    """The 1-DOF cam may reach 100 mm: a 0.2 m bore leaves its anchor no room, and cadcam design
    says so in one line, exit 2, before any solve and without writing anything."""
    from cadcam.cli import main
    out = tmp_path / "o"
    spec = MODELS / "johnston2023_1dof.toml"
    assert main(["design", str(spec), "-o", str(out), "--bore-diameter", "0.2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "rho_max = 0.1 m leaves no room" in err and "bore_diameter" in err
    assert not out.exists()
    assert reachable.unreachable(cadcam.load_problem(spec)) is None
