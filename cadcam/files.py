"""File input and output: inputs read only from regular files of bounded size as UTF-8 text,
outputs written atomically (a temporary file in the same folder, then a rename), and sets of
outputs staged and swapped into their folder whole or not at all.

A set replaces or removes only files that cadcam recorded writing: each swap records the files
of its set with their SHA-256 in the folder's hidden :data:`MANIFEST`, and a later set replaces
or removes a file only while it still matches that record; it is refused, before the caller's
work, for anything else where it would write (:func:`refuse_files_of_others`). A folder without
a manifest (or a set it does not record: written by a cadcam before the manifest) holds no file
of cadcam's: nothing in it is replaced or removed, and a file under a name the set writes
refuses it.

Temporary files, staging and backup folders are hidden and named ``.cadcam-<pid>-…``; one whose
process is gone (a run killed with SIGKILL) is removed by the next write into the same folder,
and a swap it cut short is undone first.
"""
from __future__ import annotations

import contextlib
import csv
import errno
import fcntl
import hashlib
import io
import json
import numbers
import os
import re
import secrets
import shutil
import stat
import sys
import tempfile
import tomllib
import unicodedata
from pathlib import Path

#: Start of every temporary file's and staging folder's name (followed by the writer's pid).
TEMP_PREFIX = ".cadcam-"
_TEMP_NAME = re.compile(re.escape(TEMP_PREFIX) + r"(\d+)-")

#: Largest input file read [bytes] (specs, target tables, studies, designs, catalogues); raise
#: it deliberately with the environment variable CADCAM_CAP_INPUT_BYTES.
MAX_INPUT_BYTES = 10_000_000

#: The record, hidden in a folder, of the sets of outputs cadcam swapped into it: per set, named
#: by its marker (the file the set writes last: ``result.json`` for a design, ``manifest.json``
#: for an export), each file's SHA-256 (hex) and size [bytes].
MANIFEST = ".cadcam-manifest.json"
#: The form of :data:`MANIFEST` this cadcam writes and reads (its ``cadcam_manifest`` key).
MANIFEST_FORM = 1
#: The file of a swap's backup folder giving the swap's token (which the manifest it brings in
#: holds) and the new files' digests, from which a swap cut short is undone
#: (:func:`_undo_cut_swap`); written once the backup is whole, so that a backup folder without
#: it held nothing that was not still in place.
_JOURNAL = ".cadcam-journal.json"
_SHA256 = re.compile(r"[0-9a-f]{64}")


class InputFileError(ValueError):
    """An input file that cannot be read as asked: the message is one line, without the path."""


class FolderBusy(ValueError):
    """Another cadcam run holds the output folder (:func:`held_folder`); one line."""


class NotCadcams(ValueError):
    """Something stands where a set of outputs would replace or remove a file, and it is not the
    file cadcam recorded writing there (:func:`refuse_files_of_others`); one line naming it."""


#: Unicode categories of the characters :func:`printable` escapes: controls (a terminal's
#: escape codes, line breaks, C1 controls), format characters (bidirectional overrides, zero
#: widths), surrogates (the undecodable bytes of a file name) and line and paragraph separators.
UNPRINTABLE = frozenset({"Cc", "Cf", "Cs", "Zl", "Zp"})

#: First characters of a CSV text cell that a spreadsheet takes for a formula (OWASP's CSV
#: injection list; its tab and carriage return, and any other control character, are escaped
#: before: :func:`printable`); such a cell gets a leading apostrophe (:func:`csv_text`).
FORMULA_STARTS = ("=", "+", "-", "@")

#: Most digits of a ``CADCAM_CAP_<NAME>`` value (:func:`env_cap`): more than any count of work.
CAP_DIGITS = 18


def printable(text: str) -> str:
    """``text`` with each character of :data:`UNPRINTABLE` written as an escape
    (``\\x1b``, ``\\n``, ``\\u202e``), as a Python literal writes it: what cadcam prints
    that names keys, names and paths stays on its line and sends a terminal no commands."""
    if text.isprintable():
        return text
    return "".join(_escape(ch) if unicodedata.category(ch) in UNPRINTABLE else ch for ch in text)


def _escape(ch: str) -> str:
    return repr(ch)[1:-1]  # Python escapes every character it does not print


def short_repr(value, limit: int = 80) -> str:
    """``repr(value)`` cut to ``limit`` characters, for one-line messages about input."""
    text = printable(repr(value))
    return text if len(text) <= limit else text[:limit - 1] + "…"


