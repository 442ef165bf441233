"""What the design page holds and does, without the page: the spec opened (a template, a spec
file or a result.json), the user's edits as dotted-key overrides, the designs of a
:class:`cadcam.Session` (each from the last answer of its structure) and the files to download.

The page (:mod:`cadcam.app.page`) only shows this state; the tests drive it directly too.
"""
from __future__ import annotations

import functools
import io
import json
import math
import re
import tempfile
import time
import zipfile
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import NamedTuple

from .. import examples
from ..api import Session
from ..designs import DesignError
from ..files import MANIFEST
from ..result import Result
from ..solve.compiled import CompileError
from ..spec import SpecError, apply_override, read_keys, read_spec_data
from ..sweep.study import read_catalogue
from ..targets import ExpressionError
from .form import Field, field_of_error, fields_of


class Template(NamedTuple):
    """A spec the page starts from: its title, the example spec's name and a variant of it."""

    title: str
    spec: str
    variant: str | None = None


#: The templates the page starts from. The generic torque's is its moment-arm variant, which
#: meets Ludovico2021's accuracy where the spec's own profile NLP does not, in seconds.
TEMPLATES = (
    Template("Wire cam (Johnston2023, 1-DOF)", "johnston2023_1dof"),
    Template("Pendulum balancer, anchored pulleys (Ludovico2021)", "ludovico2021_pendulum"),
    Template("Antagonistic pair, generic torque, moment arms (Ludovico2021)", "ludovico2021_generic", "moment_arm"),
    Template("Differential balancer (Fedorov2018)", "fedorov2018_balancer"),
    Template("Roller-follower cam pendulum", "roller_follower_pendulum"),
)

#: The spring catalogue the page offers for each spring (shipped with cadcam).
CATALOGUE = "spring_catalogue.csv"
#: The keys of a spring a catalogue pick sets.
PICKED = ("name", "rate", "travel", "preload")

#: Errors of a design that are the input's: shown as one line, like the command line's (a
#: spec's or an edit's ``solver.functions = "compiled"`` without a compiler among them).
INPUT_ERRORS = (SpecError, ExpressionError, DesignError, CompileError)


@dataclass
class Outcome:
    """What one design attempt gave: a result, or the one-line error and the field it names."""

    result: Result | None = None
    error: str | None = None
    field: str | None = None
    seconds: float = float("nan")


