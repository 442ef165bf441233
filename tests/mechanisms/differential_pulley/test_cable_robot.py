"""Fedorov2018's one-motor cable robot (Sec. 4.1): the pick-and-place path, the two-cable
kinematics, the idler law through the amplification stage, a helical groove's multi-turn wrap,
the spec's errors and the envelope design by the command line. (The envelope pulleys' and the
NLP design's end-effector paths and grooves are test_cable_robot_nlp.py, a module of its own:
its design takes over a minute, and a module of its own can run beside these on another
worker.)"""
import json
from dataclasses import replace
from importlib.resources import files

import numpy as np
import pytest
from jsonschema import Draft202012Validator

from cadcam.mechanisms.base import Profile, departure_solver
from cadcam.mechanisms.differential_pulley.model import DifferentialPulley
from cadcam.optimize import start_design
from cadcam.mechanisms.differential_pulley.cable_robot import cable_length, end_effector, pick_and_place
from cadcam.physics.profile import Basis
from cadcam.spec import SpecError, load_spec, parse_spec, read_spec_data
from cadcam.mechanisms.differential_pulley.fedorov_envelope import cable_lengths as pair_cable_lengths
from cadcam.mechanisms.differential_pulley.output_laws import cable_robot_slider, robot_cable, slider_cable

ROBOT = "models/fedorov2018_cable_robot.toml"
PATH = dict(start=(0.125, 0.0), lift=0.5, span=0.75, lift_share=0.45, overlap=0.2)


@pytest.fixture(scope="module")
def robot():
    return load_spec(ROBOT)


def test_path_is_750_by_500_mm_up_across_down():
    tau = np.linspace(0, 1, 20001)
    x, y = pick_and_place(tau, **PATH)
    assert (x[0], y[0]) == pytest.approx((0.125, 0.0), abs=1e-15)
    assert (x[-1], y[-1]) == pytest.approx((0.875, 0.0), abs=1e-15)
    assert np.ptp(x) == pytest.approx(0.75, abs=1e-12) and np.ptp(y) == pytest.approx(0.5, abs=1e-12)
    rising, falling = tau < PATH["lift_share"] - PATH["overlap"], tau > 1 - PATH["lift_share"] + PATH["overlap"]
    assert np.all(x[rising] == 0.125) and np.all(x[falling] == 0.875)  # straight vertical moves
    assert np.all(np.diff(y[rising]) >= 0) and np.all(np.diff(y[falling]) <= 0)
    # smooth: the speed is continuous and starts and ends at rest
    speed = np.hypot(np.diff(x), np.diff(y)) / np.diff(tau)
    assert speed[0] < 1e-6 and speed[-1] < 1e-6
    assert np.abs(np.diff(speed)).max() < 1e-3 * speed.max()


def test_end_effector_inverts_the_cable_lengths():
    rng = np.random.default_rng(3)
    pts = rng.uniform((0.05, 0.0), (0.95, 0.9), size=(200, 2)).T
    a1, a2 = (0.0, 1.0), (1.0, 1.0)
    for first, second in ((a1, a2), (a2, a1)):  # either cable first
        x, y = end_effector(cable_length(*pts, first), cable_length(*pts, second), first, second)
        assert np.abs(x - pts[0]).max() < 1e-12 and np.abs(y - pts[1]).max() < 1e-12


def test_idler_law_amplifies_the_cable_six_to_one(robot):
    theta = np.linspace(*robot.joints[0].theta_range, 901)
    for mech in robot.mechanisms:
        d = mech.output_target.data
        x = np.asarray([float(cable_robot_slider(t, d)) for t in theta])
        ell = robot_cable(theta, d)
        assert slider_cable(x, d) == pytest.approx(ell, abs=1e-12)
        assert x.min() >= d["slider_at_shortest"] - 1e-15
        assert x.min() < d["slider_at_shortest"] + 1e-6  # the grid's best sample
        assert np.ptp(x) == pytest.approx(np.ptp(ell) / 6, rel=1e-12)
    # the paper: cables from 560 to 1330 mm, about 130 mm of idler travel
    ell = robot_cable(theta, robot.mechanisms[0].output_target.data)
    assert 0.54 < ell.min() < 0.57 and ell.max() == pytest.approx(1.33, abs=2e-3)


