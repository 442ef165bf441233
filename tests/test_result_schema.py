"""result.json against the JSON Schema that ships with the package (cadcam/result.schema.json,
draft 2020-12): the schema is valid, real results (converged and failed) validate, broken ones do
not, and its closed sets agree with the code."""
import copy
import json
import math
import tomllib
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest
from jsonschema import Draft202012Validator

import cadcam
from cadcam.cli import main
from cadcam.mechanisms.base import mechanism_class, mechanism_kinds, torque_models
from cadcam.solve.ipopt import IPOPT_STATUS
from cadcam.optimize import VERDICTS

from .conftest import SPEC_1DOF

SCHEMA_FILE = files("cadcam") / "result.schema.json"


@pytest.fixture(scope="module")
def schema():
    return json.loads(SCHEMA_FILE.read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def validator(schema):
    return Draft202012Validator(schema)


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    """result.json of the 1-DOF model, designed once for this module (without figures: they
    change nothing in result.json; on a grid of 12, which the record's form does not depend on)."""
    out = tmp_path_factory.mktemp("schema_design")
    assert main(["design", str(SPEC_1DOF), "-o", str(out), "--no-figures", "--grid", "12"]) == 0
    return json.loads((out / "result.json").read_text())


def _errors(validator, instance):
    return list(validator.iter_errors(instance))


def test_schema_ships_inside_the_package():
    """The file validated against here is the package's own, declared as package data;
    tests/test_packaging.py checks that a built wheel carries it byte for byte."""
    assert SCHEMA_FILE.is_file()
    assert Path(str(SCHEMA_FILE)).resolve() == (Path(cadcam.__file__).parent / "result.schema.json").resolve()
    pyproject = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())
    assert "result.schema.json" in pyproject["tool"]["setuptools"]["package-data"]["cadcam"]


def test_schema_is_a_valid_draft_2020_12_schema(schema):
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    Draft202012Validator.check_schema(schema)


def test_a_converged_result_validates(validator, result):
    assert result["status"] == "success"
    validator.validate(result)


def test_a_failed_solve_validates(validator, tmp_path):
    """(Designed without figures: they change nothing in result.json.)"""
    spec = tmp_path / "short.toml"
    spec.write_text(SPEC_1DOF.read_text().replace("quadrature_order = 2",
                                                  "quadrature_order = 2\nmax_iter = 2"))
    out = tmp_path / "o"
    assert main(["design", str(spec), "-o", str(out), "--no-figures"]) == 1
    res = json.loads((out / "result.json").read_text())
    assert res["status"] == "max_iterations"
    validator.validate(res)


def test_nan_metrics_validate(validator, result):
    # what evaluate reports where a quantity is not computable: json writes NaN, json reads nan
    res = copy.deepcopy(result)
    res["metrics"]["rho_min"][0] = float("nan")
    res["recheck"]["objective"] = float("nan")
    res["recheck"]["margins"]["convexity"][0] = float("nan")
    res["solver"]["build_time_s"] = float("nan")
    text = json.dumps(res)
    assert "NaN" in text
    back = json.loads(text)
    assert math.isnan(back["metrics"]["rho_min"][0])
    validator.validate(back)


def _bad_status(r):
    r["status"] = "great"


def _no_design(r):
    del r["design"]


def _string_preextension(r):
    r["design"]["preextension"] = "0.01"


def _success_with_violations(r):
    r["violations"] = ["spring above its travel: spring 1 (margin -0.002)"]


@pytest.mark.parametrize("break_it, path, keyword", [
    (_bad_status, ["status"], "enum"),
    (_no_design, [], "required"),
    (_string_preextension, ["design", "preextension"], "type"),
    (_success_with_violations, ["violations"], "maxItems"),
], ids=["status-great", "missing-design", "string-preextension", "success-with-violations"])
def test_broken_results_fail_for_the_right_reason(validator, result, break_it, path, keyword):
    res = copy.deepcopy(result)
    break_it(res)
    errors = _errors(validator, res)
    assert errors, "a broken result validated"
    assert any(list(e.absolute_path) == path and e.validator == keyword for e in errors), \
        [(list(e.absolute_path), e.validator, e.message) for e in errors]


def test_closed_sets_agree_with_the_code(schema):
    props = schema["properties"]
    stopped = set(IPOPT_STATUS.values()) - {"converged"}
    assert set(props["status"]["enum"]) == stopped | set(VERDICTS) | {"solver_error"}
    trial_status = schema["$defs"]["trial"]["properties"]["status"]["enum"]
    assert set(trial_status) == set(IPOPT_STATUS.values()) | {"solver_error"}
    assert tuple(schema["$defs"]["torque_model"]["enum"]) == torque_models()


#: The mechanisms cadcam ships (a test module may register its own, such as the toy pulley).
BUILT_IN = [k for k in mechanism_kinds() if mechanism_class(k).__module__.startswith("cadcam.mechanisms.")]


def test_the_shipped_schema_is_what_the_declarations_make_of_it(schema):
    """The torque models, design methods, target kinds and each mechanism's own keys come from
    the registries and the mechanisms' folders: `make generated` writes them into the file."""
    from cadcam.outputs.schema import result_schema

    assert result_schema(schema) == schema, "the declarations changed: run `make generated`"
    kinds = [b["if"]["properties"]["kind"]["const"] for b in schema["$defs"]["mechanism"]["allOf"]]
    assert set(kinds) == set(BUILT_IN)


