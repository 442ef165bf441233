"""Exported code: generated C, shared library, serialized Functions, and the guide's example (docs/guide.md)."""
import json
import re
import shutil
import subprocess
import sys

import casadi as ca
import numpy as np
import pytest

from cadcam import Design, load_spec
from cadcam.mechanisms.base import DepartureSolver, newton_from_function
from cadcam.export.codegen import WARNINGS, export, model_functions
from cadcam.optimize import optimize
from cadcam.verify.model import NEWTON_STEPS, solved_poses, torque_function

from ..conftest import ROOT, SPEC_1DOF, SPEC_RR, TABLE3

GCC = shutil.which("gcc") or shutil.which("cc")
needs_gcc = pytest.mark.skipif(GCC is None, reason="no C compiler on this machine")


@pytest.fixture(scope="module")
def rr():
    problem = load_spec(SPEC_RR)
    return problem, Design.from_dict(json.loads(TABLE3.read_text()), problem)


@pytest.fixture(scope="module")
def exported(rr, tmp_path_factory):
    out = tmp_path_factory.mktemp("model")
    formats = ["c", "casadi"] + (["shared"] if GCC else [])
    return out, export(*rr, "model", formats, out)


def _inputs(problem, design, rng):
    return [rng.uniform(0.05, 1.5, len(problem.joints)), np.concatenate(design.coefficients)
            * (1 + 1e-3 * rng.standard_normal(sum(b.size for b in design.bases))),
            np.array([s.rate for s in problem.springs]) * rng.uniform(0.9, 1.1, len(problem.springs)),
            design.preextension + rng.uniform(0, 2e-3, len(problem.springs)),
            rng.uniform(0, 20.0, len(problem.springs))]


def test_unrolled_newton_matches_the_rootfinder(rr):
    problem, design = rr
    for i, (mech, b) in enumerate(zip(problem.mechanisms, design.bases)):
        theta = np.linspace(0, np.pi / 2, 451)
        structure, q = (type(mech), (b,)), mech.parameter_values()
        solver = DepartureSolver(structure)
        z, _ = solver.solve(theta, design.coefficients[i], q)
        start = solver.guess(theta, design.coefficients[i], q)  # near-circular cams: the guess is close
        zn = np.asarray(newton_from_function(structure, NEWTON_STEPS).map(451)(theta, start, design.coefficients[i], q))
        assert np.abs(zn - z).max() <= 1e-12


def test_exported_model_and_jacobians_equal_the_rootfinder_model(rr):
    """Newton + explicit implicit-function Jacobians against the MX rootfinder model."""
    problem, design = rr
    f, jac = model_functions(problem, design)
    ref = torque_function(problem, design.bases)
    names = [n for n in jac.name_out()]
    ref_jac = ref.factory("refjac", ["theta", "c", "k", "x0", "F0"],
                          [f"jac:{n[1:].split('_d')[0]}:{n.split('_d')[-1]}" for n in names])
    rng = np.random.default_rng(5)
    for _ in range(3):
        args = _inputs(problem, design, rng)
        for a, b in zip(f(*args), ref(*args)):
            np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-12, atol=1e-15)
        for name, a, b in zip(names, jac(*args), ref_jac(*args)):
            scale = np.abs(np.asarray(b)).max()
            assert np.abs(np.asarray(a) - np.asarray(b)).max() <= 1e-10 * scale, name


@pytest.mark.parametrize("spec, variant", [("endo2010_inverted", None), ("endo2010_ordinary", None),
                                           ("ludovico2021_generic", "moment_arm")])