def test_helical_circles_wound_oppositely_keep_the_idler_still_over_two_and_a_half_turns():
    rng_ = (0.0, np.radians(900))
    basis = Basis("chebyshev", 4, DifferentialPulley.profile_domain(rng_))
    mech = DifferentialPulley(name="p", joint=0, profiles=(Profile("p 1", basis, 0.01, 0.09),
                                                           Profile("p 2", basis, 0.01, 0.09)),
                              idler_radius=0.01, slider_range=(0.1, 0.4), groove="helical")
    coefs = [basis.from_monomial([0.04, 0, 0, 0, 0])] * 2
    # anchors 0.1 rad before each departure point's least-wound pose
    chi0 = [0.1 + np.arccos((0.04 - 0.01) / 0.2) - s * (0 if s > 0 else rng_[1]) for s in mech.sigmas]
    mech = replace(mech, anchor_angles=tuple(-w * c for w, c in zip(mech.windings, chi0)))
    solver = departure_solver(mech.structure())
    alpha0 = solver.guess(0.0, np.concatenate(coefs), mech.parameter_values())[:2, 0]
    mech = replace(mech, cable_length=pair_cable_lengths(mech, coefs, 0.0, 0.2, alpha0)[0])
    z, res = solver.solve(np.linspace(*rng_, 91), np.concatenate(coefs), mech.parameter_values())
    assert res.max() < 1e-10
    assert np.ptp(z[2]) < 1e-12 and z[2, 0] == pytest.approx(0.2, abs=1e-12)
    assert z[:2].max() > 2 * np.pi + 5  # the departure points run more than two turns
    assert np.ptp(z[0]) == pytest.approx(np.radians(900), abs=1e-9)


@pytest.mark.parametrize("key,value,message", [
    ("lift_share", 0.6, "in (0, 0.5)"),
    ("overlap", 0.5, "below lift_share: a number in [0, 0.45)"),
    ("anchor", [0.0], "[x, y]"),
    ("amplification", -6.0, "ratio G"),
])
def test_malformed_cable_robot_specs_get_one_line_errors(key, value, message):
    data = read_spec_data(ROBOT)
    data["mechanisms"][0]["output_target"][key] = value
    with pytest.raises(SpecError) as err:
        parse_spec(data, ROBOT)
    assert message in str(err.value) and "\n" not in str(err.value)
    assert f"output_target.{key}" in str(err.value)


def test_a_torque_goal_without_springs_is_refused():
    data = read_spec_data(ROBOT)
    data["joints"][0]["target"] = {"kind": "pendulum", "mass": 0.1, "length": 0.1}
    data["joints"][0]["tracking_weight"] = 1.0
    with pytest.raises(SpecError, match="needs \\[\\[springs\\]\\]"):
        parse_spec(data, ROBOT)


def test_the_two_cables_must_follow_one_path():
    data = read_spec_data(ROBOT)
    data["mechanisms"][1]["output_target"]["span"] = 0.7
    with pytest.raises(SpecError, match="output_target.span: the cables of one cable robot follow one path"):
        parse_spec(data, ROBOT)


def test_envelope_method_is_only_for_differential_pairs_with_output_laws():
    data = read_spec_data("models/ludovico2021_pendulum.toml")
    data.setdefault("solver", {})["method"] = "envelope"
    with pytest.raises(SpecError, match="solver.method: 'envelope' designs differential pairs"):
        parse_spec(data, "x.toml")


