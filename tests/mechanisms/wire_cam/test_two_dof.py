"""The 2-DOF network of Johnston2023 (Sec. 3.2, 5, 8.2, 10): structure, targets and optima."""
import dataclasses
import json

import casadi as ca
import numpy as np
import pytest

from cadcam import Design, evaluate, load_spec, optimize
from cadcam.physics.springs import Port, Spring
from cadcam.targets import serial_arm_torques
from cadcam.physics.wrap import friction_order
from cadcam.solve.transcription import Transcription
from cadcam.mechanisms.base import port_function

from ...conftest import SPEC_RR, TABLE3, TABLE4

ARM = dict(m1=0.5, m2=0.5, lc1=0.25, l1=0.5, lc2=0.25, g=9.81)  # Johnston2023, Table 1


def eq49(t1, t2, m1, m2, lc1, l1, lc2, g):
    return (m1 * g * lc1 * np.sin(t1) + m2 * g * (l1 * np.sin(t1) + lc2 * np.sin(t1 + t2)),
            m2 * g * lc2 * np.sin(t1 + t2))


def test_arm_target_is_eq49_and_minus_the_potential_gradient(rr_problem):
    rng = np.random.default_rng(7)
    f = [c.target.function(2, i) for i, c in enumerate(rr_problem.joints)]
    q = ca.SX.sym("q", 2)
    # gravity potential of the two point masses, angles from the upward vertical
    y1 = ARM["lc1"] * ca.cos(q[0])
    y2 = ARM["l1"] * ca.cos(q[0]) + ARM["lc2"] * ca.cos(q[0] + q[1])
    V = ca.Function("V", [q], [ARM["g"] * (ARM["m1"] * y1 + ARM["m2"] * y2)])
    for t in rng.uniform(-np.pi, np.pi, (10, 2)):
        tau = [float(fi(t)) for fi in f]
        np.testing.assert_allclose(tau, eq49(*t, **ARM), rtol=1e-13, atol=1e-15)
        h = 1e-6
        grad = [(float(V(t + h * e)) - float(V(t - h * e))) / (2 * h) for e in np.eye(2)]
        np.testing.assert_allclose(tau, -np.array(grad), rtol=1e-8, atol=1e-9)


def test_three_link_arm_torques_match_the_potential_gradient():
    rng = np.random.default_rng(3)
    m, lengths, lc, g = [1.0, 0.7, 0.3], [0.4, 0.35, 0.2], [0.2, 0.15, 0.1], 9.81
    q = ca.SX.sym("q", 3)
    tau = ca.Function("tau", [q], [ca.vertcat(*serial_arm_torques([q[i] for i in range(3)], m, lengths, lc, g))])
    phi = ca.cumsum(q)
    y, base = 0, 0
    for i in range(3):
        y += m[i] * g * (base + lc[i] * ca.cos(phi[i]))
        base += lengths[i] * ca.cos(phi[i])
    dV = ca.Function("dV", [q], [ca.gradient(y, q)])
    for t in rng.uniform(-2, 2, (5, 3)):
        np.testing.assert_allclose(np.asarray(tau(t)).ravel(), -np.asarray(dV(t)).ravel(), atol=1e-12)


def _without_spring2(problem):
    springs = list(problem.springs)
    springs[1] = dataclasses.replace(springs[1], rate=0.0, travel=1.0)  # gone: no force, no limit
    return dataclasses.replace(problem, springs=tuple(springs))


def _own_angle_targets(problem, expressions):
    """The problem with each joint's target replaced by an expression of its own angle."""
    joints = tuple(dataclasses.replace(c, target=dataclasses.replace(
        c.target, kind="expression", data={"expression": e, "parameters": {}}))
        for c, e in zip(problem.joints, expressions))
    return dataclasses.replace(problem, joints=joints)


def _one_dof(problem, cam, spring):
    """Cam ``cam`` alone with spring ``spring`` on its wire (the 1-DOF network)."""
    s, c = problem.springs[spring], problem.joints[cam]
    return dataclasses.replace(
        problem, springs=(Spring(s.name, s.rate, s.travel, (Port(0, "wire"),)),),
        joints=(dataclasses.replace(c, sensitivity_weights=(c.sensitivity_weights[spring],)),),
        mechanisms=(dataclasses.replace(problem.mechanisms[cam], joint=0),))


