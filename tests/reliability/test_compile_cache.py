"""Only libraries this user compiled are loaded (issue 48, rule 2): the compile cache is a
private folder, each library's SHA-256 is recorded when it is compiled and checked before it is
loaded, a damaged or foreign entry gives expanded functions and one line (never a crash, a
CasADi traceback or a library cadcam did not compile), a killed background compile is taken
for dead by its process id, and ``cadcam cache --clear`` removes only what its records say it
wrote. One small library is compiled once for the module; each test mutates copies of it."""
import hashlib
import json
import os
import random
import signal
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import casadi as ca
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cadcam import evaluate, load_spec, optimize
from cadcam.cli import main
from cadcam.files import TEMP_PREFIX
from cadcam.optimize import default_start, solve
from cadcam.solve import compiled
from cadcam.solve.transcription import Transcription

from ..conftest import SPEC_1DOF, needs_cc

pytestmark = needs_cc

#: Compiler flags of these tests (as tests/solve/test_compiled.py's: -O0 compiles fastest).
FAST = ("-O0", "-fPIC")
#: A user id that is not this process's, for files "of another user" (root may give them).
OTHER_UID = 4242
#: The small problem's options: the 1-DOF structure on a coarse grid.
SMALL = {"grid": 8, "convexity_points": 12}


@pytest.fixture(autouse=True)
def fast_compile(monkeypatch):
    """The module's compiler flags (part of every library's key), background compiles off."""
    monkeypatch.setattr(compiled, "CFLAGS", FAST)
    monkeypatch.setenv(compiled.BACKGROUND_ENV, "0")


@pytest.fixture(scope="module")
def genuine(tmp_path_factory):
    """The small problem's library compiled once, with its record, in a cache of its own; its
    key and the expanded functions' objective of the small problem."""
    folder = tmp_path_factory.mktemp("genuine")
    problem = load_spec(SPEC_1DOF).with_options(**SMALL)
    with pytest.MonkeyPatch.context() as env:
        env.setattr(compiled, "CFLAGS", FAST)
        env.setenv("CADCAM_CACHE_DIR", str(folder))
        tr = Transcription(problem.with_options(functions="expanded"))  # the graph that names it
        library, compiled_now = compiled.library(tr.nlp)
        assert compiled_now
        key = compiled.key_of(tr.nlp)
    objective = evaluate(problem, solve(tr, problem, default_start(problem)).design).metrics.objective
    return {"library": library, "record": compiled.record_path(library), "key": key, "objective": objective,
            "nlp": tr.nlp, "designed": optimize(problem.with_options(functions="expanded")).solve.objective}


def _copy(genuine, folder: Path) -> Path:
    """A private cache ``folder`` holding a copy of the genuine library and its record; the
    library's path."""
    folder.mkdir(mode=0o700)
    for name in ("library", "record"):
        shutil.copy2(genuine[name], folder / genuine[name].name)
    return folder / genuine["library"].name


def _canary_loaded(canary: Path) -> bool:
    return (canary.parent / "loaded").exists()


def _other_user(path: Path) -> None:
    if os.geteuid() != 0:
        pytest.skip("giving a file to another user needs root")
    os.chown(path, OTHER_UID, -1, follow_symlinks=False)


def _replace(path: Path, make) -> None:
    """Put ``make(path)`` where the file ``path`` was."""
    path.unlink()
    make(path)


def _relinked(path: Path, target: Path) -> None:
    """A link to ``target`` where the file ``path`` was."""
    _replace(path, lambda p: p.symlink_to(target))


def _outside(entry: Path) -> Path:
    """A new folder beside the cache that holds ``entry``."""
    return Path(tempfile.mkdtemp(dir=entry.parent.parent))


def _elsewhere(path: Path) -> Path:
    """A copy of the cache's file ``path`` outside the cache."""
    copy = _outside(path) / path.name
    shutil.copy2(path, copy)
    return copy