def test_the_spec_reference_page_is_what_the_declarations_make():
    from cadcam.outputs.spec_reference import REFERENCE_FILE, reference

    page = REFERENCE_FILE.read_text(encoding="utf-8")
    assert page == reference(), "the declarations changed: run `make generated`"
    for kind in BUILT_IN:
        assert f'### `kind = "{kind}"`' in page


def _shipped_specs():
    """Every shipped spec with each of its variants (None: the spec as written)."""
    root = Path(__file__).resolve().parents[1]
    for path in sorted((root / "models").glob("*.toml")) + [root / "docs" / "first_balancer.toml"]:
        for variant in [None, *tomllib.loads(path.read_text()).get("variants", {})]:
            yield path, variant


@pytest.mark.parametrize("path,variant", list(_shipped_specs()), ids=lambda v: getattr(v, "stem", str(v)))
def test_every_key_the_reader_reads_of_a_shipped_spec_is_declared_and_on_the_reference_page(path, variant):
    from cadcam.outputs.spec_reference import REFERENCE_FILE, declared_keys
    from cadcam.spec import read_keys, read_spec_data

    page = REFERENCE_FILE.read_text(encoding="utf-8")
    names = {name for _, name in declared_keys()}
    _, reads = read_keys(read_spec_data(path, variant), str(path), path.parent)
    given = [r for r in reads if r.given]
    assert given
    for read in given:
        assert read.declaration.name in names, read.key
        assert f"`{read.declaration.name}`" in page or f".{read.declaration.name}`" in page, read.key



def test_every_top_level_field_is_documented(schema, result):
    # the top level stays open for newer fields, so check here that the schema names them all
    def resolve(node):
        while "$ref" in node and "description" not in node:
            node = schema["$defs"][node["$ref"].rsplit("/", 1)[1]]
        return node

    props = schema["properties"]
    assert set(result) <= set(props), set(result) - set(props)
    assert set(schema["required"]) <= set(result)
    for name, node in props.items():
        assert resolve(node).get("description"), f"{name} has no description"


def test_the_design_grid_is_kept_whole_while_it_is_small(result):
    grid = result["metrics"]["grid"]
    assert result["target_samples_grid"] == {"sampled": False, "stride": 1, "indices": list(range(grid))}
    assert len(result["target_samples"][0]) == grid


def test_a_result_without_target_samples_grid_still_validates(validator, result):
    # files of an older cadcam hold the whole design grid and no description of it
    old = copy.deepcopy(result)
    del old["target_samples_grid"]
    validator.validate(old)


@pytest.fixture(scope="module")
def three_cam_arm():
    """The three-cam arm's problem and cadcam's start design (no solve: target_samples needs an
    evaluation only)."""
    from cadcam import load_spec
    from cadcam.optimize import default_start
    problem = load_spec(Path(__file__).resolve().parents[1] / "models" / "johnston2023_three_cam_arm.toml")
    return problem, default_start(problem)


@pytest.mark.parametrize("grid, stride, kept", [(16, 1, 16), (26, 2, 14), (100, 7, 16)])
def test_three_joints_keep_a_bounded_tensor_grid_of_the_target(schema, three_cam_arm, grid, stride, kept):
    """m·(m + 1) numbers per point: three joints keep at most 50 000 / 12 points, every
    stride-th angle of each joint with both ends, and the rows are the target's own values
    there (its CasADi function, point by point)."""
    from cadcam.verify.evaluate import evaluate
    from cadcam.result import TARGET_SAMPLE_NUMBERS, target_samples, target_samples_grid

    problem, design = three_cam_arm
    ev = evaluate(problem, design, grid=grid, profile=False)
    samples, where = target_samples(ev), target_samples_grid(ev)
    Draft202012Validator(schema["properties"]["target_samples"]).validate(samples)
    Draft202012Validator(schema["properties"]["target_samples_grid"]).validate(where)
    index = list(range(0, grid, stride)) + ([grid - 1] if (grid - 1) % stride else [])
    assert where == {"sampled": stride > 1, "stride": stride, "indices": index} and len(index) == kept
    assert 3 * 4 * kept**3 <= TARGET_SAMPLE_NUMBERS
    if stride > 1:  # the smallest stride that fits: one less would keep too many
        assert 3 * 4 * len(set(range(0, grid, stride - 1)) | {grid - 1})**3 > TARGET_SAMPLE_NUMBERS
    # well below the 10 MB a reader accepts, as result.json writes it
    assert len(json.dumps({"target_samples": samples}, indent=2)) < 2.2e6
    angles = [j.grid(grid)[index] for j in problem.joints]
    theta = np.vstack([a.ravel() for a in np.meshgrid(*angles, indexing="ij")])  # C order
    for i, (joint, rows) in enumerate(zip(problem.joints, samples)):
        rows = np.array(rows)
        assert rows.shape == (kept**3, 4)
        np.testing.assert_array_equal(rows[:, :3], theta.T)
        tau_d = np.asarray(joint.target.function(3, i).map(theta.shape[1])(theta)).ravel()
        np.testing.assert_allclose(rows[:, 3], tau_d, rtol=1e-12, atol=1e-15)
