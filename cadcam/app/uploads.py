"""An upload of the design page, without the page: a spec (TOML) or a result.json, and the CSV
files it names (a table target's ``file``, a spring's ``catalogue``), chosen together in the
browser.

Each file is written under a name of the page's own to the upload's folder, and the spec the
page reads is a copy naming those copies: a name the spec gives is looked up among the files
uploaded with it, by its last part (the browser sends no folders), never on the server's disk.
The spec as uploaded is kept beside it, for the spec to download (the user's names in it).
"""
from __future__ import annotations

import json
import tomllib
from pathlib import Path, PurePosixPath
from typing import NamedTuple

from ..files import loads_toml, printable
from ..spec import SpecError

#: What a file uploaded with others must be named to be one of the spec's tables.
TABLE_SUFFIX = ".csv"
#: The page's names for the spec it reads and for the spec as uploaded (``.toml`` or
#: ``.json`` added, as its content is), and for the ``n``-th table (from 1).
SPEC_COPY = "upload"
SPEC_GIVEN = "given"
TABLE_COPY = "table{n}.csv"
#: The name of a spec that names itself nothing, uploaded under a name that gives none.
UNNAMED = "design"
#: Longest name of a file a message quotes [characters].
NAME_CHARS = 60


class Uploaded(NamedTuple):
    """An upload written to its folder (:func:`save`)."""

    #: The page's copy of the spec, naming the page's copies of its tables
    path: Path
    #: The spec as uploaded
    original: Path
    #: The browser's name for the spec
    name: str
    #: The browser's name of each table the spec names, in the order the spec names them
    tables: tuple[str, ...]
    #: The name the user knows each file written by, by its path
    aliases: dict[str, str]


def save(files: list[tuple[str, bytes]], folder: Path) -> Uploaded:
    """Write the upload ``files`` ((browser's name, content) pairs) to ``folder``: one file is the
    spec whatever its name; among several, those named ``*.csv`` are tables and the other one is
    the spec. A spec is judged by its content (a result.json opens with ``{``, which no TOML
    does); each file it names (:func:`references`) is replaced by the page's copy of the table
    of that name, and a TOML spec that gives no ``name`` is named after the browser's name for
    it, as the spec reader names a spec file.

    Raises
    ------
    SpecError
        One line: no spec or several among the files, two tables of one name, or a file the
        spec names that is not among them.
    """
    name, data, tables = _split(files)
    kind = ".json" if data.lstrip()[:1] == b"{" else ".toml"
    original, path = folder / (SPEC_GIVEN + kind), folder / (SPEC_COPY + kind)
    original.write_bytes(data)
    aliases = {str(original): name, str(path): name}
    document = _parsed(data, kind)
    spec = document.get("problem") if kind == ".json" and document is not None else document
    named = kind == ".json" or not isinstance(spec, dict) or "name" in spec
    if not named:  # a spec is named after its file by default (cadcam.spec): the user's, not the copy's
        spec["name"] = PurePosixPath(last_part(name)).stem.strip() or UNNAMED
    try:
        found = references(spec) if isinstance(spec, dict) else []
    except RecursionError:  # every name must be found before the spec is read: refused
        raise SpecError(f"{shown(name)}: nested too deeply to be a spec") from None
    copies: dict[str, Path] = {}
    for trail, given in found:
        last = last_part(given)
        if last not in tables:
            raise SpecError(f"{shown(name)}: {_where(trail)} = {shown(given)}: {shown(last)} is not among the files "
                            "opened; choose the spec and every CSV file it names together")
        if last not in copies:
            copies[last] = folder / TABLE_COPY.format(n=len(copies) + 1)
            copies[last].write_bytes(tables[last])
            # the path a spring's catalogue is named by in the problem is the resolved one
            aliases |= {str(copies[last]): last, str(copies[last].resolve()): last}
        _set(spec, trail, copies[last].name)
    path.write_bytes(_dumped(document, kind) if found or not named else data)
    return Uploaded(path, original, name, tuple(copies), aliases)