#: Ways a cache entry is damaged, swapped or planted: (library, record, canary, position) →
#: None, each leaving something under the library's name that cadcam must not load.
ENTRY_MUTATIONS = {
    "truncated": lambda lib, rec, canary, pos: os.truncate(lib, pos % lib.stat().st_size),
    "emptied": lambda lib, rec, canary, pos: os.truncate(lib, 0),
    "byte flipped": lambda lib, rec, canary, pos: _flip(lib, pos),
    "bytes appended": lambda lib, rec, canary, pos: lib.write_bytes(lib.read_bytes() + pos.to_bytes(4, "little")),
    "garbage": lambda lib, rec, canary, pos: lib.write_bytes(random.Random(pos).randbytes(lib.stat().st_size)),
    "another library under its name": lambda lib, rec, canary, pos: shutil.copyfile(canary, lib),
    "canary planted, no record": lambda lib, rec, canary, pos: (shutil.copyfile(canary, lib), rec.unlink()),
    "no record": lambda lib, rec, canary, pos: rec.unlink(),
    "record truncated": lambda lib, rec, canary, pos: os.truncate(rec, pos % (rec.stat().st_size - 1)),
    "record garbage": lambda lib, rec, canary, pos: rec.write_bytes(random.Random(pos).randbytes(pos % 9000)),
    "record a folder": lambda lib, rec, canary, pos: _replace(rec, Path.mkdir),
    "record a link": lambda lib, rec, canary, pos: _relinked(rec, _elsewhere(rec)),
    "record of another user": lambda lib, rec, canary, pos: _other_user(rec),
    "record group-writable": lambda lib, rec, canary, pos: rec.chmod(0o620),
    "a link to the library": lambda lib, rec, canary, pos: _relinked(lib, _elsewhere(lib)),
    "a link to the canary": lambda lib, rec, canary, pos: _relinked(lib, canary),
    "a link to nothing": lambda lib, rec, canary, pos: _relinked(lib, lib.parent / "gone"),
    "a folder": lambda lib, rec, canary, pos: _replace(lib, Path.mkdir),
    "a FIFO": lambda lib, rec, canary, pos: _replace(lib, os.mkfifo),
    "of another user": lambda lib, rec, canary, pos: _other_user(lib),
    "group-writable": lambda lib, rec, canary, pos: lib.chmod(0o520),
    "writable by others": lambda lib, rec, canary, pos: lib.chmod(0o502),
}
#: The entry mutations this process can make (giving a file to another user needs root).
MUTABLE = sorted(name for name in ENTRY_MUTATIONS if os.geteuid() == 0 or "another user" not in name)


def _flip(path: Path, pos: int) -> None:
    data = bytearray(path.read_bytes())
    data[pos % len(data)] ^= 1 << pos % 8
    path.write_bytes(bytes(data))


def _mutated(genuine, canary, folder: Path, name: str, pos: int = 12345) -> Path:
    """A copy of the genuine cache in ``folder`` with its entry mutated as ``name`` says."""
    lib = _copy(genuine, folder)
    ENTRY_MUTATIONS[name](lib, compiled.record_path(lib), canary, pos)
    return folder


def _one_warning(err: str, *words: str) -> str:
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("cadcam: warning: "), err
    assert all(word in lines[0] for word in words), lines[0]
    return lines[0]


@settings(max_examples=80, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(MUTABLE), pos=st.integers(0, 2**31))
def test_no_damaged_or_foreign_entry_is_ever_offered_for_loading(genuine, planted, tmp_path, monkeypatch, capsys,
                                                                 name, pos):
    folder = _mutated(genuine, planted, Path(tempfile.mkdtemp(dir=tmp_path)) / "cache", name, pos)
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(folder))
    assert compiled.cached_library(genuine["key"]) is None
    _one_warning(capsys.readouterr().err, "compiled library", "not loaded", "expanded functions")
    assert compiled.cached_libraries() == []
    assert not _canary_loaded(planted)


