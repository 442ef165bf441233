"""How IPOPT's functions are evaluated (solver.functions): expanded, mapped and compiled give the
same optimum; the compiled library is cached on disk by structure, not by a case's numbers,
and written atomically."""
import os
import subprocess
import sys

import casadi as ca
import numpy as np
import pytest

from cadcam import evaluate, load_spec
from cadcam.cli import main
from cadcam.files import TEMP_PREFIX
from cadcam.solve import compiled
from cadcam.solve.transcription import Transcription
from cadcam.optimize import default_start, solve

from ..conftest import SPEC_1DOF, at_once, needs_cc


@pytest.fixture
def small():
    """The 1-DOF problem on a coarse grid: the same structure of functions, a small NLP."""
    return load_spec(SPEC_1DOF).with_options(grid=8, convexity_points=12)


#: Compiler flags of these tests: what is tested does not depend on optimised code, and -O0
#: compiles several times faster than the default -O1.
FAST = ("-O0", "-fPIC")


@pytest.fixture(autouse=True)
def fast_compile(monkeypatch):
    monkeypatch.setattr(compiled, "CFLAGS", FAST)


@pytest.fixture(scope="module")
def shared(tmp_path_factory):
    """One cache folder for the tests of this module that may share compiled libraries (a
    compile takes seconds)."""
    return tmp_path_factory.mktemp("shared-cache")


@pytest.fixture
def cache(shared, monkeypatch):
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(shared))
    return shared


@pytest.fixture
def empty_cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(folder))
    return folder


def _objective(problem):
    tr = Transcription(problem)
    sol = solve(tr, problem, default_start(problem))
    assert sol.status == "converged"
    return evaluate(problem, sol.design).metrics.objective, tr


@needs_cc
def test_expanded_mapped_and_compiled_functions_reach_the_same_optimum(small, cache):
    values = {fn: _objective(small.with_options(functions=fn))[0]
              for fn in ("expanded", "mapped", "compiled")}
    ref = values["expanded"]
    assert all(abs(v - ref) <= 1e-6 * ref for v in values.values()), values


def test_functions_rebuilt_with_shared_subexpressions_give_the_same_values_to_the_bit(small):
    """The library's functions are nlpsol's, rebuilt with ``FUNCTION_OPTIONS`` (common
    subexpressions merged): fewer instructions, the very same numbers."""
    nlp = Transcription(small.with_options(functions="mapped")).nlp
    solver = ca.nlpsol("plain", "ipopt", nlp, {"oracle_options": {"max_num_dir": compiled.DIRECTIONS}})
    library = compiled.oracle_functions(nlp)
    rng = np.random.default_rng(0)
    for name in compiled.ORACLE:
        plain, merged = compiled.rebuilt(solver.get_function(name), {}), library[name]
        assert merged.n_instructions() < plain.n_instructions(), name
        args = [rng.normal(size=plain.sparsity_in(i).shape) for i in range(plain.n_in())]
        for a, b in zip(plain.call(args), merged.call(args)):
            assert np.array_equal(np.asarray(a), np.asarray(b)), name


@needs_cc
def test_the_library_is_compiled_once_per_structure_and_found_again(small, cache):
    problem = small.with_options(functions="compiled")
    Transcription(problem)  # compiled here, or by an earlier test of this module
    libraries = set(cache.glob("*.so"))
    assert len(libraries) == 1
    # other numbers (spring rates, the limit margin) are parameters or bounds of the same
    # structure: the library is found, not compiled again
    again = Transcription(problem.with_spring_rates(1.3).with_options(limit_margin=2e-4))
    assert not again.compiled_now and set(cache.glob("*.so")) == libraries
    # a finer grid is another structure
    finer = Transcription(problem.with_options(grid=9))
    assert finer.compiled_now and len(list(cache.glob("*.so"))) == 2
    assert not [p for p in cache.iterdir() if p.name.startswith(TEMP_PREFIX)]  # no build folder