@dataclass
class DesignState:
    """The spec being designed and its edits.

    Parameters
    ----------
    path : Path
        A spec (TOML) or a cadcam ``result.json``; its tables resolve against its folder.
    variant : str, optional
        The spec's ``[variants.NAME]`` applied under the edits.
    """

    path: Path
    variant: str | None = None
    session: Session = field(default_factory=Session)
    overrides: dict = field(default_factory=dict)
    picks: dict[int, dict] = field(default_factory=dict)
    fields: list[Field] = field(init=False)
    names: dict[str, str] = field(init=False)
    absent: set[str] = field(init=False)
    #: Each mechanism's table (``mechanisms.1``) and the design methods of its kind
    methods: dict[str, dict] = field(init=False)
    #: The spec's design method (``solver.method``, its variant applied), before any edit
    spec_method: str = field(init=False)
    last: Outcome = field(default_factory=Outcome)
    result: Result | None = None  # the last design made (the last outcome may be an error)

    def __post_init__(self):
        self.path = Path(self.path)
        problem, reads = read_keys(read_spec_data(self.path, self.variant), str(self.path), self.path.parent)
        self.fields = [replace(f, value=getattr(problem.workshop, f.key.split(".")[1]))
                       if f.key.startswith("workshop.") and f.value is None else f for f in fields_of(reads)]
        self.absent = {r.key for r in reads if isinstance(r.value, dict) and not r.given}
        label = "cams" if any(f.key.startswith("cams.") for f in self.fields) else "joints"
        self.names = {f"springs.{j + 1}": s.name for j, s in enumerate(problem.springs)}
        self.names |= {f"mechanisms.{u + 1}": m.name for u, m in enumerate(problem.mechanisms)}
        self.names |= {f"{label}.{i + 1}": j.name for i, j in enumerate(problem.joints)}
        self.methods = {f"mechanisms.{u + 1}": {d.name: d for d in m.methods} for u, m in enumerate(problem.mechanisms)}
        self.spec_method = problem.options.method

    @classmethod
    def template(cls, name: str, **kwargs) -> "DesignState":
        """The state of the example spec ``name`` (:data:`TEMPLATES`); ``kwargs`` as the
        fields (a ``variant``)."""
        return cls(examples.path(name), **kwargs)

    def table_names(self) -> dict[str, str]:
        """The numbered tables' names (:attr:`names`), a spring picked from the catalogue named
        as the catalogue names it."""
        return self.names | {f"springs.{n}": pick["name"] for n, pick in self.picks.items()}

    def field(self, key: str) -> Field:
        return next(f for f in self.fields if f.key == key)

    def value(self, key: str):
        """Field ``key``'s value now: the user's, else the catalogue spring's, else the spec's."""
        if key in self.overrides:
            return self.overrides[key]
        return self._unedited(key)

    def _unedited(self, key: str):
        """Field ``key``'s value without the user's edit: its picked spring's, else the spec's."""
        match = re.fullmatch(r"springs\.(\d+)\.([a-z_]+)", key)
        pick = self.picks.get(int(match.group(1)), {}) if match else {}
        return pick[match.group(2)] if match and match.group(2) in pick else self.field(key).value

    def set_by_method(self, key: str) -> str | None:
        """The design method chosen now (``solver.method``, edited or the spec's) where it
        chooses field ``key`` itself, so that its value is not used
        (:attr:`cadcam.mechanisms.base.DesignMethod.sets`); else None."""
        table, _, name = key.rpartition(".")
        method = self.methods.get(table, {}).get(self.overrides.get("solver.method", self.spec_method))
        return method.name if method is not None and name in method.sets else None

    def edit(self, key: str, text: str) -> str | None:
        """Set field ``key`` to ``text`` (empty: its value in the spec); the one-line error of
        text that is no value, else None."""
        f = self.field(key)
        try:
            value = f.parse(text)
        except SpecError as exc:
            return str(exc)
        if value is None or value == self._unedited(key):
            self.overrides.pop(key, None)
        else:
            self.overrides[key] = value
        return None

    def pick_spring(self, number: int, name: str | None) -> None:
        """Spring ``number`` (from 1) becomes the catalogue's spring ``name`` (None: the spec's
        own again): its name, rate, travel and preload, the edits of those dropped."""
        self.picks.pop(number, None)
        if name is not None:
            self.picks[number] = next(s for s in catalogue() if s["name"] == name)
        for key in PICKED:
            self.overrides.pop(f"springs.{number}.{key}", None)

    def override_pairs(self) -> list[tuple[str, object]]:
        """The edits as ``--set`` pairs; a key whose table the spec leaves out (its
        ``[workshop]``, a joint's ``acceptance``) sets that table, which then holds it."""
        pairs: list[tuple[str, object]] = [(f"springs.{j}", dict(spring)) for j, spring in self.picks.items()]
        for key, value in self.overrides.items():
            table, _, name = key.rpartition(".")
            pairs.append((table, {name: value}) if table in self.absent else (key, value))
        return pairs

    def design(self, edited: str | None = None) -> Outcome:
        """Design the spec with the edits through the session; a spec error names its field
        (the one it names, else ``edited``)."""
        start = time.perf_counter()
        try:
            result = self.session.design(self.path, variant=self.variant, overrides=self.override_pairs())
        except INPUT_ERRORS as exc:
            message = str(exc)
            self.last = Outcome(error=message, field=field_of_error(message, [f.key for f in self.fields], edited),
                                seconds=time.perf_counter() - start)
        else:
            self.last = Outcome(result=result, seconds=time.perf_counter() - start)
            self.result = result
        return self.last

    # -------------------------------------------------------------------- the files to download
    def spec_toml(self) -> str:
        """The spec with its variant and the edits, as TOML: a spec file keeps its comments and
        layout; a result.json's resolved problem is written out."""
        import tomlkit

        if self.path.suffix == ".toml":
            doc = tomlkit.parse(self.path.read_text(encoding="utf-8").removeprefix("\ufeff"))
        else:
            doc = tomlkit.document()
            doc.update(_without_none(read_spec_data(self.path)))
        variant = list(doc["variants"][self.variant].unwrap().items()) if self.variant else []
        for key, value in variant + self.override_pairs():
            apply_override(doc, key, value, "the page's edits")
        return tomlkit.dumps(doc)

    def result_files(self, result: Result, figures: bool = False, solids: bool = False) -> dict[str, bytes]:
        """What ``cadcam design`` writes for ``result`` (:meth:`Result.save`: result.json, the
        tables, the workshop files; with ``figures`` the PNG figures and drawing sheets; with
        ``solids`` the STL and, where the extra ``step`` is installed, the STEP solids, of the
        spec's ``stl`` thickness or :data:`cadcam.problem.SOLID_THICKNESS`), by file name."""
        workshop = result.problem.workshop.with_solids() if solids else "spec"
        with tempfile.TemporaryDirectory(prefix="cadcam-app-") as tmp:
            try:
                result.save(tmp, workshop=workshop, figures=figures)
            except ValueError:  # a workshop file that cannot be made: the others are written
                pass
            # without the folder's record of what cadcam wrote (cadcam.files.MANIFEST): not an output
            return {p.name: p.read_bytes() for p in sorted(Path(tmp).iterdir()) if p.is_file() and p.name != MANIFEST}


@functools.cache
def catalogue() -> tuple[dict, ...]:
    """The shipped spring catalogue's springs: {name, rate [N/m], travel [m], preload [N]}."""
    return read_catalogue(examples.path(CATALOGUE))


def zipped(files: dict[str, bytes]) -> bytes:
    """``files`` (name → bytes) as a ZIP archive."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in files.items():
            z.writestr(name, data)
    return buffer.getvalue()


def _without_none(value):
    """Spec data without its None members (TOML has no null)."""
    if isinstance(value, dict):
        return {k: _without_none(v) for k, v in value.items() if v is not None}
    if isinstance(value, list):
        return [_without_none(v) for v in value if v is not None]
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


def result_json(result: Result) -> str:
    """``result.json`` of ``result``, as ``cadcam design`` writes it."""
    return json.dumps(result.to_dict(), indent=2) + "\n"