def test_the_genuine_copy_is_loaded(genuine, tmp_path, monkeypatch, capsys):
    """The control: a copy of the library with its record, in a private folder, is used."""
    lib = _copy(genuine, tmp_path / "cache")
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(tmp_path / "cache"))
    assert compiled.cached_library(genuine["key"]) == lib and compiled.cached_libraries() == [lib]
    assert capsys.readouterr().err == ""


#: Ways the cache folder is another's: (folder) → None.
FOLDER_MUTATIONS = {
    "shared, mode 1777": lambda folder: folder.chmod(0o1777),
    "mode 777": lambda folder: folder.chmod(0o777),
    "group-writable": lambda folder: folder.chmod(0o770),
    "group-writable only": lambda folder: folder.chmod(0o720),
    "writable by others only": lambda folder: folder.chmod(0o702),
    "of another user": lambda folder: _other_user(folder),
    "a link to a shared folder": lambda folder: _replace_folder(folder),
}


def _replace_folder(folder: Path) -> None:
    """``folder`` moved to a shared (1777) folder and a link to it left in its place."""
    shared = _outside(folder / "x") / "shared"
    folder.rename(shared)
    shared.chmod(0o1777)
    folder.symlink_to(shared)


def _forged(folder: Path, genuine, canary) -> None:
    """The canary under the genuine library's name with a record that matches it: all that
    stands between it and loading is the folder's own check."""
    lib = folder / genuine["library"].name
    shutil.copyfile(canary, lib)
    lib.chmod(compiled.LIBRARY_MODE)
    data = canary.read_bytes()
    record = {"library": lib.name, "bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}
    compiled.record_path(lib).write_text(json.dumps(record))


@pytest.mark.parametrize("name", sorted(FOLDER_MUTATIONS))
def test_a_cache_folder_others_may_write_is_not_used(genuine, planted, tmp_path, monkeypatch, capsys, name):
    folder = tmp_path / "cache"
    _copy(genuine, folder)
    _forged(folder, genuine, planted)
    FOLDER_MUTATIONS[name](folder)
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(folder))
    monkeypatch.setenv(compiled.BACKGROUND_ENV, "1")
    monkeypatch.setattr(compiled, "_compile", _never)  # nothing is compiled into it either
    monkeypatch.setattr(compiled.subprocess, "Popen", _never)
    assert compiled.cached_library(genuine["key"]) is None
    assert compiled.library(genuine["nlp"], key=genuine["key"]) == (None, False)
    assert not compiled.compile_in_background(genuine["nlp"], key=genuine["key"])
    _one_warning(capsys.readouterr().err, "compile cache", "not used", "expanded functions", "CADCAM_CACHE_DIR")
    assert compiled.cached_libraries() == [] and not _canary_loaded(planted)
    assert main(["cache"]) == 0 and "not used" in capsys.readouterr().out
    assert main(["cache", "--clear"]) == 2
    assert len(capsys.readouterr().err.splitlines()) == 1
    assert (folder / genuine["library"].name).exists()  # not cleared either


def _never(*args, **kwargs):
    raise AssertionError("called where the cache may not be used")


def test_the_folder_is_created_private(tmp_path, monkeypatch):
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(tmp_path / "new" / "cache"))
    assert compiled.folder_refusal(create=True) is None
    assert (tmp_path / "new" / "cache").stat().st_mode & 0o777 == compiled.FOLDER_MODE


