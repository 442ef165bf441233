"""The minimax design of anchored pulleys in the coefficients of their moment arms r_m(θ)
(cadcam/mechanisms/anchored_pulley/moment_arm.py; Ludovico2021 Sec. II–III) on the
Ludovico2021 specs: the torque it claims against the pulley its envelope builds, by geometry
alone, and its limits on a grid finer than its own."""
import dataclasses
import json
from importlib.resources import files
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from jsonschema import Draft202012Validator

import cadcam
from cadcam.api import load_problem
from cadcam.errors import SpecError
from cadcam.mechanisms.anchored_pulley.moment_arm import design_moment_arms, sample_moment_arms
from cadcam.mechanisms.anchored_pulley.starts import uniform_polar
from cadcam.physics.profile import fit_profile
from cadcam.targets import Target
from cadcam.verify.evaluate import evaluate

from .test_kim_deshpande import geometric_extension

MODELS = Path(__file__).resolve().parents[3] / "models"
#: issue 30's goal for Ludovico2021's generic torque (Eq. 39) [N·m]
GENERIC_GOAL = 5e-3


@pytest.fixture(scope="module")
def generic():
    problem = load_problem(MODELS / "ludovico2021_generic.toml")
    return problem, design_moment_arms(problem, degree=5)


@pytest.fixture(scope="module")
def pendulum():
    """The pendulum spec with order-12 profiles (for the fit below; the moment-arm design does
    not depend on the profiles' order) and its moment-arm design."""
    problem = load_problem(MODELS / "ludovico2021_pendulum.toml")
    problem = dataclasses.replace(problem, mechanisms=tuple(
        dataclasses.replace(m, profiles=tuple(dataclasses.replace(p, basis=dataclasses.replace(p.basis, order=12))
                                              for p in m.profiles)) for m in problem.mechanisms))
    return problem, design_moment_arms(problem, degree=5)


def test_generic_torque_reaches_the_goal_in_the_moment_arms(generic):
    """Ludovico2021 Eq. 39 with Table III's springs, the spec's limits and r_m of degree 5, as
    the paper's QCQP: the largest error on the re-check grid (451 angles) is within the goal
    (measured 1.28e-3 N·m; the spec's variant nlp, cadcam's profile NLP at order 5, stops at
    0.10 N·m)."""
    _, d = generic
    assert d.status == "Solve_Succeeded"
    print("largest torque error", d.max_abs_error, "N·m")
    assert d.max_abs_error <= GENERIC_GOAL


def test_generic_design_keeps_its_limits_between_its_grid_angles(generic):
    problem, d = generic
    fine = sample_moment_arms(problem, 0, d.basis, d.coefficients, np.linspace(*d.theta[[0, -1]], 4001))
    assert np.max(np.abs(fine.torque - fine.target)) <= GENERIC_GOAL
    for u, state, env in zip(fine.mechanisms, fine.states, fine.envelopes):
        mech, prof = problem.mechanisms[u], problem.profiles[u]
        spring = problem.springs[u]
        assert np.all(state.sigma * env.dnu > 0)  # Ludovico2021 Eq. 6
        assert env.radius_of_curvature.min() >= prof.min_curvature_radius
        assert state.r_m.min() >= mech.min_moment_arm
        assert env.span.min() >= mech.min_free_span
        assert prof.rho_min <= env.rho.min() and env.rho.max() <= prof.rho_max
        assert state.u.min() >= 0 and state.u.max() <= spring.travel


@pytest.mark.parametrize("spec", ["generic", "pendulum"])
def test_envelope_pulleys_give_the_designed_torque_by_geometry(spec, request):
    """Each pulley built from its envelope points (a polygon; cable length = arc to the
    departure vertex + free span) extends its spring as the design says, and the torque k·u·du/dθ
    of those geometric extensions is the design's: an independent check of du/dθ = σ r_m and
    τ = σ k u r_m (Ludovico2021 Eq. 1)."""
    problem, d = request.getfixturevalue(spec)
    fine = sample_moment_arms(problem, 0, d.basis, d.coefficients, np.linspace(*d.theta[[0, -1]], 4001))
    torque = np.zeros_like(fine.theta)
    for u, state, env in zip(fine.mechanisms, fine.states, fine.envelopes):
        ell, chi0 = problem.mechanisms[u].parameter_values()[:2]
        c, s = np.cos(chi0), np.sin(chi0)  # geometric_extension's spring end is at χ = σθ
        points = env.points @ np.array([[c, -s], [s, c]])  # rotated by −χ0
        order, x = geometric_extension(SimpleNamespace(state=state, envelope=SimpleNamespace(points=points)), ell)
        np.testing.assert_allclose(x, state.u[order], rtol=0, atol=2e-8)
        theta = state.theta[order]
        k, F0 = problem.springs[u].rate, problem.springs[u].preload
        torque[order] += (k * x + F0) * np.gradient(x, theta, edge_order=2)  # ∂V/∂θ = F du/dθ
    inner = slice(2, -2)  # one-sided differences at the ends
    np.testing.assert_allclose(torque[inner], fine.torque[inner], rtol=0, atol=5e-5)  # measured 9.5e-6
    print(spec, "largest torque error", np.max(np.abs(fine.torque - fine.target)), "N·m")


