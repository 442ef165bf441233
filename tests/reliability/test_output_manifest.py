"""Issue 48, rule 3: files in an output folder are judged by content, not by name.

Each set of outputs records its files' SHA-256 and size in the folder's manifest; a later set
replaces or removes only the files that still match it, is refused before any work (one line;
exit 2 at the command line) for anything else where it would write, and comes in whole or not
at all. One design of the 1-DOF spec is written once per module as a full set (figures, sheets,
STL) and as a lean one (``--no-figures``); the tests edit,
plant and break files in copies of them, over every file name a run writes, the damage done to
them and the steps of the swap at which it fails.
"""
from __future__ import annotations

import errno
import hashlib
import importlib
import json
import os
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cadcam.cli import main
from cadcam.files import MANIFEST, NotCadcams, recorded_sets, remove_leftovers, staged_folder
from cadcam.make import step
from cadcam.outputs.run_files import run_file_names

from ..conftest import SPEC_1DOF

#: The set a design names itself by in the manifest: the file it writes last.
MARKER = "result.json"
#: Names of files a 1-DOF design writes under other options or other designs (a second cam's,
#: a helical groove's, a mechanism with an output law's), and names no design writes.
OTHER_NAMES = ("cam2.dxf", "cam2_sheet.png", "cam1_groove.csv", "output.csv", "output.png", "notes.txt",
               "cam1_notes.txt")


def _settings(n: int):
    return settings(max_examples=n, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))


@dataclass(frozen=True)
class Written:
    """A set of one design's outputs as written by ``Result.save(folder, workshop, figures)``."""

    folder: Path
    figures: bool
    workshop: object

    def names(self) -> list[str]:
        return sorted(n for n in os.listdir(self.folder) if n != MANIFEST)


class Made(tuple):
    """(the design's Result, its sets by name), shown short in hypothesis's reports."""

    def __repr__(self) -> str:
        return f"<the 1-DOF design and its sets {sorted(self[1])}>"


@pytest.fixture(scope="module")
def made(tmp_path_factory, result_1dof):
    """The design and its two sets, ``full`` and ``lean``. The full set has no STEP solid even
    where build123d is installed: it takes longer than the rest of the module, and its name is
    one more of the set's, swapped like the STL's (``run_file_names`` foresees it)."""
    result = result_1dof
    root = tmp_path_factory.mktemp("sets")
    solids = result.problem.workshop.with_solids()
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(step, "available", lambda: False)
        result.save(root / "full", workshop=solids, workers=2)
    result.save(root / "lean", figures=False)
    return Made((result, {"full": Written(root / "full", True, solids), "lean": Written(root / "lean", False, "spec")}))


@pytest.fixture
def scratch(tmp_path_factory):
    """A new empty folder per call (a hypothesis example needs one of its own)."""
    return lambda: tmp_path_factory.mktemp("case")


def tree(folder: Path) -> dict:
    """Every entry under ``folder``, hidden ones included: its bytes, or what it is."""
    return {str(p.relative_to(folder)): "link" if p.is_symlink() else p.read_bytes() if p.is_file() else "folder"
            for p in sorted(folder.rglob("*"))}


def digests(folder: Path, names) -> dict:
    """(SHA-256, size) of the files ``names`` of ``folder``, computed here."""
    return {n: (hashlib.sha256(b := (folder / n).read_bytes()).hexdigest(), len(b)) for n in names}


def clone(written: Written, folder: Path) -> Path:
    """A copy of the set ``written`` (its manifest too) as the folder ``folder``/out."""
    return Path(shutil.copytree(written.folder, folder / "out", symlinks=True))


def save(result, written: Written, folder: Path) -> None:
    """``result`` saved into ``folder`` as ``written`` was saved."""
    result.save(folder, workshop=written.workshop, figures=written.figures)


def assert_whole_new_set(folder: Path, names, others: dict) -> None:
    """``folder`` holds the set of ``names``, each as its manifest records it, and the files
    ``others`` (name → bytes) as they were; nothing else, no hidden file but the manifest."""
    listing = sorted(os.listdir(folder))
    assert listing == sorted([*names, *others, MANIFEST])
    assert recorded_sets(folder)[MARKER] == digests(folder, names)
    assert all((folder / n).read_bytes() == data for n, data in others.items())


