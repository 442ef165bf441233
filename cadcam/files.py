"""File input and output: inputs read only from regular files of bounded size as UTF-8 text,
outputs written atomically (a temporary file in the same folder, then a rename), and folders of
outputs staged so that a run that fails or is killed never leaves a final-looking set.

Temporary files and staging folders are hidden and named ``.cadcam-<pid>-…``; one whose process
is gone (a run killed with SIGKILL) is removed by the next write into the same folder.
"""
from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import re
import shutil
import stat
import tempfile
import tomllib
from pathlib import Path

#: Start of every temporary file's and staging folder's name (followed by the writer's pid).
TEMP_PREFIX = ".cadcam-"
_TEMP_NAME = re.compile(re.escape(TEMP_PREFIX) + r"(\d+)-")

#: Largest input file read [bytes] (specs, target tables, studies, designs, catalogues); raise
#: it deliberately with the environment variable CADCAM_CAP_INPUT_BYTES.
MAX_INPUT_BYTES = 10_000_000


class InputFileError(ValueError):
    """An input file that cannot be read as asked: the message is one line, without the path."""


class FolderBusy(ValueError):
    """Another cadcam run holds the output folder (:func:`held_folder`); one line."""


def short_repr(value, limit: int = 80) -> str:
    """``repr(value)`` cut to ``limit`` characters, for one-line messages about input."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 1] + "…"


def env_cap(name: str, default: int) -> int:
    """A cap on work: the environment variable ``CADCAM_CAP_<NAME>`` if it is a positive
    integer, else ``default``."""
    text = os.environ.get(f"CADCAM_CAP_{name.upper()}", "")
    return int(text) if text.isdigit() and int(text) > 0 else default


def read_input(path) -> str:
    """The text of the regular file ``path``, refused (:class:`InputFileError`) if it is
    missing, not a regular file (a folder, a device such as /dev/zero, a FIFO), larger than
    :data:`MAX_INPUT_BYTES` or not UTF-8."""
    limit = env_cap("input_bytes", MAX_INPUT_BYTES)
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
    """Remove the temporary files and staging folders in ``folder`` whose writing process is
    gone (see the module docstring); return their names."""
    removed = []
    with contextlib.suppress(FileNotFoundError, NotADirectoryError):
        for name in os.listdir(folder):
            match = _TEMP_NAME.match(name)
            if match and int(match[1]) != os.getpid() and not process_alive(int(match[1])):
                path = Path(folder) / name
                if path.is_dir() and not path.is_symlink():
                    shutil.rmtree(path)
                else:
                    path.unlink()
                removed.append(name)
    return removed


def _temp_prefix(name: str = "") -> str:
    return f"{TEMP_PREFIX}{os.getpid()}-{name}"


def loads_toml(text: str) -> dict:
    """``tomllib.loads``, with a document nested too deeply for the parser reported as a
    ``tomllib.TOMLDecodeError`` like any other malformed TOML."""
    try:
        return tomllib.loads(text)
    except RecursionError:
        raise tomllib.TOMLDecodeError("nested too deeply") from None


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
def staged_folder(folder, last: tuple[str, ...] = (), owned: re.Pattern | None = None):
    """Yield a hidden staging folder inside ``folder`` to write a set of outputs into; on
    success move each file into ``folder`` in name order, the names in ``last`` after the others.

    Before the move the old copies of ``last`` are removed, so a run killed while moving
    leaves no final-looking file (such as ``result.json``) beside a partial set; so are the
    files of ``folder`` whose names ``owned`` matches in full (the names a set may hold) and
    the new set does not hold, so no file of an earlier set stays beside it. On an exception
    the staging folder, and the folders this call created, are removed and ``folder``'s
    previous content is left as it was.
    """
    with _made_folder(Path(folder)) as folder:
        remove_leftovers(folder)
        stage = Path(tempfile.mkdtemp(prefix=_temp_prefix("stage-"), dir=folder))
        try:
            yield stage
            new = set(os.listdir(stage))
            _refuse_folders_in_the_way(folder, new)
            ours = bool(last) and written_by_cadcam(folder / last[0])
            if not ours:
                _refuse_files_of_others(folder, new, last)
            stale = [] if owned is None or not ours else [
                n for n in os.listdir(folder) if owned.fullmatch(n) and n not in new and (folder / n).is_file()]
            for name in [*last, *stale]:
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(folder / name)
            for name in sorted(new, key=lambda n: (n in last, n)):
                os.replace(stage / name, folder / name)
            stage.rmdir()
        except OSError as exc:  # name the file the user knows, not its staged copy
            if isinstance(exc.filename, str) and exc.filename.startswith(str(stage)):
                exc.filename = str(folder) + exc.filename[len(str(stage)):]
            raise
        finally:
            shutil.rmtree(stage, ignore_errors=True)


def written_by_cadcam(marker: Path) -> bool:
    """Whether ``marker`` (the file a set of outputs writes last: ``result.json``,
    ``manifest.json``) is cadcam's: JSON naming the ``cadcam_version`` that wrote it."""
    try:
        data = json.loads(read_input(marker))
    except (InputFileError, OSError, ValueError, RecursionError):
        return False
    return isinstance(data, dict) and isinstance(data.get("cadcam_version"), str)


def files_of_others(folder: Path, names, last: tuple[str, ...]) -> list[str]:
    """The files among ``names`` in ``folder`` that cadcam did not write: every one that exists,
    unless the folder holds a set of cadcam's (its ``last[0]``, :func:`written_by_cadcam`)."""
    existing = [n for n in sorted(names) if (folder / n).is_file()]
    if not existing or (last and written_by_cadcam(folder / last[0])):
        return []
    return existing


def _refuse_files_of_others(folder: Path, names, last: tuple[str, ...]) -> None:
    """FileExistsError, before anything moves, where a file stands under the name of an output
    in a folder that holds no set of cadcam's: cadcam replaces only its own files."""
    others = [n for n in sorted(names) if (folder / n).is_file()]
    if others:
        raise FileExistsError(errno.EEXIST, f"a file cadcam did not write stands where an output goes (no "
                              f"{last[0] if last else 'set'} of cadcam's beside it); cadcam replaces only its own "
                              "files: move it or give another output folder", str(folder / others[0]))


def in_the_way(folder: Path, names) -> list[str]:
    """The names among ``names`` under which something other than a file stands in ``folder``
    (a folder, a link to one or to nothing), in name order: cadcam replaces files it writes,
    never a folder or a link of the user's."""
    return [n for n in sorted(names) if os.path.lexists(folder / n) and not (folder / n).is_file()]


def _refuse_folders_in_the_way(folder: Path, names) -> None:
    """IsADirectoryError, before anything moves, where :func:`in_the_way` finds an output's
    name taken."""
    taken = in_the_way(folder, names)
    if taken:
        raise IsADirectoryError(errno.EISDIR, "something other than a file (a folder, or a link to one "
                                "or to nothing) stands where this output file goes; cadcam replaces "
                                "only files: move it or give another output folder", str(folder / taken[0]))


def write_text(path, text: str) -> None:
    """Write ``text`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def write_json(path, data) -> None:
    """Write ``data`` as indented JSON to ``path`` atomically."""
    write_text(path, json.dumps(data, indent=2) + "\n")


def write_csv(path, header: list[str], rows) -> None:
    """Write a CSV table with ``header`` and numeric ``rows`` atomically (full precision)."""
    lines = [",".join(header)] + [",".join(repr(float(v)) for v in row) for row in rows]
    write_text(path, "\n".join(lines) + "\n")