def test_pendulum_pulleys_as_profiles_have_the_designed_moment_arm_by_the_mechanisms_pose(pendulum):
    """The pendulum's envelope pulleys fitted as Chebyshev profiles of order 12 in the spec's
    frame (its default anchors), then evaluated as cadcam evaluates any design (the departure by
    the rootfinder, the moment arm p × t̂ of model.py): their moment arm is the designed r_m(θ)
    within the fit's error (measured 8.3e-6 m on 28–47 mm), so the design's σ, χ0 and u0 are the
    mechanism's."""
    problem, d = pendulum
    theta = problem.joints[0].grid(201)
    dense = sample_moment_arms(problem, 0, d.basis, d.coefficients, np.linspace(theta[0], theta[-1], 4001))
    coefficients = [fit_profile(prof.basis, *uniform_polar(env, 2000))
                    for prof, env in zip(problem.profiles, dense.envelopes)]
    design = cadcam.Design([p.basis for p in problem.profiles], coefficients,
                           np.array([s.preextension for s in problem.springs]))
    evaluation = evaluate(problem, design, grid=201)
    designed = sample_moment_arms(problem, 0, d.basis, d.coefficients, theta)
    for u, state in zip(designed.mechanisms, designed.states):
        arm = problem.mechanisms[u].sigma * evaluation.units[u].arm[0]
        np.testing.assert_allclose(arm, state.r_m, rtol=0, atol=2e-5)


@pytest.mark.slow  # a whole cadcam design with every file: make test-slow
def test_design_command_by_the_moment_arm_method_meets_the_generic_goal_in_its_files(tmp_path, capsys):
    """``cadcam design models/ludovico2021_generic.toml`` (docs/guide.md), the spec's default
    path: Ludovico2021's generic torque by the moment arms of degree 5, each pulley fitted as a
    profile of order 35 and re-checked like an optimum, with the spec's spring and limits. The
    largest torque error on the fine re-check grid, read from the user's torque_recheck.csv, is
    within issue 30's goal (measured 3.84e-3 N·m; the spec's variant nlp, the profile NLP of
    order 5, stops at 0.10 N·m), and so is the RMSE; the design re-evaluated from its
    result.json gives that torque again; and the workshop files pass their own verification."""
    from cadcam.cli import main
    out = tmp_path / "out"
    assert main(["design", str(MODELS / "ludovico2021_generic.toml"), "-o", str(out)]) == 0
    assert capsys.readouterr().out.startswith("success: moment_arm design")
    rows = np.loadtxt(out / "torque_recheck.csv", delimiter=",", skiprows=1)
    error = np.max(np.abs(rows[:, 1] - rows[:, 2]))
    print("largest torque error on the fine re-check grid", error, "N·m")
    assert error <= GENERIC_GOAL and np.sqrt(np.mean((rows[:, 1] - rows[:, 2]) ** 2)) <= GENERIC_GOAL
    result = json.loads((out / "result.json").read_text())
    assert result["solver"]["name"] == "moment_arm" and result["solver"]["iterations"] == 0
    Draft202012Validator(json.loads((files("cadcam") / "result.schema.json").read_text())).validate(result)
    again = cadcam.evaluate(MODELS / "ludovico2021_generic.toml", out / "result.json", grid=rows.shape[0])
    np.testing.assert_allclose(np.ravel(again.tau), rows[:, 1], rtol=0, atol=1e-9)
    assert "PASSED" in (out / "verification.md").read_text()


def test_moment_arm_method_refuses_a_pulley_without_a_spring_of_its_own():
    problem = load_problem(MODELS / "ludovico2021_generic.toml", variant="moment_arm",
                           overrides={"springs.1.ports": ["cable:1", "cable:2"]})
    with pytest.raises(SpecError, match="moment_arm.*pulley 1.*spring of its own"):
        cadcam.optimize(problem)


def test_moment_arm_method_refuses_a_target_coupled_to_another_joint():
    problem = load_problem(MODELS / "endo2010_five_bar.toml", overrides={"solver.method": "moment_arm"})
    coupled = Target("expression", {"expression": "0.5*sin(theta) + 0.2*sin(theta2)"})
    joints = (dataclasses.replace(problem.joints[0], target=coupled),) + problem.joints[1:]
    assert coupled.coupled_joints(2, 0) == [1]
    assert [j.target.coupled_joints(2, i) for i, j in enumerate(problem.joints)] == [[], []]
    with pytest.raises(SpecError, match="moment_arm.*joint 'J1 .*depends on the angle of joint 'J2"):
        cadcam.optimize(dataclasses.replace(problem, joints=joints))