#: Designs of the small problem in a fresh process, each with the ``functions`` and the cache
#: folder given (in pairs): a JSON line naming each case before it runs (where a crash such as
#: SIGBUS stopped) and one with how it ended.
DESIGNS = """
import contextlib, io, json, os, shutil, sys
from cadcam import evaluate, load_spec
from cadcam.optimize import default_start, solve
from cadcam.solve import compiled
from cadcam.solve.transcription import Transcription

compiled.CFLAGS = {flags!r}
genuine = {genuine!r}
# a compile here gives the genuine library: what is tested is which library is loaded
compiled._compile = lambda cc, source: source
compiled._run = lambda command: shutil.copyfile(genuine, command[command.index("-o") + 1])
small = load_spec({spec!r}).with_options(**{small!r})
for functions, folder in zip(sys.argv[1::2], sys.argv[2::2]):
    os.environ["CADCAM_CACHE_DIR"] = folder
    print(json.dumps({{"case": folder}}), flush=True)
    problem = small.with_options(functions=functions)
    with contextlib.redirect_stderr(io.StringIO()) as err:
        tr = Transcription(problem)
        design = solve(tr, problem, default_start(problem)).design
    print(json.dumps({{"functions": tr.functions_used, "stderr": err.getvalue(),
                      "objective": evaluate(problem, design).metrics.objective}}), flush=True)
"""


def _designs(genuine, cases: list[tuple[str, Path]]) -> list[dict]:
    """How a design of the small problem went with each (functions, cache folder) of ``cases``
    (:data:`DESIGNS`)."""
    code = DESIGNS.format(flags=FAST, genuine=str(genuine["library"]), spec=str(SPEC_1DOF), small=SMALL)
    run = subprocess.run([sys.executable, "-c", code, *(str(x) for case in cases for x in case)],
                         capture_output=True, text=True, timeout=600)
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    assert run.returncode == 0, (run.returncode, lines[-1:], run.stderr[-2000:])  # -7: SIGBUS
    assert run.stderr == ""
    return lines[1::2]


#: The mutations a whole design is run through in a fresh process, by ``functions`` (all of
#: them would take long; the generated test above shows that none is offered for loading, and
#: the command line's test below runs the truncated library with auto).
DESIGNED = {"auto": ("another library under its name", "canary planted, no record",
                     "a link to the canary", "shared folder"),
            "compiled": ("truncated", "a folder", "shared folder")}


def test_a_design_from_a_damaged_or_foreign_entry_returns_the_expanded_numbers(genuine, planted, tmp_path):
    """Each design expands its functions (auto) or compiles the library again (compiled, here
    the genuine one put in its place), with one line saying why, and reaches the optimum of
    expanded functions; the truncated library no longer ends the process with SIGBUS."""
    cases = []
    for functions, names in DESIGNED.items():
        for name in names:
            folder = tmp_path / f"{functions}-{name}"
            if name == "shared folder":  # the canary with a record that matches it
                _copy(genuine, folder)
                _forged(folder, genuine, planted)
                folder.chmod(0o1777)
            else:
                _mutated(genuine, planted, folder, name)
            cases.append((functions, folder))
    for (functions, folder), out in zip(cases, _designs(genuine, cases)):
        again = functions == "compiled" and folder.name.endswith("truncated")
        assert out["functions"] == ("compiled (now)" if again else "expanded"), folder.name
        assert out["objective"] == pytest.approx(genuine["objective"], rel=1e-6 if again else 1e-12), folder.name
        _one_warning(out["stderr"], "compiling it again" if again else "expanded functions")
        if again:  # the genuine library, recorded, in the damaged one's place
            assert compiled.library_refusal(folder / genuine["library"].name) is None
    assert not _canary_loaded(planted)


def test_the_command_line_survives_a_truncated_library(genuine, planted, tmp_path):
    """Before: SIGBUS for every design of the structure until the cache was cleared."""
    folder = _mutated(genuine, planted, tmp_path / "cache", "truncated", 4096)
    code = (f"import sys; from cadcam.solve import compiled; compiled.CFLAGS = {FAST!r}; "
            "from cadcam.cli import main; sys.exit(main(sys.argv[1:]))")
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, "-c", code, "design", str(SPEC_1DOF), "-o", str(out), "--no-figures",
                          "--grid", str(SMALL["grid"]), "--set", f"solver.convexity_points={SMALL['convexity_points']}"],
                         capture_output=True, text=True, timeout=600,
                         env={**os.environ, "CADCAM_CACHE_DIR": str(folder), compiled.BACKGROUND_ENV: "0"})
    assert run.returncode == 0, run.stderr
    _one_warning(run.stderr, "not loaded", "its content is not what cadcam compiled")
    solver = json.loads((out / "result.json").read_text())["solver"]
    assert solver["functions"] == "expanded"
    assert solver["objective"] == pytest.approx(genuine["designed"], rel=1e-12)  # as cadcam.optimize expanded


