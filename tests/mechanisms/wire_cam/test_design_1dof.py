"""`cadcam design` on the 1-DOF model: a verified optimum and files that agree with it."""
import csv
import json
import subprocess
import sys

import numpy as np
import pytest

from cadcam import Design, evaluate, load_spec
from cadcam.cli import main
from cadcam.files import MANIFEST
from cadcam.verify.evaluate import LENGTH_TOL

from ...conftest import SPEC_1DOF, check_output_file


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("design")
    rc = main(["design", str(SPEC_1DOF), "-o", str(out)])
    return rc, out, json.loads((out / "result.json").read_text())


def test_design_succeeds_and_writes_its_files(run):
    rc, out, res = run
    assert rc == 0 and res["status"] == "success"
    for name in ("torque.csv", "torque_recheck.csv", "profile.csv", "profile.png", "torque.png", "springs.png",
                 "cam1.dxf", "cam1.svg", "cam1_points.csv", "cam1_sheet.pdf", "cam1_sheet.png"):
        check_output_file(out / name)
    assert not (out / "cam1.stl").exists()  # STL only on request
    assert [p.name for p in out.iterdir() if p.name.startswith(".")] == [MANIFEST]  # the set's record only
    assert res["torque_model"] == res["friction_model"] == "energy"
    assert res["solver"]["iterations"] > 0 and res["solver"]["solve_time_s"] > 0


def test_constraints_hold_on_the_fine_recheck(run):
    _, _, res = run
    problem = load_spec(SPEC_1DOF)
    fine = res["recheck"]
    assert fine["grid"] == 10 * (problem.options.grid - 1) + 1
    assert fine["violations"] == []
    assert min(fine["convexity_min"]) > 0
    cam = problem.profiles[0]
    assert fine["rho_min"][0] >= cam.rho_min - LENGTH_TOL
    assert fine["rho_max"][0] <= cam.rho_max + LENGTH_TOL
    for s, lo, hi in zip(problem.springs, fine["extension_min"], fine["extension_max"]):
        assert -LENGTH_TOL <= lo and hi <= s.travel + LENGTH_TOL
    assert fine["tangency_residual_max"] <= 1e-10


def test_nlp_and_rootfinder_agree_on_the_tangency(run):
    _, _, res = run
    assert res["solver"]["tangency_nlp_vs_rootfinder_max"] <= 1e-7


def test_reported_metrics_survive_the_interchange_form_and_match_the_nlp_objective(run, capsys):
    _, out, res = run
    # the saved design, read back through the interchange form only (monomial coefficients)
    mono = {"cams": [{"monomial_coefficients": c["monomial_coefficients"]} for c in res["design"]["cams"]],
            "preextension": res["design"]["preextension"]}
    d = out / "mono.json"
    d.write_text(json.dumps(mono))
    assert main(["evaluate", str(SPEC_1DOF), "--design", str(d)]) == 0
    metrics = json.loads(capsys.readouterr().out)["metrics"]
    np.testing.assert_allclose(metrics["rmse"], res["metrics"]["rmse"], rtol=1e-6)
    np.testing.assert_allclose(metrics["max_abs_error"], res["metrics"]["max_abs_error"], rtol=1e-6)
    # and from the result alone (its resolved problem), without the spec; the rootfinder starts
    # from its own guess here, not from the NLP's angles, so the roots agree to its tolerance
    problem = load_spec(out / "result.json")
    ev = evaluate(problem, Design.from_dict(res, problem))
    np.testing.assert_allclose(ev.metrics.rmse, res["metrics"]["rmse"], rtol=1e-9)
    # the NLP's own objective (its segment quadrature, its tangency variables, its split
    # s⁺ + s⁻ ≥ |x̄·a|) agrees with the independent evaluation
    assert res["solver"]["objective"] == pytest.approx(res["metrics"]["objective"], rel=1e-5)
    # torque.csv holds the same torques
    rows = list(csv.DictReader(open(out / "torque.csv")))
    err = np.array([float(r["error1_Nm"]) for r in rows])
    assert np.sqrt(np.mean(err**2)) == pytest.approx(res["metrics"]["rmse"][0], rel=1e-12)


def test_ipopt_steps_stay_bounded(run):
    # the sensitivity terms are split as s⁺ − s⁻ = x̄·a: split as a alone and weighted by x̄,
    # s± cost nothing where a spring is slack (x̄ = 0, as spring 1 is here at its optimum) and
    # IPOPT's barrier pushed both up together, with steps of 1.4e7 (scaled units: mm)
    _, _, res = run
    assert max(res["solver"]["history"]["d_norm"]) < 1e4


def test_optimum_beats_the_circular_start_and_tracks_the_target(run):
    _, _, res = run
    from cadcam.optimize import default_start
    problem = load_spec(SPEC_1DOF)
    start = evaluate(problem, default_start(problem))
    assert res["metrics"]["objective"] < 0.01 * start.metrics.objective
    # τ_d reaches 0.08·(π/2)² ≈ 197 N·mm; the optimum tracks it to ~1 %
    assert res["metrics"]["rmse"][0] < 2e-3