def _replace_the_solve(monkeypatch, solve) -> None:
    """``cadcam.optimize.optimize`` replaced by ``solve`` for the command line (which imports
    it from there when it runs); cadcam.api imported before, so that its own name for the
    function stays the real one in the tests that run after."""
    importlib.import_module("cadcam.api")
    monkeypatch.setattr(importlib.import_module("cadcam.optimize"), "optimize", solve)


@pytest.fixture
def no_work(monkeypatch):
    """Fail the test if a design run begins its work: the solve, or writing its files."""
    def began(*args, **kwargs):
        raise AssertionError("the work began before the folder was checked")
    _replace_the_solve(monkeypatch, began)
    monkeypatch.setattr("cadcam.result.write_workshop_files", began)
    monkeypatch.setattr("cadcam.result.write_outputs", began)


@pytest.fixture
def cli(monkeypatch, made, capsys):
    """``cadcam design`` of the 1-DOF spec with the solve replaced by the finished one: (exit
    code, stdout, stderr)."""
    _replace_the_solve(monkeypatch, lambda problem: made[0])

    def run(out: Path, *flags: str):
        code = main(["design", str(SPEC_1DOF), "-o", str(out), *flags])
        captured = capsys.readouterr()
        return code, captured.out, captured.err
    return run


# -- what a set records -------------------------------------------------------------------------
def test_a_set_records_every_file_it_wrote_and_each_was_foreseen(made):
    result, sets = made
    for written in sets.values():
        names = written.names()
        assert recorded_sets(written.folder) == {MARKER: digests(written.folder, names)}
        sizes = result.problem.workshop if written.workshop == "spec" else written.workshop
        assert set(names) <= set(run_file_names(result.problem, written.figures, sizes))
    full, lean = sets["full"].names(), sets["lean"].names()
    assert {"profile.png", "torque.png", "springs.png", "convergence.png", "cam1_sheet.pdf", "cam1_sheet.png",
            "cam1.stl", "cam1.dxf", "verification.json"} <= set(full)
    assert "cam1.step" in run_file_names(result.problem, True, sets["full"].workshop)
    assert set(lean) < set(full) and not [n for n in lean if n.endswith((".png", ".pdf", ".stl", ".step"))]


# -- a file of the set changed since: refused before any work ------------------------------------
def _edited(path: Path, monkeypatch) -> None:
    path.write_bytes(path.read_bytes() + b"\n")


def _same_size_other_bytes(path: Path, monkeypatch) -> None:
    data = path.read_bytes()
    path.write_bytes(bytes([data[0] ^ 1]) + data[1:])


def _truncated(path: Path, monkeypatch) -> None:
    path.write_bytes(b"")


def _unreadable(path: Path, monkeypatch) -> None:
    """Read permission removed; where that does not stop this process (root), its opening
    fails as it would."""
    path.chmod(0)
    real = os.open

    def refused(file, *args, **kwargs):
        if os.fspath(file) == str(path):
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real(file, *args, **kwargs)
    monkeypatch.setattr(os, "open", refused)


def _link_to_a_copy(path: Path, monkeypatch) -> None:
    """The same bytes, through a link: cadcam writes files, never links, and replacing a link
    would not replace what it leads to."""
    copy = path.parent.parent / f"copy-{path.name}"
    path.rename(copy)
    path.symlink_to(copy)


def _a_folder(path: Path, monkeypatch) -> None:
    path.unlink()
    path.mkdir()
    (path / "mine.txt").write_text("the user's")


DAMAGE = {f.__name__.strip("_"): f for f in (_edited, _same_size_other_bytes, _truncated, _unreadable,
                                              _link_to_a_copy, _a_folder)}


def _assert_refused_before_work(result, written: Written, folder: Path, name: str) -> None:
    before = tree(folder)
    with pytest.raises(NotCadcams) as refused:
        save(result, written, folder)
    message = str(refused.value)
    assert message.startswith(f"{folder / name}: ") and "\n" not in message and "move it away" in message
    assert tree(folder) == before


