"""A library is compiled by one process at a time: a design that needs a library another process
is compiling (a background compile, ``cadcam cache --build``) waits for it and loads it, one
whose compiler died takes the compile over, and no background compile starts beside it."""
import subprocess
import sys
import threading
import time

import pytest

from cadcam import load_spec
from cadcam.solve import compiled
from cadcam.solve.transcription import Transcription

from ..conftest import SPEC_1DOF, needs_cc


@pytest.fixture
def nlp():
    """The 1-DOF problem's NLP on a coarse grid (a small library)."""
    problem = load_spec(SPEC_1DOF).with_options(grid=8, convexity_points=12, functions="mapped")
    return Transcription(problem).nlp


@pytest.fixture(autouse=True)
def cache(monkeypatch, tmp_path):
    """A cache of the test's own."""
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(tmp_path / "cache"))


def _install(folder, key: str) -> None:
    """Install a library of ``key`` in the cache ``folder`` as a compile does, with its record:
    its content does not matter to the claims tested here (what a compile installs is)."""
    built = folder / "built.so"
    built.write_bytes(b"a library")
    compiled._install(folder, folder / compiled.LIBRARY_NAME.format(key), built)


@pytest.fixture
def compiles(monkeypatch):
    """The compiles this process starts, each standing in for a real one (no C is compiled)."""
    count = []

    def compile_library(nlp, cc, folder, path):
        count.append(path)
        _install(folder, path.name[len("nlp_"):-len(".so")])

    monkeypatch.setattr(compiled, "_compile_library", compile_library)
    return count


@pytest.fixture
def other_process():
    """A live process of this host, standing for another that compiles."""
    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
    yield proc
    proc.kill()
    proc.wait()


def _claim(key: str, pid: int):
    """The cache's claim of ``key``'s compile, held by process ``pid``."""
    folder = compiled.cache_dir()
    folder.mkdir(mode=compiled.FOLDER_MODE, parents=True, exist_ok=True)
    pending = compiled._claimed(folder, key)
    compiled._write_owner(pending, pid)
    return folder, pending


@needs_cc
def test_a_design_waits_for_the_compile_another_process_holds_and_loads_its_library(nlp, compiles, other_process):
    key = compiled.key_of(nlp)
    folder, pending = _claim(key, other_process.pid)
    got = []
    waiting = threading.Thread(target=lambda: got.append(compiled.library(nlp, key=key)))
    waiting.start()
    time.sleep(1.0)
    assert waiting.is_alive() and not compiles  # waiting, not compiling it a second time
    _install(folder, key)  # the other process's compile ends: its library, then its claim gone
    compiled._remove(pending)
    waiting.join(timeout=60)
    assert got == [(folder / compiled.LIBRARY_NAME.format(key), False)]
    assert not compiles


@needs_cc
def test_a_claim_whose_process_ended_is_taken_over(nlp, compiles):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    key = compiled.key_of(nlp)
    folder, pending = _claim(key, dead.pid)
    path, compiled_now = compiled.library(nlp, key=key)
    assert compiled_now and path.is_file() and len(compiles) == 1
    assert not pending.exists()


@needs_cc
def test_while_a_design_compiles_a_library_no_background_compile_of_it_starts(nlp, monkeypatch):
    key = compiled.key_of(nlp)
    started = []

    def compile_library(nlp, cc, folder, path):
        # the claim is held now: a design needing the library meanwhile starts no compile
        with pytest.MonkeyPatch.context() as meanwhile:
            meanwhile.setenv(compiled.BACKGROUND_ENV, "1")
            meanwhile.setattr(subprocess, "Popen", lambda *a, **k: started.append(a))
            assert compiled.compile_in_background(nlp, key=key)  # "a compile is under way"
        _install(folder, key)

    monkeypatch.setattr(compiled, "_compile_library", compile_library)
    path, compiled_now = compiled.library(nlp, key=key)
    assert compiled_now and path.is_file() and not started
    assert not (compiled.cache_dir() / compiled.PENDING_NAME.format(key)).exists()
