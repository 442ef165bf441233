"""The friction band of a design (cadcam.verify.friction): read from a spec's [friction], the
issue's closed forms on a designed balancer, a design that tracks the band's centre, the band in
result.json (against the schema), the summary and the torque figure, and a two-joint network
whose spring joins both joints."""
import json
import math
import tomllib
from dataclasses import replace
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest
from jsonschema import Draft202012Validator

import cadcam
from cadcam import Design, evaluate
from cadcam.errors import SpecError
from cadcam.outputs.plots import torque_figure
from cadcam.physics.friction import Friction, Guide, JointBearing
from cadcam.spec import parse_spec
from cadcam.verify.friction import friction_band

from ..conftest import SPEC_RR, TABLE3

ROOT = Path(__file__).resolve().parents[2]
TUTORIAL = ROOT / "docs" / "first_balancer.toml"
#: A rope over a fixed steel post (docs/physics.md): μ, and its wrap [deg].
MU, WRAP_DEG = 0.16, 90.0
#: The joint's plain bearing: a constant torque [N·m], μ_b and its radius [m].
BEARING = {"joint": 1, "torque": 0.002, "coefficient": 0.2, "radius": 0.003}


def tutorial(friction: dict | None) -> dict:
    """The tutorial's spec with ``friction`` as its [friction]."""
    data = tomllib.loads(TUTORIAL.read_text(encoding="utf-8"))
    if friction is not None:
        data["friction"] = friction
    return data


@pytest.fixture(scope="module")
def centred():
    """The tutorial's balancer with its cable over a post and a plain joint bearing, designed to
    track the band's centre (a few s)."""
    problem = parse_spec(tutorial({"centre": True, "guides": [{"spring": 1, "mu": MU, "wrap_deg": WRAP_DEG}],
                                   "joints": [BEARING]}), "first_balancer.toml")
    result = cadcam.optimize(problem)
    assert result.success
    return result


@pytest.fixture(scope="module")
def frictionless(centred):
    """The centred design evaluated without friction: its frictionless torque, by the network's
    own path."""
    return evaluate(replace(centred.problem, friction=None), centred.design)


def test_with_mu_zero_every_band_collapses_onto_the_frictionless_torque(centred, frictionless):
    port = centred.problem.springs[0].ports[0]
    zero = Friction(guides=(Guide(0, port, 0.0, math.pi),), joints=(JointBearing(0),))
    for ev in (frictionless, centred.evaluation):
        band = friction_band(ev, zero)
        np.testing.assert_allclose(band.plus, frictionless.tau, rtol=1e-14, atol=0)
        np.testing.assert_allclose(band.minus, frictionless.tau, rtol=1e-14, atol=0)


def test_a_guide_alone_gives_e_to_the_2_mu_beta_at_its_wrap(frictionless):
    assert np.all(frictionless.tau > 0)
    port = frictionless.problem.springs[0].ports[0]
    for wrap in (math.radians(30.0), math.pi, 2.5 * math.pi):
        band = friction_band(frictionless, Friction(guides=(Guide(0, port, MU, wrap),)))
        np.testing.assert_allclose(band.plus / band.minus, math.exp(2 * MU * wrap), rtol=1e-13)


def test_a_joint_bearing_shifts_both_edges_by_its_torque(frictionless):
    bearing = JointBearing(0, BEARING["torque"], BEARING["coefficient"], BEARING["radius"])
    band = friction_band(frictionless, Friction(joints=(bearing,)))
    spring = frictionless.problem.springs[0]
    expected = bearing.torque + bearing.coefficient * bearing.radius * (spring.preload + spring.rate * frictionless.x[0])
    np.testing.assert_allclose(band.plus[0] - frictionless.tau[0], expected, rtol=1e-12)
    np.testing.assert_allclose(frictionless.tau[0] - band.minus[0], expected, rtol=1e-12)


def test_the_centred_design_puts_the_target_mid_band(centred, frictionless):
    band = centred.friction
    L = MU * math.radians(WRAP_DEG)
    np.testing.assert_allclose(band.frictionless, frictionless.tau, rtol=1e-13)
    # what it tracks is the centre, Σ t cosh L, and the centre meets the target as τ did before
    np.testing.assert_allclose(band.centre, centred.evaluation.tau, rtol=1e-13)
    np.testing.assert_allclose(band.centre, math.cosh(L) * frictionless.tau, rtol=1e-13)
    assert np.abs(band.centre - band.target).max() <= centred.evaluation.metrics.max_abs_error[0] * (1 + 1e-9)
    # its half-width, the largest error of a held payload: Σ |t| sinh L + τ_b
    spring = centred.problem.springs[0]
    tension = spring.preload + spring.rate * frictionless.x[0]
    bearing = BEARING["torque"] + BEARING["coefficient"] * BEARING["radius"] * tension
    np.testing.assert_allclose(band.width[0] / 2, math.sinh(L) * frictionless.tau[0] + bearing, rtol=1e-12)


