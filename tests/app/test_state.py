"""The design page's state without a browser: the form from the reader's declarations, edits as
overrides, errors named by field, the spec written back with the edits."""
import tomllib

import numpy as np
import pytest

from cadcam import load_problem
from cadcam.app.form import field_of_error
from cadcam.app.state import TEMPLATES, DesignState
from cadcam.solve import compiled
from cadcam.solve.ipopt import COMPILED_CACHED, EXPANDED_COMPILING
from cadcam.spec import read_keys, read_spec_data

from ..conftest import needs_cc, wait_for_library


@pytest.fixture(scope="module")
def wire_cam():
    return DesignState.template("johnston2023_1dof")


def test_the_fields_carry_the_readers_forms_and_units(wire_cam):
    rate = wire_cam.field("springs.1.rate")
    assert (rate.group, rate.label, rate.help, rate.value) == (
        "Springs", "rate [N/m]", "the spring's rate k: a number > 0 [N/m]", 1100.0)
    assert wire_cam.field("cams.1.target.expression").label == "target.expression [N·m]"
    assert wire_cam.field("workshop.bore_diameter").value == 0.006  # the Workshop default, not None
    keys = [f.key for f in wire_cam.fields]
    assert len(keys) == len(set(keys)) and not {"name", "springs.1.ports", "cams.1.kind"} & set(keys)


def test_read_keys_records_every_key_with_its_value_or_default():
    path = "models/roller_follower_pendulum.toml"
    _, reads = read_keys(read_spec_data(path))
    by_key = {r.key: r for r in reads}
    mass = by_key["joints.1.target.mass"]
    assert (mass.key, mass.form, mass.value, mass.given) == (
        "joints.1.target.mass", "the pendulum's mass m: a number > 0 [kg]", 0.5, True)
    assert mass.declaration.unit == "kg"
    assert by_key["joints.1.target.g"].value == 9.81 and not by_key["joints.1.target.g"].given


@pytest.mark.parametrize("template", TEMPLATES, ids=lambda t: t.title)
def test_every_template_opens_with_a_form(template):
    state = DesignState.template(template.spec, variant=template.variant)
    assert {"Target and range", "Springs", "Geometry"} <= {f.group for f in state.fields}


def test_an_edit_in_a_table_the_spec_leaves_out_sets_that_table_and_the_spec_keeps_it(tmp_path):
    state = DesignState.template("johnston2023_1dof")
    assert state.edit("cams.1.acceptance.max_abs_error", "0.002") is None
    assert state.edit("workshop.bore_diameter", "0.005") is None
    assert state.edit("springs.1.rate", "1200") is None
    problem = load_problem(state.path, overrides=state.override_pairs())
    assert problem.joints[0].acceptance == (("max_abs_error", 0.002),)
    assert problem.workshop.bore_diameter == 0.005 and problem.springs[0].rate == 1200
    written = tmp_path / "edited.toml"
    written.write_text(state.spec_toml())
    assert load_problem(written).to_dict() == problem.to_dict()
    assert "# 1-DOF wire-wrapped cam of Johnston" in written.read_text()  # the comments stay


def test_a_value_equal_to_the_spec_or_empty_is_no_edit():
    state = DesignState.template("johnston2023_1dof")
    state.edit("springs.1.rate", "1200")
    state.edit("springs.1.rate", "1100.0")
    state.edit("springs.1.preload", "")
    assert state.overrides == {}


def test_an_error_names_its_field_else_the_field_edited():
    keys = ["springs.1.rate", "springs.1.travel", "cams.1.target.expression"]
    assert field_of_error("x.toml: springs[1].rate = -5: expected a positive spring rate [N/m]", keys,
                          "springs.1.travel") == "springs.1.rate"
    assert field_of_error("x.toml: cams[1].target.expression: unknown name 'q'", keys, None) == \
        "cams.1.target.expression"
    assert field_of_error("x.toml: something else", keys, "springs.1.travel") == "springs.1.travel"


def test_a_bad_value_is_one_line_beside_its_field():
    state = DesignState.template("johnston2023_1dof")
    state.edit("springs.1.rate", "-5")
    outcome = state.design("springs.1.rate")
    assert outcome.result is None and outcome.field == "springs.1.rate"
    assert outcome.error.endswith("springs[1].rate = -5: expected the spring's rate k: a number > 0 [N/m]")
    assert "\n" not in outcome.error