# -- background compiles whose process was killed ----------------------------------------------

def _ended() -> int:
    """The id of a process that has ended."""
    proc = subprocess.Popen(["true"])
    proc.wait()
    return proc.pid


class _Started:
    """Stands in for ``subprocess.Popen`` in the cache module: records the background
    compiles started, starts none."""

    pid = 999_999

    def __init__(self, command, **kwargs):
        type(self).commands.append(command)


def _owned(pending: Path, pid: int, host: str | None = None) -> None:
    (pending / compiled.OWNER_FILE).write_text(f"{pid} {host or socket.gethostname()}\n")


def _aged(pending: Path) -> None:
    old = os.stat(pending).st_mtime - compiled.PENDING_STALE_S - 1
    os.utime(pending, (old, old))


def _linked_away(pending: Path) -> None:
    """A link to a folder of the user's where the folder ``pending`` was."""
    shutil.rmtree(pending)
    target = _outside(pending)
    (target / "keep").write_text("the user's")
    pending.symlink_to(target)


#: What a background compile's folder holds when the next design comes, and whether that
#: design starts the compile again at once.
PENDING = {
    "its process was killed": (lambda p: _owned(p, _ended()), True),
    "its process was killed, its NLP truncated": (lambda p: (_owned(p, _ended()), os.truncate(p / compiled.NLP_FILE, 7)), True),
    "its process runs": (lambda p: _owned(p, os.getpid()), False),
    "its process runs on another host": (lambda p: _owned(p, _ended(), "elsewhere.invalid"), False),
    "its process is not named yet": (lambda p: None, False),
    "its process named in garbage": (lambda p: (p / compiled.OWNER_FILE).write_bytes(b"\xff\x00 12"), False),
    "pending past the limit (its pid reused)": (lambda p: (_owned(p, os.getpid()), _aged(p)), True),
    "another host's, past the limit": (lambda p: (_owned(p, 1, "elsewhere.invalid"), _aged(p)), True),
    "a file in its place": (lambda p: (shutil.rmtree(p), p.write_text("not a folder")), True),
    "a link in its place": (lambda p: _linked_away(p), True),
}


@pytest.mark.parametrize("name", sorted(PENDING))
def test_a_killed_background_compile_does_not_block_the_next(genuine, tmp_path, monkeypatch, name):
    folder = tmp_path / "cache"
    folder.mkdir(mode=0o700)
    pending = folder / compiled.PENDING_NAME.format(genuine["key"])
    pending.mkdir()
    (pending / compiled.NLP_FILE).write_text("the NLP")
    make, again = PENDING[name]
    make(pending)
    target = pending.resolve() if pending.is_symlink() else None
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(folder))
    monkeypatch.setenv(compiled.BACKGROUND_ENV, "1")
    monkeypatch.setattr(_Started, "commands", [], raising=False)
    monkeypatch.setattr(compiled.subprocess, "Popen", _Started)
    assert compiled.compile_in_background(genuine["nlp"], key=genuine["key"])  # under way either way
    assert len(_Started.commands) == int(again)
    if again:  # a fresh folder naming the new process, holding the NLP to compile
        assert pending.is_dir() and not pending.is_symlink()
        assert (pending / compiled.OWNER_FILE).read_text().split() == [str(_Started.pid), socket.gethostname()]
        assert ca_function_inputs(pending / compiled.NLP_FILE) == 2
    if target is not None:
        assert target.is_dir() and list(target.iterdir())  # the link's folder untouched


