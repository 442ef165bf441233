"""The re-check on the tensor grid of several joints, computed from one-angle shares and streamed
(cadcam.verify.evaluate), against a brute-force evaluation of the single-point torque model
(cadcam.verify.model) at every grid point; and its bounded cost for three joints."""
import csv
import tracemalloc

import numpy as np
import pytest

from cadcam import Design, load_spec
from cadcam.api import load_problem
from cadcam.verify.evaluate import evaluate
from cadcam.verify.model import torque_function, torque_jacobian_function
from cadcam.optimize import default_start
from cadcam.physics.quadrature import trapezoid_weights
from cadcam.problem import Options, size_error
from cadcam.spec import read_spec_data
from cadcam.outputs.run_files import TABLE_POINTS, write_torque_csv

from ..conftest import ROOT, SPEC_RR

SPEC_3 = ROOT / "models" / "johnston2023_three_cam_arm.toml"


def brute_force(problem, design, n: int) -> dict:
    """The re-check's grid metrics, point by point: τ and x from the torque model at every one
    of the n^m points of the tensor grid, ∂τ/∂k from its Jacobian, τ_d from each target's
    CasADi function, sums with the product trapezoid weights."""
    m = len(problem.joints)
    grids = [j.grid(n) for j in problem.joints]
    theta = np.vstack([a.ravel() for a in np.meshgrid(*grids, indexing="ij")])
    N, S = theta.shape[1], len(problem.springs)
    args = (theta, np.concatenate(design.coefficients), [s.rate for s in problem.springs],
            design.preextension, [s.preload for s in problem.springs])
    tau, x, _ = (np.asarray(v) for v in torque_function(problem, design.bases).map(N)(*args))
    jac = torque_jacobian_function(problem, design.bases)
    dtau_dk = np.asarray(jac.map(N)(*args)[jac.index_out("dtau_dk")]).reshape(m, N, S)
    tau_d = np.vstack([np.asarray(j.target.function(m, i).map(N)(theta)).ravel()
                       for i, j in enumerate(problem.joints)])
    W = np.prod(np.meshgrid(*[trapezoid_weights(g) for g in grids], indexing="ij"), axis=0).ravel()
    err = tau - tau_d
    sens = np.einsum("inj,n->ij", np.abs(dtau_dk), W)
    return {
        "theta": theta, "error": err,
        "rmse": np.sqrt(np.mean(err**2, axis=1)),
        "relative_rmse": np.sqrt(np.mean(err**2, axis=1)) / np.sqrt(np.mean(tau_d**2, axis=1)),
        "max_abs_error": np.abs(err).max(axis=1),
        "extension_min": x.min(axis=1), "extension_max": x.max(axis=1),
        "sensitivity_integral": sens,
        "objective": sum(j.tracking_weight * np.dot(err[i] ** 2, W) + np.dot(j.sensitivity_weights, sens[i])
                         for i, j in enumerate(problem.joints)),
        "worst": [np.unravel_index(int(np.argmax(np.abs(e))), (n,) * m) for e in err],
    }


def assert_matches(ev, bf, rtol=1e-9):
    for key in ("rmse", "relative_rmse", "max_abs_error", "extension_min", "extension_max",
                "sensitivity_integral", "objective"):
        np.testing.assert_allclose(ev.metrics[key], bf[key], rtol=rtol, atol=1e-12, err_msg=key)
    assert [tuple(w) for w in ev.worst] == [tuple(int(k) for k in w) for w in bf["worst"]]


def wavy(problem) -> Design:
    """The default circular start with every cam made to spiral out a little (a convex,
    non-circular design)."""
    start = default_start(problem)
    coefficients = []
    for b, c in zip(start.bases, start.coefficients):
        mono = np.zeros(b.size)
        mono[:3] = [b.to_monomial(c)[0], 0.006, -0.002]
        coefficients.append(b.from_monomial(mono))
    return Design(start.bases, coefficients, start.preextension)


def coupled_rr(target1: str, target2: dict):
    """The RR arm of Johnston2023 Sec. 10.4 with other targets: an expression of both angles
    on joint 1 and ``target2`` on joint 2."""
    data = read_spec_data(SPEC_RR)
    data["cams"][0]["target"] = {"kind": "expression", "expression": target1}
    data["cams"][1]["target"] = target2
    return load_problem(data)


