"""Libraries compiled ahead: ``cadcam.compile_ahead`` and ``cadcam cache --build`` compile what a
spec's first design on the default path loads, so that it loads them instead of solving with
expanded functions; ``cadcam app`` starts that for its templates as it starts."""
import subprocess

import pytest

from cadcam.api import compile_ahead, load_problem
from cadcam.cli import compile_templates_in_background, main
from cadcam.optimize import start_design
from cadcam.solve import compiled
from cadcam.solve.ipopt import COMPILED_CACHED
from cadcam.solve.transcription import Transcription

from .conftest import SPEC_1DOF, needs_cc


@pytest.fixture
def small(tmp_path, monkeypatch):
    """The 1-DOF problem on a coarse grid, compiled at -O0 into a cache of the test's own."""
    monkeypatch.setattr(compiled, "CFLAGS", ("-O0", "-fPIC"))
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(tmp_path / "cache"))
    return load_problem(SPEC_1DOF, grid=8, convexity_points=12)


@needs_cc
def test_the_first_design_after_compile_ahead_loads_its_library(small):
    assert compile_ahead(small) >= 1
    assert Transcription(start_design(small)[0]).functions_used == COMPILED_CACHED
    assert compile_ahead(small) == 0  # all in the cache


def test_a_spec_whose_design_loads_no_library_compiles_nothing(small):
    for problem in (small.with_options(functions="expanded"), small.with_options(functions="mapped")):
        assert compile_ahead(problem) is None
    assert not compiled.cache_dir().exists()


def test_the_command_says_what_it_compiled_for_each_spec(tmp_path, capsys):
    spec = tmp_path / "expanded.toml"
    spec.write_text(SPEC_1DOF.read_text().replace("[solver]\n", '[solver]\nfunctions = "expanded"\n', 1))
    assert main(["cache", "--build", str(spec)]) == 0
    assert capsys.readouterr().out.strip() == f"{spec}: its design loads no compiled library"


def test_by_default_the_command_compiles_the_design_pages_templates(monkeypatch, capsys):
    from cadcam import api
    from cadcam.app.state import TEMPLATES

    asked = []
    monkeypatch.setattr(api, "compile_ahead", lambda path: asked.append(path.stem) or 0)
    assert main(["cache", "--build"]) == 0
    assert asked == [t.spec for t in TEMPLATES if t.variant is None]
    assert capsys.readouterr().out.splitlines() == [f"{name}: in the cache already" for name in asked]


def test_building_and_clearing_are_not_asked_at_once(capsys):
    assert main(["cache", "--build", "--clear"]) == 2
    assert "--clear: not allowed with argument --build" in capsys.readouterr().err


def test_the_page_starts_compiling_its_templates_in_the_background(monkeypatch):
    started = []
    monkeypatch.setattr(subprocess, "Popen", lambda command, **kwargs: started.append((command, kwargs)))
    assert compile_templates_in_background(["johnston2023_1dof"]) is None  # the tests' setting: none
    assert not started
    monkeypatch.setenv(compiled.BACKGROUND_ENV, "1")
    compile_templates_in_background(["johnston2023_1dof", "roller_follower_pendulum"])
    ((command, kwargs),) = started
    assert command[-5:] == ["cadcam", "cache", "--build", "johnston2023_1dof", "roller_follower_pendulum"]
    assert kwargs["start_new_session"] and kwargs["stdout"] == subprocess.DEVNULL
