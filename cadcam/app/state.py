"""What the design page holds and does, without the page: the spec opened (a template, a spec
file, an upload or a result.json), the user's edits as dotted-key overrides (a tabulated target's
rows among them, :mod:`cadcam.app.tables`), the designs of a
:class:`cadcam.Session` (each from the last answer of its structure) and the history of those the
user made (:mod:`cadcam.app.history`: undo, redo), the catalogue table of each spring with its
lights (:mod:`cadcam.app.parts`) and the files to download.

A design is asked for in two steps, so that the page's worker designs the edits as they were when
asked while the user edits on: :meth:`DesignState.ask` (the edits taken and parsed) and
:meth:`DesignState.run` (the design), then :meth:`DesignState.keep` (the design shown, recorded);
:meth:`DesignState.design` does the three.

The page (:mod:`cadcam.app.page`) only shows this state; the tests drive it directly too.
"""
from __future__ import annotations

import copy
import functools
import io
import json
import math
import re
import tempfile
import time
import zipfile
from dataclasses import dataclass, field, replace
from pathlib import Path, PurePath
from typing import NamedTuple

import pandas as pd

from .. import examples
from ..api import Session, load_problem
from ..designs import DesignError
from ..files import MANIFEST
from ..physics.catalogue import Catalogue, Need, Screen, load_catalogue, screen
from ..problem import Problem
from ..result import Result
from ..solve.compiled import CompileError
from ..spec import FILLED_BY_PART, SpecError, apply_override, filled_by_part, read_keys, read_spec_data
from ..sweep.springs import part_spec, slot_need, verdict
from ..sweep.study import read_catalogue
from ..targets import ExpressionError
from .form import Field, field_of_error, fields_of
from .history import Edits, History
from .parts import catalogue_numbers, table as catalogue_table
from .tables import TargetTable, checked, pasted, spec_table


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

#: The name of the files downloaded where the file opened gives none (:func:`download_stem`).
DOWNLOAD_STEM = "design"
#: Longest start of a file downloaded's name [characters].
STEM_CHARS = 80

#: Errors of a design that are the input's: shown as one line, like the command line's (a
#: spec's or an edit's ``solver.functions = "compiled"`` without a compiler among them).
INPUT_ERRORS = (SpecError, ExpressionError, DesignError, CompileError)


class CatalogueView(NamedTuple):
    """The catalogue table of one spring (:meth:`DesignState.catalogue_view`)."""

    rows: pd.DataFrame
    #: What the screen asked of the spring (nothing: ``Need()``, where it shares its joint's work)
    need: Need
    #: The catalogue, as messages name it
    origin: str


@dataclass
class Outcome:
    """What one design attempt gave: a result, or the one-line error and the field it names."""

    result: Result | None = None
    error: str | None = None
    field: str | None = None
    seconds: float = float("nan")


@dataclass
class Request:
    """A design asked for (:meth:`DesignState.ask`): the edits as they were, the spec with them
    parsed (or the one-line error of a spec that cannot be, and the field it names), and the
    catalogue table's context of each spring made a part (:meth:`DesignState._context`), and
    the time the parse took [s]."""

    edits: Edits
    problem: Problem | None
    error: Outcome | None
    contexts: dict[int, str]
    seconds: float = 0.0


