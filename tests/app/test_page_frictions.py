"""What a newcomer tripped on, without a browser: Fedorov2018's balancer's quantities given twice
kept as one, the build time of each design its own, and no folder of the server in what the page
shows (its designs stubbed where a test needs no solve)."""
import tempfile
from pathlib import Path

import pytest

from cadcam import load_problem
from cadcam.app.state import DesignState

#: A full design per module fixture and more: too heavy for make test's five minutes.
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
SPEC_1DOF = ROOT / "models" / "johnston2023_1dof.toml"
#: Fedorov2018's output law balances the pendulum of the joint's target with the slider springs:
#: each of its keys that is one of theirs, and theirs.
IN_STEP = {"mechanisms.1.output_target.mass": "joints.1.target.mass",
           "mechanisms.1.output_target.length": "joints.1.target.length",
           "mechanisms.1.output_target.g": "joints.1.target.g",
           "mechanisms.1.output_target.rate": "springs.1.rate",
           "mechanisms.1.output_target.preload": "springs.1.preload"}


@pytest.fixture(scope="module")
def balancer():
    return DesignState.template("fedorov2018_balancer")


def test_the_balancers_pendulum_and_springs_are_one_quantity_each_in_the_form(balancer):
    """The output law's mass, length, g, rate and initial tension follow the target's and the
    spring's (its phase, another angle, does not); an edit of either is an edit of both."""
    assert balancer.links == IN_STEP
    problem = load_problem(balancer.path)
    assert problem.joints[0].target.data["phase"] != problem.mechanisms[0].output_target.data["phase"]
    assert balancer.edit("joints.1.target.mass", "0.2") is None
    assert balancer.edit("mechanisms.1.output_target.preload", "3.5") is None  # the spring's, then
    assert balancer.value("mechanisms.1.output_target.mass") == 0.2
    edited = load_problem(balancer.path, overrides=balancer.override_pairs())
    assert edited.joints[0].target.data["mass"] == edited.mechanisms[0].output_target.data["mass"] == 0.2
    assert edited.springs[0].preload == edited.mechanisms[0].output_target.data["preload"] == 3.5
    assert balancer.overrides == {"joints.1.target.mass": 0.2, "springs.1.preload": 3.5}
    balancer.overrides.clear()


def test_a_spring_picked_from_the_catalogue_carries_the_balancers_law_along(balancer):
    balancer.pick_spring(1, "ACM12-100 (Endo2010 Sec. II-C (Endo et al. 2010))")
    edited = load_problem(balancer.path, overrides=balancer.override_pairs())
    law = edited.mechanisms[0].output_target.data
    assert (law["rate"], law["preload"]) == (edited.springs[0].rate, edited.springs[0].preload) == (1150.0, 14.71)
    balancer.pick_spring(1, None)


@pytest.mark.parametrize("template", ["johnston2023_1dof", "ludovico2021_pendulum", "roller_follower_pendulum"])
def test_specs_without_an_output_law_keep_every_field_their_own(template):
    assert DesignState.template(template).links == {}


def test_the_page_shows_a_field_in_step_with_another_as_that_ones(balancer, monkeypatch):
    pytest.importorskip("panel", reason="Panel is the app extra's (make test installs it)")
    from cadcam.app import page

    async def no_design(*args, **kwargs):
        """No design: Fedorov2018's takes a minute."""

    monkeypatch.setattr(page.DesignPage, "design", no_design)
    view = page.DesignPage(DesignState.template("fedorov2018_balancer"))
    follower = view.inputs["mechanisms.1.output_target.mass"]
    assert follower.disabled and follower.name == "output_target.mass [kg]: kept equal to target.mass of pendulum"
    rate = view.inputs["mechanisms.1.output_target.rate"]
    assert rate.disabled and rate.name == "output_target.rate [N/m]: kept equal to rate of spring 1"
    view.inputs["joints.1.target.mass"].value = "0.25"
    assert follower.value == "0.25" and view.state.overrides == {"joints.1.target.mass": 0.25}


def test_a_design_through_a_kept_nlp_reports_no_build(tmp_path, monkeypatch):
    """The first design of a structure builds its NLP; the next, an edit, builds none: its
    summary says so, not the first one's time."""
    from cadcam.solve.builds import forget_builds

    forget_builds()
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(tmp_path / "cache"))
    state = DesignState.template("johnston2023_1dof")
    for key, value in (("solver.grid", "10"), ("solver.convexity_points", "12"), ("solver.functions", "expanded")):
        assert state.edit(key, value) is None
    first = state.design().result
    assert first.success and first.build_time_s > 0
    state.edit("springs.1.rate", "1122")
    again = state.design().result
    assert again.success and again.build_time_s == 0.0 and "build 0.000 s" in again.summary()
    forget_builds()


# -- no folder of the server ----------------------------------------------------------------------
@pytest.fixture
def page(tmp_path, monkeypatch):
    pytest.importorskip("panel", reason="Panel is the app extra's (make test installs it)")
    from cadcam.app import page

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "temp"))
    (tmp_path / "temp").mkdir()
    return page


def test_a_folder_of_the_server_with_blanks_in_its_name_is_left_out(page, tmp_path):
    folder = Path(tempfile.gettempdir()) / "my specs" / "a b"
    assert page.public(f"{folder}/x.toml: springs[1].rate = -5", {}) == "x.toml: springs[1].rate = -5"
    assert page.public(f"reading '{ROOT}/docs/two words/t.csv' failed", {}) == "reading 't.csv' failed"
    assert page.scrubbed(f"a\n{folder}/x.toml\nb", {}) == "a\nx.toml\nb"  # its lines kept


def test_what_the_page_says_of_an_upload_names_it_by_the_browsers_name(page, tmp_path):
    """A spec error, the verdict and a failure name the uploaded spec as the browser did, never
    the page's copy or its folder."""
    import asyncio

    view = page.DesignPage(DesignState.template("johnston2023_1dof"))
    spec = SPEC_1DOF.read_bytes().replace(b"rate = 1100.0", b"rate = -5.0", 1)
    view.upload.param.update(value=[spec], filename=["my spec.toml"])  # refused on opening: under the upload
    assert view.open_error.object.startswith("my spec.toml: springs[1].rate = -5.0")
    view.upload.param.update(value=[SPEC_1DOF.read_bytes()], filename=["my spec.toml"])
    view.inputs["springs.1.rate"].value = "-5"  # the design refuses it (before any solve)
    asyncio.run(view.design("springs.1.rate"))
    assert "not designed: my spec.toml: springs[1].rate = -5" in view.verdict.object
    view.fail("reading the file", OSError(2, "No such file or directory", str(view.state.path)))
    assert view.failure.object == ("reading the file failed: FileNotFoundError: [Errno 2] No such file or directory: "
                                   "'my spec.toml'")
    for shown in (view.open_error.object, view.verdict.object, view.failure.object):
        assert "upload" not in shown and "given" not in shown and str(tmp_path) not in shown
    view.close()
