"""Parameter studies: a base spec, parameters varied by dotted key, and the cases they make.

A study file (TOML) or a :class:`Study` built in Python names the base model spec (and a
variant), the parameters to vary (``springs.1.rate``, ``cams.1.idler.offset``,
``cams.*.sensitivity_weights``, ``solver.grid``, …) and how:

``design = "factorial"`` (default)
    every combination of the parameters' values;
``design = "zip"``
    the i-th value of every parameter together (all lists of one length);
``design = "latin_hypercube"``
    ``samples`` points of a Latin hypercube (scipy.stats.qmc, ``seed``) over the parameters'
    ``range`` (log-uniform with ``log = true``, rounded with ``integer = true``) or, for
    parameters given by ``values``, an index into them.

A parameter gives ``values = [...]`` (any spec values; a table updates the table at its key),
``range = [lo, hi]`` with ``num`` (linear, or logarithmic with ``log = true``), or
``catalogue = "file.csv"`` (a spring catalogue: header
``id,source,rate_N_per_m,travel_m,pretension_N,notes``; each row becomes the spring table
``{name, rate, travel, preload}``, the pretension becoming the preload). ``record`` lists the metrics the exports show (all are stored).

Everything is checked before any case is solved: every key with every one of its values (or
its range ends) must give a valid spec, and the study must have at least one case.
"""
from __future__ import annotations

import copy
import csv
import hashlib
import io
import itertools
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..verify.evaluate import METRIC_NAMES
from ..files import InputFileError, loads_toml, read_input, short_repr
from ..keys import is_real
from ..problem import Problem, cap
from ..spec import SpecError, apply_override, parse_spec, read_spec_data

DESIGNS = ("factorial", "zip", "latin_hypercube")
DEFAULT_RECORD = ("rmse", "max_abs_error", "objective", "extension_max", "convexity_min")


class StudyError(ValueError):
    """A study that cannot run; the message is one line naming the file and the key."""


@dataclass(frozen=True)
class Parameter:
    """One varied spec value: explicit ``values``, or a ``range`` sampled ``num`` times."""

    key: str
    values: tuple = ()
    range: tuple[float, float] | None = None
    num: int = 0
    log: bool = False
    integer: bool = False

    def levels(self) -> list:
        """The values a factorial or zip design uses."""
        if self.values:
            return list(self.values)
        lo, hi = self.range
        pts = np.geomspace(lo, hi, self.num) if self.log else np.linspace(lo, hi, self.num)
        return [int(round(v)) if self.integer else float(v) for v in pts]

    def at(self, u: float):
        """The value at the unit-interval coordinate ``u`` (Latin hypercube)."""
        if self.values:
            return self.values[min(int(u * len(self.values)), len(self.values) - 1)]
        lo, hi = self.range
        v = math.exp(math.log(lo) + u * (math.log(hi) - math.log(lo))) if self.log else lo + u * (hi - lo)
        return int(round(v)) if self.integer else float(v)

    def extremes(self) -> list:
        """Values that validation tries: every explicit value, or the range's ends."""
        if self.values:
            return list(self.values)
        lo, hi = self.range
        return [int(round(lo)), int(round(hi))] if self.integer else [float(lo), float(hi)]