def test_result_json_the_summary_and_the_figure_carry_the_band(centred):
    out = centred.to_dict()
    schema = json.loads((files("cadcam") / "result.schema.json").read_text(encoding="utf-8"))
    assert list(Draft202012Validator(schema).iter_errors(out)) == []
    band = out["friction_band"]
    joint = band["joints"][0]
    peak = np.abs(centred.evaluation.tau_d).max()
    assert band["centre_tracked"] is True and joint["outside_max"] == 0.0
    assert joint["width_max_share"] == pytest.approx(centred.friction.width.max() / peak)
    assert band["paths"] == [{"path": "spring 1 → cable:1", "log_ratio": pytest.approx(MU * math.radians(WRAP_DEG)),
                              "ratio": pytest.approx(math.exp(MU * math.radians(WRAP_DEG)))}]
    rows = np.array(band["samples"][0])
    np.testing.assert_allclose(rows[:, 1], centred.friction.minus[0], rtol=1e-15)
    np.testing.assert_allclose(rows[:, 3], centred.friction.plus[0], rtol=1e-15)
    line = next(line for line in centred.summary().splitlines() if "friction band" in line)
    assert f"{100 * joint['width_max_share']:.3g} % of the target's peak" in line and "its centre tracked" in line
    fig = torque_figure(centred.evaluation, centred.band, centred.friction)
    labels = [c.get_label() for c in fig.axes[0].collections]
    assert any(label.startswith("friction band") for label in labels)
    # the problem reads back from result.json with its friction
    assert parse_spec(json.loads(json.dumps(out["problem"])), "result.json").friction == centred.problem.friction


def test_a_spec_without_friction_weighs_no_arm():
    problem = parse_spec(tutorial(None), "first_balancer.toml")
    assert problem.friction is None and problem.network().W.tolist() == problem.network().P.tolist()


@pytest.mark.parametrize("friction, words", [
    ({"guides": [{"spring": 2, "mu": 0.1, "wrap_deg": 90}]}, "friction.guides[1].spring = 2: expected the spring"),
    ({"guides": [{"spring": 1, "port": "wire:1", "mu": 0.1, "wrap_deg": 90}]},
     "friction.guides[1].port = 'wire:1': expected one of spring 1's ports: cable:1"),
    ({"idlers": [{"spring": 1, "coefficient": 1.0, "wrap_deg": 90}]}, "friction.idlers[1].coefficient = 1.0: expected"),
    ({"joints": [{"joint": 1, "torque": 0.1}, {"joint": 1, "torque": 0.2}]},
     "friction.joints[2].joint = 1: expected one [[friction.joints]] table per joint"),
    ({"guides": [{"spring": 1, "mu": 0.1}]}, "missing key 'friction.guides[1].wrap_deg'"),
    ({"centre": "yes"}, "friction.centre = 'yes': expected"),
    ({"posts": []}, "unknown key 'friction.posts'"),
])
def test_a_friction_the_spec_gets_wrong_is_one_line(friction, words):
    with pytest.raises(SpecError) as err:
        parse_spec(tutorial(friction), "first_balancer.toml")
    assert words in str(err.value) and "\n" not in str(err.value)


def test_on_a_spring_joining_two_joints_a_guide_acts_on_its_ports_cable_only():
    data = tomllib.loads(SPEC_RR.read_text(encoding="utf-8"))
    data["friction"] = {"guides": [{"spring": 2, "mu": 0.3, "wrap_deg": 90}]}
    with pytest.raises(SpecError, match="spring 2 joins several ports"):
        parse_spec(data, "rr.toml")
    data["friction"] = {"guides": [{"spring": 2, "port": "platform:2", "mu": 0.3, "wrap_deg": 90}]}
    problem = parse_spec(data, "rr.toml")
    ev = evaluate(problem, Design.from_dict(json.loads(TABLE3.read_text()), problem), grid=9)
    band = friction_band(ev)
    np.testing.assert_allclose(band.plus[0], ev.tau[0], rtol=1e-14)  # joint 1 feels nothing
    np.testing.assert_allclose(band.minus[0], ev.tau[0], rtol=1e-14)
    # joint 2: spring 2's term through platform:2 split by e^{±μβ}, spring 3's untouched
    springs = problem.spring_parameters()
    tension = springs.preload[:, None] + springs.rate[:, None] * ev.x
    arm = ev.tensor.arms[1, 1][np.searchsorted(ev.tensor.axes[1], ev.theta[1])]
    term = tension[1] * arm
    L = 0.3 * math.pi / 2
    np.testing.assert_allclose(band.plus[1] - band.minus[1], np.abs(term) * 2 * math.sinh(L), rtol=1e-10, atol=1e-15)
    assert band.width[1].max() > 0
    rows = np.array(band.to_dict([0, 4, 8])["samples"][1])  # every 4th angle of both joints, C order
    np.testing.assert_allclose(rows[:, :2], np.array([[a, b] for a in ev.tensor.axes[0][[0, 4, 8]]
                                                       for b in ev.tensor.axes[1][[0, 4, 8]]]), rtol=1e-15)
    np.testing.assert_allclose(rows[:, 4], band.plus[1].reshape(9, 9)[np.ix_([0, 4, 8], [0, 4, 8])].ravel(), rtol=1e-15)