@dataclass
class DesignState:
    """The spec being designed and its edits.

    Parameters
    ----------
    path : Path
        A spec (TOML) or a cadcam ``result.json``; its tables resolve against its folder.
    variant : str, optional
        The spec's ``[variants.NAME]`` applied under the edits.
    original : Path, optional
        The spec as the user gave it, where ``path`` is the page's copy of an upload naming the
        page's copies of its CSV files (:func:`cadcam.app.uploads.save`): the spec to download
        is written from it.
    aliases : dict, optional
        The name the user knows each of the page's copies by, by the copy's path
        (:attr:`cadcam.app.uploads.Uploaded.aliases`).
    """

    path: Path
    variant: str | None = None
    original: Path | None = None
    aliases: dict[str, str] = field(default_factory=dict)
    session: Session = field(default_factory=Session)
    overrides: dict = field(default_factory=dict)
    picks: dict[int, dict] = field(default_factory=dict)
    #: The catalogue part picked for a spring (by its number, from 1), in its catalogue table
    parts: dict[int, str] = field(default_factory=dict)
    fields: list[Field] = field(init=False)
    names: dict[str, str] = field(init=False)
    absent: set[str] = field(init=False)
    #: Each mechanism's table (``mechanisms.1``) and the design methods of its kind
    methods: dict[str, dict] = field(init=False)
    #: The spec's design method (``solver.method``, its variant applied), before any edit
    spec_method: str = field(init=False)
    #: Each spring's table as the spec gives it (its variant applied), by its number
    springs: dict[int, dict] = field(init=False)
    #: Each spring's catalogue (the file its spec names, None: the shipped one) and the part the
    #: spec itself names (or None), by its number
    catalogues: dict[int, str | None] = field(init=False)
    spec_parts: dict[int, str | None] = field(init=False)
    #: Each tabulated torque target (``joints.1.target``) as the spec gives it, and as edited
    tables: dict[str, TargetTable] = field(init=False)
    table_edits: dict[str, TargetTable] = field(default_factory=dict)
    #: The fields that are another field's quantity, with that field (:func:`in_step`)
    links: dict[str, str] = field(init=False)
    last: Outcome = field(default_factory=Outcome)
    result: Result | None = None  # the last design made (the last outcome may be an error)
    #: The designs made from this file, to step back and forth through
    history: History = field(default_factory=History)
    #: The verdict of each part designed with, by (the other edits, spring number, part)
    #: (:meth:`_context`): a part's light is its design's while those edits stand
    verdicts: dict[tuple[str, int, str], tuple[str, str]] = field(default_factory=dict)
    #: The spec with the edits, parsed, and its screens, kept while the edits are the same
    _parsed: tuple[str, Problem, dict] | None = field(default=None, repr=False)
    #: Each catalogue's columns that no edit changes (:func:`cadcam.app.parts.catalogue_numbers`), by its origin
    _numbers: dict[str, tuple[Catalogue, pd.DataFrame]] = field(default_factory=dict, repr=False)

    def __post_init__(self):
        self.path = Path(self.path)
        data = read_spec_data(self.path, self.variant)
        problem, reads = read_keys(copy.deepcopy(data), str(self.path), self.path.parent)
        self.springs = {j + 1: s for j, s in enumerate(data.get("springs", []))}
        self.catalogues = {j + 1: s.catalogue for j, s in enumerate(problem.springs)}
        self.spec_parts = {j + 1: s.part for j, s in enumerate(problem.springs)}
        self.fields = [replace(f, value=getattr(problem.workshop, f.key.split(".")[1]))
                       if f.key.startswith("workshop.") and f.value is None else f for f in fields_of(reads)]
        self.absent = {r.key for r in reads if isinstance(r.value, dict) and not r.given}
        label = "cams" if any(f.key.startswith("cams.") for f in self.fields) else "joints"
        self.tables = {f"{label}.{i + 1}.target": spec_table(j["target"], self.path.parent)
                       for i, j in enumerate(data.get(label, []))
                       if isinstance(j.get("target"), dict) and j["target"].get("kind") == "table"}
        # the table editor sets a table target's keys (its file and angle unit): no field does;
        # nor does one name a file, which comes with an upload (cadcam.app.uploads), never typed
        owned = tuple(f"{key}." for key in self.tables)
        self.fields = [f for f in self.fields if not f.key.startswith(owned) and not f.key.endswith(".file")]
        self.links = in_step(reads, problem, label, {f.key for f in self.fields})
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
        return (self.names | {f"springs.{n}": pick["name"] for n, pick in self.picks.items()}
                | {f"springs.{n}": part_name(part) for n, part in self.parts.items()})

    def field(self, key: str) -> Field:
        return next(f for f in self.fields if f.key == key)

    def value(self, key: str):
        """Field ``key``'s value now: the user's, else the catalogue spring's, else the spec's
        (a field in step with another, that other's)."""
        key = self.links.get(key, key)
        if key in self.overrides:
            return self.overrides[key]
        return self._unedited(key)

    def _unedited(self, key: str):
        """Field ``key``'s value without the user's edit: its picked spring's or part's, else the
        spec's."""
        match = re.fullmatch(r"springs\.(\d+)\.([a-z_]+)", key)
        number = int(match.group(1)) if match else 0
        pick = self.picks.get(number, {})
        if number in self.parts:
            cat = self.catalogue_of(number)
            pick = filled_by_part(cat.spring_body(cat.index(self.parts[number])))
        return pick[match.group(2)] if match and match.group(2) in pick else self.field(key).value

    def set_by_method(self, key: str) -> str | None:
        """The design method chosen now (``solver.method``, edited or the spec's) where it
        chooses field ``key`` itself, so that its value is not used
        (:attr:`cadcam.mechanisms.base.DesignMethod.sets`); else None."""
        table, _, name = key.rpartition(".")
        method = self.methods.get(table, {}).get(self.overrides.get("solver.method", self.spec_method))
        return method.name if method is not None and name in method.sets else None

    def set_by_part(self, key: str) -> str | None:
        """The part of field ``key``'s spring where the part sets the field's value
        (:data:`cadcam.spec.FILLED_BY_PART`), so that it is no edit; else None."""
        match = re.fullmatch(r"springs\.(\d+)\.([a-z_]+)", key)
        if match is None or match.group(2) not in FILLED_BY_PART:
            return None
        return self.part(int(match.group(1)))

    def part(self, number: int) -> str | None:
        """The catalogue part spring ``number`` is now: the one picked in its table, else the
        spec's own (unless a spring of the papers' catalogue replaced it); None if none."""
        if number in self.parts:
            return self.parts[number]
        return None if number in self.picks else self.spec_parts.get(number)

    def edit(self, key: str, text: str) -> str | None:
        """Set field ``key`` to ``text`` (empty: its value in the spec; a field in step with
        another sets that other); the one-line error of text that is no value, else None."""
        key = self.links.get(key, key)
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
        self.parts.pop(number, None)
        if name is not None:
            self.picks[number] = next(s for s in catalogue() if s["name"] == name)
        for key in PICKED:
            self.overrides.pop(f"springs.{number}.{key}", None)

    def pick_part(self, number: int, part: str) -> None:
        """Spring ``number`` (from 1) becomes part ``part`` of its catalogue
        (:meth:`catalogue_of`), named after it: the spec gets ``part = "…"`` and loses the keys the
        part fills (:func:`cadcam.sweep.springs.part_spec`), the edits of those dropped."""
        self.catalogue_of(number).index(part)  # a KeyError naming the nearest parts, for a part not in it
        self.picks.pop(number, None)
        self.parts[number] = part
        for key in FILLED_BY_PART:
            self.overrides.pop(f"springs.{number}.{key}", None)

    def override_pairs(self) -> list[tuple[str, object]]:
        """The edits as ``--set`` pairs (:meth:`_field_pairs`), each table target edited
        replacing its joint's target: ``("joints.1", {"target": {...}})``."""
        return self._field_pairs() + [(key.rpartition(".")[0], {"target": table.target()})
                                      for key, table in self.table_edits.items()]

    def _field_pairs(self) -> list[tuple[str, object]]:
        """The edits of the fields and springs as ``--set`` pairs; a key whose table the spec
        leaves out (its ``[workshop]``, a joint's ``acceptance``) sets that table, which then
        holds it; a field in step with another takes that other's value."""
        pairs: list[tuple[str, object]] = [("springs", self._springs_with_parts())] if self.parts else []
        pairs += [(f"springs.{j}", dict(spring)) for j, spring in self.picks.items()]
        for key, value in self.overrides.items():
            table, _, name = key.rpartition(".")
            pairs.append((table, {name: value}) if table in self.absent else (key, value))
        pairs += [(key, self.value(key)) for key in self.links if self.value(key) != self.field(key).value]
        return pairs

    # ------------------------------------------------------------------ the table targets
    def table(self, key: str) -> TargetTable:
        """Table target ``key``'s (``joints.1.target``) table now: the user's, else the spec's."""
        return self.table_edits.get(key, self.tables[key])

    def edit_table(self, key: str, rows=None, unit: str | None = None) -> str | None:
        """Table target ``key`` becomes ``rows`` of (angle, torque [N·m]) (default: its rows
        now) with angles in ``unit`` (default: its unit now); the one-line error of rows that
        are no table (:func:`cadcam.app.tables.checked`), else None."""
        now = self.table(key)
        try:
            table = checked(now.rows if rows is None else rows, unit or now.unit, _bracketed(key))
        except SpecError as exc:
            return str(exc)
        self._set_table(key, table)
        return None

    def paste_table(self, key: str, text: str, unit: str | None = None) -> str | None:
        """Table target ``key`` becomes the rows of ``text`` pasted from a spreadsheet
        (:func:`cadcam.app.tables.pasted`; angles in the unit its header names, else ``unit``,
        else its unit now); the one-line error of text that is no table, else None."""
        try:
            table = pasted(text, unit or self.table(key).unit, _bracketed(key))
        except SpecError as exc:
            return str(exc)
        self._set_table(key, table)
        return None

    def _set_table(self, key: str, table: TargetTable) -> None:
        if table.same(self.tables[key]):
            self.table_edits.pop(key, None)
        else:
            self.table_edits[key] = table

    def _springs_with_parts(self) -> list[dict]:
        """The spec's springs, each with a part picked made that part and named after it."""
        data = {"springs": [self.springs[n] for n in sorted(self.springs)]}
        for number, part in self.parts.items():
            data = part_spec(data, number - 1, part, self.springs[number].get("catalogue"))
            spring = data["springs"][number - 1]
            data["springs"][number - 1] = {"name": part_name(part), **{k: v for k, v in spring.items() if k != "name"}}
        return data["springs"]

    def problem(self) -> Problem:
        """The spec with the edits, parsed once for the same edits (the screen and the design
        share it).

        Raises
        ------
        SpecError
            As :func:`cadcam.load_problem`.
        """
        pairs = self.override_pairs()
        key = repr(pairs)
        if self._parsed is None or self._parsed[0] != key:
            self._parsed = (key, load_problem(self.path, variant=self.variant, overrides=pairs), {})
        return self._parsed[1]

    def edits(self) -> Edits:
        """The user's edits now, as a copy (:class:`cadcam.app.history.Edits`)."""
        return Edits.of(self.overrides, self.picks, self.parts, self.table_edits)

    def ask(self, edited: str | None = None) -> Request:
        """A design of the edits now (``edited``: the field just edited, which an error names
        where it names none): the edits taken and the spec with them parsed, or its error."""
        start = time.perf_counter()
        contexts = {number: self._context(number) for number in self.parts}
        try:
            problem = self.problem()
        except INPUT_ERRORS as exc:
            return Request(self.edits(), None, self._failed(exc, edited, start), contexts)
        return Request(self.edits(), problem, None, contexts, time.perf_counter() - start)

    def run(self, request: Request, edited: str | None = None, recheck: bool = True) -> Outcome:
        """Design ``request`` through the session; a spec error names its field (the one it
        names, else ``edited``). The verdict of each catalogue part designed with is kept for
        its light (:meth:`catalogue_view`). Without ``recheck``, a provisional design
        (:meth:`cadcam.Session.design`: while a slider moves), which sets no light."""
        if request.error is not None:
            outcome = request.error
        else:
            start = time.perf_counter() - request.seconds  # the parse counted in
            try:
                result = self.session.design(request.problem, recheck=recheck)
            except INPUT_ERRORS as exc:
                outcome = self._failed(exc, edited, start)
            else:
                outcome = Outcome(result=result, seconds=time.perf_counter() - start)
                for j, spring in enumerate(result.problem.springs):
                    if spring.part is not None and j + 1 in request.contexts and recheck:
                        self.verdicts[request.contexts[j + 1], j + 1, spring.part] = verdict(_verdict_row(result, j))
        if outcome.error is not None and recheck:
            for number, part in request.edits.parts.items():
                self.verdicts[request.contexts[number], number, part] = ("infeasible", outcome.error)
        return outcome

    def _failed(self, exc: Exception, edited: str | None, start: float) -> Outcome:
        message = str(exc)
        keys = [f.key for f in self.fields] + list(self.tables)
        return Outcome(error=message, field=field_of_error(message, keys, edited), seconds=time.perf_counter() - start)

    def keep(self, request: Request, outcome: Outcome) -> Outcome:
        """``outcome``, the design of ``request``, made the one shown: the last outcome, the
        last design made where it is one, and recorded in :attr:`history`."""
        self.last = outcome
        if outcome.result is not None:
            self.result = outcome.result
        self.history.record(request.edits, outcome)
        return outcome

    def design(self, edited: str | None = None) -> Outcome:
        """Design the spec with the edits now (:meth:`ask`, :meth:`run`, :meth:`keep`)."""
        request = self.ask(edited)
        return self.keep(request, self.run(request, edited))

    def restore(self, edits: Edits, outcome: Outcome) -> None:
        """The edits and the design of a step back or forth in :attr:`history`, shown again as
        they were (not designed again)."""
        self.overrides, self.picks, self.parts, self.table_edits = (
            copy.deepcopy(d) for d in (edits.overrides, edits.picks, edits.parts, edits.tables))
        self.last = outcome
        if outcome.result is not None:
            self.result = outcome.result

    # ---------------------------------------------------------------- the catalogue table
    def catalogue_of(self, number: int) -> Catalogue:
        """The catalogue spring ``number``'s parts come from: the one its spec names, else the
        shipped one."""
        return load_catalogue(self.catalogues[number])

    def screen(self, number: int) -> tuple[Need, Screen]:
        """What spring ``number`` must at least do in the spec as edited now and its catalogue
        screened for that (:func:`cadcam.sweep.springs.screen_slot`), kept while the edits are
        the same.

        Raises
        ------
        SpecError
            The spec as edited cannot be read (:meth:`problem`).
        """
        problem = self.problem()
        assert self._parsed is not None  # set by problem()
        screens = self._parsed[2]
        if number not in screens:
            need = slot_need(problem, number - 1)
            screens[number] = need, screen(self.catalogue_of(number), need)
        return screens[number]

    def catalogue_view(self, number: int, say=str) -> "CatalogueView | None":
        """The catalogue table of spring ``number`` (:func:`cadcam.app.parts.table`) for the spec
        as edited now: each part's light is its verdict where it was designed with under the
        same edits (:meth:`design`; its reason as ``say`` gives it), else the screen's; None
        where the spec as edited cannot be read (its design says why)."""
        try:
            need, screened = self.screen(number)
        except INPUT_ERRORS:
            return None
        cat = self.catalogue_of(number)
        kept = self._numbers.get(cat.origin)
        if kept is None or kept[0] is not cat:
            kept = self._numbers[cat.origin] = (cat, catalogue_numbers(cat))
        context = self._context(number)
        designed = {part: (word, say(reason)) for (c, n, part), (word, reason) in self.verdicts.items()
                    if n == number and c == context}
        return CatalogueView(catalogue_table(kept[1], screened, designed), need, cat.origin)

    def _context(self, number: int) -> str:
        """The edits a design with a part as spring ``number`` depends on: all but that spring's
        own pick and the keys its part fills."""
        own = {f"springs.{number}.{k}" for k in FILLED_BY_PART}
        return repr((sorted((k, v) for k, v in self.overrides.items() if k not in own),
                     sorted((n, p["name"]) for n, p in self.picks.items() if n != number),
                     sorted((n, p) for n, p in self.parts.items() if n != number),
                     sorted(self.table_edits.items())))

    # -------------------------------------------------------------------- the files to download
    def spec_toml(self) -> str:
        """The spec with its variant and the edits, as TOML: a spec file keeps its comments and
        layout; a result.json's resolved problem is written out. A table target edited, or read
        from a CSV file, is written inline (:func:`_inlined`): the spec needs no other file."""
        import tomlkit

        source = self.original or self.path
        if source.suffix == ".toml":
            doc = tomlkit.parse(source.read_text(encoding="utf-8").removeprefix("\ufeff"))
        else:
            doc = tomlkit.document()
            doc.update(_without_none(read_spec_data(source)))
        variant = list(doc["variants"][self.variant].unwrap().items()) if self.variant else []
        for key, value in variant + self._field_pairs():
            apply_override(doc, key, value, "the page's edits")
        for key, spec in self.tables.items():
            if key in self.table_edits or spec.file is not None:
                _inlined(doc, key, self.table(key), spec.file)
        return tomlkit.dumps(doc)

    def own_names(self, text: str) -> str:
        """``text`` (a result.json) naming each of the page's copies of an upload's files
        (:attr:`aliases`) by the user's name for it, not by its path on the server."""
        for path in sorted(self.aliases, key=len, reverse=True):
            text = text.replace(json.dumps(path)[1:-1], json.dumps(self.aliases[path])[1:-1])
        return text

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
            files = {p.name: p.read_bytes() for p in sorted(Path(tmp).iterdir()) if p.is_file() and p.name != MANIFEST}
        if "result.json" in files:
            files["result.json"] = self.own_names(files["result.json"].decode("utf-8")).encode("utf-8")
        return files


