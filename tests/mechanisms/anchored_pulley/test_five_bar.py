"""Endo2010's parallel five-bar arm (Sec. III, Eq. 3–8): gravity torques by the transposed
Jacobian, each joint's torque a function of its own angle only (Eq. 8), checked against the
closed form and against −∂V/∂θ by finite differences of positions computed with numpy
alone."""
import copy
import math
import tomllib

import casadi as ca
import numpy as np
import pytest

from cadcam.spec import SpecError, parse_spec
from cadcam.targets import Target, five_bar_torques

from ...conftest import SPEC_RR

G = 9.81
# Endo2010 Sec. IV.B / Table I: l_u = l_a = 0.5 m; the masses and short crank are our choice,
# two of them (m4, m6) solved so that J1 ≡ 1.18 kg at 0.5 m (inverted) and J2 ≡ 0.33 kg at
# 0.5 m (ordinary): m1 l1 + m3 l3 + (m4+m5+m6) l_u = 0.59 kg·m and
# m2 l2 + m3 l_c + m5 l5 − m6 l_a = −0.165 kg·m (Endo2010 Eq. 8).
ENDO = {"masses": [0.40, 0.10, 0.20, 0.24, 0.25, 0.39], "upper": 0.5, "crank": 0.08,
        "fore": 0.5, "com": [0.25, 0.04, 0.25, 0.04], "g": G}


def lengths(d):
    return {k: d[k] for k in ("upper", "crank", "fore", "com")}


def random_arm(rng):
    return {"masses": list(rng.uniform(0.05, 2.0, 6)), "upper": rng.uniform(0.2, 0.8),
            "crank": rng.uniform(0.03, 0.2), "fore": rng.uniform(0.2, 0.8),
            "com": list(rng.uniform(0.0, 0.4, 4)), "g": G}


def closed_form(t1, t2, d):
    """Endo2010 Eq. 8 in the geometry of :func:`five_bar_torques`."""
    m1, m2, m3, m4, m5, m6 = d["masses"]
    l1, l2, l3, l5 = d["com"]
    return (d["g"] * (m1 * l1 + m3 * l3 + (m4 + m5 + m6) * d["upper"]) * math.sin(t1),
            d["g"] * (m2 * l2 + m3 * d["crank"] + m5 * l5 - m6 * d["fore"]) * math.sin(t2))


def potential(t1, t2, d):
    """V = g Σ m_k y_k [J] with the six points built by numpy (independent of the code)."""
    u1, u2 = np.array([math.sin(t1), math.cos(t1)]), np.array([math.sin(t2), math.cos(t2)])
    l1, l2, l3, l5 = d["com"]
    elbow, c = d["upper"] * u1, d["crank"] * u2
    d_point = c + d["upper"] * u1
    # the forearm is rigid through D and E: D − E must be the crank's direction
    assert np.allclose(d_point - elbow, d["crank"] * u2)
    points = [l1 * u1, l2 * u2, c + l3 * u1, elbow, elbow + l5 * u2, elbow - d["fore"] * u2]
    return d["g"] * sum(m * p[1] for m, p in zip(d["masses"], points))


def torque_function(d):
    q = ca.SX.sym("q", 2)
    tau = ca.vertcat(*five_bar_torques(q[0], q[1], d["masses"], lengths(d), d["g"]))
    return ca.Function("tau", [q], [tau, ca.jacobian(tau, q)])


def test_each_torque_depends_on_its_own_angle_only():
    rng = np.random.default_rng(2010)
    for _ in range(5):
        d = random_arm(rng)
        f = torque_function(d)
        for t in rng.uniform(-math.pi, math.pi, (10, 2)):
            _, jac = f(t)
            jac = np.asarray(jac)
            assert abs(jac[0, 1]) < 1e-12 and abs(jac[1, 0]) < 1e-12  # Endo2010 Eq. 8
            c1, c2 = closed_form(0.5 * math.pi, 0.5 * math.pi, d)  # g·coefficient
            assert jac[0, 0] == pytest.approx(c1 * math.cos(t[0]), rel=1e-12, abs=1e-12)
            assert jac[1, 1] == pytest.approx(c2 * math.cos(t[1]), rel=1e-12, abs=1e-12)
            assert abs(jac[0, 0]) > 1e-6 and abs(jac[1, 1]) > 1e-6


def test_torques_are_the_closed_form_and_minus_the_potential_gradient():
    rng = np.random.default_rng(8)
    h = 1e-6
    for _ in range(5):
        d = random_arm(rng)
        f = torque_function(d)
        for t1, t2 in rng.uniform(-math.pi, math.pi, (10, 2)):
            tau = np.asarray(f([t1, t2])[0]).ravel()
            assert tau == pytest.approx(closed_form(t1, t2, d), rel=1e-12, abs=1e-12)
            fd = [-(potential(t1 + h, t2, d) - potential(t1 - h, t2, d)) / (2 * h),
                  -(potential(t1, t2 + h, d) - potential(t1, t2 - h, d)) / (2 * h)]
            assert tau == pytest.approx(fd, rel=1e-7, abs=1e-8)