def env_cap(name: str, default: int) -> int:
    """A cap on work: the environment variable ``CADCAM_CAP_<NAME>`` if it is a positive
    integer (ASCII digits, at most :data:`CAP_DIGITS`), else ``default``: a value that is not
    one leaves the cap where it was."""
    text = os.environ.get(f"CADCAM_CAP_{name.upper()}", "")
    if not (text.isascii() and text.isdigit() and len(text) <= CAP_DIGITS):
        return default
    return int(text) or default


def read_input(path) -> str:
    """The text of the regular file ``path``, refused (:class:`InputFileError`) if it is
    missing, not a regular file (a folder, a device such as /dev/zero, a FIFO), larger than
    :data:`MAX_INPUT_BYTES` or not UTF-8."""
    limit = env_cap("input_bytes", MAX_INPUT_BYTES)
    if "\0" in os.fsdecode(path):  # a spec's string may hold one; the system takes no such name
        raise InputFileError("cannot read it (a NUL character in its name)")
    try:
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode):
            raise InputFileError("not a regular file (a folder, device or pipe); give a file")
        if st.st_size > limit:
            raise InputFileError(f"{st.st_size} bytes, over the cap of {limit} (raise it deliberately "
                                 "with CADCAM_CAP_INPUT_BYTES)")
        with open(path, "rb") as fh:
            data = fh.read(limit + 1)
    except OSError as exc:
        raise InputFileError(f"cannot read it ({exc.strerror or exc})") from None
    if len(data) > limit:
        raise InputFileError(f"over the cap of {limit} bytes (raise it deliberately with CADCAM_CAP_INPUT_BYTES)")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputFileError(f"not UTF-8 text (byte {exc.start}); save it as UTF-8") from None


