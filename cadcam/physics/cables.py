"""The cable as a part: its diameter, the least radius it may bend round and its breaking load,
from the shipped table (:data:`SHIPPED`, sources in its README) or given in full by a spec's
``[cable]`` table (:data:`CABLE_KEYS`).

Two limits of a design follow from it, each a row of the NLP and a check of the fine re-check:

* **Bend.** The cable lies on the cut outline, its radius d/2 inside the designed profile (its
  centre line). The outline's radius of curvature on the wrapped arc must be at least the
  cable's least bend radius, so the designed profile's at least that plus d/2
  (:attr:`Cable.least_profile_radius`).
* **Tension.** The cable carries the force F0 + k·x of the spring it pulls; that force must stay
  within its working load, the breaking load over the safety factor of its kind
  (:data:`SAFETY_FACTORS`). Force grows with the extension, so the limit is an upper bound on
  the spring's extension, like its travel (:meth:`Cable.extension_limit`). Where a differential
  pair shares a spring between two cable ends each carries less than the spring's force: the
  bound is then on the safe side. Friction on a guide, which raises the tension along the wrap,
  is not counted.

The table's numbers are engineering guidance (its README says where they come from), not a
supplier's rating: a cable bought with its own data sheet is given in full.
"""
from __future__ import annotations

import difflib
import functools
from dataclasses import dataclass
from importlib.resources import files as package_files

from ..keys import Key, KeyTable
from .catalogue import fail_at, number_at, table_rows, unique_at

#: The shipped cable table, inside the package.
SHIPPED = "data/cables/cables.csv"

#: The safety factor [-] of each kind of cable: its working load is its breaking load over it.
#: 5 for wire rope and 7 for fibre rope are the working coefficients of the EU Machinery
#: Directive 2006/42/EC, Annex I 4.1.2.5, for wire ropes and textile ropes: they cover wear,
#: bending over pulleys, terminations and dynamic loads.
SAFETY_FACTORS = {"wire rope": 5.0, "fibre rope": 7.0}

#: The kind whose safety factor applies to a cable given without its kind: the stricter one.
UNKNOWN_KIND = max(SAFETY_FACTORS, key=SAFETY_FACTORS.__getitem__)

#: The largest cable diameter [m] a spec may give.
MAX_DIAMETER = 0.02

#: The columns of a cable table CSV (SI units).
COLUMNS = KeyTable("cable table CSV", "A table of cables, one a row (cadcam.physics.cables).", (
    Key("name", "", "the cable's name, unique in the table", "string", min_length=1),
    Key("construction", "", "its construction (strands × wires, or braid)", "string", min_length=1),
    Key("kind", "", "its kind, which sets its safety factor", "choice", choices=tuple(SAFETY_FACTORS)),
    Key("material", "", "what it is made of", "string", min_length=1),
    Key("diameter", "m", "its nominal diameter d", low=0, open_low=True, high=MAX_DIAMETER),
    Key("bend_ratio", "-", "its least bend radius over d, to its inner side", low=0, open_low=True),
    Key("breaking_load", "N", "its minimum breaking load", low=0, open_low=True),
))

#: The default words of a key a cable's name fills.
_FILLED = "the named cable's; required without a name"

#: The ``[cable]`` table's keys: a cable of the shipped table by name, or one given in full.
CABLE_KEYS = KeyTable("[cable]", "The cable the profiles wrap, as a part: a cable of the shipped table "
                      "(cadcam/data/cables/cables.csv) by name, or one given in full (diameter, min_bend_radius, "
                      "breaking_load and its kind). The design keeps every wrapped arc's cut outline no tighter than "
                      "the cable's least bend radius and its tension within its working load. Without it, "
                      "[workshop] cable_diameter gives a diameter alone, checked for neither.", (
    Key("name", "", "a cable of the shipped table: fills diameter, min_bend_radius, breaking_load and kind from its "
        "row", "string", min_length=1, default=None, default_text="none (the spec gives the cable in full)"),
    Key("diameter", "m", "the cable's diameter d; the designed profile is its centre line, the cut outline lies d/2 "
        "inside (it sets [workshop] cable_diameter)", low=0, open_low=True, high=MAX_DIAMETER, default=None,
        default_text=_FILLED),
    Key("min_bend_radius", "m", "the least radius the cable may bend round, to its inner side (a pulley's tread "
        "radius): the least radius of curvature of the cut outline on the wrapped arc", low=0, default=None,
        default_text=_FILLED),
    Key("breaking_load", "N", "the cable's minimum breaking load", low=0, open_low=True, default=None,
        default_text=_FILLED),
    Key("kind", "", "the cable's kind, which sets the safety factor of its working load (5 for wire rope, 7 for "
        "fibre rope)", "choice", choices=tuple(SAFETY_FACTORS), default=UNKNOWN_KIND,
        default_text=f"the named cable's; without a name '{UNKNOWN_KIND}', the stricter"),
))