def test_a_catalogue_spring_replaces_the_specs_and_an_edit_still_wins():
    state = DesignState.template("johnston2023_1dof")
    state.pick_spring(1, "ACM12-100 (Endo2010 Sec. II-C (Endo et al. 2010))")
    assert state.value("springs.1.rate") == 1150.0 and state.value("springs.1.preload") == 14.71
    problem = load_problem(state.path, overrides=state.override_pairs())
    spring = problem.springs[0]
    assert (spring.rate, spring.travel, spring.preload, spring.ports[0].label()) == (1150.0, 0.07521, 14.71, "wire:1")
    state.edit("springs.1.rate", "1200")
    assert load_problem(state.path, overrides=state.override_pairs()).springs[0].rate == 1200
    state.edit("springs.1.rate", "1150")  # the picked spring's own rate: no edit
    assert "springs.1.rate" not in state.overrides
    state.pick_spring(1, None)
    assert state.value("springs.1.rate") == 1100.0


def test_a_picked_springs_table_is_named_as_the_catalogue_names_it():
    state = DesignState.template("johnston2023_1dof")
    own = state.table_names()["springs.1"]
    assert own == load_problem(state.path).springs[0].name
    name = "ACM12-100 (Endo2010 Sec. II-C (Endo et al. 2010))"
    state.pick_spring(1, name)
    assert state.table_names()["springs.1"] == name
    assert load_problem(state.path, overrides=state.override_pairs()).springs[0].name == name
    assert state.table_names()["springs.2"] == load_problem(state.path).springs[1].name
    state.pick_spring(1, None)
    assert state.table_names()["springs.1"] == own


def test_a_result_json_opens_with_its_resolved_problem(tmp_path):
    from cadcam.app.state import result_json

    state = DesignState.template("roller_follower_pendulum")
    outcome = state.design()
    path = tmp_path / "result.json"
    path.write_text(result_json(outcome.result))
    opened = DesignState(path)
    assert opened.field("joints.1.target.mass").value == 0.5
    assert load_problem(path).to_dict() == outcome.result.problem.to_dict()
    written = tmp_path / "spec.toml"
    written.write_text(opened.spec_toml())
    assert load_problem(written).to_dict() == outcome.result.problem.to_dict()


def test_the_generic_torque_template_is_its_variant_in_the_form_the_designs_and_the_spec_written(tmp_path):
    """The template of a spec's variant (the generic torque's moment-arm method): the form shows
    the variant's numbers, the designs are made by its method, an edit designs again, and the
    spec written back with the edit designs the same problem."""
    from cadcam.optimize import completed

    template = next(t for t in TEMPLATES if t.variant)
    state = DesignState.template(template.spec, variant=template.variant)
    variant = tomllib.loads(state.path.read_text(encoding="utf-8"))["variants"][template.variant]
    assert state.field("solver.method").value == variant["solver.method"]
    assert state.field("mechanisms.1.order").value == variant["mechanisms.1.order"]
    first = state.design().result
    assert first.success and first.problem.options.method == variant["solver.method"]
    rate = state.field("springs.1.rate").value
    assert state.edit("springs.1.rate", repr(1.02 * rate)) is None
    again = state.design("springs.1.rate").result
    assert again.success and again.problem.springs[0].rate == pytest.approx(1.02 * rate)
    written = tmp_path / "spec.toml"
    written.write_text(state.spec_toml())
    assert completed(load_problem(written)).to_dict() == again.problem.to_dict()


def test_the_keys_the_moment_arm_method_sets_itself_are_marked_and_not_used():
    """Under the moment-arm method the form marks each anchored pulley's anchor angle and start
    radius as set by the method; a design with other values of them gives the same pulleys; with
    the method edited back to the NLP they are the user's again."""
    template = next(t for t in TEMPLATES if t.variant)
    state = DesignState.template(template.spec, variant=template.variant)
    marked = {f.key for f in state.fields if state.set_by_method(f.key)}
    assert marked == {f"mechanisms.{u}.{key}" for u in (1, 2) for key in ("anchor_angle", "initial_radius")}
    first = state.design().result
    assert state.edit("mechanisms.1.anchor_angle", "1.0") is None
    assert state.edit("mechanisms.1.initial_radius", "0.03") is None
    again = state.design().result
    assert again.problem.mechanisms[0].anchor_angle == pytest.approx(first.problem.mechanisms[0].anchor_angle,
                                                                     abs=1e-9)
    for before, after in zip(first.design.coefficients, again.design.coefficients):
        np.testing.assert_allclose(after, before, rtol=0, atol=1e-9)
    assert state.edit("solver.method", "nlp") is None
    assert not any(state.set_by_method(f.key) for f in state.fields)