def test_network_without_spring2_is_two_independent_one_dof_cams(rr_problem, table3):
    p = _own_angle_targets(_without_spring2(rr_problem), ["3.7*sin(theta)", "1.2*sin(theta)"])
    two = evaluate(p, table3, grid=9)
    for cam, spring in ((0, 0), (1, 2)):
        one = evaluate(_one_dof(p, cam, spring), Design(
            [table3.bases[cam]], [table3.coefficients[cam]], table3.preextension[[spring]]), grid=9)
        expected = np.interp(two.theta[cam], one.theta[0], one.tau[0])
        np.testing.assert_allclose(two.tau[cam], expected, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(two.tau_d[cam], np.interp(two.theta[cam], one.theta[0], one.tau_d[0]))


def test_optimum_without_spring2_equals_the_two_one_dof_optima(rr_problem):
    """Decoupled joints: the two 1-DOF optima, put together, are an optimum of the 2-joint
    problem (IPOPT started there stays there), whose objective integrates each joint's 1-DOF
    objective over the other joint's range as well (span π/2)."""
    p = _own_angle_targets(_without_spring2(rr_problem), ["3.7*sin(theta)", "1.2*sin(theta)"])
    p = p.with_options(grid=12, convexity_points=30)
    ones = [optimize(_one_dof(p, cam, spring)) for cam, spring in ((0, 0), (1, 2))]
    # optima, whatever share of these made-up targets cubic cams can follow
    assert [(one.solve.status, one.recheck.violations) for one in ones] == [("converged", [])] * 2
    x0 = np.array([ones[0].design.preextension[0], 0.005, ones[1].design.preextension[0]])
    start = Design([o.design.bases[0] for o in ones], [o.design.coefficients[0] for o in ones], x0)
    two = optimize(p, start=start)
    assert (two.solve.status, two.recheck.violations) == ("converged", [])
    assert two.solve.objective == pytest.approx(np.pi / 2 * sum(o.solve.objective for o in ones), rel=1e-6)
    for cam, (spring, one) in enumerate(zip((0, 2), ones)):
        np.testing.assert_allclose(two.evaluation.metrics.rmse[cam], one.evaluation.metrics.rmse[0],
                                   rtol=1e-4)
        np.testing.assert_allclose(two.design.monomial(cam), one.design.monomial(0), rtol=1e-3, atol=1e-7)
        assert two.design.preextension[spring] == pytest.approx(one.design.preextension[0], abs=1e-7)


@pytest.fixture(scope="module")
def solved():
    """Sec. 10.4 (the base spec) and Sec. 10.5 (variant): problem, optimum, published design."""
    out = {}
    for variant, table in ((None, TABLE3), ("sec10_5", TABLE4)):
        problem = load_spec(SPEC_RR, variant)
        out[variant] = (problem, optimize(problem),
                        Design.from_dict(json.loads(table.read_text()), problem))
    return out


@pytest.mark.parametrize("variant", [None, "sec10_5"])
@pytest.mark.slow  # the RR arm designed twice on its 46 × 46 grid: make test-slow
def test_two_dof_optimum_is_verified_and_beats_the_published_design(solved, variant):
    problem, result, published = solved[variant]
    assert result.status == "success"
    fine = result.recheck
    assert fine.grid == 10 * (problem.options.grid - 1) + 1
    assert fine.violations == []
    for s, hi in zip(problem.springs, fine.metrics.extension_max):
        assert hi <= s.travel
    assert min(fine.metrics.extension_min) >= 0
    assert min(fine.metrics.convexity_min) > 0
    assert min(fine.metrics.rho_min) >= problem.profiles[0].rho_min
    theirs = evaluate(problem, published).metrics.objective  # same (energy) torque model
    assert result.evaluation.metrics.objective < theirs


def test_sec10_4_optimum_under_the_force_model_matches_an_independent_solve():
    """docs/physics.md (checked with an independent implementation): under Johnston2023's force
    model with the corrected capstan, the Sec. 10.4 optima sit around cam 1 RMSE ≈ 320 N·mm and
    cam 2 ≈ 130 N·mm."""
    result = optimize(load_spec(SPEC_RR).with_torque_model("force"))
    assert result.status == "success"
    np.testing.assert_allclose(np.array(result.evaluation.metrics.rmse) * 1e3, [320, 130], rtol=0.02)


def _trig(f) -> int:
    """Number of sin/cos instructions in SX Function ``f``."""
    return sum(f.instruction_id(k) in (ca.OP_SIN, ca.OP_COS) for k in range(f.n_instructions()))


def test_tangency_evaluations_grow_linearly_with_the_grid(rr_problem):
    """Each cam's tangency is evaluated at its own n angles, never at the n² grid pairs.

    Counted in the compiled NLP functions: all their trigonometry is the tangency geometry
    (profiles are polynomials), and each grid angle added must add exactly one evaluation of
    the per-angle model (Eq. 1–8, 14–21) per cam — the trig instructions of one call of the
    per-angle function the NLP maps over its grid.
    """
    opt = rr_problem.options
    per_evaluation = _trig(port_function(rr_problem.mechanisms[0].structure(), rr_problem.torque_model,
                                         friction_order(opt.quadrature_order), "closed-form"))
    m = len(rr_problem.joints)
    trig = {}
    for n in (6, 12, 24):
        tr = Transcription(rr_problem.with_options(grid=n, convexity_points=20))
        trig[n] = sum(_trig(tr.solver.get_function(name)) for name in ("nlp_f", "nlp_g"))
    per_angle = (trig[24] - trig[12]) / 12
    assert per_angle == (trig[12] - trig[6]) / 6  # linear in n, no n² term
    assert per_angle / per_evaluation == m  # one tangency evaluation per cam and angle