def test_every_file_of_a_set_edited_since_refuses_the_next_run_before_work(made, scratch, no_work):
    """Every name of the full set, edited by the user: a rerun as the full set (which would
    replace it) and as the lean one (which would replace or remove it) refuses, naming it."""
    result, sets = made
    for name in sets["full"].names():
        folder = clone(sets["full"], scratch())
        _edited(folder / name, None)
        for new in sets.values():
            _assert_refused_before_work(result, new, folder, name)


@_settings(30)
@given(data=st.data(), damage=st.sampled_from(sorted(DAMAGE)), old=st.sampled_from(["full", "lean"]),
       new=st.sampled_from(["full", "lean"]))
def test_a_damaged_file_of_a_set_refuses_the_next_run_and_is_left_as_it_is(made, scratch, monkeypatch, no_work,
                                                                           data, damage, old, new):
    result, sets = made
    name = data.draw(st.sampled_from(sets[old].names()), label="name")
    folder = clone(sets[old], scratch())
    undamaged = tree(folder)
    with monkeypatch.context() as patch:
        DAMAGE[damage](folder / name, patch)
        before = undamaged if damage == "unreadable" else tree(folder)  # its bytes as they were
        with pytest.raises(NotCadcams) as refused:
            save(result, sets[new], folder)
    assert str(refused.value).startswith(f"{folder / name}: ") and "\n" not in str(refused.value)
    if damage == "unreadable":
        (folder / name).chmod(0o644)
    assert tree(folder) == before


# -- a user's file under a name: refused where the run writes, untouched elsewhere ---------------
@_settings(12)
@given(data=st.data(), base=st.sampled_from(["a set", "a set of a cadcam that kept no manifest", "nothing"]),
       entry=st.sampled_from(["Result.save", "cadcam design"]))
@pytest.mark.slow  # a design for each user's file planted: make test-slow
def test_a_users_file_is_never_replaced_or_removed(made, scratch, cli, data, base, entry):
    """A user's file in the folder: where the lean rerun would write it (or, without a
    manifest, where any file of the run stands) the run is refused before work, one line naming
    a file, exit 2 from the command line; elsewhere the new set comes in whole beside it."""
    result, sets = made
    lean = sets["lean"]
    name = data.draw(st.sampled_from(sorted({*sets["full"].names(), *OTHER_NAMES})), label="name")
    folder = scratch() / "out" if base == "nothing" else clone(lean, scratch())
    folder.mkdir(exist_ok=True)
    if base.endswith("no manifest"):
        (folder / MANIFEST).unlink()
    (folder / name).write_bytes(b"the user's own " + name.encode())
    before = tree(folder)
    foreseen = run_file_names(result.problem, lean.figures, result.problem.workshop)
    refused = name in foreseen or (base != "nothing" and not (folder / MANIFEST).exists())
    if entry == "Result.save":
        raised = None
        try:
            save(result, lean, folder)
        except NotCadcams as exc:
            raised = str(exc)
        assert (raised is not None) == refused
        assert raised is None or ("\n" not in raised and raised.startswith(str(folder)))
    else:
        code, out, err = cli(folder, "--no-figures")
        assert code == (2 if refused else 0)
        assert not refused or (out == "" and err.startswith("cadcam: error: ") and err.count("\n") == 1
                               and str(folder) in err)
    if refused:
        assert tree(folder) == before
    else:
        assert_whole_new_set(folder, lean.names(), {name: before[name]})


# -- a damaged manifest: refused, naming it ------------------------------------------------------
def _entry(data: bytes) -> dict:
    return {"sha256": hashlib.sha256(data).hexdigest(), "size": len(data)}


MANIFESTS = {
    "not JSON": lambda folder: "{",
    "another form": lambda folder: json.dumps({"cadcam_manifest": 99, "sets": {}}),
    "a name leading out of the folder": lambda folder: json.dumps(
        {"cadcam_manifest": 1, "sets": {MARKER: {"../victim.txt": _entry(b"the user's")}}}),
    "an absolute name": lambda folder: json.dumps(
        {"cadcam_manifest": 1, "sets": {MARKER: {str(folder.parent / "victim.txt"): _entry(b"the user's")}}}),
    "a digest that is not one": lambda folder: json.dumps(
        {"cadcam_manifest": 1, "sets": {MARKER: {"torque.csv": {"sha256": "x", "size": -1}}}}),
    "sets that are not a table": lambda folder: json.dumps({"cadcam_manifest": 1, "sets": []}),
}


