"""An installed package adds a mechanism through the entry-point group ``cadcam.mechanisms``:
``tests/plugin`` (the toy pulley, its own pyproject.toml) is installed with pip into a folder of
its own, and ``cadcam design`` in a new process designs a spec of its kind; a class that lacks
a required hook is refused at registration, naming the hook."""
import json
import os
import subprocess
import sys
from dataclasses import dataclass

import pytest

from cadcam.mechanisms.base import Mechanism, missing_hooks, register

from ..conftest import PLUGIN
from .test_toy_mechanism import write_spec


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """The plug-in installed by pip (no dependencies, no network: the build backend is this
    environment's setuptools) into a folder that a process then puts on its path."""
    target = tmp_path_factory.mktemp("site")
    build = tmp_path_factory.mktemp("build")
    run = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
                          "--no-index", "--target", str(target), str(PLUGIN)],
                         capture_output=True, text=True, cwd=build, timeout=300)
    assert run.returncode == 0, run.stderr
    assert any(p.name.startswith("cadcam_toy_pulley") and p.suffix == ".dist-info" for p in target.iterdir())
    return target


@pytest.mark.slow  # a package installed, then a whole cadcam design: make test-slow
def test_cadcam_design_finds_an_installed_mechanism_by_its_entry_point(installed, tmp_path):
    spec = write_spec(tmp_path / "toy.toml")
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(installed), os.environ.get("PYTHONPATH")]))}
    run = subprocess.run([sys.executable, "-m", "cadcam", "design", str(spec), "-o", str(out), "--no-figures"],
                         capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr
    assert run.stdout.startswith("success")
    data = json.loads((out / "result.json").read_text())
    assert data["problem"]["mechanisms"][0]["kind"] == "toy_pulley"
    # without the package the kind is unknown: one line naming the kinds there are
    bare = subprocess.run([sys.executable, "-m", "cadcam", "design", str(spec), "-o", str(tmp_path / "bare")],
                          capture_output=True, text=True, cwd=tmp_path, timeout=300,
                          env=os.environ)
    assert bare.returncode == 2 and "mechanisms[1].kind" in bare.stderr
    assert "toy_pulley" not in bare.stderr.split("expected", 1)[1]


def test_a_mechanism_without_a_required_hook_is_refused_naming_it():
    @dataclass(frozen=True)
    class Incomplete(Mechanism):
        kind = "incomplete"
        citation = "Ludovico2021"
        ports = ("cable",)

    missing = missing_hooks(Incomplete)
    assert "declarations: per_angle" in missing and "geometry: residual" in missing
    with pytest.raises(TypeError, match=r"Incomplete \(incomplete\) does not provide .*geometry: residual"):
        register(Incomplete)