@pytest.mark.slow  # the cable robot's envelope design with every file
def test_design_command_writes_the_envelope_design_and_groove_centre_lines(tmp_path, capsys):
    from cadcam.cli import main
    assert main(["design", ROBOT, "--variant", "envelope", "-o", str(tmp_path / "out"),
                 "--groove-pitch", "0.005"]) == 0
    printed = capsys.readouterr().out
    assert printed.startswith("success: envelope design")
    assert "cable robot: the end effector deviates" in printed
    groove = np.loadtxt(tmp_path / "out" / "cam1_groove.csv", delimiter=",", skiprows=1)
    turns = groove[-1, 0] / (2 * np.pi)
    assert turns > 2.4 and groove[-1, 4] == pytest.approx(5.0 * turns, rel=1e-12)  # z in mm
    assert np.hypot(groove[:, 2], groove[:, 3]) == pytest.approx(groove[:, 1], rel=1e-12)
    assert not (tmp_path / "out" / "springs.png").exists()
    result = json.loads((tmp_path / "out" / "result.json").read_text())
    assert result["status"] == "success" and result["solver"]["iterations"] == 0
    assert result["solver"]["name"] == "envelope"  # no NLP solver made it
    Draft202012Validator(json.loads((files("cadcam") / "result.schema.json").read_text())).validate(result)



@pytest.mark.slow  # seconds of designs: make test-slow
def test_least_squares_on_joints_without_a_torque_goal_builds():
    """The cable robot has no springs and no torque goal (only output laws): its least-squares
    objective had a tracking term of an empty torque and failed in CasADi (a dot product of
    shapes (1, 1) and (1, n)); a joint with no torque goal adds no tracking term."""
    import cadcam
    from cadcam.solve.transcription import Transcription

    problem = cadcam.load_problem(ROBOT, functions="mapped", overrides={
        "solver.objective": "least_squares", "solver.grid": 6, "solver.convexity_points": 10})
    assert not problem.springs and all(j.tracking_weight == 0 for j in problem.joints)
    completed, _ = start_design(problem)
    assert Transcription(completed).v.vector().shape[0] > 0


@pytest.mark.slow  # seconds of designs: make test-slow
def test_envelope_start_takes_the_cable_length_at_the_nearest_pose_newton_solves():
    """At order 20 the fitted right-hand pulleys leave Newton no tangency near its start at the
    reference pose: the cable length is taken at the nearest pose where it finds both, and the
    design is judged by its re-check (a status that says why), not refused as a bad spec."""
    from cadcam.mechanisms.differential_pulley.fedorov_envelope import cable_lengths, differential_envelopes, fit_pulley
    from cadcam.mechanisms.differential_pulley.starts import _law
    from cadcam.optimize import optimize

    problem = load_spec(ROBOT, variant="envelope", overrides=[("mechanisms.1.order", 20), ("mechanisms.2.order", 20),
                                                             ("solver.grid", 21)])
    mech = problem.mechanisms[1]
    theta = np.linspace(*problem.joints[mech.joint].theta_range, 2001)
    x, dx = _law(mech, theta)
    mech, envs = differential_envelopes(mech, theta, x, dx, mech.start_radius(mech.profiles[0]))
    fitted = [fit_pulley(p.basis, env) for p, env in zip(mech.profiles, envs)]
    lengths = cable_lengths(mech, fitted, theta, x, np.vstack([env.phi_polar for env in envs]))
    k = int(np.argmin(np.abs(theta - mech.reference_angle)))
    assert np.isnan(lengths[k]) and np.isfinite(lengths).mean() > 0.5
    result = optimize(problem)
    taken = result.problem.mechanisms[1].cable_length
    near = np.flatnonzero(np.isfinite(lengths))
    assert taken == lengths[near[np.argmin(np.abs(theta[near] - mech.reference_angle))]]
    assert result.status in ("success", "recheck_failed") and result.message.startswith("envelope design")