@dataclass
class Study:
    """A parameter study over a base spec (see the module docstring for the file format)."""

    name: str
    base: Path
    parameters: list[Parameter]
    variant: str | None = None
    design: str = "factorial"
    samples: int = 0
    seed: int = 0
    record: tuple[str, ...] = DEFAULT_RECORD
    warm_start: bool = False
    origin: str = "<study>"
    _base_data: dict = field(default=None, init=False, repr=False, compare=False)

    # -- cases ------------------------------------------------------------------------------
    def n_cases(self) -> int:
        """How many cases :meth:`cases` makes, counted without making them."""
        sizes = [len(p.values) if p.values else p.num for p in self.parameters]
        if self.design == "factorial":
            return math.prod(sizes)
        return min(sizes) if self.design == "zip" else self.samples

    def cases(self) -> list[dict]:
        """The ordered list of cases, each a dict key → value."""
        keys = [p.key for p in self.parameters]
        if self.design == "factorial":
            rows = itertools.product(*[p.levels() for p in self.parameters])
        elif self.design == "zip":
            rows = zip(*[p.levels() for p in self.parameters])
        else:
            from scipy.stats import qmc  # imported here: scipy.stats takes a second to import

            u = qmc.LatinHypercube(d=len(self.parameters), seed=self.seed).random(self.samples)
            rows = ([p.at(x) for p, x in zip(self.parameters, row)] for row in u)
        return [dict(zip(keys, row)) for row in rows]

    def spec_data(self, case: dict) -> dict:
        """The base spec as data with the case's values applied."""
        if self._base_data is None:
            try:
                self._base_data = read_spec_data(self.base, self.variant)
            except SpecError as exc:
                raise StudyError(f"{self.origin}: base: {exc}") from None
        data = copy.deepcopy(self._base_data)
        for key, value in case.items():
            apply_override(data, key, value, str(self.base))
        return data

    def problem(self, case: dict) -> Problem:
        """The validated problem of one case."""
        return parse_spec(self.spec_data(case), str(self.base), self.base.parent)

    @staticmethod
    def case_id(case: dict) -> str:
        """A stable identifier of a case: a hash of its values."""
        return hashlib.sha1(json.dumps(case, sort_keys=True).encode()).hexdigest()[:16]

    # -- checks ------------------------------------------------------------------------------
    def validate(self) -> list[dict]:
        """Check everything that can be checked before solving; return the cases."""
        if not self.parameters:
            raise StudyError(f"{self.origin}: the study varies no parameter; add [[parameters]]")
        if self.design not in DESIGNS:
            raise StudyError(f"{self.origin}: design = {self.design!r}: expected one of {DESIGNS}")
        if self.design == "zip" and len({len(p.levels()) for p in self.parameters}) > 1:
            raise StudyError(f"{self.origin}: design = 'zip' needs the same number of values "
                             "for every parameter")
        for k, p in enumerate(self.parameters):
            for value in p.extremes():
                try:
                    self.problem({p.key: value})
                except SpecError as exc:
                    raise StudyError(f"{self.origin}: parameters[{k + 1}] ({p.key} = {value!r}): "
                                     f"{str(exc).split(': ', 1)[-1]}") from None
        cases = self.cases()
        if not cases:
            raise StudyError(f"{self.origin}: the study has no cases")
        return cases

    def to_dict(self) -> dict:
        """JSON-ready description (stored with the results)."""
        return {"name": self.name, "base": str(self.base), "variant": self.variant,
                "design": self.design, "samples": self.samples, "seed": self.seed,
                "record": list(self.record), "warm_start": self.warm_start,
                "parameters": [{"key": p.key, "values": list(p.values),
                                "range": list(p.range) if p.range else None, "num": p.num,
                                "log": p.log, "integer": p.integer} for p in self.parameters]}

    @classmethod
    def from_dict(cls, d: dict, origin: str = "<study>") -> "Study":
        """Inverse of :meth:`to_dict`."""
        return cls(name=d["name"], base=Path(d["base"]), variant=d["variant"], design=d["design"],
                   samples=d["samples"], seed=d["seed"], record=tuple(d["record"]),
                   warm_start=d["warm_start"], origin=origin,
                   parameters=[Parameter(p["key"], tuple(p["values"]),
                                         tuple(p["range"]) if p["range"] else None, p["num"],
                                         p["log"], p["integer"]) for p in d["parameters"]])


#: The columns a spring catalogue (CSV) must have; ``pretension_N`` and ``notes`` may follow.
CATALOGUE_COLUMNS = ("id", "source", "rate_N_per_m", "travel_m")