@pytest.mark.parametrize("how", [*MANIFESTS, "a link to a manifest", "a folder"])
def test_a_manifest_cadcam_cannot_read_refuses_the_run(made, tmp_path, no_work, how):
    """A damaged or planted manifest is never trusted, and never leads outside the folder: the
    user's victim.txt beside the output folder, whose digest it gives, stays."""
    result, sets = made
    folder = clone(sets["lean"], tmp_path)
    (tmp_path / "victim.txt").write_text("the user's")
    manifest = folder / MANIFEST
    if how == "a link to a manifest":
        manifest.rename(tmp_path / "real-manifest.json")
        manifest.symlink_to(tmp_path / "real-manifest.json")
    elif how == "a folder":
        manifest.unlink()
        manifest.mkdir()
    else:
        manifest.write_text(MANIFESTS[how](folder))
    before = tree(tmp_path)
    with pytest.raises(NotCadcams, match="not a record of cadcam's") as refused:
        save(result, sets["lean"], folder)
    assert str(refused.value).startswith(f"{manifest}: ") and "\n" not in str(refused.value)
    assert tree(tmp_path) == before


# -- the swap: whole or not at all ----------------------------------------------------------------
#: Calls of the swap that may fail, and how they fail.
FAILURES = {"EIO": OSError(errno.EIO, "Input/output error"), "EPERM": PermissionError(errno.EPERM, "Operation not permitted"),
            "ENOSPC": OSError(errno.ENOSPC, "No space left on device"), "interrupt": KeyboardInterrupt()}
CALLS = ("replace", "unlink", "link")


def _failing_at(monkeypatch, folder: Path, at: int, calls, effect) -> list:
    """Make the ``at``-th call (from 0) of ``os.<call>`` for ``calls`` on an entry of
    ``folder`` itself run ``effect()`` instead; the calls seen, by name, returned."""
    seen = []

    def wrap(name, real):
        def call(*args, **kwargs):
            if any(isinstance(a, (str, Path)) and os.path.dirname(os.path.abspath(a)) == str(folder) for a in args):
                seen.append(name)
                if len(seen) == at + 1:
                    return effect()
            return real(*args, **kwargs)
        return call
    for name in calls:
        monkeypatch.setattr(os, name, wrap(name, getattr(os, name)))
    return seen


def _staged(written: Written, stage: Path) -> None:
    """The files of the set ``written`` copied into ``stage``."""
    for name in written.names():
        shutil.copyfile(written.folder / name, stage / name)


#: A user's files that no set writes: one named like a second cam's outline.
USERS = {"notes.txt": b"the user's", "cam2.dxf": b"the user's own outline"}


def _with_users_files(folder: Path) -> Path:
    for name, data in USERS.items():
        (folder / name).write_bytes(data)
    return folder


@_settings(30)
@given(old=st.sampled_from(["full", "lean"]), new=st.sampled_from(["full", "lean"]),
       at=st.sampled_from(range(40)), calls=st.sampled_from([*CALLS, "any"]), failure=st.sampled_from(sorted(FAILURES)))
def test_a_swap_that_fails_at_any_step_leaves_the_earlier_set_whole(made, scratch, monkeypatch, old, new, at,
                                                                    calls, failure):
    """A failure at a step of the swap (a rename, a removal, a link of the backup): the earlier
    set stays whole, with its manifest, and the error says so; or, where a link failed and a copy
    kept the file instead, the new set comes in whole. The user's files stay either way, and no
    hidden folder is left."""
    sets = made[1]
    folder = _with_users_files(clone(sets[old], scratch()))
    before = tree(folder)

    def effect():
        raise FAILURES[failure]
    raised = None
    try:
        with monkeypatch.context() as patch, staged_folder(folder, MARKER) as stage:
            _staged(sets[new], stage)
            seen = _failing_at(patch, folder, at, CALLS if calls == "any" else [calls], effect)
    except (OSError, KeyboardInterrupt) as exc:
        raised = exc
    if raised is None:
        assert len(seen) <= at or seen[at] == "link"  # a link failed: its file was copied instead
        assert_whole_new_set(folder, sets[new].names(), USERS)
        assert all((folder / n).read_bytes() == (sets[new].folder / n).read_bytes() for n in sets[new].names())
    else:
        assert tree(folder) == before
        assert isinstance(raised, KeyboardInterrupt) or "the earlier one is left whole" in str(raised)