def download_stem(name: str, variant: str | None = None) -> str:
    """The start of the names of the files downloaded of the design opened as ``name`` (the
    file's name as the page shows it): its stem, without the ``_result`` of a result.json's
    name, its ``variant`` added; characters other than letters, digits, ``.``, ``-`` and ``_``
    made ``_``; :data:`DOWNLOAD_STEM` where nothing is left."""
    stem = PurePath(name.replace("\\", "/")).stem if name not in ("", ".", "..") else ""
    stem = stem.removesuffix("_result") + (f"_{variant}" if variant else "")
    stem = re.sub(r"[^\w.-]+", "_", stem, flags=re.ASCII).strip("._-")[:STEM_CHARS].rstrip("._-")
    return stem or DOWNLOAD_STEM


def _bracketed(key: str) -> str:
    """A dotted key as the spec reader's messages write it (``joints[1].target``)."""
    return re.sub(r"\.(\d+)", r"[\1]", key)


def _inlined(doc, key: str, table: TargetTable, file: str | None) -> None:
    """Write table target ``key`` (``joints.1.target``) of TOML document ``doc`` as ``table``'s
    rows inline, in place of its rows or its CSV ``file`` (named in a comment); an inline
    table's rows stay on its one line, as TOML asks."""
    import tomlkit
    from tomlkit.items import InlineTable

    label, number, name = key.split(".")
    target = doc[label][int(number) - 1][name]
    for k in ("file", "angle_unit", "samples"):
        target.pop(k, None)
    rows = tomlkit.array()
    rows.extend(table.target()["samples"])
    if not isinstance(target, InlineTable):
        rows.multiline(True)
        if file is not None:
            target.add(tomlkit.comment(f"the rows the design page had, in place of {PurePath(file).name}"))
    target["angle_unit"] = table.unit
    target["samples"] = rows