def _split(files: list[tuple[str, bytes]]) -> tuple[str, bytes, dict[str, bytes]]:
    """The spec's name and content and the tables by their names' last parts, of ``files``."""
    if len(files) == 1:
        return files[0][0], files[0][1], {}
    specs = [(n, d) for n, d in files if not n.lower().endswith(TABLE_SUFFIX)]
    if len(specs) != 1:
        said = (f"none of these {len(files)} files is a spec" if not specs else
                f"{len(specs)} of these files are specs ({', '.join(shown(n) for n, _ in specs[:3])})")
        raise SpecError(f"{said}: choose one spec (TOML) or result.json together with the CSV files it names, "
                        f"each named *{TABLE_SUFFIX}")
    tables: dict[str, bytes] = {}
    for n, d in files:
        if n.lower().endswith(TABLE_SUFFIX):
            if last_part(n) in tables:
                raise SpecError(f"two files named {shown(last_part(n))}: choose one of them")
            tables[last_part(n)] = d
    return specs[0][0], specs[0][1], tables


def _parsed(data: bytes, kind: str) -> dict | None:
    """The document of ``data`` (a result.json's spec is its ``problem``), or None where it is
    no document at all: then the spec reader says why, reading the spec as uploaded."""
    try:
        text = data.decode("utf-8").removeprefix("\ufeff")
        parsed = json.loads(text) if kind == ".json" else loads_toml(text)
    except (UnicodeDecodeError, ValueError, RecursionError, tomllib.TOMLDecodeError):
        return None
    return parsed if isinstance(parsed, dict) else None


def references(spec: dict) -> list[tuple[tuple, str]]:
    """The files ``spec`` names, as (the trail of keys and 0-based indices to the name, the
    name): each table target's ``file`` (a joint's target, a mechanism's ``output_target``
    too) and each spring's ``catalogue``, in the order of the spec. Its ``variants`` are not
    looked in: the page applies none to an upload."""
    found: list[tuple[tuple, str]] = []

    def walk(node, trail: tuple) -> None:
        if isinstance(node, dict):
            if node.get("kind") == "table" and isinstance(node.get("file"), str):
                found.append(((*trail, "file"), node["file"]))
            for key, value in node.items():
                if trail or key != "variants":
                    walk(value, (*trail, key))
        elif isinstance(node, list):
            for i, value in enumerate(node):
                walk(value, (*trail, i))

    walk(spec, ())
    springs = spec.get("springs")
    for i, spring in enumerate(springs if isinstance(springs, list) else []):
        if isinstance(spring, dict) and isinstance(spring.get("catalogue"), str):
            found.append((("springs", i, "catalogue"), spring["catalogue"]))
    return found


def _where(trail: tuple) -> str:
    """A trail of :func:`references` as the spec reader's messages write a key
    (``joints[1].target.file``)."""
    return "".join(f"[{p + 1}]" if isinstance(p, int) else f".{p}" for p in trail).lstrip(".")


def _set(data: dict, trail: tuple, value: str) -> None:
    """Set the member of ``data`` at ``trail`` to ``value``."""
    node = data
    for part in trail[:-1]:
        node = node[part]
    node[trail[-1]] = value


def _dumped(data: dict, kind: str) -> bytes:
    """Spec ``data`` written as JSON or TOML (``kind``)."""
    if kind == ".json":
        return json.dumps(data).encode("utf-8")
    import tomlkit

    return tomlkit.dumps(data).encode("utf-8")


def last_part(name: str) -> str:
    """The last part of a file's name, its folders (either slash) left out."""
    return PurePosixPath(name.replace("\\", "/")).name or name


def shown(name: str) -> str:
    """A file's name as a message quotes it: printable and short."""
    text = printable(name)
    return repr(text if len(text) <= NAME_CHARS else text[:NAME_CHARS - 1] + "…")


__all__ = ["TABLE_SUFFIX", "Uploaded", "last_part", "references", "save", "shown"]