def read_catalogue(path: Path) -> tuple[dict, ...]:
    """Spring tables {name, rate [N/m], travel [m], preload [N]} from a catalogue CSV (module
    docstring); an empty or missing ``pretension_N`` is no preload.

    Raises ValueError with one line naming the data row: a quote left open or a stray one, a
    row of another number of cells than the header, or a number that is not a finite one (a
    byte order mark before the header, as spreadsheets write, is not part of it).
    """
    try:  # strict: an unclosed quote would otherwise swallow the rest of the file as one cell
        rows = list(csv.reader(io.StringIO(read_input(path).removeprefix("\ufeff"), newline=""), strict=True))
    except csv.Error as exc:
        raise ValueError(f"not a readable CSV ({exc}): close every quote, or remove it") from None
    header = [h.strip() for h in rows[0]] if rows else []
    if any(k not in header for k in CATALOGUE_COLUMNS):
        raise ValueError(f"the header must include {','.join(CATALOGUE_COLUMNS)}")
    out = []
    for k, cells in enumerate(rows[1:], start=1):
        if not cells:
            continue  # a blank line
        if len(cells) != len(header):
            raise ValueError(f"data row {k} has {len(cells)} cells and the header {len(header)}: give every "
                             "column of the header, empty where unknown")
        out.append(_catalogue_spring(k, dict(zip(header, cells))))
    if not out:
        raise ValueError("the catalogue has no springs: give one row per spring after the header")
    return tuple(out)


def _catalogue_spring(k: int, row: dict) -> dict:
    """The spring table of catalogue data row ``k`` (the header's names → its cells)."""
    try:
        rate, travel = float(row["rate_N_per_m"]), float(row["travel_m"])
        preload = float((row.get("pretension_N") or "").strip() or 0.0)
    except ValueError:
        rate = travel = preload = math.nan
    if not all(map(math.isfinite, (rate, travel, preload))):
        raise ValueError(f"data row {k} (spring {short_repr(row['id'], 40)}): rate_N_per_m, travel_m and "
                         "pretension_N must be finite numbers")
    return {"name": f"{row['id']} ({row['source']})", "rate": rate, "travel": travel, "preload": preload}


def load_study(path) -> Study:
    """Read and check a study file; raises :class:`StudyError` with one line."""
    path = Path(path)
    origin = str(path)
    raw = _read_study_table(path)

    def need(key, ok, form, default=None):
        if key not in raw:
            if default is None:
                raise StudyError(f"{origin}: missing key '{key}': expected {form}")
            return default
        if not ok(raw[key]):
            raise StudyError(f"{origin}: {key} = {raw[key]!r}: expected {form}")
        return raw[key]

    design = raw.get("design", "factorial")
    params = [_parameter(p, f"parameters[{k + 1}]", design, path)
              for k, p in enumerate(need("parameters", lambda v: isinstance(v, list), "an array of [[parameters]]", []))]
    study = Study(
        name=need("name", lambda v: isinstance(v, str) and v, "a non-empty string"),
        base=path.parent / need("base", lambda v: isinstance(v, str) and v, "a spec path relative to the study"),
        variant=need("variant", lambda v: isinstance(v, str), "a variant name", "") or None,
        design=need("design", lambda v: v in DESIGNS, f"one of {DESIGNS}", "factorial"),
        samples=need("samples", lambda v: isinstance(v, int) and v >= 1, "an integer ≥ 1", 0),
        seed=need("seed", lambda v: type(v) is int and 0 <= v < 2**32, "an integer from 0 to 2**32 − 1", 0),
        record=tuple(need("record", lambda v: isinstance(v, list) and all(x in METRIC_NAMES for x in v),
                          f"a list of metric names from {', '.join(METRIC_NAMES)}", list(DEFAULT_RECORD))),
        warm_start=need("warm_start", lambda v: isinstance(v, bool), "true or false", False),
        parameters=params, origin=origin)
    if study.design == "latin_hypercube" and study.samples < 1:
        raise StudyError(f"{origin}: samples: a latin_hypercube design needs samples ≥ 1")
    if study.n_cases() > cap("cases"):
        raise StudyError(f"{origin}: the study has {study.n_cases()} cases, over the cap of {cap('cases')} "
                         "(fewer values, a smaller num or fewer samples; or raise the cap deliberately "
                         "with the environment variable CADCAM_CAP_CASES)")
    return study


