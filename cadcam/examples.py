"""The example specs that ship with cadcam, wherever it is installed.

The repository's ``models/`` folder — the papers' specs, the published designs they are
compared with and the spring catalogue — installs as ``cadcam/models`` (in the repository
that is a symbolic link to ``models/``, so an editable install and a wheel see the same files).
Specs name sibling files relative to their own folder (a ``table`` target's ``file``, a study's
``catalogue``), so the folder is handed out whole: a spec from :func:`path` finds its siblings.

>>> from cadcam import examples
>>> "johnston2023_1dof" in examples.names()
True
>>> examples.path("johnston2023_1dof").name
'johnston2023_1dof.toml'
"""
from __future__ import annotations

import atexit
import functools
import pathlib
import shutil
import tempfile
from importlib.resources import files as _resources

#: Folder of the examples inside the package.
FOLDER = "models"
#: Suffixes of the files that ship: specs, designs, catalogues and tables.
SUFFIXES = (".toml", ".json", ".csv")

__all__ = ["FOLDER", "SUFFIXES", "UnknownExample", "files", "folder", "names", "path"]


class UnknownExample(LookupError):
    """A name that is neither an example spec nor a shipped file; the message lists them."""


@functools.cache
def folder() -> pathlib.Path:
    """The folder of the installed examples, as a real directory.

    From an ordinary install (a wheel, an editable install, the source tree) it is the package's
    own ``cadcam/models``; from a zipped package its files are copied once into a temporary
    folder that is removed when the interpreter exits.
    """
    root = _resources("cadcam") / FOLDER
    if isinstance(root, pathlib.Path):
        return root
    copy = pathlib.Path(tempfile.mkdtemp(prefix="cadcam-examples-"))
    atexit.register(shutil.rmtree, copy, ignore_errors=True)
    for item in root.iterdir():
        if item.is_file() and item.name.endswith(SUFFIXES):
            (copy / item.name).write_bytes(item.read_bytes())
    return copy


def files() -> list[str]:
    """Every shipped file name, sorted: specs (``.toml``), designs (``.json``), tables and
    catalogues (``.csv``)."""
    here = folder()
    return sorted(p.name for p in here.iterdir() if p.is_file() and p.suffix in SUFFIXES)


def names() -> list[str]:
    """The example specs' names, sorted: what ``cadcam design --example NAME`` accepts."""
    return [name.removesuffix(".toml") for name in files() if name.endswith(".toml")]


def path(name: str) -> pathlib.Path:
    """The file of example ``name``: a spec's name (``"johnston2023_1dof"``) or any shipped
    file's name with its suffix (``"johnston2023_table3_design.json"``,
    ``"spring_catalogue.csv"``).

    Raises
    ------
    UnknownExample
        For any other name (paths are not accepted), with the choices in its message.
    """
    shipped = files()
    for candidate in (f"{name}.toml", name):
        if candidate in shipped:
            return folder() / candidate
    others = sorted(set(shipped) - {f"{n}.toml" for n in names()})
    raise UnknownExample(f"no example {name!r}: expected one of {', '.join(names())} "
                         f"(or a shipped file: {', '.join(others)})")
