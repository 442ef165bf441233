"""Catalogues of stock extension springs: a CSV of one spring per row, read into typed rows in SI
units, their bodies' limits, and a vectorised screen of the whole catalogue.

The shipped catalogue (:data:`SHIPPED`) holds McMaster-Carr's 1,284 stock extension springs
(from jay-j/virtual-counterweight, MIT licence, notice beside the file). A user catalogue is a
CSV with the columns of :data:`COLUMNS` (a header row, then one spring a row; other columns are
ignored).

The largest extension a row allows. A row gives two: its longest length, x_L = L_max − L0, and
its largest load, x_F = (F_max − F0)/k. They should agree (F_max ≈ F0 + k·(L_max − L0)), but 82
rows of the shipped catalogue differ by more than 5 % (:data:`CONSISTENCY_RTOL`): rounding, or a
limit set by something else. The rule: trust neither alone, take the smaller, so that neither
limit is exceeded; the wire's static stress allowance (:data:`MATERIALS`) is a third bound, and
the spring's travel is the least of the three (:meth:`cadcam.physics.springs.SpringBody.extension_limits`).
"""
from __future__ import annotations

import csv
import difflib
import functools
import io
import math
import os
from dataclasses import dataclass
from importlib.resources import files as package_files
from pathlib import Path

import numpy as np

from ..errors import SpecError
from ..files import InputFileError, read_input, short_repr
from ..keys import Key, KeyTable
from .springs import BODY_LIMITS, SpringBody

#: The shipped catalogue, inside the package.
SHIPPED = "data/springs/mcmaster_extension_springs.csv"

#: The relative difference [-] between F_max and F0 + k·(L_max − L0) above which a row is
#: reported as contradicting itself (the catalogue README's 5 %).
CONSISTENCY_RTOL = 0.05

#: The columns of a catalogue CSV, in the shipped file's units.
COLUMNS = KeyTable("catalogue CSV", "A catalogue of extension springs, one a row (cadcam.physics.catalogue).", (
    Key("part_number", "", "the vendor's part number, unique in the catalogue", "string", min_length=1),
    Key("stiffness", "N/m", "the rate k", low=0, open_low=True),
    Key("load_min", "N", "the initial tension F0, the force that starts to open the coils", low=0),
    Key("length_natural", "m", "the free length L0 inside the hooks", low=0, open_low=True),
    Key("length_max", "m", "the longest allowed length L_max", low=0, open_low=True),
    Key("load_max", "N", "the largest allowed load F_max", low=0, open_low=True),
    Key("wire_dia", "m", "the wire diameter d", low=0, open_low=True),
    Key("od", "m", "the outside coil diameter", low=0, open_low=True),
    Key("material", "", "the wire's material, naming music wire or spring-tempered steel", "string", min_length=1),
    Key("pkg_qty", "-", "the springs in a pack", low=1, default=None),
    Key("pkg_cost", "USD", "the price of a pack", low=0, default=None),
))


@dataclass(frozen=True)
class Material:
    """A spring wire's tensile strength Rm(d) = A·(d / 1 mm)^(−m) and the fraction of it its
    corrected shear stress may reach under a static load.

    Attributes
    ----------
    name : str
    words : tuple of str
        Lower-case words of a catalogue's ``material`` that name it.
    strength : float
        A [Pa]: the least tensile strength of 1 mm wire.
    exponent : float
        m [-].
    fraction : float
        The static allowance τ_allowed / Rm [-].
    source : str
    """

    name: str
    words: tuple[str, ...]
    strength: float
    exponent: float
    fraction: float
    source: str

    def allowed_stress(self, wire_diameter):
        """The static shear-stress allowance [Pa] of wire of diameter ``wire_diameter`` [m]."""
        return self.fraction * self.strength * (np.asarray(wire_diameter) / 1e-3) ** (-self.exponent)


