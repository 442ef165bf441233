"""Every malformed spec gets one line naming file, key and expected form, and exit code 2."""
import subprocess
import sys

import pytest

import cadcam

from cadcam.cli import main

from .conftest import SPEC_1DOF

BASE = SPEC_1DOF.read_text()

CASES = {
    "unknown top-level key": ("torque_model = \"energy\"", "torque_model = \"energy\"\ncolour = 1",
                              "unknown key 'colour'"),
    "unknown cam key": ("order = 3", "order = 3\nradius = 0.02", "unknown key 'cams[1].radius'"),
    "unknown idler key": ("offset = 0.015", "offset = 0.015\nheight = 1.0", "cams[1].idler.height"),
    "missing spring rate": ("rate = 1100.0\n", "", "missing key 'springs[1].rate'"),
    "missing idler radius": ("radius = 0.020\n", "", "missing key 'cams[1].idler.radius'"),
    "missing rho_min": ("rho_min = 0.010\n", "", "missing key 'cams[1].rho_min'"),
    "missing target": ("[cams.target]\nkind = \"expression\"\nexpression = \"0.08*theta**2\"\n", "",
                       "missing key 'cams[1].target'"),
    "rate as a string": ("rate = 1100.0", "rate = \"1100\"", "springs[1].rate = '1100'"),
    "order not an integer": ("order = 3", "order = 3.5", "cams[1].order = 3.5"),
    "range as a string": ("theta_range_deg = [0.0, 90.0]", "theta_range_deg = \"0..90\"",
                          "cams[1].theta_range_deg"),
    "negative rate": ("rate = 7350.0", "rate = -7350.0", "springs[2].rate = -7350.0: expected the spring's rate k: a number > 0 [N/m]"),
    "zero rate": ("rate = 1100.0", "rate = 0.0", "springs[1].rate = 0.0: expected the spring's rate k: a number > 0 [N/m]"),
    "rho_min >= rho_max": ("rho_max = 0.100", "rho_max = 0.010", "cams[1].rho_max = 0.01"),
    "empty angle range": ("theta_range_deg = [0.0, 90.0]", "theta_range_deg = [90.0, 90.0]",
                          "0 < max − min ≤ 3600 [deg]"),
    "reversed angle range": ("theta_range_deg = [0.0, 90.0]", "theta_range_deg = [90.0, 0.0]",
                             "0 < max − min ≤ 3600 [deg]"),
    "target not finite": ("0.08*theta**2", "0.08/theta", "a divisor that is zero or changes sign (a pole) near theta = [0.0] deg"),
    "target with code": ("0.08*theta**2", "__import__('os').getcwd()", "__import__('os').getcwd"),
    "target attribute": ("0.08*theta**2", "theta.real", "Attribute 'theta.real' is not allowed"),
    "unknown torque model": ("torque_model = \"energy\"", "torque_model = \"coulomb\"",
                             "torque_model = 'coulomb'"),
    "old and new model keys": ("torque_model = \"energy\"",
                               "torque_model = \"energy\"\nfriction_model = \"exact\"",
                               "give only torque_model"),
    "port the mechanism lacks": ("ports = [\"wire:1\"]", "ports = [\"cable:1\"]",
                                 "a port of mechanism 1 (wire_cam): wire, platform"),
    "negative preload": ("rate = 1100.0", "rate = 1100.0\npreload = -1.0", "springs[1].preload = -1.0"),
    "fixed pre-extension past the travel": ("rate = 1100.0", "rate = 1100.0\npreextension = 1.0",
                                            "springs[1].preextension = 1.0"),
    "bad port": ("ports = [\"wire:1\"]", "ports = [\"rope:1\"]", "springs[1].ports"),
    "port of a missing cam": ("ports = [\"wire:1\"]", "ports = [\"wire:2\"]", "a mechanism number between 1 and 1"),
    "wrong number of weights": ("sensitivity_weights = [1.0, 1.0]", "sensitivity_weights = [1.0]",
                                "one weight per spring of ∫|∂τ/∂k_j| in the objective (Johnston2023 Eq. 47): a list of 2 numbers"),
    "not TOML": ("[solver]", "[solver", "not valid TOML"),
    "workshop bore of zero": ("[workshop]", "[workshop]\nbore_diameter = 0.0",
                              "workshop.bore_diameter = 0.0: expected the shaft bore of every planar outline: a number in [0.0001, 1] [m]"),
    "workshop tolerance in mm": ("[workshop]", "[workshop]\ntolerance = 0.01",
                                 "workshop.tolerance = 0.01: expected the loosest fit of the DXF and SVG arcs and the CSV and STL polygons (the files are fitted tighter where the design's accuracy asks): a number in [1e-07, 0.001] [m]"),
    "unknown workshop key": ("[workshop]", "[workshop]\nbore = 0.004",
                             "unknown key 'workshop.bore'"),
    "workshop not a table": ("[workshop]\n", "workshop = 0.004\n[ignored]\n",
                             "workshop = 0.004: expected sizes of the workshop files (see [workshop]): a table"),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_spec_gives_one_line_and_exit_2(name, tmp_path, capsys):
    old, new, expected = CASES[name]
    assert old in BASE
    spec = tmp_path / "bad.toml"
    spec.write_text(BASE.replace(old, new, 1))
    out = tmp_path / "out"
    assert main(["design", str(spec), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("cadcam: error: ")
    assert str(spec) in err
    assert expected in err
    assert not out.exists()  # nothing written for bad input


def test_missing_spec_file(tmp_path, capsys):
    assert main(["evaluate", str(tmp_path / "none.toml"), "--design", "x.json"]) == 2
    assert "none.toml: the spec: cannot read it (No such file" in capsys.readouterr().err


def test_bad_design_file(tmp_path, capsys):
    d = tmp_path / "d.json"
    d.write_text('{"design": {"cams": [{"monomial_coefficients": [0.02]}], "preextension": [0.0]}}')
    assert main(["evaluate", str(SPEC_1DOF), "--design", str(d)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "preextension must hold 2" in err


def test_no_traceback_from_the_command(tmp_path):
    spec = tmp_path / "bad.toml"
    spec.write_text(BASE.replace("rate = 1100.0", "rate = -1.0"))
    p = subprocess.run([sys.executable, "-m", "cadcam", "design", str(spec), "-o", str(tmp_path / "o")],
                       capture_output=True, text=True)
    assert p.returncode == 2
    assert "Traceback" not in p.stderr and p.stderr.count("\n") == 1


def test_acceptance_on_a_joint_without_a_torque_target_is_refused(tmp_path, capsys):
    """[joints.acceptance] on a joint whose target is kind = "none" was ignored: refused now."""
    robot = SPEC_1DOF.parent / "fedorov2018_cable_robot.toml"
    spec = tmp_path / "robot.toml"
    spec.write_text(robot.read_text().replace('[joints.target]\nkind = "none"',
                                              '[joints.acceptance]\nrmse = 1.0\n\n[joints.target]\nkind = "none"'))
    assert "[joints.acceptance]" in spec.read_text()
    assert main(["design", str(spec), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "joints[1].acceptance" in err and 'kind = "none"' in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("grow, words", [
    (lambda d: d.update(cams=d["cams"] * 1500), "cams: 1500 exceed the cap 16"),
    (lambda d: d.update(springs=[d["springs"][0]] * 3000), "springs: 3000 exceed the cap 128"),
])
def test_counts_beyond_their_caps_are_refused_before_any_work(grow, words):
    """1,500 cams crashed formatting the cap's own message; 3,000 springs on one port were
    still building after 90 s."""
    import tomllib

    from cadcam.spec import SpecError, parse_spec

    data = tomllib.loads(BASE)
    grow(data)
    with pytest.raises(SpecError, match=words):
        parse_spec(data, "x.toml")


def test_mechanisms_on_one_joint_beyond_their_cap_are_refused():
    """400 anchored pulleys on one joint ended in std::bad_alloc."""
    import tomllib

    from cadcam.spec import SpecError, parse_spec

    data = tomllib.loads((SPEC_1DOF.parent / "ludovico2021_pendulum.toml").read_text())
    data["mechanisms"] = [dict(data["mechanisms"][0], name=f"p{i}") for i in range(400)]
    with pytest.raises(SpecError, match=r"the mechanisms on joints\[1\]: 400 exceed the cap 8"):
        parse_spec(data, "x.toml")


def test_a_size_message_never_fails_to_format():
    from cadcam.problem import Options, size_error

    name, message = size_error(Options(grid=46), 1500)
    assert name == "grid" and "about 10^2494 points" in message


@pytest.mark.parametrize("expression, degrees", [
    ("(theta-0.5)**(-1)", 90), ("0.01/(theta-0.5)**2", 90), ("0.01/sqrt((theta-0.5)**2)", 90),
    ("0.01*exp(-log((theta-0.5)**2))", 90), ("tan(theta)", 90), ("0.01/cos(theta)**2", 100),
])
def test_a_target_with_a_pole_the_form_hides_is_refused_by_its_values(expression, degrees):
    """Each of these ended success with max errors from 1.2e3 to 2.7e30 N·m: the guards read the
    expression's form, and these poles hide from it."""
    with pytest.raises(cadcam.SpecError, match="has a pole or a jump near theta"):
        cadcam.load_problem(SPEC_1DOF, overrides=[("cams.1.target.expression", expression),
                                                  ("cams.1.theta_range_deg", [0.0, degrees])])


@pytest.mark.parametrize("expression", ["0.1*exp(-100*(theta-1)**2)", "0.1*tanh(20*(theta-0.7))", "sqrt((theta-0.5)**2)"])
def test_a_steep_or_kinked_but_bounded_target_is_accepted(expression):
    problem = cadcam.load_problem(SPEC_1DOF, overrides=[("cams.1.target.expression", expression)])
    assert problem.joints[0].target.data["expression"] == expression


def test_a_planar_profile_over_more_than_a_turn_is_refused():
    """An Endo2010 pulley over [18°, 738°] collapsed to a 5 mm circle and reported success."""
    with pytest.raises(cadcam.SpecError, match=r"joints\[1\]\.theta_range_deg = \[18, 738\]: expected a span of "
                                              r"at most 360°: mechanism 'pulley'"):
        cadcam.load_problem(SPEC_1DOF.parent / "endo2010_ordinary.toml",
                            overrides=[("joints.1.theta_range_deg", [18.0, 738.0])])
    robot = cadcam.load_problem(SPEC_1DOF.parent / "fedorov2018_cable_robot.toml")  # helical grooves: 900°
    lo, hi = robot.joints[0].theta_range
    assert hi - lo > 2 * 3.1416


def test_minimax_on_joints_coupled_by_a_spring_is_a_spec_error():
    """The RR arm with solver.objective = "minimax" ended in a ValueError traceback."""
    with pytest.raises(cadcam.SpecError, match=r"solver.objective = 'minimax' needs joint torques"):
        cadcam.design(SPEC_1DOF.parent / "johnston2023_rr_arm.toml", overrides={"solver.objective": "minimax"})


def test_an_output_law_beyond_the_slider_is_refused_before_the_envelope_start(tmp_path, capsys):
    """Fedorov's balancer with the pendulum's mass × 100 ended in a rootfinder traceback (its
    acceptance is opened here, else its springs' energy budget refuses it first)."""
    spec = tmp_path / "heavy.toml"
    text = (SPEC_1DOF.parent / "fedorov2018_balancer.toml").read_text().replace("mass = 0.17", "mass = 17.0")
    spec.write_text(text.replace("[[mechanisms]]", "[joints.acceptance]\nrelative_rmse = 1.0\n\n[[mechanisms]]", 1))
    assert main(["design", str(spec), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "outside its slider_range [100, 200] mm" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("target", ["missing/folder", "loop"])
@pytest.mark.parametrize("command", [["design", str(SPEC_1DOF), "-o", "{}"],
                                     ["design", str(SPEC_1DOF), "-o", "{}/sub"],
                                     ["sweep", str(SPEC_1DOF.parents[1] / "studies" / "basis_order.toml"), "-o", "{}"]])
def test_an_output_through_a_link_to_nothing_is_refused_before_work(tmp_path, capsys, target, command):
    """'-o' at a dangling symbolic link or a loop solved first and failed after."""
    link = tmp_path / "link"
    link.symlink_to(tmp_path / target if target != "loop" else link)
    assert main([a.format(link) for a in command]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "is a symbolic link to nothing" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link"]