def process_alive(pid: int) -> bool:
    """Whether process ``pid`` runs on this machine (another user's process counts as running)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process (EPERM): alive
        return True
    return True


def remove_leftovers(folder) -> list[str]:
    """Remove the temporary files, staging and backup folders in ``folder`` whose writing
    process is gone (see the module docstring), undoing the swap a backup folder was kept for
    (a backup that still holds what could not be put back stays); return their names."""
    removed = []
    with contextlib.suppress(FileNotFoundError, NotADirectoryError):
        for name in os.listdir(folder):
            match = _TEMP_NAME.match(name)
            if match and int(match[1]) != os.getpid() and not process_alive(int(match[1])):
                path = Path(folder) / name
                if path.is_dir() and not path.is_symlink():
                    if (path / _JOURNAL).exists() and not _undo_cut_swap(Path(folder), path):
                        continue
                    shutil.rmtree(path)
                else:
                    path.unlink()
                removed.append(name)
    return removed


def _temp_prefix(name: str = "") -> str:
    return f"{TEMP_PREFIX}{os.getpid()}-{name}"


def loads_toml(text: str) -> dict:
    """``tomllib.loads``, with a document nested too deeply for the parser and an integer too
    long for ``int`` (:func:`sys.get_int_max_str_digits`) reported as a
    ``tomllib.TOMLDecodeError`` like any other malformed TOML."""
    try:
        return tomllib.loads(text)
    except RecursionError:
        raise tomllib.TOMLDecodeError("nested too deeply") from None
    except tomllib.TOMLDecodeError:
        raise
    except ValueError:  # the parser's int() of a literal past Python's digit limit
        raise tomllib.TOMLDecodeError(f"an integer of more than {sys.get_int_max_str_digits()} digits") from None


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; on success rename it onto ``path``.

    On an exception the temporary file is removed and ``path`` is left as it was, so nothing
    half-written is ever seen under the final name.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_leftovers(path.parent)
    fd, tmp = tempfile.mkstemp(prefix=_temp_prefix(f"{path.name}."), suffix=path.suffix, dir=path.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the file the usual mode
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        if isinstance(exc, OSError) and exc.filename == tmp:
            exc.filename = str(path)  # name the file the user knows, not the temporary one
        raise


@contextlib.contextmanager
def _made_folder(folder: Path):
    """``folder`` with its missing parents made; those this call made are removed again (if
    empty) when the block fails."""
    created = [p for p in (folder, *folder.parents) if not p.exists()]
    folder.mkdir(parents=True, exist_ok=True)
    try:
        yield folder
    except BaseException:
        for p in created:  # innermost first
            with contextlib.suppress(OSError):
                p.rmdir()
        raise


@contextlib.contextmanager
def held_folder(folder):
    """Hold ``folder`` (created if missing) for this run alone, from its start to its end: a
    second run into it is refused (:class:`FolderBusy`) rather than replace the first one's
    files under it. The hold is a lock on the folder itself, released when this process ends
    however it ends; folders this call created are removed if the run fails and leaves them
    empty."""
    with _made_folder(Path(folder)) as folder:
        fd = os.open(folder, os.O_RDONLY)
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise FolderBusy(f"{folder}: another cadcam run is writing into this folder; wait for it to "
                                 "end or give another output folder") from None
            yield folder
        finally:
            os.close(fd)


@contextlib.contextmanager
def staged_folder(folder, marker: str, names=()):
    """Yield a hidden staging folder inside ``folder`` to write a set of outputs into; on
    success swap the set into ``folder`` whole or not at all (:func:`_swap`).

    ``marker`` is the file the set writes last (``result.json``, ``manifest.json``); it names
    the set in the folder's :data:`MANIFEST`. The swap replaces or removes only the files of
    the previous set of that name that still match the manifest; anything else where it would
    replace or remove a file is refused (:func:`refuse_files_of_others`), on entry already for
    ``names`` (every name the set may write), so that the caller is refused before its work.
    On an exception the staging folder, and the folders this call created, are removed and
    ``folder``'s previous content is left as it was.
    """
    with _made_folder(Path(folder)) as folder:
        remove_leftovers(folder)
        refuse_files_of_others(folder, names, marker)
        stage = Path(tempfile.mkdtemp(prefix=_temp_prefix("stage-"), dir=folder))
        try:
            yield stage
            _swap(folder, stage, marker)
        except OSError as exc:  # name the file the user knows, not its staged copy
            if isinstance(exc.filename, str) and exc.filename.startswith(str(stage)):
                exc.filename = str(folder) + exc.filename[len(str(stage)):]
            raise
        finally:
            shutil.rmtree(stage, ignore_errors=True)


def file_digest(path) -> tuple[str, int]:
    """SHA-256 (hex) and size [bytes] of the regular file ``path``, a link not followed;
    OSError if it is something else or cannot be read."""
    fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)  # a FIFO must not block
    with os.fdopen(fd, "rb") as fh:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise OSError(errno.EINVAL, "not a regular file", str(path))
        return hashlib.file_digest(fh, "sha256").hexdigest(), st.st_size


def recorded_sets(folder) -> dict[str, dict[str, tuple[str, int]]]:
    """The sets the :data:`MANIFEST` of ``folder`` records: marker → file name → (SHA-256,
    size); empty without one. :class:`NotCadcams` for one that is not a regular file or not a
    manifest of :data:`MANIFEST_FORM` (cadcam writes no other: it may be another's file)."""
    path = Path(folder) / MANIFEST
    if not os.path.lexists(path):
        return {}
    try:
        if os.path.islink(path):
            raise InputFileError("a link, not a file")
        return _parsed_manifest(read_input(path))
    except (InputFileError, ValueError, RecursionError) as exc:
        raise NotCadcams(f"{path}: not a record of cadcam's it can read ({exc}); cadcam replaces or removes only "
                         "the files it recorded writing there: move it away or give another output folder") from None


def _parsed_manifest(text: str) -> dict[str, dict[str, tuple[str, int]]]:
    """The sets of the manifest ``text``; ValueError, saying what is wrong, for anything but
    a manifest of :data:`MANIFEST_FORM` whose every name is a plain file name."""
    data = json.loads(text)
    if not isinstance(data, dict) or data.get("cadcam_manifest") != MANIFEST_FORM:
        raise ValueError(f"no cadcam_manifest = {MANIFEST_FORM}")
    return {marker: {name: _digest_entry(entry) for name, entry in _named(files)}
            for marker, files in _named(data.get("sets"))}


def _named(table):
    """The (name, value) pairs of the manifest's object ``table``, every name a plain file name
    of the folder (no path, no ``..``, not the manifest or a temporary file): a manifest never
    leads cadcam to a file elsewhere."""
    if not isinstance(table, dict):
        raise ValueError("a table that is not one")
    for name, value in table.items():
        if name in ("", ".", "..", MANIFEST) or "/" in name or "\0" in name or _TEMP_NAME.match(name):
            raise ValueError(f"{short_repr(name)} is not a file name of the folder")
        yield name, value


def _digest_entry(entry) -> tuple[str, int]:
    """A manifest entry ``{"sha256": …, "size": …}`` as (SHA-256, size)."""
    if not (isinstance(entry, dict) and isinstance(entry.get("sha256"), str) and _SHA256.fullmatch(entry["sha256"])
            and type(entry.get("size")) is int and entry["size"] >= 0):
        raise ValueError("an entry without its sha256 and size")
    return entry["sha256"], entry["size"]


def _manifest_text(sets: dict[str, dict[str, tuple[str, int]]], swap: str) -> str:
    """:data:`MANIFEST` recording ``sets`` (marker → file name → (SHA-256, size)), brought in by
    the swap of token ``swap``."""
    return json.dumps({"cadcam_manifest": MANIFEST_FORM, "swap": swap,
                       "sets": {marker: {name: {"sha256": sha, "size": size} for name, (sha, size) in sorted(files.items())}
                                for marker, files in sorted(sets.items())}}, indent=2) + "\n"


def refuse_files_of_others(folder, names, marker: str) -> dict[str, dict[str, tuple[str, int]]]:
    """:class:`NotCadcams`, naming the first, for each entry of ``folder`` that a set of
    ``marker`` writing ``names`` would replace or remove and that is not the file the
    :data:`MANIFEST` records for the set: under a name in ``names``, anything it does not record
    (a user's file, a folder, a link, a file of a cadcam that kept no manifest); and every file it
    records for the set (each is replaced or removed) that changed since, or cannot be read to
    tell. Entries under other names are not looked at. Returns the recorded sets."""
    folder = Path(folder)
    sets = recorded_sets(folder)
    ours = sets.get(marker, {})
    for name in sorted({*names, *ours}):
        why = _why_not_ours(folder / name, ours.get(name))
        if why:
            raise NotCadcams(f"{folder / name}: {why}; cadcam replaces or removes only the files it recorded writing "
                             "there: move it away or give another output folder")
    return sets


def _why_not_ours(path: Path, recorded: tuple[str, int] | None) -> str | None:
    """Why the entry ``path`` is not the file ``recorded`` ((SHA-256, size), None: none is), in
    words; None where it is, or where nothing stands."""
    if not os.path.lexists(path):
        return None
    if not stat.S_ISREG(os.lstat(path).st_mode):
        return "not a file (a folder, a link, a device) where cadcam writes one"
    if recorded is None:
        return (f"a file with no record of cadcam's writing it (none in {MANIFEST}: another's file, or one of a "
                "cadcam that kept no record)")
    try:
        digest = file_digest(path)
    except OSError as exc:
        return f"cannot be read to tell whether it is the file cadcam wrote ({exc.strerror or exc})"
    return None if digest == recorded else "changed since cadcam wrote it"


def _swap(folder: Path, stage: Path, marker: str) -> None:
    """Move the set of ``marker`` staged in ``stage`` into ``folder`` whole, or leave ``folder``
    as it was and say so (OSError).

    Checked first (:func:`refuse_files_of_others`, for the names actually written). Every file
    the swap replaces or removes is then kept in a hidden backup folder (:func:`_backup`); the
    old marker goes (a swap cut short leaves no final-looking set), the new files come in, the
    old set's files the new one does not hold go, and the marker and the manifest come in last.
    If a step fails, the steps done are undone from the backup; a swap cut short by SIGKILL is
    undone by the next :func:`remove_leftovers`.
    """
    new = sorted(os.listdir(stage))
    sets = refuse_files_of_others(folder, new, marker)
    written = {name: file_digest(stage / name) for name in new}
    stale = sorted(n for n in sets.get(marker, {}) if n not in written and os.path.lexists(folder / n))
    swap = secrets.token_hex(16)
    journal = {"swap": swap, "files": written}
    write_text(stage / MANIFEST, _manifest_text({**sets, marker: written}, swap))
    last = [n for n in (marker, MANIFEST) if n == MANIFEST or n in written]
    displaced = [n for n in (*new, MANIFEST, *stale) if os.path.lexists(folder / n)]
    first = [marker] if marker in written and marker in displaced else []
    # (name, the folder it comes from; None: it is removed)
    steps = ([(n, None) for n in first] + [(n, stage) for n in new if n != marker]
             + [(n, None) for n in stale] + [(n, stage) for n in last])
    try:
        backup = _backup(folder, displaced, journal)
    except OSError as exc:
        raise _left_whole(exc, folder / marker) from exc
    done: list[str] = []
    try:
        for name, source in steps:
            if source is None:
                os.unlink(folder / name)
            else:
                os.replace(source / name, folder / name)
            done.append(name)
    except BaseException as exc:
        _undo(folder, backup, done)
        if isinstance(exc, OSError):
            raise _left_whole(exc, folder / name) from exc
        raise
    shutil.rmtree(backup, ignore_errors=True)


def _left_whole(exc: OSError, path: Path) -> OSError:
    """The error ``exc`` of a swap into ``path``'s folder that was undone, saying so."""
    return OSError(exc.errno, f"{exc.strerror or exc}; the new set was not moved in and the earlier one is left "
                   "whole", str(path))


def _backup(folder: Path, names: list[str], journal: dict) -> Path:
    """A hidden folder ``.cadcam-<pid>-old-…`` in ``folder`` keeping its files ``names`` (hard
    links, or copies where there can be none: an immutable file, a file system without links),
    then the ``journal`` of the swap (:data:`_JOURNAL`); removed again if that fails, nothing in
    ``folder`` changed."""
    backup = Path(tempfile.mkdtemp(prefix=_temp_prefix("old-"), dir=folder))
    try:
        for name in names:
            try:
                os.link(folder / name, backup / name, follow_symlinks=False)
            except OSError:
                shutil.copy2(folder / name, backup / name, follow_symlinks=False)
        write_text(backup / _JOURNAL, json.dumps(journal))
    except BaseException:
        shutil.rmtree(backup, ignore_errors=True)
        raise
    return backup


def _undo(folder: Path, backup: Path, done: list[str]) -> None:
    """Undo the swap steps ``done`` (names, in order) from ``backup`` (:func:`_backup`), latest
    first, and remove the backup; an OSError naming the backup, which is then kept, if a
    step cannot be undone."""
    try:
        for name in reversed(list(dict.fromkeys(done))):
            if os.path.lexists(backup / name):
                os.replace(backup / name, folder / name)
            else:
                os.unlink(folder / name)
    except OSError as exc:
        raise OSError(exc.errno, f"{exc.strerror or exc}: a failed swap could not be undone; the earlier files not "
                      f"put back are kept in {backup} (the next cadcam run into this folder puts them back)",
                      str(folder / name)) from exc
    shutil.rmtree(backup, ignore_errors=True)


def _undo_cut_swap(folder: Path, backup: Path) -> bool:
    """Undo the swap a killed run was making in ``folder`` from its backup folder ``backup``
    (:func:`_swap`), unless the swap ended (the manifest is the one it brought in: a new set may
    hold the same bytes as the old one, so the swap's token tells); whether the backup may go:
    False where it still holds what could not be put back."""
    try:
        journal = json.loads(read_input(backup / _JOURNAL))
        if _swap_of(folder) == journal["swap"]:
            return True
        files = {name: tuple(d) for name, d in journal["files"].items()}
        kept = sorted(set(os.listdir(backup)) - {_JOURNAL})
        for name, digest in files.items():  # new files moved in under names that were free
            if name not in kept and _digest_or_none(folder / name) == digest:
                os.unlink(folder / name)
        for name in kept:
            os.replace(backup / name, folder / name)
    except (InputFileError, OSError, ValueError, KeyError, TypeError, AttributeError):
        return False  # left for the user: nothing in it is removed unread
    return True


def _swap_of(folder: Path) -> str | None:
    """The token of the swap that brought in the :data:`MANIFEST` of ``folder``; None where
    there is none to read."""
    try:
        data = json.loads(read_input(folder / MANIFEST))
    except (InputFileError, ValueError, RecursionError):
        return None
    return data.get("swap") if isinstance(data, dict) else None


def _digest_or_none(path: Path) -> tuple[str, int] | None:
    """:func:`file_digest` of ``path``, None where it has none."""
    try:
        return file_digest(path)
    except OSError:
        return None


def write_text(path, text: str) -> None:
    """Write ``text`` to ``path`` atomically, as UTF-8 (whatever the locale's encoding)."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_json(path, data) -> None:
    """Write ``data`` as indented JSON to ``path`` atomically."""
    write_text(path, json.dumps(data, indent=2) + "\n")


def write_csv(path, header: list[str], rows) -> None:
    """Write a CSV table with ``header`` and ``rows`` atomically: each cell a number (integers
    as integers, the others in full precision), None (empty) or text (:func:`csv_text`)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow([csv_text(name) for name in header])
    if getattr(rows, "dtype", None) is not None and rows.dtype.kind == "f":
        # a numpy table of floats, the run files' (10⁵–10⁶ cells): as Python floats, no text
        buffer.writelines(",".join(map(repr, row)) + "\n" for row in rows.tolist())
    else:
        writer.writerows([_csv_cell(value) for value in row] for row in rows)
    write_text(path, buffer.getvalue())


def _csv_cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return str(int(value))
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return repr(float(value))
    return csv_text(value)


def csv_text(value) -> str:
    """``value`` as a CSV text cell: :func:`printable`, and with a leading apostrophe where it
    would start like a spreadsheet formula (:data:`FORMULA_STARTS`), which spreadsheets then
    show as text."""
    text = printable(str(value))
    return "'" + text if text.startswith(FORMULA_STARTS) else text
