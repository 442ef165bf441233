"""A releasable package: one version, a licence, a changelog, type information, and a wheel
that carries the JSON Schema and the example specs where :mod:`cadcam.examples` finds them —
built from a copy of the sources (offline: no build isolation) and imported from where pip
would unpack it, and from the zip itself."""
from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import tomllib
import zipfile
from importlib.metadata import version
from importlib.resources import files
from pathlib import Path

import pytest

import cadcam
from cadcam import examples, load_spec
from cadcam.examples import UnknownExample

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
VERSION = PYPROJECT["project"]["version"]


def test_the_version_is_written_once_and_read_back():
    assert cadcam.__version__ == version("cadcam") == VERSION, (
        "the installed metadata is older than pyproject.toml: run make (or pip install -e .)")
    literal = re.compile(re.escape(VERSION))
    written = [p for p in (ROOT / "cadcam").rglob("*.py") if literal.search(p.read_text())]
    assert written == []


def test_the_changelog_has_a_section_for_this_version():
    text = (ROOT / "CHANGELOG.md").read_text()
    released = re.sub(r"\.dev\d+$", "", VERSION)
    heading = "## [Unreleased]" if released != VERSION else f"## [{VERSION}]"
    assert heading in text and "## [0.1.0]" in text


def test_the_licence_is_mit_and_declared():
    assert PYPROJECT["project"]["license"] == "MIT"
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("MIT License") and "Copyright (c) 2026 the cadcam authors" in text


def test_examples_are_every_spec_of_models_and_each_loads():
    shipped = sorted(p.name for p in (ROOT / "models").iterdir() if p.suffix in examples.SUFFIXES)
    assert examples.files() == shipped
    assert examples.names() == [n.removesuffix(".toml") for n in shipped if n.endswith(".toml")]
    assert "johnston2023_1dof" in examples.names()
    for name in examples.names():
        path = examples.path(name)
        assert path.parent == examples.folder() and path.read_bytes() == (ROOT / "models" / path.name).read_bytes()
        assert load_spec(path).name  # a valid spec, siblings resolved from its own folder
    assert examples.path("spring_catalogue.csv").is_file()
    assert examples.path("johnston2023_table3_design.json") == examples.folder() / "johnston2023_table3_design.json"


@pytest.mark.parametrize("name", ["nope", "../pyproject.toml", "johnston2023_1dof.toml/..", "", "models"])
def test_an_unknown_example_names_the_choices(name):
    with pytest.raises(UnknownExample, match="johnston2023_1dof") as err:
        examples.path(name)
    assert "\n" not in str(err.value)


def test_the_package_says_it_is_typed():
    assert (files("cadcam") / "py.typed").is_file()
    assert "py.typed" in PYPROJECT["tool"]["setuptools"]["package-data"]["cadcam"]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel pip builds from a copy of the sources (as in a fresh clone: cadcam/models is
    the link to models/)."""
    src = tmp_path_factory.mktemp("src")
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(ROOT / name, src / name)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copytree(ROOT / "cadcam", src / "cadcam", symlinks=True, ignore=ignore)
    shutil.copytree(ROOT / "models", src / "models", ignore=ignore)
    out = tmp_path_factory.mktemp("wheel")
    run = subprocess.run([sys.executable, "-m", "pip", "wheel", str(src), "--no-deps", "--no-index",
                          "--no-build-isolation", "--quiet", "-w", str(out)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]
    (built,) = out.glob("cadcam-*.whl")
    return built


def test_the_wheel_holds_the_package_its_data_and_licence(wheel):
    assert wheel.name == f"cadcam-{VERSION}-py3-none-any.whl"
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        sources = {p.relative_to(ROOT).as_posix() for p in (ROOT / "cadcam").rglob("*.py")
                   if "__pycache__" not in p.parts}
        assert sources <= names, sorted(sources - names)
        for data in ["cadcam/py.typed", "cadcam/result.schema.json",
                     "cadcam/data/springs/mcmaster_extension_springs.csv",
                     "cadcam/data/springs/LICENSE.virtual-counterweight",
                     "cadcam/data/cables/cables.csv", "cadcam/data/cables/README.md",
                     *(f"cadcam/models/{n}" for n in examples.files())]:
            assert z.read(data) == (ROOT / data).read_bytes(), data
        info = f"cadcam-{VERSION}.dist-info"
        assert f"{info}/licenses/LICENSE" in names
        metadata = z.read(f"{info}/METADATA").decode()
    assert f"Version: {VERSION}\n" in metadata and "License-Expression: MIT\n" in metadata


def test_the_schema_the_tests_validate_against_is_the_one_that_ships(wheel):
    """tests/test_result_schema.py validates results against the package's own schema file;
    the wheel carries that file byte for byte."""
    with zipfile.ZipFile(wheel) as z:
        shipped = z.read("cadcam/result.schema.json")
    assert shipped == (files("cadcam") / "result.schema.json").read_bytes()
    assert json.loads(shipped)["$schema"] == "https://json-schema.org/draft/2020-12/schema"


PROBE = """
import json, cadcam, importlib.metadata as m
from importlib.resources import files
from cadcam import examples
from cadcam.physics.catalogue import shipped
spec = cadcam.load_spec(examples.path("johnston2023_1dof"))
print(json.dumps({"file": cadcam.__file__, "version": cadcam.__version__, "metadata": m.version("cadcam"),
                  "names": examples.names(), "folder": str(examples.folder()), "spec": spec.name,
                  "siblings": sorted(p.name for p in examples.path("johnston2023_rr_arm").parent.iterdir()),
                  "schema": (files("cadcam") / "result.schema.json").is_file(),
                  "catalogue": len(shipped())}))
"""


@pytest.mark.parametrize("form", ["unpacked", "zipped"])
def test_an_installed_wheel_reports_the_version_and_reaches_the_examples(wheel, tmp_path, form):
    """Unpacked as pip installs it, or imported from the zip: the version comes from the
    wheel's metadata and the examples (with their sibling files) from the installed package."""
    if form == "unpacked":
        where = tmp_path / "site"
        with zipfile.ZipFile(wheel) as z:
            z.extractall(where)
    else:
        where = wheel
    run = subprocess.run([sys.executable, "-c", PROBE], cwd=tmp_path, capture_output=True, text=True,
                         env={"PYTHONPATH": str(where), "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)},
                         timeout=120)
    assert run.returncode == 0, run.stderr[-3000:]
    got = json.loads(run.stdout)
    assert got["file"].startswith(str(where)), got["file"]  # not the source tree
    assert got["version"] == got["metadata"] == VERSION
    assert got["names"] == examples.names() and got["spec"] == "johnston2023_1dof" and got["schema"]
    assert got["catalogue"] == 1284  # the shipped spring catalogue, read from the package
    assert got["siblings"] == examples.files()
    if form == "unpacked":
        assert got["folder"] == str(where / "cadcam" / "models")