def test_table3_rr_arm_equals_brute_force(rr_problem, table3):
    for model in ("energy", "force-as-printed"):
        problem = rr_problem.with_torque_model(model)
        ev = evaluate(problem, table3, grid=46)
        assert_matches(ev, brute_force(problem, table3, 46))
    # Johnston2023 Table 3 under the printed model (README): RMSE 270.5 and 128.4 N·mm
    np.testing.assert_allclose(1e3 * np.array(ev.metrics.rmse), [270.5, 128.4], atol=0.05)


@pytest.mark.parametrize("target1,target2", [
    # sin of a sum of two joints' angles (expanded by angle addition) and exp of their product
    # (evaluated on each block)
    ("2*sin(theta1 + theta2)*cos(theta1) + 0.3*exp(theta1*theta2)",
     {"kind": "expression", "expression": "1.5*cos(theta1 - theta2) + theta2**2/(1 + theta1)"}),
    # a table target: CasADi's interpolant, evaluated point by point on its own joint
    ("sqrt(1 + theta1*theta2) - 1", {"kind": "table", "samples": [[0, 0], [0.5, 0.3], [1.0, 0.8], [1.6, 1.0]]}),
])
def test_a_target_coupling_both_joints_equals_brute_force(target1, target2):
    problem = coupled_rr(target1, target2)
    design = wavy(problem)
    for n in (31, 46):
        assert_matches(evaluate(problem, design, grid=n, profile=False), brute_force(problem, design, n))


@pytest.fixture(scope="module")
def three_cam():
    problem = load_spec(SPEC_3)
    return problem, wavy(problem)


def test_three_cam_arm_equals_brute_force_on_a_small_grid(three_cam):
    problem, design = three_cam
    assert len(problem.joints) == 3 and [len(problem.network().joints_of(j)) for j in range(5)] == [1, 2, 1, 2, 1]
    small = load_problem(SPEC_3, grid=12)
    assert small.options.grid == 12 and small.options.recheck_grid == 111
    ev = evaluate(small, design)
    bf = brute_force(small, design, 12)
    assert_matches(ev, bf)
    # the arm's targets depend on every angle: joint 1's error spans the whole grid
    assert ev.tensor.error_joints(0) == (0, 1, 2)
    # the materialised arrays are the brute force's too
    np.testing.assert_allclose(ev.theta, bf["theta"], rtol=0, atol=0)
    np.testing.assert_allclose(ev.tau - ev.tau_d, bf["error"], rtol=1e-9, atol=1e-12)


def test_torque_csv_is_the_whole_grid_or_the_lines_through_the_worst_points(three_cam, tmp_path):
    problem, design = three_cam
    small = evaluate(problem, design, grid=12, profile=False)  # 1728 points: every one
    write_torque_csv(tmp_path / "small.csv", small)
    rows = list(csv.reader(open(tmp_path / "small.csv")))
    assert len(rows) == 1 + 12**3 and rows[0][:4] == ["theta1_rad", "theta2_rad", "theta3_rad", "tau1_Nm"]
    n = 111  # 111³ > TABLE_POINTS: the lines through each joint's worst point
    assert n**3 > TABLE_POINTS
    fine = evaluate(problem, design, grid=n, profile=False)
    write_torque_csv(tmp_path / "fine.csv", fine)
    with open(tmp_path / "fine.csv") as f:
        header = next(csv.reader(f))
        table = np.loadtxt(f, delimiter=",")
    assert header == rows[0] and table.shape == (3 * 3 * n, len(header)) and np.all(np.isfinite(table))
    for i in range(3):
        block = table[3 * n * i:3 * n * (i + 1)]
        error = block[:, header.index(f"error{i + 1}_Nm")]
        assert np.abs(error).max() == pytest.approx(fine.metrics.max_abs_error[i], rel=1e-12)
        for axis in range(3):  # the line along joint axis + 1's angle: the other angles fixed
            line = block[axis * n:(axis + 1) * n, :3]
            np.testing.assert_allclose(line[:, axis], problem.joints[axis].grid(n))
            assert all(np.ptp(line[:, c]) == 0 for c in range(3) if c != axis)
        # its worst point, recomputed by the single-point model
        point = np.array([problem.joints[c].grid(n)[fine.worst[i][c]] for c in range(3)])
        tau = np.asarray(torque_function(problem, design.bases)(
            point, np.concatenate(design.coefficients), [s.rate for s in problem.springs],
            design.preextension, [s.preload for s in problem.springs])[0]).ravel()
        tau_d = float(problem.joints[i].target.function(3, i)(point))
        assert abs(tau[i] - tau_d) == pytest.approx(fine.metrics.max_abs_error[i], rel=1e-9)