def test_exported_model_equals_the_recheck_over_the_whole_fine_grid(spec, variant):
    """Strongly non-circular pulleys, where the closed-form guess sends Newton to a root outside
    the wrap (τ ~ 1e110 N·m on Endo's inverted pendulum; NaN on Ludovico's generic torque, whose
    moment-arm pulleys are order-35 polynomials on a short polar range, one of them round a
    tight corner) or where the departure nears a fold (the end of Endo's ordinary pendulum's
    range): the exported model and the rootfinder model, started from the design's poses, give
    the re-check's torque at every angle of its fine grid."""
    result = optimize(load_spec(ROOT / "models" / f"{spec}.toml", variant=variant))
    problem, design, fine = result.problem, result.design, result.recheck
    assert result.success, result.message
    args = [fine.theta, np.concatenate(design.coefficients), [s.rate for s in problem.springs],
            design.preextension, [s.preload for s in problem.springs]]
    exported, _ = model_functions(problem, design)
    rootfinder = torque_function(problem, design.bases, poses=solved_poses(problem, design))
    for model in (exported, rootfinder):
        tau = np.asarray(model.map(fine.theta.shape[1])(*args)[0])
        assert np.abs(tau - fine.tau).max() <= 1e-10 * np.abs(fine.tau).max()


@needs_gcc
def test_generated_c_compiles_warning_free(exported, tmp_path):
    """At -O1; at -O2 test_readme_c_example_compiles_and_runs compiles the same file with the
    same warnings as errors (beside the guide's example, as the guide does)."""
    out, _ = exported
    run = subprocess.run([GCC, *WARNINGS, "-O1", "-c", str(out / "cadcam_model.c"), "-o", str(tmp_path / "m.o")],
                         capture_output=True, text=True)
    assert run.returncode == 0 and run.stderr == "", run.stderr


@needs_gcc
def test_shared_library_matches_in_process_values_and_jacobians(rr, exported):
    problem, design = rr
    out, manifest = exported
    rng = np.random.default_rng(11)
    for fn in model_functions(problem, design):
        ext = ca.external(fn.name(), str(out / "libcadcam_model.so"))
        for _ in range(5):
            args = _inputs(problem, design, rng)
            for a, b in zip(ext(*args), fn(*args)):
                a, b = np.asarray(a), np.asarray(b)
                assert np.abs(a - b).max() <= 1e-12 * max(np.abs(b).max(), 1e-300)
    shapes = {f["name"]: [o["shape"] for o in f["outputs"]] for f in manifest["functions"]}
    assert shapes["cadcam_torque"] == [[2, 1], [3, 1], [4, 1]]  # τ per joint, x per spring, z