def test_numbers_in_numbers_out():
    tau = five_bar_torques(0.3, -0.7, ENDO["masses"], lengths(ENDO), G)
    assert [float(t) for t in tau] == pytest.approx(closed_form(0.3, -0.7, ENDO), rel=1e-12)


def test_endo_parameters_give_the_equivalent_pendula_of_sec_iv_b():
    """J1 ≡ inverted pendulum 1.18 kg at 0.5 m, J2 ≡ ordinary pendulum 0.33 kg at 0.5 m."""
    for t1, t2 in [(math.radians(14.5), math.radians(-90.0)), (math.radians(60.0), -0.4)]:
        tau1, tau2 = (float(t) for t in five_bar_torques(t1, t2, ENDO["masses"], lengths(ENDO), G))
        assert tau1 == pytest.approx(1.18 * G * 0.5 * math.sin(t1), rel=1e-12)
        assert tau2 == pytest.approx(-0.33 * G * 0.5 * math.sin(t2), rel=1e-12)
    assert float(five_bar_torques(0.0, -math.pi / 2, ENDO["masses"], lengths(ENDO), G)[1]) \
        == pytest.approx(0.33 * G * 0.5)  # 1.6187 N·m at θ2 = −90°


def five_bar_spec(**changes):
    """The RR-arm spec with five_bar targets over Endo2010's ranges; ``changes`` edit the
    first joint's target (a value of None deletes the key)."""
    data = tomllib.loads(SPEC_RR.read_text())
    del data["arm"], data["variants"]
    for j, (cam, rng) in enumerate(zip(data["cams"], ([14.5, 90.0], [-90.0, 0.0]))):
        cam["theta_range_deg"] = rng
        cam["target"] = {"kind": "five_bar", "joint": j + 1, **copy.deepcopy(ENDO)}
    target = data["cams"][0]["target"]
    for k, v in changes.items():
        if v is None:
            del target[k]
        else:
            target[k] = v
    return data


def test_spec_five_bar_targets_evaluate_and_round_trip():
    problem = parse_spec(five_bar_spec(), "endo.toml")
    t1, t2 = math.radians(40.0), math.radians(-30.0)
    for i, (expected, angle) in enumerate([(1.18, t1), (-0.33, t2)]):
        f = problem.joints[i].target.function(2, i)
        assert float(f([t1, t2])) == pytest.approx(expected * G * 0.5 * math.sin(angle), rel=1e-12)
    again = problem.joints[0].target.to_dict()
    assert again == {"kind": "five_bar", "joint": 1, **ENDO}
    assert parse_spec(problem.to_dict(), "again").joints[1].target == problem.joints[1].target
    assert Target("five_bar", {k: v for k, v in again.items() if k != "kind"}) \
        == problem.joints[0].target


@pytest.mark.parametrize("changes, expected", [
    ({"masses": [0.4, 0.1, 0.2, 0.24, 0.25]},
     "cams[1].target.masses = [0.4, 0.1, 0.2, 0.24, 0.25]: expected the point masses m1…m6: a list of 6 numbers each > 0 [kg]"),
    ({"masses": [0.4, 0.1, -0.2, 0.24, 0.25, 0.39]}, "cams[1].target.masses = [0.4, 0.1, -0.2"),
    ({"com": [0.25, 0.04, -0.25, 0.04]}, "cams[1].target.com = [0.25, 0.04, -0.25, 0.04]: "
     "expected the distances [l1, l2, l3, l5]: a list of 4 numbers each ≥ 0 [m]"),
    ({"crank": 0.0}, "cams[1].target.crank = 0.0: expected the crank's length l_c: a number > 0 [m]"),
    ({"fore": "0.5"}, "cams[1].target.fore = '0.5': expected the forearm's length l_a, elbow to tip: a number ≥ 0 [m]"),
    ({"joint": 3}, "cams[1].target.joint = 3: expected 1 (link 1, theta1) or 2"),
    ({"joint": 1.0}, "cams[1].target.joint = 1.0: expected 1"),
    ({"upper": None}, "missing key 'cams[1].target.upper': expected the upper arm's length l_u: a number > 0 [m]"),
    ({"lengths": [0.5, 0.5]}, "unknown key 'cams[1].target.lengths'"),
    ({"kind": "five-bar"}, "cams[1].target.kind = 'five-bar': expected the kind of law: one of"),
])
def test_malformed_five_bar_target_gets_one_line(changes, expected):
    with pytest.raises(SpecError) as err:
        parse_spec(five_bar_spec(**changes), "endo.toml")
    message = str(err.value)
    assert "\n" not in message and message.startswith("endo.toml: ")
    assert expected in message


def test_five_bar_target_needs_two_joints():
    data = five_bar_spec()
    data["cams"] = data["cams"][:1]
    data["springs"] = [s for s in data["springs"] if all(p.endswith(":1") for p in s["ports"])]
    data["cams"][0]["sensitivity_weights"] = [0.0] * len(data["springs"])
    with pytest.raises(SpecError, match=r"^endo\.toml: cams\[1\]\.target\.kind = 'five_bar': "
                                        r"expected a five_bar target only in a problem of 2 "
                                        r"joints .*; this one has 1$"):
        parse_spec(data, "endo.toml")