@needs_cc
def test_a_library_compiled_by_another_process_is_loaded_not_rebuilt(small, cache):
    Transcription(small.with_options(functions="compiled"))  # in the cache from here on
    code = (f"from cadcam.solve import compiled; compiled.CFLAGS = {FAST!r}; "
            "from cadcam import load_spec; from cadcam.solve.transcription import Transcription; "
            f"p = load_spec({str(SPEC_1DOF)!r}).with_options(grid=8, convexity_points=12, "
            "functions='compiled'); print(Transcription(p).compiled_now)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={**os.environ, "CADCAM_CACHE_DIR": str(cache)}).stdout.strip()
    assert out == "False"


@needs_cc
def test_concurrent_writers_leave_one_whole_library(small, empty_cache):
    """Two threads compile the same structure at once (the compiler runs outside the GIL):
    both get a library that works, one file is left and no temporary folder."""
    problem = small.with_options(functions="compiled")
    nlp = Transcription(small.with_options(functions="expanded")).nlp  # the graph that names the library
    paths = []
    errors = at_once(lambda: paths.append(compiled.library(nlp)[0]))
    assert not errors and len(set(paths)) == 1
    assert sorted(p.name for p in empty_cache.iterdir()) == sorted([paths[0].name,
                                                                    compiled.record_path(paths[0]).name])
    objective, tr = _objective(problem)
    assert not tr.compiled_now and np.isfinite(objective)


def test_a_failed_compile_names_the_error_and_leaves_nothing(small, empty_cache, monkeypatch):
    monkeypatch.setattr(compiled, "CFLAGS", ("--no-such-flag",) + FAST)
    with pytest.raises(compiled.CompileError, match="compiling the NLP failed"):
        Transcription(small.with_options(functions="compiled"))
    assert not empty_cache.exists() or not list(empty_cache.iterdir())


@needs_cc
def test_a_failed_compile_stops_the_files_not_yet_started(small, empty_cache, monkeypatch):
    """On one core the files compile one after the other: when the first fails, the others
    (six more) are cancelled, not compiled in vain before the error is raised."""
    started = []

    def failing(cc, source):
        started.append(source.name)
        raise compiled.CompileError(f"compiling the NLP failed: {source.name}")

    monkeypatch.setattr(compiled, "_compile", failing)
    monkeypatch.setattr(compiled.os, "cpu_count", lambda: 1)
    with pytest.raises(compiled.CompileError, match="compiling the NLP failed"):
        Transcription(small.with_options(functions="compiled"))
    assert 1 <= len(started) <= 2 < len(compiled.ORACLE) + 1  # the worker may take one more
    assert not [p for p in empty_cache.iterdir() if p.name.startswith(TEMP_PREFIX)]  # no build folder


def test_without_a_compiler_the_cli_says_what_to_do(tmp_path, empty_cache, monkeypatch, capsys):
    monkeypatch.setattr(compiled.shutil, "which", lambda name: None)
    code = main(["design", str(SPEC_1DOF), "-o", str(tmp_path / "out"), "--grid", "8",
                 "--set", "solver.functions=compiled"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert "needs a C compiler" in err and "functions = 'auto'" in err
    assert not (tmp_path / "out").exists()


def test_the_spec_refuses_an_unknown_functions_value(tmp_path):
    from cadcam.spec import SpecError

    text = SPEC_1DOF.read_text().replace("[solver]", '[solver]\nfunctions = "jit"', 1)
    assert '"jit"' in text
    spec = tmp_path / "bad.toml"
    spec.write_text(text)
    with pytest.raises(SpecError, match="solver.functions.*one of"):
        load_spec(spec)


@needs_cc
def test_cache_command_lists_and_clears_the_compiled_libraries(small, empty_cache, capsys):
    assert main(["cache"]) == 0
    assert capsys.readouterr().out.startswith(f"{empty_cache}: 0 compiled NLP libraries, 0.0 MB")
    Transcription(small.with_options(functions="compiled"))
    (library,) = empty_cache.glob("nlp_*.so")
    (empty_cache / "notes.txt").write_text("not a library")
    assert main(["cache"]) == 0
    assert capsys.readouterr().out.startswith(
        f"{empty_cache}: 1 compiled NLP library, {library.stat().st_size / 1e6:.1f} MB")
    assert main(["cache", "--clear"]) == 0
    assert capsys.readouterr().out.startswith("removed 1 compiled NLP library")
    assert not library.exists() and (empty_cache / "notes.txt").exists()
    assert Transcription(small.with_options(functions="compiled")).compiled_now  # compiled again


def test_an_interrupted_compile_leaves_no_process_of_its_own(monkeypatch):
    """SIGTERM during `export --format shared` left the compiler's children running (6 of 7
    runs): the driver runs in a session of its own, killed whole when the wait is stopped."""
    import os
    import subprocess
    import time

    started = []
    real = subprocess.Popen.communicate

    def interrupted(self, *args, **kwargs):
        started.append(self.pid)
        time.sleep(0.3)  # the driver's own child is running by now
        raise KeyboardInterrupt
    monkeypatch.setattr(subprocess.Popen, "communicate", interrupted)
    with pytest.raises(KeyboardInterrupt):
        compiled.run_compiler(["sh", "-c", "sleep 60 & sleep 60"])  # a driver with a child, as cc has
    monkeypatch.setattr(subprocess.Popen, "communicate", real)
    deadline = time.monotonic() + 10  # killed at once; reaped (by init, here) within a second or two
    while time.monotonic() < deadline:
        try:
            os.killpg(started[0], 0)
        except ProcessLookupError:
            return  # no process of that session is left
        time.sleep(0.1)
    pytest.fail("a process of the compiler's session outlived the interrupt (its 60 s sleep)")


@needs_cc
def test_the_functions_called_once_after_a_solve_compile_with_their_own_flags(small, empty_cache, monkeypatch):
    """``nlp_grad`` (one call after a solve) compiles unoptimised, every function IPOPT calls
    at each iteration with CFLAGS; the flags name the library, and it solves as the expanded
    functions do."""
    commands, run = [], compiled._run
    monkeypatch.setattr(compiled, "_run", lambda command: (commands.append(command), run(command))[1])
    monkeypatch.setattr(compiled, "AFTER_SOLVE_CFLAGS", ("-O0", "-fPIC", "-DCADCAM_AFTER_SOLVE"))
    expanded = Transcription(small.with_options(functions="expanded"))
    key = compiled.key_of(expanded.nlp)
    assert _objective(small.with_options(functions="compiled"))[0] == pytest.approx(
        _objective(small.with_options(functions="expanded"))[0], rel=1e-6)
    flags = {os.path.basename(c[c.index("-c") + 1]): c[1:c.index("-c")] for c in commands if "-c" in c}
    assert flags.pop("nlp_grad.c") == ["-O0", "-fPIC", "-DCADCAM_AFTER_SOLVE"]
    assert set(flags) == {f"{name}.c" for name in ("nlp", *compiled.ORACLE) if name != "nlp_grad"}
    assert all(f == list(FAST) for f in flags.values())
    monkeypatch.setattr(compiled, "AFTER_SOLVE_CFLAGS", ("-O1", "-fPIC"))
    assert compiled.key_of(expanded.nlp) != key