#: The keys of a study file.
STUDY_KEYS = {"name", "base", "variant", "design", "samples", "seed", "record", "warm_start",
              "parameters", "notes"}


def _read_study_table(path: Path) -> dict:
    """The study file at ``path`` as a TOML table holding no key but :data:`STUDY_KEYS`."""
    origin = str(path)
    try:
        raw = loads_toml(read_input(path))
    except InputFileError as exc:
        raise StudyError(f"{origin}: the study: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise StudyError(f"{origin}: not valid TOML ({exc})") from None
    if extra := sorted(set(raw) - STUDY_KEYS):
        raise StudyError(f"{origin}: unknown key '{extra[0]}'; allowed: {', '.join(sorted(STUDY_KEYS))}")
    return raw


def _parameter(p, where: str, design: str, path: Path) -> Parameter:
    """One [[parameters]] table ``p`` (``where`` in the study file at ``path``): its key and
    exactly one of values, catalogue (read relative to the study) and range; ``design`` is the
    study's (a range needs ``num`` unless it is sampled by a Latin hypercube)."""
    origin = str(path)
    if not isinstance(p, dict) or not isinstance(p.get("key"), str) or not p["key"]:
        raise StudyError(f"{origin}: {where}.key: expected a dotted key such as 'springs.1.rate'")
    if extra := sorted(set(p) - {"key", "values", "range", "num", "log", "integer", "catalogue"}):
        raise StudyError(f"{origin}: unknown key '{where}.{extra[0]}'")
    given = [k for k in ("values", "range", "catalogue") if k in p]
    if len(given) != 1:
        raise StudyError(f"{origin}: {where} ({p['key']}): give exactly one of values, range, catalogue")
    values, rng, num = (), None, 0
    if "values" in p:
        if not isinstance(p["values"], list) or not p["values"]:
            raise StudyError(f"{origin}: {where}.values: expected a non-empty list")
        values = tuple(p["values"])
    elif "catalogue" in p:
        values = _catalogue_values(p["catalogue"], where, path)
    else:
        rng, num = _parameter_range(p, where, design, origin)
    return Parameter(p["key"], values, rng, num, bool(p.get("log", False)), bool(p.get("integer", False)))


def _catalogue_values(name, where: str, path: Path) -> tuple[dict, ...]:
    """The spring tables of a parameter's ``catalogue`` file ``name``, relative to the study
    file at ``path``."""
    if not isinstance(name, str) or not name:
        raise StudyError(f"{path}: {where}.catalogue = {name!r}: expected the path of a "
                         "spring catalogue (CSV) relative to the study")
    try:
        return read_catalogue(path.parent / name)
    except (OSError, ValueError) as exc:
        raise StudyError(f"{path}: {where}.catalogue: {exc}") from None


def _parameter_range(p: dict, where: str, design: str, origin: str) -> tuple[tuple[float, float], int]:
    """A parameter's ``range`` (low, high) and its ``num`` (at least 2, unless ``design`` is a
    Latin hypercube, which samples the range itself)."""
    r = p["range"]
    if not (isinstance(r, list) and len(r) == 2 and all(is_real(x) for x in r) and r[1] > r[0]):
        raise StudyError(f"{origin}: {where}.range = {r!r}: expected [low, high] numbers with high > low")
    if p.get("log") and r[0] <= 0:
        raise StudyError(f"{origin}: {where}.range: a log range needs low > 0")
    num = p.get("num", 0)
    if design != "latin_hypercube" and not (isinstance(num, int) and not isinstance(num, bool) and num >= 2):
        raise StudyError(f"{origin}: {where}.num = {num!r}: expected an integer ≥ 2 for a range")
    return (float(r[0]), float(r[1])), num
