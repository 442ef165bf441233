"""The default ``solver.functions = "auto"``: expanded functions while the structure's library
compiles in a background process, that library from the cache after it; expanded alone where
there is no compiler, background compiles are off, or one failed before."""
import os
import socket
import time

import numpy as np
import pytest

from cadcam import evaluate, load_spec
from cadcam.optimize import default_start, solve
from cadcam.solve import compiled
from cadcam.solve.builds import built_for, forget_builds
from cadcam.solve.ipopt import COMPILED_CACHED, EXPANDED_COMPILING
from cadcam.solve.transcription import Transcription

from ..conftest import SPEC_1DOF, needs_cc, wait_for_library


@pytest.fixture
def small():
    """The 1-DOF problem on a coarse grid, functions as its spec leaves them (auto)."""
    problem = load_spec(SPEC_1DOF).with_options(grid=8, convexity_points=12)
    assert problem.options.functions == "auto"
    return problem


@pytest.fixture
def background(tmp_path, monkeypatch):
    """An empty cache folder, background compiles on."""
    folder = tmp_path / "cache"
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(folder))
    monkeypatch.setenv(compiled.BACKGROUND_ENV, "1")
    return folder


def _optimum(tr, problem):
    sol = solve(tr, problem, default_start(problem))
    assert sol.status == "converged"
    return evaluate(problem, sol.design).metrics.objective


def _pending(problem, folder):
    """(a build of the graph auto names ``problem``'s library by, that key, the path of the
    folder of its background compile in the cache ``folder``, which is created)."""
    tr = Transcription(problem.with_options(functions="expanded"))  # the graph auto names libraries by
    key = compiled.library_key(tr.nlp, compiled.compiler())
    folder.mkdir(mode=0o700, parents=True)
    return tr, key, folder / compiled.PENDING_NAME.format(key)


@needs_cc
def test_auto_expands_while_the_library_compiles_in_the_background_then_loads_it(small, background):
    forget_builds()
    first, built = built_for(small)
    assert built and first.functions_used == EXPANDED_COMPILING
    assert not first.adopt_compiled()  # nothing to adopt yet
    pending = list(background.glob(compiled.PENDING_NAME.format("*")))
    assert len(pending) == 1  # the lock of the one compile of this structure
    expanded = _optimum(first, small)
    (library,) = wait_for_library()
    deadline = time.monotonic() + 10  # the process removes its NLP file after the rename
    while pending[0].exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not pending[0].exists()
    again = Transcription(small)
    assert again.functions_used == COMPILED_CACHED and not again.compiled_now
    assert _optimum(again, small) == pytest.approx(expanded, rel=1e-6)
    assert compiled.cached_libraries() == [library]  # loaded, not compiled again
    kept, built = built_for(small)  # the build kept from before solves through the library now
    assert kept is first and not built and first.functions_used == COMPILED_CACHED
    assert _optimum(first, small) == pytest.approx(expanded, rel=1e-6)
    forget_builds()


@needs_cc
def test_a_compile_under_way_is_not_started_twice_and_a_stale_one_is(small, background):
    tr, key, pending = _pending(small, background)
    pending.mkdir()
    owner = pending / compiled.OWNER_FILE
    owner.write_text(f"{os.getpid()} {socket.gethostname()}\n")  # a compile under way, its process alive
    assert compiled.compile_in_background(tr.nlp)
    assert owner.read_text().split()[0] == str(os.getpid())  # not taken over
    old = time.time() - compiled.PENDING_STALE_S - 1
    os.utime(pending, (old, old))  # its process id since reused by another
    assert compiled.compile_in_background(tr.nlp)
    assert pending.stat().st_mtime > old  # started again
    assert wait_for_library()


@needs_cc
def test_a_failed_background_compile_is_noted_and_not_tried_again(small, background):
    tr, key, pending = _pending(small, background)
    pending.mkdir()
    (pending / compiled.NLP_FILE).write_text("not a serialized CasADi function")
    compiled.compile_pending(key, pending)
    note = background / compiled.FAILED_NAME.format(key)
    assert note.read_text() and not pending.exists()
    assert not compiled.compile_in_background(tr.nlp)
    assert Transcription(small).functions_used == "expanded"
    assert not list(background.glob(compiled.PENDING_NAME.format("*")))
    compiled.clear_cache()
    assert not note.exists()


def test_auto_is_expanded_without_a_compiler_or_with_background_compiles_off(small, background, monkeypatch):
    monkeypatch.setenv(compiled.BACKGROUND_ENV, "0")
    assert Transcription(small).functions_used == "expanded"
    monkeypatch.setenv(compiled.BACKGROUND_ENV, "1")
    monkeypatch.setattr(compiled.shutil, "which", lambda name: None)
    assert Transcription(small).functions_used == "expanded"
    assert not background.exists()  # nothing was written


def test_the_summary_and_result_json_say_how_the_functions_were_evaluated(small):
    from cadcam import optimize
    result = optimize(small.with_options(functions="mapped"))
    assert "(functions mapped)" in result.summary()
    assert result.to_dict()["solver"]["functions"] == "mapped"
    assert np.isfinite(result.solve.objective)