@_settings(16)
@given(old=st.sampled_from(["full", "lean"]), new=st.sampled_from(["full", "lean"]), at=st.sampled_from(range(40)))
def test_a_swap_cut_short_by_sigkill_is_undone_by_the_next_run(made, scratch, old, new, at):
    """The writer killed (SIGKILL: nothing of its own runs) at a step of the swap: the next
    write into the folder finds its backup and puts the earlier set back whole, or finds the
    swap ended and keeps the new one."""
    sets = made[1]
    folder = _with_users_files(clone(sets[old], scratch()))
    before = tree(folder)
    pid = os.fork()
    if pid == 0:  # the writer
        try:
            with pytest.MonkeyPatch.context() as patch, staged_folder(folder, MARKER) as stage:
                _staged(sets[new], stage)
                _failing_at(patch, folder, at, CALLS, lambda: os._exit(9))
        finally:
            os._exit(0)
    _, status = os.waitpid(pid, 0)
    assert os.WEXITSTATUS(status) in (0, 9)
    remove_leftovers(folder)
    if tree(folder) != before:
        assert_whole_new_set(folder, sets[new].names(), USERS)


def _chattr(flag: str, path: Path) -> bool:
    try:
        return subprocess.run(["chattr", flag, str(path)], capture_output=True).returncode == 0
    except OSError:
        return False


@pytest.mark.parametrize("name", ["torque.csv", "torque.png"], ids=["replaced", "removed"])
def test_an_immutable_file_stops_the_swap_and_the_earlier_set_stays_whole(made, tmp_path, cli, name):
    """``chattr +i`` on a file the --no-figures rerun replaces (torque.csv) or removes (the
    full set's torque.png): exit 1, one line saying so; the whole earlier set, result.json and
    figures included, as it was."""
    folder = _with_users_files(clone(made[1]["full"], tmp_path))
    before = tree(folder)
    if not _chattr("+i", folder / name):
        pytest.skip("chattr +i is not available here (needs root and a file system that has it)")
    try:
        code, out, err = cli(folder, "--no-figures")
    finally:
        _chattr("-i", folder / name)
    # the design succeeded but its files were not written: the first line says so
    assert code == 1 and out.startswith(f"not written: {folder / name}: ")
    assert err.count("\n") == 1 and f"{folder / name}: " in err and "the earlier one is left whole" in err
    assert tree(folder) == before


# -- two kinds of set in one folder: a design's and an export's ---------------------------------
def test_an_export_beside_a_design_keeps_each_set_to_its_own_files(made, tmp_path, monkeypatch):
    from cadcam.export import codegen

    result, sets = made
    folder = _with_users_files(clone(sets["lean"], tmp_path))
    codegen.export(result.problem, result.design, "model", ["casadi"], folder)
    design_files = {n: (folder / n).read_bytes() for n in sets["lean"].names()}
    exported = sorted(recorded_sets(folder)["manifest.json"])
    assert exported == sorted(codegen.export_file_names("model", ["casadi"]))
    assert recorded_sets(folder)[MARKER] == digests(folder, design_files)
    (folder / exported[0]).write_bytes(b"edited")
    with monkeypatch.context() as patch:  # refused before the functions are built
        patch.setattr(codegen, "_write", lambda *args: pytest.fail("the export began"))
        with pytest.raises(NotCadcams, match=exported[0]):
            codegen.export(result.problem, result.design, "model", ["c"], folder)
    (folder / exported[0]).unlink()
    codegen.export(result.problem, result.design, "model", ["c"], folder)  # the .casadi files go
    assert sorted(recorded_sets(folder)["manifest.json"]) == sorted(codegen.export_file_names("model", ["c"]))
    assert not [n for n in os.listdir(folder) if n.endswith(".casadi")]
    assert {n: (folder / n).read_bytes() for n in design_files} == design_files
    assert recorded_sets(folder)[MARKER] == digests(folder, design_files)
    assert all((folder / n).read_bytes() == data for n, data in USERS.items())