def ca_function_inputs(path: Path) -> int:
    return ca.Function.load(str(path)).n_in()


def test_a_background_compile_killed_at_once_is_started_again_by_the_next_design(genuine, tmp_path, monkeypatch):
    """The real detached process, killed with SIGKILL: before, every design said "compiling
    in the background" for 15 minutes and nothing compiled."""
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv(compiled.BACKGROUND_ENV, "1")
    pending = tmp_path / "cache" / compiled.PENDING_NAME.format(genuine["key"])
    pids = []
    for _ in range(2):
        assert compiled.compile_in_background(genuine["nlp"], key=genuine["key"])
        pid = int((pending / compiled.OWNER_FILE).read_text().split()[0])
        os.kill(pid, signal.SIGKILL)
        pids.append(pid)
        # the signal takes a moment; a child of this process, it stays a zombie until reaped
        deadline = time.monotonic() + 30
        while not compiled._ended(pid):
            assert time.monotonic() < deadline, "a killed compile's process taken for running"
            time.sleep(0.05)
    assert pids[0] != pids[1] and os.getpid() not in pids
    assert compiled.clear_cache() == (0, 0, [])  # the killed compile's folder is gone with it
    assert not pending.exists()


def test_a_truncated_pending_nlp_is_noted_as_failed_not_a_crash(genuine, tmp_path):
    """The detached process itself, on its NLP cut short at several places."""
    nlp = tmp_path / "nlp.casadi"
    compiled._nlp_function(genuine["nlp"]).save(str(nlp))
    size = nlp.stat().st_size
    folders = []
    for i, cut in enumerate(random.Random(48).sample(range(size), 3) + [0]):
        folder = tmp_path / f"cache{i}"
        pending = folder / compiled.PENDING_NAME.format(genuine["key"])
        pending.mkdir(parents=True)
        shutil.copyfile(nlp, pending / compiled.NLP_FILE)
        os.truncate(pending / compiled.NLP_FILE, cut)
        folders.append(pending)
    code = ("import sys; from pathlib import Path; from cadcam.solve import compiled\n"
            "for pending in sys.argv[2:]: compiled.compile_pending(sys.argv[1], Path(pending))")
    run = subprocess.run([sys.executable, "-c", code, genuine["key"], *map(str, folders)], capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0 and run.stderr == "", run.stderr
    for pending in folders:
        assert not pending.exists()
        assert (pending.parent / compiled.FAILED_NAME.format(genuine["key"])).read_text()


# -- cadcam cache and cadcam cache --clear --------------------------------------------------------

def _crowded(genuine, canary, folder: Path) -> tuple[Path, list[str]]:
    """A cache with the genuine library and, under other libraries' names, every mutation;
    the genuine library's path and the mutated entries' names."""
    lib = _copy(genuine, folder)
    names = []
    for i, mutation in enumerate(MUTABLE):
        other = folder / compiled.LIBRARY_NAME.format(f"{i:032x}")
        shutil.copy2(lib, other)
        shutil.copy2(compiled.record_path(lib), compiled.record_path(other))
        ENTRY_MUTATIONS[mutation](other, compiled.record_path(other), canary, 1000 + i)
        names.append(other.name)
    return lib, names


def test_the_cache_command_lists_what_it_would_load_and_names_the_rest(genuine, planted, tmp_path, monkeypatch,
                                                                        capsys):
    lib, others = _crowded(genuine, planted, tmp_path / "cache")
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(tmp_path / "cache"))
    assert main(["cache"]) == 0
    out = capsys.readouterr()
    assert out.err == "" and len(out.out.splitlines()) == 1
    assert out.out.startswith(f"{tmp_path / 'cache'}: 1 compiled NLP library, {lib.stat().st_size / 1e6:.1f} MB")
    assert f"never loaded: {others[0]!r} (" in out.out and f"and {len(others) - 3} more" in out.out


