"""The command lines the README and the issues name, and spec overrides by dotted key."""
import json
import subprocess
import sys

import numpy as np
import pytest

from cadcam import load_spec
from cadcam.cli import main
from cadcam.spec import SpecError

from .conftest import ROOT, SPEC_1DOF, SPEC_RR, TABLE3


def test_evaluate_table3_as_printed_from_the_command_line():
    p = subprocess.run([sys.executable, "-m", "cadcam", "evaluate", str(SPEC_RR), "--design", str(TABLE3),
                        "--grid", "46", "--torque-model", "force-as-printed"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert out["torque_model"] == "force-as-printed"
    # docs/physics.md (independent values): ≈ 270 / 862 (cam 1) and ≈ 128 / 389 N·mm (cam 2)
    np.testing.assert_allclose(np.array(out["metrics"]["rmse"]) * 1e3, [270, 128], rtol=0.01)
    np.testing.assert_allclose(np.array(out["metrics"]["max_abs_error"]) * 1e3, [862, 389], rtol=0.01)
    # the papers' coefficient order is printed back next to the increasing one
    assert out["design"]["cams"][0]["monomial_coefficients_highest_first"] == [-0.0052, 0.0133, 0.0046, 0.025]


def test_variant_applies_the_sec10_5_weights():
    base, v = load_spec(SPEC_RR), load_spec(SPEC_RR, "sec10_5")
    assert [c.tracking_weight for c in base.joints] == [10.0, 10.0]
    assert [c.tracking_weight for c in v.joints] == [1.0, 1.0]
    assert all(c.sensitivity_weights == (1000.0,) * 3 for c in v.joints)


def test_set_overrides_by_dotted_key():
    p = load_spec(SPEC_1DOF, overrides=[("springs.1.rate", 1200.0), ("cams.*.order", 5),
                                        ("solver.grid", 31)])
    assert p.springs[0].rate == 1200.0 and p.profiles[0].basis.order == 5 and p.options.grid == 31


@pytest.mark.parametrize("key,value,message", [
    ("springs.3.rate", 1.0, "has 2 entries"),
    ("spring.1.rate", 1.0, "the spec has no 'spring'"),
    ("springs.1.rate.x", 1.0, "is a value"),
    ("cams.1.colour", 1.0, "unknown key 'cams[1].colour'"),
    ("springs.1.rate", "soft", "springs[1].rate = 'soft'"),
])
def test_bad_overrides_are_refused_in_one_line(key, value, message):
    with pytest.raises(SpecError) as err:
        load_spec(SPEC_1DOF, overrides=[(key, value)])
    assert message in str(err.value) and "\n" not in str(err.value)


def test_cli_set_and_unknown_variant(tmp_path, capsys):
    d = tmp_path / "d.json"
    d.write_text(TABLE3.read_text())
    assert main(["evaluate", str(SPEC_RR), "--design", str(d), "--grid", "5",
                 "--set", "springs.2.rate=0.0"]) == 2
    assert "springs[2].rate = 0.0: expected the spring's rate k: a number > 0" in capsys.readouterr().err
    assert main(["evaluate", str(SPEC_RR), "--design", str(d), "--variant", "nope"]) == 2
    assert "no variant 'nope'" in capsys.readouterr().err
    assert main(["evaluate", str(SPEC_RR), "--design", str(d), "--grid", "5",
                 "--set", "springs.2.rate=7000.0"]) == 0


def test_readme_general_form_spec_loads_and_matches_the_shorthand(tmp_path):
    """The guide's [[joints]]/[[mechanisms]] example is a valid spec, and it is the 1-DOF model
    (written in the [[cams]] shorthand) with a preload on spring 2."""
    import re
    from pathlib import Path
    readme = (Path(__file__).resolve().parents[1] / "docs" / "guide.md").read_text()
    (tmp_path / "general.toml").write_text(re.search(r"```toml\n(name = \"example_1dof\".*?)```", readme, re.S)[1])
    general, shorthand = load_spec(tmp_path / "general.toml"), load_spec(SPEC_1DOF)
    assert general.mechanisms[0].parameter_values() == shorthand.mechanisms[0].parameter_values()
    assert [s.rate for s in general.springs] == [s.rate for s in shorthand.springs]
    assert [s.preload for s in general.springs] == [0.0, 23.22]
    assert general.joints[0].sensitivity_weights == shorthand.joints[0].sensitivity_weights


def test_evaluate_grid_is_capped_like_the_recheck_not_like_a_design_grid(monkeypatch, capsys):
    """``cadcam evaluate --grid N`` streams the N^m points exactly and holds none of them, so
    N^m is capped by recheck_points, not by grid_points (which a design grid's N^m is)."""
    monkeypatch.setenv("CADCAM_CAP_GRID_POINTS", "100")
    monkeypatch.setenv("CADCAM_CAP_RECHECK_POINTS", "1000")
    # the spec's own grid, 5² points and a re-check of 9², fits the lowered caps
    spec = [str(SPEC_RR), "--set", "solver.grid=5", "--set", "solver.recheck_factor=2"]
    assert main(["evaluate", *spec, "--design", str(TABLE3), "--grid", "20"]) == 0  # 400 points
    metrics = json.loads(capsys.readouterr().out)["metrics"]
    assert metrics["grid"] == 20 and np.isfinite(metrics["rmse"]).all()
    # the same grid as a design grid is refused: it would hold 400 points in memory
    assert main(["check", *spec, "--grid", "20", "--no-nlp"]) == 2
    assert "design grid would hold 400 points" in capsys.readouterr().err
    assert main(["evaluate", *spec, "--design", str(TABLE3), "--grid", "32"]) == 2  # 1024 points
    err = capsys.readouterr().err
    assert err == ("cadcam: error: --grid: the evaluation would stream 1,024 points (grid^2), beyond the "
                   "cap 1,000: lower grid, or raise the cap deliberately with CADCAM_CAP_RECHECK_POINTS\n")


def test_evaluate_grid_beyond_the_recheck_caps_is_refused_before_any_work(tmp_path, capsys):
    from cadcam.optimize import default_start

    def start(spec):
        path = tmp_path / f"{spec.stem}.json"
        path.write_text(json.dumps(default_start(load_spec(spec)).to_dict()))
        return str(path)
    spec = ROOT / "models" / "johnston2023_three_cam_arm.toml"
    # 1001³ points, beyond the default recheck_points 1e9
    assert main(["evaluate", str(spec), "--design", start(spec), "--grid", "1001"]) == 2
    err = capsys.readouterr().err
    assert "--grid: the evaluation would stream 1,003,003,001 points (grid^3), beyond the cap 1,000,000,000" in err
    assert err.count("\n") == 1
    # one joint: the angles per joint, whose samples are held, are capped at the re-check's
    # largest, (2000 − 1)·100 + 1
    assert main(["evaluate", str(SPEC_1DOF), "--design", start(SPEC_1DOF), "--grid", "199902"]) == 2
    err = capsys.readouterr().err
    assert "--grid: 199902 angles per joint exceed the cap 199901" in err and err.count("\n") == 1