@pytest.mark.slow  # a three-joint re-check at grid 46: make test-slow
def test_a_three_joint_recheck_at_grid_46_runs_in_bounded_memory(three_cam):
    problem, design = three_cam
    options = problem.with_options(grid=46).options
    assert options.recheck_grid**3 == 451**3 and size_error(options, 3) is None
    tracemalloc.start()
    ev = evaluate(problem, design, grid=options.recheck_grid)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    # one float64 array over the 451³ grid would be 734 MB
    assert peak < 100e6, f"peak {peak / 1e6:.0f} MB"  # measured: 22 MB
    coarse = evaluate(problem, design, grid=46)
    m = ev.metrics
    assert all(np.isfinite(m[k]).all() for k in ("rmse", "max_abs_error", "sensitivity_integral", "objective"))
    # the fine grid holds the coarse one (451 = 10·45 + 1): its largest error is at least as
    # large, and the spring extremes too; the RMS moves by a fraction
    assert all(f >= c - 1e-12 for f, c in zip(m["max_abs_error"], coarse.metrics.max_abs_error))
    assert all(f <= c + 1e-12 for f, c in zip(m["extension_min"], coarse.metrics.extension_min))
    np.testing.assert_allclose(m["rmse"], coarse.metrics.rmse, rtol=0.05)
    # the tensor itself is not materialised on demand beyond the cap
    with pytest.raises(ValueError, match="materialised"):
        _ = ev.tau


def test_caps_count_the_streamed_recheck_and_the_held_design_grid():
    # a fourth joint at the default grid would stream 451⁴ ≈ 4.1e10 points
    assert "fine re-check would evaluate 4.14e+10 points" in size_error(Options(grid=46), 4)[1]
    assert size_error(Options(grid=46, recheck_factor=3), 4) is None  # 136⁴ ≈ 3.4e8
    reason = size_error(Options(grid=300, recheck_factor=1), 3)[1]
    assert "design grid would hold 2.7e+07 points" in reason and "CADCAM_CAP_GRID_POINTS" in reason


def test_a_run_of_angles_on_another_root_is_brought_back_by_continuation():
    """Cam 3 of a three-cam optimum: from the guess, Newton lands on another root of the
    tangency equations at the last angles (z jumps by ~0.6 rad); continuation from the rest of
    the grid brings them back onto the branch the cable is on."""
    from cadcam.mechanisms.base import _jumps, departure_solver
    from cadcam.physics.profile import Basis
    problem = load_spec(SPEC_3)
    mech = problem.mechanisms[2]
    basis = Basis("chebyshev", 3, (0.0, 2.617993877991494))  # the optimum's cam 3 (an input here)
    c = np.array([-0.022768229061280922, -0.0833360255981286, -0.04525659716986235, -0.009691300459777112])
    solver = departure_solver((type(mech), (basis,)))
    theta = problem.joints[mech.joint].grid(26)
    q = np.asarray(mech.parameter_values(), dtype=float)
    raw, raw_res = solver._solve(theta, solver.guess(theta, c, q), c, q)
    assert raw_res.max() < 1e-9 and _jumps(raw).size  # converged, but not all on one branch
    z, res = solver.solve(theta, c, q)
    steps = np.abs(np.diff(z, axis=1)).max(axis=0)
    assert res.max() < 1e-9 and not _jumps(z).size and steps.max() < 2 * np.median(steps)
    assert np.array_equal(z[:, :20], raw[:, :20])  # the run that was right is left as it was


def test_angles_newton_leaves_after_its_first_pass_are_solved_and_the_rest_keep_their_roots():
    """Fedorov2018's balancer at its start (Fedorov's envelope pulleys): from the guess, Newton
    leaves some angles unconverged after its first pass; the solve brings every angle to its
    root, and where Newton from the guess converges with every iteration the solve's z is that
    one, unchanged."""
    from cadcam.mechanisms.base import departure_solver
    from cadcam.optimize import start_design
    problem, start = start_design(load_spec(ROOT / "models" / "fedorov2018_balancer.toml"))
    mech = problem.mechanisms[0]
    c = np.concatenate(start.coefficients[problem.profile_slices()[0]])
    q = np.asarray(mech.parameter_values(), dtype=float)
    solver = departure_solver(mech.structure())
    theta = problem.joints[mech.joint].grid(61)
    guess = solver.guess(theta, c, q)
    first = solver._solve(theta, guess, c, q, solver._first)[1]
    every_z, every = solver._solve(theta, guess, c, q)
    z, res = solver.solve(theta, c, q)
    assert (first > 1e-9).any() and res.max() < 1e-9
    assert np.array_equal(z[:, every <= 1e-9], every_z[:, every <= 1e-9])