#: The wire materials a catalogue may name. Rm(d) = A/d^m is Shigley's fit of the least tensile
#: strength (Shigley's Mechanical Engineering Design, 10th ed., Table 10-4): music wire ASTM
#: A228 (close to EN 10270-1 grade DH) A = 2211 MPa·mm^m, m = 0.145; hard-drawn ASTM A227
#: (EN 10270-1 grade SH), the weaker of the wires sold as "spring-tempered", A = 1783 MPa·mm^m,
#: m = 0.190. The allowance 0.45·Rm is EN 13906-2's static allowance for the body of an
#: extension spring (and Shigley Table 10-7's 45 % for cold-drawn wire).
MATERIALS = (
    Material("music wire", ("music",), 2211e6, 0.145, 0.45,
             "ASTM A228 (Shigley Table 10-4); 0.45 Rm per EN 13906-2"),
    Material("spring-tempered steel", ("tempered", "hard-drawn", "hard drawn"), 1783e6, 0.190, 0.45,
             "ASTM A227 hard-drawn (Shigley Table 10-4); 0.45 Rm per EN 13906-2"),
)


def material_of(text: str) -> Material | None:
    """The :data:`MATERIALS` entry a catalogue's ``material`` names, or None."""
    low = text.lower()
    return next((m for m in MATERIALS if any(w in low for w in m.words)), None)


class CatalogueError(SpecError):
    """A catalogue that cannot be used: one line naming the file, row and column."""


@dataclass(frozen=True)
class Catalogue:
    """A catalogue's springs, each column an array in row order (SI units).

    Attributes
    ----------
    origin : str
        The file, as messages name it.
    parts : tuple of str
    materials : tuple of str
        Each row's material as the catalogue writes it.
    body : SpringBody
        Every spring's body, each field an array.
    pack_quantity, pack_price : ndarray
        Springs in a pack and its price [USD] (NaN where the catalogue has none).
    """

    origin: str
    parts: tuple[str, ...]
    materials: tuple[str, ...]
    body: SpringBody
    pack_quantity: np.ndarray
    pack_price: np.ndarray

    def __len__(self) -> int:
        return len(self.parts)

    def index(self, part: str) -> int:
        """The row of ``part``.

        Raises
        ------
        KeyError
            An unknown part, its message naming the nearest part numbers.
        """
        try:
            return self.parts.index(part)
        except ValueError:
            near = difflib.get_close_matches(part, self.parts, n=3, cutoff=0.0)
            raise KeyError(f"no part {part!r} in {self.origin}; the nearest: {', '.join(near)}") from None

    def spring_body(self, i: int) -> SpringBody:
        """Row ``i``'s body, its fields numbers."""
        return SpringBody(**{k: float(np.asarray(v)[i]) for k, v in vars(self.body).items()})

    def extension_limits(self) -> dict:
        """Every row's largest extension [m] by each limit (arrays; see the module docstring)."""
        return self.body.extension_limits()

    def travel(self) -> tuple[np.ndarray, np.ndarray]:
        """Every row's travel (the least of its limits) [m] and the index into
        :data:`~cadcam.physics.springs.BODY_LIMITS` of the limit that binds."""
        table = np.stack([self.extension_limits()[k] for k in BODY_LIMITS])
        return table.min(axis=0), table.argmin(axis=0)

    def contradictions(self) -> np.ndarray:
        """The rows whose largest load differs from F0 + k·(L_max − L0) by more than
        :data:`CONSISTENCY_RTOL` of it."""
        b = self.body
        implied = b.preload + b.rate * (b.length_max - b.free_length)
        return np.flatnonzero(np.abs(b.load_max - implied) > CONSISTENCY_RTOL * b.load_max)

    def summary(self) -> str:
        """One line: the springs, the contradicting rows and which limit binds their travel."""
        bad = self.contradictions()
        _, binding = self.travel()
        counts = {name: int(np.sum(binding[bad] == k)) for k, name in enumerate(BODY_LIMITS)}
        unusable = int(np.sum(self.travel()[0] <= 0))
        return (f"{self.origin}: {len(self)} springs; {bad.size} rows contradict themselves "
                f"(largest load ≠ F0 + k·(L_max − L0) by > {CONSISTENCY_RTOL:.0%}): their travel is the "
                f"least their limits allow, bound by " + ", ".join(f"{n} {c}" for n, c in counts.items())
                + f"; {unusable} springs have no travel within their wire's stress allowance")