#: The ``[cable]`` keys a name fills from its row.
FILLED_BY_NAME = ("diameter", "min_bend_radius", "breaking_load", "kind")


@dataclass(frozen=True)
class Cable:
    """A cable: its sizes and strength (SI units).

    Attributes
    ----------
    diameter : float
        d [m].
    min_bend_radius : float
        The least radius [m] it may bend round, measured to its inner side.
    breaking_load : float
        Its minimum breaking load [N].
    kind : str
        A key of :data:`SAFETY_FACTORS`.
    name : str or None
        Its name in the shipped table; None for a cable given in full.
    construction, material : str
        As the table gives them ("" for a cable given in full).
    """

    diameter: float
    min_bend_radius: float
    breaking_load: float
    kind: str = UNKNOWN_KIND
    name: str | None = None
    construction: str = ""
    material: str = ""

    @property
    def safety_factor(self) -> float:
        """The safety factor [-] of its kind (:data:`SAFETY_FACTORS`)."""
        return SAFETY_FACTORS[self.kind]

    @property
    def working_load(self) -> float:
        """The largest tension [N] a design may give it: the breaking load over the safety
        factor."""
        return self.breaking_load / self.safety_factor

    @property
    def least_profile_radius(self) -> float:
        """The least radius of curvature [m] of a designed profile it wraps, its centre line:
        the least bend radius plus its radius."""
        return self.min_bend_radius + self.diameter / 2

    def extension_limit(self, rate, preload):
        """The largest extension [m] of a spring of rate ``rate`` [N/m] and initial tension
        ``preload`` [N] whose force F0 + k·x it carries within its working load (≤ 0: the
        initial tension alone is beyond it); numbers or arrays."""
        return (self.working_load - preload) / rate

    def label(self) -> str:
        """Its name quoted, or its diameter and kind for one given in full."""
        return repr(self.name) if self.name else f"a {1e3 * self.diameter:g} mm {self.kind}"

    def to_dict(self) -> dict:
        """The spec form (``[cable]``): its name, if any, and the values it sets."""
        return {**({"name": self.name} if self.name else {}),
                **{k: getattr(self, k) for k in FILLED_BY_NAME}}

    def report(self, tensions, radii) -> dict:
        """Its data and its checks in a design (SI units): the largest tension [N] each spring
        puts on it, ``tensions``, against its working load, and the least radius of curvature
        [m] of each profile it wraps, ``radii``, against its least profile radius."""
        tensions, radii = [float(t) for t in tensions], [float(r) for r in radii]
        return {**self.to_dict(), "construction": self.construction, "material": self.material,
                "safety_factor": self.safety_factor, "working_load": self.working_load,
                "least_profile_radius": self.least_profile_radius, "curvature_radius_min": radii,
                "tension_max": tensions, "peak_tension": max(tensions, default=0.0)}


@dataclass(frozen=True)
class CableTable:
    """A table's cables, in row order; ``origin`` names its file in messages."""

    origin: str
    cables: tuple[Cable, ...]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(str(c.name) for c in self.cables)

    def cable(self, name: str) -> Cable:
        """The cable called ``name``.

        Raises
        ------
        KeyError
            An unknown name, its message naming the nearest names.
        """
        try:
            return self.cables[self.names.index(name)]
        except ValueError:
            near = difflib.get_close_matches(name, self.names, n=3, cutoff=0.0)
            raise KeyError(f"no cable {name!r} in {self.origin}; the nearest: {', '.join(near)}") from None


def parse_cables(text: str, origin: str) -> CableTable:
    """A cable table from CSV ``text``; ``origin`` names the file in messages.

    Raises
    ------
    cadcam.physics.catalogue.CatalogueError
        Empty, unreadable CSV, a missing column, a short row, a value a column does not allow
        (:data:`COLUMNS`) or a name already on an earlier row: one line naming the file, row
        and column.
    """
    seen: dict[str, int] = {}
    cables = []
    for line, raw in table_rows(text, origin, COLUMNS, "cables"):
        unique_at(origin, line, COLUMNS["name"], raw["name"], seen, "a name")
        for key in ("construction", "material", "kind"):
            if not COLUMNS[key].ok(raw[key]):
                fail_at(origin, line, key, raw[key], COLUMNS[key].form())
        d, ratio, load = (number_at(origin, line, COLUMNS[k], raw[k]) for k in ("diameter", "bend_ratio", "breaking_load"))
        cables.append(Cable(d, ratio * d, load, raw["kind"], raw["name"], raw["construction"], raw["material"]))
    return CableTable(origin, tuple(cables))


@functools.lru_cache(maxsize=1)
def shipped_cables() -> CableTable:
    """The shipped cable table."""
    text = package_files("cadcam").joinpath(SHIPPED).read_text(encoding="utf-8")
    return parse_cables(text, "the shipped cable table")