def test_cadcam_app_refuses_a_spec_it_cannot_read_in_one_line(tmp_path, capsys):
    from cadcam.cli import main

    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\nsource = "y"\n[[springs]]\nrate = -1\n')
    assert main(["app", str(bad), "--no-browser"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("cadcam: error: ") and "\n" not in err


def test_the_files_to_download_are_those_cadcam_design_writes(tmp_path):
    state = DesignState.template("johnston2023_1dof")
    assert state.edit("solver.grid", "12") is None  # the files are those of any design grid
    result = state.design().result
    files = state.result_files(result)
    assert {"result.json", "torque.csv", "profile.csv", "cam1.dxf", "cam1.svg", "cam1_points.csv"} <= set(files)
    assert not any(name.endswith(".png") for name in files)  # figures=False draws none
    result.save(tmp_path, figures=False)
    assert files["cam1.dxf"].count(b"LWPOLYLINE") == (tmp_path / "cam1.dxf").read_bytes().count(b"LWPOLYLINE")


@pytest.mark.slow  # a design and its solids: make test-slow
def test_the_solids_to_download_need_no_stl_thickness_in_the_spec():
    from cadcam.make.step import available
    from cadcam.problem import SOLID_THICKNESS

    state = DesignState.template("johnston2023_1dof")
    result = state.design().result
    assert result.problem.workshop.stl is None
    assert not any(name.endswith((".stl", ".step")) for name in state.result_files(result))
    files = state.result_files(result, solids=True)
    assert "cam1.stl" in files and ("cam1.step" in files) == available()
    z = np.frombuffer(files["cam1.stl"][84:], dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)),
                                                              ("a", "<u2")]))["v"][..., 2]
    assert z.max() - z.min() == pytest.approx(1e3 * SOLID_THICKNESS)  # the STL is in millimetres


def test_the_link_angle_is_a_geometry_field_of_every_mechanism():
    from cadcam.mechanisms.base import LINK_ANGLE

    state = DesignState.template("roller_follower_pendulum")
    link = state.field("mechanisms.1.link_angle")
    assert (link.group, link.label, link.value) == ("Geometry", "link_angle [rad]", None)
    assert link.help == LINK_ANGLE.form() and link.help.endswith("[rad]")
    assert state.edit("mechanisms.1.link_angle", "1.2") is None
    assert load_problem(state.path, overrides=state.override_pairs()).mechanisms[0].link_angle == 1.2


@pytest.fixture
def small_wire_cam(tmp_path, monkeypatch):
    """The 1-DOF template on a coarse grid (a small NLP of the same structure of functions), an
    empty cache with background compiles on, its NLP built afresh (not kept from another test)."""
    from cadcam.solve.builds import forget_builds

    forget_builds()
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv(compiled.BACKGROUND_ENV, "1")
    state = DesignState.template("johnston2023_1dof")
    for key, value in (("solver.grid", "10"), ("solver.convexity_points", "12")):
        assert state.edit(key, value) is None
    yield state
    forget_builds()


@needs_cc
def test_the_page_designs_first_with_expanded_functions_then_through_their_library(small_wire_cam):
    """The page's Session path with the spec's default functions (auto): the first design of a
    structure does not wait for a compile; an edit after the library compiled in the background
    is designed warm from the last answer through the library."""
    state = small_wire_cam
    assert state.value("solver.functions") == "auto"
    first = state.design()
    assert first.result.success and first.result.functions == EXPANDED_COMPILING
    libraries = wait_for_library()
    assert libraries
    state.edit("springs.1.rate", "1122")
    again = state.design("springs.1.rate")
    assert again.result.success and again.result.functions == COMPILED_CACHED
    assert again.result.message.endswith("(warm start from the last design)")
    assert compiled.cached_libraries() == libraries  # loaded, not compiled again
    assert "functions" not in state.spec_toml()  # the spec's default, not written into it


def test_without_a_compiler_the_page_designs_with_expanded_functions(small_wire_cam, monkeypatch):
    monkeypatch.setattr(compiled.shutil, "which", lambda name: None)
    outcome = small_wire_cam.design()
    assert outcome.result.success and outcome.result.functions == "expanded"


def test_compiled_functions_named_without_a_compiler_are_the_fields_error(monkeypatch):
    """Naming compiled functions where there is no compiler is the command line's one-line
    error, shown under the field."""
    monkeypatch.setattr(compiled, "_found", lambda: None)
    state = DesignState.template("johnston2023_1dof")
    state.edit("solver.functions", "compiled")
    outcome = state.design("springs.1.rate")
    assert outcome.result is None and outcome.field == "solver.functions"
    assert outcome.error.startswith("solver.functions = 'compiled' needs a C compiler")