def fail_at(origin: str, row: int, column: str, value, words: str):
    """Raise :class:`CatalogueError`: one line naming the file, row and column, the value found
    and the value ``words`` expected (every CSV table of parts reads its fields through this)."""
    raise CatalogueError(f"{origin}: row {row}, column '{column}' = {short_repr(value)}: expected {words}")


def number_at(origin: str, row: int, key: Key, text: str) -> float:
    """The number ``text`` of column ``key`` on ``row``, or :func:`fail_at` where the column
    does not allow it."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not key.ok(value):
        fail_at(origin, row, key.name, text, key.form())
    return value


def unique_at(origin: str, row: int, key: Key, text: str, seen: dict, noun: str) -> None:
    """Refuse ``text`` in column ``key`` on ``row`` where the column does not allow it or an
    earlier row of ``seen`` (value → row, to which it is added) has it, ``noun`` naming it."""
    if not key.ok(text):
        fail_at(origin, row, key.name, text, key.form())
    if text in seen:
        fail_at(origin, row, key.name, text, f"{noun} not already on row {seen[text]}")
    seen[text] = row


def table_rows(text: str, origin: str, columns: KeyTable, what: str) -> list[tuple[int, dict[str, str]]]:
    """The rows of CSV ``text`` whose columns ``columns`` declares: for each non-blank row below
    the header, its line number and its fields by column name (stripped; the declared columns
    it has, others ignored). ``what`` names a row's contents in plural (``springs``).

    Raises
    ------
    CatalogueError
        Empty, unreadable CSV, a required column missing, no row below the header, or a row
        whose number of fields is not the header's: one line naming the file and row.
    """
    reader = csv.reader(io.StringIO(text.removeprefix("\ufeff"), newline=""), strict=True)
    try:
        rows = [(reader.line_num, r) for r in reader if any(f.strip() for f in r)]
    except csv.Error as exc:
        raise CatalogueError(f"{origin}: row {reader.line_num}: not readable CSV ({exc})") from None
    if not rows:
        raise CatalogueError(f"{origin}: empty: expected a header row naming the columns "
                             f"{', '.join(columns.names)}")
    head = [h.strip() for h in rows[0][1]]
    missing = [k.name for k in columns.keys if k.required and k.name not in head]
    if missing:
        fail_at(origin, 1, missing[0], ",".join(head), f"a header naming the column '{missing[0]}'")
    if len(rows) == 1:
        raise CatalogueError(f"{origin}: no {what}: expected a row per {what.removesuffix('s')} below the header")
    col = {name: head.index(name) for name in columns.names if name in head}
    out = []
    for line, fields in rows[1:]:
        if len(fields) != len(head):
            raise CatalogueError(f"{origin}: row {line}: {len(fields)} fields, expected {len(head)} (the header's)")
        out.append((line, {n: fields[i].strip() for n, i in col.items()}))
    return out


def parse_catalogue(text: str, origin: str) -> Catalogue:
    """A catalogue from CSV ``text``; ``origin`` names the file in messages.

    Raises
    ------
    CatalogueError
        Empty, unreadable CSV, a missing column, a short row, a value a column does not allow
        (:data:`COLUMNS`), a material not in :data:`MATERIALS`, a row whose longest length is
        not above its free length, largest load not above its initial tension or outside
        diameter not above twice its wire, or a duplicate part number: one line naming the
        file, row and column.
    """
    values: dict[str, list] = {name: [] for name in COLUMNS.names}
    seen: dict[str, int] = {}
    for line, raw in table_rows(text, origin, COLUMNS, "springs"):
        _row(origin, line, raw, values, seen)
    return _catalogue(origin, values)


def _row(origin: str, line: int, raw: dict, values: dict, seen: dict) -> None:
    """Check one row and append its values."""
    part = raw["part_number"]
    unique_at(origin, line, COLUMNS["part_number"], part, seen, "a part number")
    if material_of(raw["material"]) is None:
        fail_at(origin, line, "material", raw["material"],
              "a material naming one of " + ", ".join(m.name for m in MATERIALS))
    row = {k.name: number_at(origin, line, k, raw[k.name]) for k in COLUMNS.keys
           if k.type == "number" and k.name in raw and (k.required or raw[k.name])}
    for above, below, words in (("length_max", "length_natural", "the free length"),
                                ("load_max", "load_min", "the initial tension"),
                                ("od", "wire_dia", "twice the wire diameter")):
        floor = row[below] * (2 if above == "od" else 1)
        if not row[above] > floor:
            fail_at(origin, line, above, raw[above], f"a value above {words} ({floor:g})")
    values["part_number"].append(part)
    values["material"].append(raw["material"])
    for k in COLUMNS.keys:
        if k.type == "number":
            values[k.name].append(row.get(k.name, math.nan))


def _catalogue(origin: str, values: dict) -> Catalogue:
    a = {k: np.asarray(v, dtype=float) for k, v in values.items() if k not in ("part_number", "material")}
    mats = [material_of(m) for m in values["material"]]
    allowed = np.array([m.allowed_stress(d) for m, d in zip(mats, a["wire_dia"])], dtype=float)
    body = SpringBody(rate=a["stiffness"], preload=a["load_min"], free_length=a["length_natural"],
                      length_max=a["length_max"], load_max=a["load_max"], wire_diameter=a["wire_dia"],
                      coil_diameter=a["od"] - a["wire_dia"], allowed_stress=allowed)
    return Catalogue(origin, tuple(values["part_number"]), tuple(values["material"]), body,
                     a["pkg_qty"], a["pkg_cost"])


@functools.lru_cache(maxsize=8)
def _cached(path: str, stamp: tuple) -> Catalogue:
    try:
        text = read_input(path)
    except InputFileError as exc:
        raise CatalogueError(f"{path}: {exc}") from None
    return parse_catalogue(text, path)


def shipped() -> Catalogue:
    """The shipped McMaster-Carr catalogue."""
    return _shipped()


@functools.lru_cache(maxsize=1)
def _shipped() -> Catalogue:
    text = package_files("cadcam").joinpath(SHIPPED).read_text(encoding="utf-8")
    return parse_catalogue(text, "the shipped catalogue (McMaster-Carr)")


def load_catalogue(path=None) -> Catalogue:
    """The catalogue at ``path`` (None: :func:`shipped`), read once per change of the file.

    Raises
    ------
    CatalogueError
        As :func:`parse_catalogue`, or a file that cannot be read.
    """
    if path is None:
        return shipped()
    path = str(path)
    try:
        st = os.stat(path)
        stamp: tuple = (st.st_mtime_ns, st.st_size)
    except OSError:
        stamp = ()
    return _cached(str(Path(path)), stamp)


#: The screen's tests, in the order a rejected spring's one reason is chosen: what each asks.
#: The work and the peak torque are what a design meeting the slot's acceptance must at least
#: deliver (:class:`Slack`), not the target's own.
SCREEN_TESTS = {
    "energy": "the energy it stores within its travel, ½k·x² + F0·x, covers the target's work over its range",
    "force": "its largest force times the largest moment arm reaches the target's peak torque",
    "stroke": "the energy it stores over the last r_max·Δθ of its travel (the most cable the largest "
              "radius winds over the range) covers the target's work",
    "room": "for some moment arm h up to r_max, its free length plus the extension at which it pulls "
            "the peak torque over h fits in the longest straight line from its mount to where a cable of "
            "arm h leaves a profile (the mechanism's, :meth:`cadcam.mechanisms.base.Mechanism.mount_room`)",
}


@dataclass(frozen=True)
class Slack:
    """How far a design's torque may miss the target and still meet the slot's acceptance, and
    what that leaves of the target's work and peak torque.

    A design whose torque τ_s has RMSE e from the target τ over the range Δθ misses the work
    over any part of it by at most Δθ·e (Cauchy–Schwarz: |∫(τ_s − τ)| ≤ √(b − a)·√(Δθ)·e),
    and over a window of width w its mean |τ_s| is at least the target's less e·√(Δθ/w), so
    somewhere there |τ_s| reaches that.

    Attributes
    ----------
    span : float
        Δθ [rad].
    rmse : float
        The RMSE [N·m] the relative limit allows against the target's RMS (inf: no limit).
    per_joule : float
        The RMSE [N·m] the relative limit allows per joule a spring stores within its travel,
        against its torque floor (:data:`cadcam.problem.TORQUE_FLOOR`) [N·m/J].
    cap : float
        The absolute RMSE limit [N·m] (inf: none).
    max_error : float
        The largest |τ_s − τ| allowed [N·m] (inf: no limit).
    windows : tuple of (float, float)
        Per window width w: √(Δθ/w) and the largest mean |τ| over a window that wide [N·m].
    """

    span: float
    rmse: float
    per_joule: float
    cap: float
    max_error: float
    windows: tuple[tuple[float, float], ...]

    def allowed(self, energy: np.ndarray) -> np.ndarray:
        """The largest RMSE [N·m] a design with springs of ``energy`` [J] within their travel
        may have (the relative limit's share of the larger of the target's RMS and the floor,
        within the absolute limit)."""
        return np.minimum(self.cap, np.maximum(self.rmse, self.per_joule * np.asarray(energy)))

    def least_peak(self, peak: float, rmse: np.ndarray) -> np.ndarray:
        """The torque [N·m] a design of RMSE ``rmse`` (per spring) must reach somewhere, the
        target's peak being ``peak``: the best of the windows' means less their slack, and the
        peak less the largest error allowed (the peak itself where ``rmse`` is 0)."""
        c, m = (np.array(v, dtype=float) for v in zip(*self.windows))
        rmse = np.asarray(rmse, dtype=float)
        with np.errstate(invalid="ignore"):  # inf × 0: a window with no slack and no limit
            windowed = np.nan_to_num((m[None, :] - rmse[:, None] * c[None, :]).max(axis=1), nan=-np.inf)
        pointwise = np.where(rmse > 0, peak - self.max_error, peak)
        return np.maximum(np.maximum(windowed, pointwise), 0.0)


#: How many intervals of moment arm the room test bounds the spring's fit over, evenly up to
#: the largest.
ROOM_ARMS = 128


@dataclass(frozen=True)
class Need:
    """What a spring slot asks of a spring, for :func:`screen`.

    Attributes
    ----------
    energy : float or None
        The span of the target's work over the joint's range, max − min of ∫τ_d dθ [J]; None
        where the slot's spring shares the work with others (no energy test).
    torque : float or None
        The target's largest |τ_d| [N·m]; None: no force test.
    arm : float or None
        The largest moment arm the mechanism allows [m]; None: no force or stroke test.
    angle : float or None
        The joint's range Δθ [rad]; None: no stroke test.
    rooms : tuple of float or None
        At each moment arm of :func:`room_arms`, the longest straight line from the spring's
        mount to where a cable of that arm leaves a profile [m]
        (:meth:`cadcam.mechanisms.base.Mechanism.mount_room`); None: no room test.
    slack : Slack or None
        How far a design may miss the target and meet the acceptance; None: the tests take
        the target's work and peak torque as they are.
    """

    energy: float | None = None
    torque: float | None = None
    arm: float | None = None
    angle: float | None = None
    rooms: tuple[float, ...] | None = None
    slack: Slack | None = None


@dataclass(frozen=True)
class Screen:
    """A catalogue screened for one :class:`Need` (arrays in catalogue row order).

    Attributes
    ----------
    passed : ndarray of bool
    reasons : tuple of str
        One reason per rejected spring ("" where it passed).
    travel : ndarray
        Each spring's travel, the least extension its limits allow [m].
    binding : tuple of str
        The limit that sets each travel (``length``, ``load`` or ``stress``).
    energy, force : ndarray
        The energy [J] and force [N] at that travel.
    """

    passed: np.ndarray
    reasons: tuple[str, ...]
    travel: np.ndarray
    binding: tuple[str, ...]
    energy: np.ndarray
    force: np.ndarray


def room_arms(arm: float) -> np.ndarray:
    """The moment arms [m] the room test bounds between: 0 and :data:`ROOM_ARMS` more, evenly
    up to the largest, ``arm``."""
    return arm * np.arange(ROOM_ARMS + 1) / ROOM_ARMS


def _room_spare(body, need: Need, torque: np.ndarray) -> np.ndarray:
    """The room test (:data:`SCREEN_TESTS`): per spring, an upper bound [m] of the most by which
    the room ``need.rooms`` exceeds its free length plus its extension at force ``torque`` / h
    (the peak a design must reach, per spring), over
    every moment arm h up to the largest. Between two arms of :func:`room_arms`, the room is at
    most that at the smaller (it falls as h grows) and the extension at least that at the
    larger (so does the force): the bound holds at every arm, not only at those tried."""
    h = room_arms(need.arm)[1:]
    stretch = np.maximum((torque[:, None] / h[None, :] - body.preload[:, None]) / body.rate[:, None], 0.0)
    return (np.asarray(need.rooms)[None, :-1] - body.free_length[:, None] - stretch).max(axis=1)


def screen(catalogue: Catalogue, need: Need) -> Screen:
    """Every spring of ``catalogue`` tested against ``need`` by :data:`SCREEN_TESTS`, vectorised.

    Each test is necessary, not sufficient: a spring that fails one cannot meet the target, and
    one that passes all may still not. A rejected spring's reason is its first failed test.
    """
    b = catalogue.body
    travel, which = catalogue.travel()
    energy = 0.5 * b.rate * travel**2 + b.preload * travel
    force = b.force(travel)
    slack = need.slack
    rmse = slack.allowed(energy) if slack is not None else np.zeros(len(catalogue))
    work = None if need.energy is None else need.energy - (slack.span if slack is not None else 0.0) * rmse
    torque = (None if need.torque is None else
              slack.least_peak(need.torque, rmse) if slack is not None else np.full(len(catalogue), need.torque))
    fails = {}
    if work is not None:
        fails["energy"] = energy < work
    if torque is not None and need.arm is not None:
        fails["force"] = force * need.arm < torque
    if work is not None and need.arm is not None and need.angle is not None:
        start = np.maximum(travel - need.arm * need.angle, 0.0)
        fails["stroke"] = energy - (0.5 * b.rate * start**2 + b.preload * start) < work
    if need.rooms is not None and torque is not None and need.arm is not None:
        spare = _room_spare(b, need, torque)
        fails["room"] = spare < 0
    binding = tuple(BODY_LIMITS[k] for k in which)
    within = " (missing the target by all its acceptance allows)" if slack is not None else ""
    words = {
        "energy": lambda i: (f"energy: stores {energy[i]:.3g} J within its {1e3 * travel[i]:.3g} mm travel "
                             f"(bound by its {binding[i]}), the target needs {work[i]:.3g} J{within}"),
        "force": lambda i: (f"force: {force[i]:.3g} N at its travel × {need.arm:.3g} m gives "
                            f"{force[i] * need.arm:.3g} N·m < the peak {torque[i]:.3g} N·m{within}"),
        "stroke": lambda i: (f"stroke: over the {1e3 * need.arm * need.angle:.3g} mm of cable the largest "
                             f"radius winds it stores less than the {work[i]:.3g} J needed{within}"),
        "room": lambda i: (f"room: its {1e3 * b.free_length[i]:.3g} mm free length and its stretch at the peak "
                           f"torque exceed the room its mount leaves at every moment arm, by "
                           f"{-1e3 * spare[i]:.3g} mm at best"),
    }
    reasons = [""] * len(catalogue)
    for name in SCREEN_TESTS:
        if name in fails:
            for i in np.flatnonzero(fails[name]):
                if not reasons[i]:
                    reasons[i] = words[name](i)
    passed = np.array([not r for r in reasons], dtype=bool)
    return Screen(passed, tuple(reasons), travel, binding, energy, force)
