"""Every key a spec may hold, declared once: its name, type, unit, default, allowed range and
meaning (:class:`Key`), gathered in the table it belongs to (:class:`KeyTable`).

The spec reader reads a key only through its declaration, so its one-line messages are the
declaration's words (:meth:`Key.form`); the design page labels and helps its fields with them;
the result's JSON Schema (:meth:`Key.schema`) and ``docs/spec_reference.md`` are generated from
them. A table is declared where what it configures lives: a spring's keys beside the spring, a
mechanism's own keys in its class, a target kind's with the kind.

This module imports nothing of cadcam's: every layer may declare keys.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Callable

#: The types a key may have: a number, an integer, text, a choice among :attr:`Key.choices`,
#: a list of numbers, a list of texts, a list of rows of :attr:`Key.length` numbers, a table, or
#: an array of tables.
TYPES = ("number", "integer", "string", "choice", "numbers", "strings", "rows", "table", "tables")


class _Required:
    """The default of a key a spec must give."""

    def __repr__(self) -> str:
        return "required"


#: :attr:`Key.default` of a key without a default: the spec must give it.
REQUIRED: Any = _Required()


#: The unit a value is most often typed in by mistake, by a key's :attr:`Key.unit`: its name
#: and its size in the key's unit (a millimetre is 1e-3 m). A value outside its key's
#: :attr:`Key.plausible` range that this unit brings inside it is told as typed in it.
UNIT_SLIPS = {"m": ("mm", 1e-3), "kg": ("g", 1e-3), "N/m": ("N/mm", 1e3), "m/s²": ("mm/s²", 1e-3),
              "ratio": ("%", 1e-2)}


@dataclass(frozen=True)
class Plausible:
    """Where the magnitude of a key's value is plausible: a value outside is allowed, and warned
    of in one line (:meth:`Key.implausible`), as typed in another unit or beyond any catalogue.
    Zero is plausible in every unit.

    Attributes
    ----------
    low, high : float or None
        The least and greatest plausible magnitude, in the key's unit (None: no bound).
    what : str
        Whose values the range holds, as the warning names them (``a balanced body's mass``).
    """

    low: float | None = None
    high: float | None = None
    what: str = ""

    def holds(self, v: float) -> bool:
        """Whether the magnitude of ``v`` lies in the range (zero always does)."""
        return v == 0 or ((self.low is None or abs(v) >= self.low) and (self.high is None or abs(v) <= self.high))

    def words(self, v: float, unit: str) -> str:
        """Why ``v`` [``unit``] is implausible (``is outside … (up to 50 kg)``), with the value it
        would be if typed in the unit of :data:`UNIT_SLIPS` that brings it inside the range,
        else a word to check it."""
        shown = _shown(unit)
        if self.low is not None and self.high is not None:
            span = f"{self.low:.3g}–{self.high:.3g}{shown}"
        else:
            span = f"up to {self.high:.3g}{shown}" if self.high is not None else f"from {self.low:.3g}{shown}"
        slip = UNIT_SLIPS.get(unit)
        fix = (f"if it is in {slip[0]}, write {v * slip[1]:.6g}" if slip is not None and self.holds(v * slip[1])
               else f"check its value and its unit, {unit}")
        return f"is outside {self.what} ({span}): {fix}"


def _literal(value) -> str:
    """A value as a spec writes it: TOML's ``true`` and ``false``, else its repr."""
    return str(value).lower() if isinstance(value, bool) else repr(value)


def _shown(unit: str) -> str:
    """A unit as it follows a number in words: `` kg``, or nothing for a ratio."""
    return "" if unit in ("", "-", "ratio") else f" {unit}"


#: Sizes [m] of a mechanism's parts: profile radii, idlers, spring ends and travels, sliders.
PART_SIZE = Plausible(high=1.0, what="the sizes of a mechanism's parts")
#: Sizes [m] of what a mechanism balances or moves: links, a pendulum, a cable robot's workspace.
REACH = Plausible(high=5.0, what="the sizes of an arm or a workspace")
#: Masses [kg] a spring balancer carries: a limb, a tool, a robot's link.
MASS = Plausible(high=50.0, what="the masses a spring balancer carries")
#: Gravity [m/s²], on the Moon (1.62) and beyond the Earth's (9.81).
GRAVITY = Plausible(1.0, 30.0, "a planet's gravity")
#: A share of a quantity [ratio] that is a tolerance or an accepted error: at most the whole.
SHARE = Plausible(high=1.0, what="the shares of a whole")


def is_real(v) -> bool:
    """Whether ``v`` read from a file is a finite real number: a float, or an int a float can
    hold (a longer int is no quantity, and ``math.isfinite`` raises ``OverflowError`` on it)."""
    if not isinstance(v, (int, float)) or isinstance(v, bool):
        return False
    try:
        return math.isfinite(v)
    except OverflowError:
        return False


@dataclass(frozen=True)
class Key:
    """One key of a spec table.

    Attributes
    ----------
    name : str
        The key as the spec writes it.
    unit : str
        Its SI unit (``m``, ``rad``, ``N/m``, ``N``, ``kg``, ``-``), or "" for text, choices and
        tables.
    description : str
        What it sets, a phrase starting in lower case (``the spring's rate``): what a message
        names.
    details : str
        More about it, for the reference and the schema, not for one-line messages.
    type : str
        One of :data:`TYPES`.
    default : object
        Its value where the spec leaves it out, :data:`REQUIRED` where the spec must give it,
        or None where its absence means something of its own (:attr:`default_text` says what).
    default_text : str
        The default in words where it depends on other keys (``the range's first angle``).
    low, high : float or None
        Bounds of a number, or of each number of a list.
    open_low, open_high : bool
        Whether :attr:`low` (:attr:`high`) itself is excluded.
    choices : tuple
        The values of a ``choice``.
    length : int or None
        The length a list must have.
    min_length : int
        The least length of a list or array of tables.
    check : callable or None
        A further test of a value, beyond its type and bounds, that :attr:`words` states
        (``angles increasing``).
    words : str
        What :attr:`check` asks, appended to the constraint in words.
    fields : KeyTable or None
        The keys of a ``table`` whose contents are declared.
    plausible : Plausible, callable or None
        Where a number's magnitude (each number's, of a list) is plausible, or a function that
        gives it when first asked (a catalogue's range, read when a spec is); None: anywhere
        its bounds allow.
    """

    name: str
    unit: str
    description: str
    type: str = "number"
    default: Any = REQUIRED
    default_text: str = ""
    low: float | None = None
    high: float | None = None
    open_low: bool = False
    open_high: bool = False
    choices: tuple = ()
    length: int | None = None
    min_length: int = 0
    check: Callable[[Any], bool] | None = field(default=None, compare=False)
    words: str = ""
    fields: "KeyTable | None" = None
    details: str = ""
    plausible: "Plausible | Callable[[], Plausible] | None" = field(default=None, compare=False)

    def __post_init__(self):
        if self.type not in TYPES:
            raise ValueError(f"key {self.name!r}: type {self.type!r} is not one of {TYPES}")

    @property
    def required(self) -> bool:
        """Whether a spec must give the key."""
        return self.default is REQUIRED

    def within(self, **bounds) -> "Key":
        """The key with bounds (or a length, choices) that depend on other keys of the spec."""
        return replace(self, **bounds)

    # -- checks ------------------------------------------------------------------------------------
    def _in_range(self, v) -> bool:
        if not is_real(v):
            return False
        if self.low is not None and (v < self.low or (self.open_low and v == self.low)):
            return False
        return self.high is None or not (v > self.high or (self.open_high and v == self.high))

    def ok(self, v) -> bool:
        """Whether ``v`` is a value the key allows: its type, bounds and :attr:`check`."""
        return self._typed(v) and (self.check is None or bool(self.check(v)))

    def _typed(self, v) -> bool:
        if self.type == "number":
            return self._in_range(v)
        if self.type == "integer":
            return isinstance(v, int) and not isinstance(v, bool) and self._in_range(v)
        if self.type == "string":
            return isinstance(v, str) and (self.min_length == 0 or bool(v.strip()))
        if self.type == "choice":
            return any(v == c and type(v) is type(c) or (is_real(v) and is_real(c) and v == c)
                       for c in self.choices)
        if self.type in ("numbers", "strings"):
            entry = self._in_range if self.type == "numbers" else (lambda x: isinstance(x, str))
            return (isinstance(v, list) and (self.length is None or len(v) == self.length)
                    and len(v) >= self.min_length and all(entry(x) for x in v))
        if self.type == "rows":
            return (isinstance(v, list) and len(v) >= self.min_length
                    and all(isinstance(r, list) and len(r) == self.length and all(is_real(x) for x in r) for r in v))
        if self.type == "table":
            return isinstance(v, dict)
        return isinstance(v, list) and len(v) >= self.min_length and all(isinstance(x, dict) for x in v)

    def implausible(self, value, where: str) -> str | None:
        """One line saying that ``value`` of the key at ``where`` (``springs[1].rate``), a value
        the key allows, is plausible only in another unit or lies outside every catalogue
        (:attr:`plausible`; a list's first such number), and what to write; else None."""
        if self.plausible is None:
            return None
        plausible = self.plausible() if callable(self.plausible) else self.plausible
        numbers = value if isinstance(value, list) else [value]
        bad = next((v for v in numbers if is_real(v) and not plausible.holds(v)), None)
        if bad is None:
            return None
        shown = f"{bad:.6g}{_shown(self.unit)}"
        given = f"{where} = {shown}" if numbers is not value else f"{where}: its {shown}"
        return f"{given} {plausible.words(bad, self.unit)}"

    # -- words ---------------------------------------------------------------------------------------
    def _bounds(self) -> str:
        """The range of a number in words: ``> 0``, ``≥ 0``, ``in (0, 1.5)``, or ""."""
        lo, hi = self.low, self.high
        if lo is not None and hi is not None:
            return f"in {'(' if self.open_low else '['}{lo:g}, {hi:g}{')' if self.open_high else ']'}"
        if lo is not None:
            return f"{'>' if self.open_low else '≥'} {lo:g}"
        if hi is not None:
            return f"{'<' if self.open_high else '≤'} {hi:g}"
        return ""

    def constraint(self) -> str:
        """What the value must be, in words (``a number > 0``, ``one of 'cw', 'ccw'``)."""
        bounds = self._bounds()
        if self.type in ("number", "integer"):
            return f"{'a number' if self.type == 'number' else 'an integer'}{' ' + bounds if bounds else ''}"
        if self.type == "string":
            return "a non-empty string" if self.min_length else "a string"
        if self.type == "choice":
            return "one of " + ", ".join(_literal(c) for c in self.choices)
        if self.type in ("numbers", "strings"):
            size = f"{self.length} " if self.length is not None else (
                f"at least {self.min_length} " if self.min_length else "")
            what = "numbers" if self.type == "numbers" else "strings"
            return f"a list of {size}{what}{' each ' + bounds if bounds else ''}"
        if self.type == "rows":
            return f"a list of at least {self.min_length} rows of {self.length} numbers"
        if self.type == "table":
            return "a table"
        return f"an array of {'at least ' + str(self.min_length) + ' ' if self.min_length > 1 else ''}tables"

    def form(self) -> str:
        """The form expected, as error messages word it: the meaning, the constraint and the
        unit in brackets (``the spring's rate: a number > 0 [N/m]``)."""
        unit = f" [{self.unit}]" if self.unit else ""
        words = f", {self.words}" if self.words else ""
        return f"{self.description}: {self.constraint()}{words}{unit}"

    def default_words(self) -> str:
        """The default as the reference shows it: ``required``, its value, or its words."""
        if self.required:
            return "required"
        if self.default_text:
            return self.default_text
        return "none" if self.default is None else _literal(self.default)

    # -- schema --------------------------------------------------------------------------------------
    def schema(self) -> dict:
        """The key as a JSON Schema property."""
        unit = f" [{self.unit}]" if self.unit else ""
        more = f" ({self.details})" if self.details else ""
        out: dict[str, Any] = {"description": f"{self.description[:1].upper()}{self.description[1:]}{more}{unit}."}
        number = {"number": "number", "integer": "integer"}
        if self.type in number:
            out["type"] = number[self.type]
            out.update(self._schema_bounds())
        elif self.type == "string":
            out["type"] = "string"
        elif self.type == "choice":
            out["enum"] = list(self.choices)
        elif self.type in ("numbers", "strings"):
            out["type"] = "array"
            out["items"] = ({"type": "number", **self._schema_bounds()} if self.type == "numbers"
                            else {"type": "string"})
            if self.length is not None:
                out["minItems"] = out["maxItems"] = self.length
            elif self.min_length:
                out["minItems"] = self.min_length
        elif self.type == "rows":
            out["type"] = "array"
            out["minItems"] = self.min_length
            out["items"] = {"type": "array", "items": {"type": "number"},
                            "minItems": self.length, "maxItems": self.length}
        elif self.type == "table":
            out["type"] = "object"
            if self.fields is not None:
                inner = self.fields.schema()
                out.update(required=inner["required"], additionalProperties=False,
                           properties=inner["properties"])
        else:
            out["type"] = "array"
            out["items"] = {"type": "object"}
        return out

    def _schema_bounds(self) -> dict:
        out = {}
        if self.low is not None:
            out["exclusiveMinimum" if self.open_low else "minimum"] = self.low
        if self.high is not None:
            out["exclusiveMaximum" if self.open_high else "maximum"] = self.high
        return out


@dataclass(frozen=True)
class KeyTable:
    """The keys of one spec table, in reading order.

    Attributes
    ----------
    path : str
        The table as the reference names it (``[[springs]]``, ``[joints.target] kind = "pendulum"``).
    description : str
        What the table sets.
    keys : tuple of Key
        Its keys.
    """

    path: str
    description: str
    keys: tuple[Key, ...]

    def __getitem__(self, name: str) -> Key:
        for key in self.keys:
            if key.name == name:
                return key
        raise KeyError(f"{self.path} declares no key {name!r}")

    @property
    def names(self) -> tuple[str, ...]:
        """The names of its keys."""
        return tuple(k.name for k in self.keys)

    def schema(self) -> dict:
        """The table as a JSON Schema object: its keys' properties and the required ones."""
        return {"description": self.description,
                "required": [k.name for k in self.keys if k.required],
                "properties": {k.name: k.schema() for k in self.keys}}