def in_step(reads, problem: Problem, label: str, keys: set[str]) -> dict[str, str]:
    """The fields among ``keys`` that are another field's quantity, each with that other: a key
    of a mechanism's output law that its joint's torque target (``label`` names the joints'
    tables) or the one spring on the mechanism's ports also has, of the same unit and equal in
    the spec. Fedorov2018's balancer gives its output law the pendulum's mass and length and its
    springs' rate and initial tension (the law balances that pendulum with those springs), so
    that an edit of one must be an edit of both."""
    by_key = {r.key: r for r in reads}
    links = {}
    for u, mechanism in enumerate(problem.mechanisms, 1):
        law = f"mechanisms.{u}.output_target."
        springs = [s for s, spring in enumerate(problem.springs, 1) if any(p.mechanism == u - 1 for p in spring.ports)]
        for key in sorted(k for k in keys if k.startswith(law)):
            name = key.removeprefix(law)
            others = [f"{label}.{mechanism.joint + 1}.target.{name}", *(f"springs.{s}.{name}" for s in springs)]
            same = [k for k in others if k in keys and _same_quantity(by_key[k], by_key[key])]
            if len(same) == 1:
                links[key] = same[0]
    return links


def _same_quantity(a, b) -> bool:
    """Whether key reads ``a`` and ``b`` give one number of one unit."""
    return (a.declaration.unit == b.declaration.unit and isinstance(a.value, (int, float))
            and not isinstance(a.value, bool) and a.value == b.value)


def part_name(part: str) -> str:
    """The name a spring made catalogue part ``part`` on the page is given."""
    return f"part {part}"


def _verdict_row(result: Result, j: int) -> dict:
    """What :func:`cadcam.sweep.springs.verdict` reads of ``result`` for its spring ``j``
    (0-based), as a catalogue search's row gives it (:func:`cadcam.sweep.springs.design_part`)."""
    spring = result.problem.springs[j]
    return {"status": result.status, "message": result.message,
            "violations": list(result.recheck.violations) if not result.success else [],
            "body": spring.body_report(result.recheck.metrics.extension_max[j])}


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