def test_design_leaves_a_dxf_of_a_closed_cam_with_its_bore(run):
    import ezdxf
    _, out, res = run
    doc = ezdxf.readfile(out / "cam1.dxf")
    msp = doc.modelspace()
    (profile,) = msp.query('LWPOLYLINE[layer=="PROFILE"]')
    assert profile.closed
    pts = np.array([p[:2] for p in profile.get_points()])
    radii = np.hypot(*pts.T)
    # the designed arc, the cable's centre line, starts at the anchor (ρ(0), 0); the first vertex
    # is the cut outline's, the cable's radius r inside along the outward normal (ρ(0), −ρ′(0))
    rho0, drho0 = (1e3 * v for v in res["design"]["cams"][0]["monomial_coefficients"][:2])
    r = 1e3 * res["problem"]["workshop"]["cable_diameter"] / 2
    assert r > 0
    cut = np.array([rho0, 0.0]) - r * np.array([rho0, -drho0]) / np.hypot(rho0, drho0)
    np.testing.assert_allclose(pts[0], cut, rtol=0, atol=1e-9)
    bores = [c.dxf.radius for c in msp.query('CIRCLE[layer=="HOLES"]')]
    assert 3.0 in bores  # the default Ø6 mm bore on the rotation axis
    assert radii.min() > 3.0 + 1.0  # at least 1 mm of wall around it


@pytest.mark.slow  # seconds of designs: make test-slow
def test_stl_on_request_and_bad_workshop_sizes(tmp_path, capsys):
    """Without figures (the STL and the workshop's verdict are made without them, and
    test_design_succeeds_and_writes_its_files checks the figures of the same command)."""
    out = tmp_path / "s"
    assert main(["design", str(SPEC_1DOF), "-o", str(out), "--stl", "0.005", "--no-figures"]) == 0
    reported = float(capsys.readouterr().out.split("STL ")[1].split(" mm³")[0])
    assert check_output_file(out / "cam1.stl") == pytest.approx(reported, rel=1e-3)  # the file's own volume
    # a groove wider than the part is thick: the design stands, its solid cannot be made
    assert main(["design", str(SPEC_1DOF), "-o", str(tmp_path / "b"), "--stl", "0.005",
                 "--groove-depth", "0.001", "--groove-width", "0.006", "--no-figures"]) == 1
    err = capsys.readouterr().err
    assert "workshop files cannot be made: cam1:" in err and "groove_width" in err
    assert err.count("\n") == 1 and (tmp_path / "b" / "result.json").exists()
    record = json.loads((tmp_path / "b" / "result.json").read_text())
    assert record["status"] == "success"  # the design's own outcome, beside the workshop's
    assert record["workshop"]["status"] == "failed" and "groove_width" in record["workshop"]["message"]
    assert json.loads((out / "result.json").read_text())["workshop"]["status"] == "written"


def test_spec_workshop_table_sizes_the_files_and_a_flag_overrides_it(tmp_path):
    import ezdxf
    spec = tmp_path / "sized.toml"
    spec.write_text(SPEC_1DOF.read_text().replace(
        "[workshop]\n", "[workshop]\nbore_diameter = 0.005\nanchor_diameter = 0.002\n", 1))
    out = tmp_path / "o"
    # a grid of 12 (the sizes the files are cut to are the workshop's, whatever the design grid)
    assert main(["design", str(spec), "-o", str(out), "--no-figures", "--grid", "12", "--bore-diameter", "0.004"]) == 0
    holes = ezdxf.readfile(out / "cam1.dxf").modelspace().query('CIRCLE[layer=="HOLES"]')
    assert sorted(c.dxf.radius for c in holes) == pytest.approx([1.0, 2.0])  # anchor from the spec, bore from the flag
    workshop = json.loads((out / "result.json").read_text())["problem"]["workshop"]
    assert workshop["bore_diameter"] == 0.004 and workshop["anchor_diameter"] == 0.002  # the sizes used
    assert load_spec(out / "result.json").workshop.bore_diameter == 0.004  # and they load back


def test_failed_solve_writes_its_status_and_exits_1(tmp_path):
    # a 0.3 N·mm² torque is out of reach with a 2-iteration budget: the result says so
    # (without figures, which say nothing of the status or the exit code)
    spec = tmp_path / "short.toml"
    spec.write_text(SPEC_1DOF.read_text().replace("quadrature_order = 2", "quadrature_order = 2\nmax_iter = 2"))
    out = tmp_path / "o"
    p = subprocess.run([sys.executable, "-m", "cadcam", "design", str(spec), "-o", str(out), "--no-figures"],
                       capture_output=True, text=True)
    assert p.returncode == 1
    res = json.loads((out / "result.json").read_text())
    assert res["status"] == "max_iterations"
    assert res["solver"]["iterations"] == 2