def test_clear_removes_only_what_its_records_say_it_wrote(genuine, planted, tmp_path, monkeypatch, capsys):
    folder = tmp_path / "cache"
    lib, others = _crowded(genuine, planted, folder)
    note = folder / compiled.FAILED_NAME.format("0" * 32)
    note.write_text("compiling the NLP failed: …")
    dead = folder / f"{TEMP_PREFIX}{_ended()}-build-x"
    alive = folder / f"{TEMP_PREFIX}{os.getpid()}-build-y"
    for build in (dead, alive):
        build.mkdir()
        (build / "nlp_f.o").write_bytes(b"half an object")
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(folder))
    size = lib.stat().st_size
    assert main(["cache", "--clear"]) == 0
    out = capsys.readouterr()
    assert out.err == "" and len(out.out.splitlines()) == 1
    assert out.out.startswith(f"removed 1 compiled NLP library ({size / 1e6:.1f} MB) from {folder}; ")
    assert "left in place, not cadcam's to remove" in out.out and f"and {len(others) - 3} more" in out.out
    assert not lib.exists() and not compiled.record_path(lib).exists()
    assert all(os.path.lexists(folder / name) for name in others)  # each mutated entry stays
    assert not note.exists() and not dead.exists() and alive.exists()
    assert not _canary_loaded(planted)
    assert main(["cache", "--clear"]) == 0
    assert capsys.readouterr().out.startswith("removed 0 compiled NLP libraries")


# -- a failing compiler -------------------------------------------------------------------------

@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(output=st.binary(max_size=600), end=st.sampled_from(["exit 1", "exit 4", "kill -9 $$", "kill -11 $$"]))
def test_a_failing_compilers_message_is_one_printable_line(output, end):
    with tempfile.NamedTemporaryFile() as said:
        said.write(output)
        said.flush()
        with pytest.raises(compiled.CompileError) as failed:
            compiled._run(["sh", "-c", f"cat {said.name} >&2; {end}"])
    message = str(failed.value)
    assert message.startswith("compiling the NLP failed: ") and message.isprintable()
    assert len(message) <= len("compiling the NLP failed: ") + compiled.FAILURE_CHARS
    assert len(message.splitlines()) == 1


#: C compilers that fail, as the script named ``cc`` on PATH.
COMPILERS = {
    "two lines of error": b"#!/bin/sh\necho 'cc1: error: out of memory' >&2\necho 'compilation terminated.' >&2\n"
                          b"exit 1\n",
    "bytes that are not UTF-8": b"#!/bin/sh\nprintf '\\377\\376 Fehler: \\344\\n' >&2\nexit 1\n",
    "terminal escape codes": b"#!/bin/sh\nprintf '\\033[2J\\033]0;title\\007error: x\\n' >&2\nexit 1\n",
    "killed": b"#!/bin/sh\nkill -9 $$\n",
    "not a program": b"\x7fELF\x02\x01\x01 not really",
}


@pytest.mark.parametrize("compiler", sorted(COMPILERS))
@pytest.mark.parametrize("command", ["design", "export"])
def test_a_failing_compiler_ends_the_run_with_one_line(compiler, command, tmp_path, monkeypatch, capsys):
    from ..conftest import SPEC_RR, TABLE3

    cc = tmp_path / "bin" / "cc"
    cc.parent.mkdir()
    cc.write_bytes(COMPILERS[compiler])
    cc.chmod(0o755)
    monkeypatch.setenv("PATH", f"{cc.parent}{os.pathsep}{os.environ['PATH']}")
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "out"
    argv = {"design": ["design", str(SPEC_1DOF), "-o", str(out), "--no-figures", "--grid", "8",
                       "--set", "solver.functions=compiled"],
            "export": ["export", str(SPEC_RR), "--design", str(TABLE3), "--format", "shared", "-o", str(out)]}
    assert main(argv[command]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and err.startswith("cadcam: error: ") and err.strip().isprintable(), err
    assert not out.exists() or not [p for p in out.iterdir() if p.suffix == ".so"]