def test_serialized_functions_load_in_a_fresh_interpreter(rr, exported):
    problem, design = rr
    out, _ = exported
    args = _inputs(problem, design, np.random.default_rng(2))
    code = ("import sys, json, casadi as ca, numpy as np\n"
            "f = ca.Function.load(sys.argv[1]); a = json.loads(sys.argv[2])\n"
            "print(json.dumps([np.asarray(v).ravel(order='F').tolist() for v in f(*a)]))")
    for fn in model_functions(problem, design):
        run = subprocess.run([sys.executable, "-c", code, str(out / f"{fn.name()}.casadi"),
                              json.dumps([a.tolist() for a in args])], capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
        for a, b in zip(json.loads(run.stdout), fn(*args)):
            np.testing.assert_allclose(a, np.asarray(b).ravel(order="F"), rtol=1e-14, atol=0)


@needs_gcc
def test_readme_c_example_compiles_and_runs(rr, exported, tmp_path):
    problem, design = rr
    out, _ = exported
    readme = (ROOT / "docs" / "guide.md").read_text()
    example = re.search(r"<!-- c-example -->\s*```c\n(.*?)```", readme, re.S)[1]
    (tmp_path / "example.c").write_text(example)
    exe = tmp_path / "example"
    build = subprocess.run([GCC, *WARNINGS, "-O2", f"-I{out}", str(tmp_path / "example.c"),  # as the guide
                            str(out / "cadcam_model.c"), "-lm", "-o", str(exe)], capture_output=True, text=True)
    assert build.returncode == 0 and build.stderr == "", build.stderr
    run = subprocess.run([str(exe)], capture_output=True, text=True)
    assert run.returncode == 0
    values = [float(v) for v in re.findall(r"[-+]?\d\.\d+(?:e[-+]\d+)?", run.stdout)]
    f, jac = model_functions(problem, design)
    args = [np.array([0.5, 0.3]), np.concatenate(design.coefficients),
            np.array([s.rate for s in problem.springs]), design.preextension,
            np.array([s.preload for s in problem.springs])]
    tau = np.asarray(f(*args)[0]).ravel()
    J = dict(zip(jac.name_out(), (np.asarray(v) for v in jac(*args))))
    np.testing.assert_allclose(values, [tau[0], tau[1], J["dtau_dtheta"][0, 1], J["dtau_dk"][0, 1]],
                               rtol=1e-12)


@needs_gcc
@pytest.mark.slow  # compiles the whole exported NLP: minutes on two cores
def test_problem_export_compiles_and_matches_the_solver(tmp_path):
    problem = load_spec(SPEC_1DOF).with_options(grid=8, convexity_points=10)
    from cadcam.optimize import default_start
    manifest = export(problem, default_start(problem), "problem", ["c", "casadi"], tmp_path)
    names = [f["name"] for f in manifest["functions"]]
    assert names == ["cadcam_nlp_f", "cadcam_nlp_g", "cadcam_nlp_grad_f", "cadcam_nlp_jac_g", "cadcam_nlp_hess_l"]
    for level in ("-O1", "-O2"):
        run = subprocess.run([GCC, *WARNINGS, level, "-c", str(tmp_path / "cadcam_problem.c"),
                              "-o", str(tmp_path / "p.o")], capture_output=True, text=True)
        assert run.returncode == 0 and run.stderr == "", (level, run.stderr)
    data = json.loads((tmp_path / "problem_data.json").read_text())
    x, p = np.array(data["x0"]), np.array(data["p"])
    g = ca.Function.load(str(tmp_path / "cadcam_nlp_g.casadi"))(x, p)
    g = np.asarray(g).ravel()
    lbg, ubg = np.array(data["lbg"], dtype=float), np.array(data["ubg"], dtype=float)
    # the start is the design's feasible tangency: equality rows hold there
    eq = lbg == ubg
    assert np.abs(g[eq] - lbg[eq]).max() < 1e-9


def test_problem_export_holds_each_per_angle_function_once_whatever_the_grid(tmp_path):
    """The exported NLP's C is the mapped graph: a grid 4× finer adds only its longer sparsity
    patterns and loop bounds (an expanded graph would be about 4× larger)."""
    from cadcam.optimize import default_start
    sizes = []
    for n in (8, 32):
        problem = load_spec(SPEC_1DOF).with_options(grid=n, convexity_points=10)
        export(problem, default_start(problem), "problem", ["c"], tmp_path / str(n))
        sizes.append((tmp_path / str(n) / "cadcam_problem.c").stat().st_size)
    assert sizes[1] < 1.3 * sizes[0]


def test_model_manifest_labels_every_input_and_output(rr, exported):
    problem, _ = rr
    _, manifest = exported
    torque, jac = manifest["functions"]
    units = {e["name"]: e["unit"] for e in torque["inputs"] + torque["outputs"]}
    assert units == {"theta": "rad", "c": "m", "k": "N/m", "x0": "m", "F0": "N", "tau": "N·m",
                     "x": "m", "z": "SI (see z_layout)"}
    assert all(e["description"] for f in (torque, jac) for e in f["inputs"] + f["outputs"])
    jac_units = {e["name"]: e["unit"] for e in jac["outputs"]}
    assert jac_units["dtau_dk"] == "N·m/(N/m)" and jac_units["dx_dtheta"] == "m/rad"
    z_rows = dict((e["name"], e["shape"][0]) for e in torque["outputs"])["z"]
    assert len(manifest["z_layout"]) == z_rows == sum(len(m.unknowns) for m in problem.mechanisms)
    # the guide states the signature the manifest describes
    signature = (f"cadcam_torque({', '.join(e['name'] for e in torque['inputs'])}) -> "
                 f"({', '.join(e['name'] for e in torque['outputs'])})")
    assert signature in (ROOT / "docs" / "guide.md").read_text()


#: The roles a block of the NLP's vectors may have (cadcam.solve.blocks).
ROLES = {"design", "departure", "auxiliary", "grid", "weights", "target", "mechanism", "limits", "springs",
         "tolerances"}


def _check_layout(layout, size):
    """Blocks in offset order, without gaps or overlaps, covering the vector, each described."""
    offset = 0
    for block in layout:
        assert block["offset"] == offset, block
        assert block["size"] > 0 and block["unit"] and block["description"], block
        assert block["role"] in ROLES, block
        offset += block["size"]
    assert offset == size


def test_problem_manifest_labels_the_decision_vector_block_by_block(rr, tmp_path):
    """The NLP's x is profile coefficients, departure unknowns, pre-extensions and auxiliary
    variables (it was labelled "spring extensions, m"); each block's stated unit turns the
    exported start back into the design's SI numbers."""
    from cadcam.optimize import default_start

    problem = rr[0].with_options(grid=6, convexity_points=10)
    design = default_start(problem)
    manifest = export(problem, design, "problem", ["casadi"], tmp_path)
    data = json.loads((tmp_path / "problem_data.json").read_text())
    for f in manifest["functions"]:
        for e in f["inputs"] + f["outputs"]:
            assert e.get("unit") and e.get("description"), (f["name"], e["name"])
            if e["name"] == "x":
                assert "spring extension" not in e["description"] and "x_layout" in e["unit"]
    x_layout, p_layout = manifest["x_layout"], manifest["p_layout"]
    _check_layout(x_layout, len(data["x0"]))
    _check_layout(p_layout, len(data["p"]))
    assert [b["name"] for b in x_layout] == list(data["variables"])  # the transcription's order
    blocks = {b["name"]: b for b in x_layout}
    x0 = np.array(data["x0"])
    to_si = {"mm": 1e-3, "rad": 1.0}

    def part(name):
        b = blocks[name]
        return x0[b["offset"]:b["offset"] + b["size"]] * to_si[b["unit"]]

    for k, c in enumerate(design.coefficients):
        assert blocks[f"c{k}"]["role"] == "design"
        np.testing.assert_allclose(part(f"c{k}"), c, rtol=1e-15)
    assert blocks["x0"]["role"] == "design"
    np.testing.assert_allclose(part("x0"), design.preextension, rtol=1e-15)
    assert {b["role"] for b in x_layout} == {"design", "departure", "auxiliary"}
    alpha = part("z0_alpha")  # the wire's departure angles on cam 1: radians, within a turn
    assert blocks["z0_alpha"]["role"] == "departure" and np.all(np.abs(alpha) < 2 * np.pi)
    p = np.array(data["p"])
    pb = {b["name"]: b for b in p_layout}
    k = pb["k"]
    assert k["unit"] == "N/m"
    np.testing.assert_array_equal(p[k["offset"]:k["offset"] + k["size"]], [s.rate for s in problem.springs])


@pytest.mark.parametrize("spec", ["johnston2023_rr_arm", "ludovico2021_pendulum", "fedorov2018_balancer"])
def test_every_block_of_the_transcription_has_a_label(spec):
    """Coupled springs (RR arm), minimax epigraphs and curvature limits (Ludovico2021), a
    differential pair's closure and output law (Fedorov2018): no block goes undescribed."""
    from cadcam.solve.transcription import Transcription
    from cadcam.export.codegen import _layout
    from cadcam.solve.blocks import P_BLOCKS, X_BLOCKS

    problem = load_spec(ROOT / "models" / f"{spec}.toml").with_options(grid=6, convexity_points=10)
    tr = Transcription(problem)
    _check_layout(_layout(tr.v, X_BLOCKS, problem), tr.v.size)
    _check_layout(_layout(tr.p, P_BLOCKS, problem), tr.p.size)
