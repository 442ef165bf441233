"""File input and output: inputs read only from regular files of bounded size as UTF-8 text,
outputs written atomically (a temporary file in the same folder, then a rename)."""
from __future__ import annotations

import contextlib
import json
import os
import stat
import tempfile
from pathlib import Path

#: Largest input file read [bytes] (specs, target tables, studies, designs, catalogues); raise
#: it deliberately with the environment variable CADCAM_CAP_INPUT_BYTES.
MAX_INPUT_BYTES = 10_000_000


class InputFileError(ValueError):
    """An input file that cannot be read as asked: the message is one line, without the path."""


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


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; on success rename it onto ``path``.

    On an exception the temporary file is removed and ``path`` is left as it was, so nothing
    half-written is ever seen under the final name.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the file the usual mode
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


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
