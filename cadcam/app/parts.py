"""The design page's spring catalogue table, without the page: every spring of a catalogue with a
feasibility light for one spring of the spec as edited now.

A spring's light is its verdict (:func:`cadcam.sweep.springs.verdict`) where the page has
designed with it under the same edits, else the catalogue's screen for that spring
(:func:`cadcam.sweep.springs.screen_slot`: milliseconds for the whole catalogue): a spring it
rejects cannot meet the target, one it passes has not been tried. Lengths are shown in mm and
rates in N/mm, as a catalogue page gives them.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pandas as pd

from ..physics.catalogue import Catalogue, Screen, load_catalogue
from ..problem import Problem
from ..sweep.springs import VERDICT_COLOURS, VERDICTS


class Light(NamedTuple):
    """A light of the table: its colour (CSS) and what it says."""

    colour: str
    words: str


#: The table's lights, best first (a light's column holds its place here, so that sorting on it
#: puts the best first).
LIGHTS = {
    "feasible": Light(VERDICT_COLOURS["feasible"], VERDICTS["feasible"]),
    "near": Light(VERDICT_COLOURS["near"], VERDICTS["near"]),
    "untried": Light(VERDICT_COLOURS["not_designed"],
                     "passes the screen; not designed with these edits yet: pick it to design"),
    "undecided": Light(VERDICT_COLOURS["undecided"], VERDICTS["undecided"]),
    "infeasible": Light(VERDICT_COLOURS["infeasible"], VERDICTS["infeasible"]),
}


class Column(NamedTuple):
    """A number column of the table: the catalogue's value in SI units times ``scale`` is shown
    under ``title``; the column's filter keeps the rows ``test`` (``>=`` or ``<=``) the value
    typed."""

    name: str
    title: str
    scale: float
    test: str


#: The number columns, in table order.
NUMBERS = (
    Column("rate", "rate [N/mm]", 1e-3, ">="),
    Column("initial_tension", "initial tension [N]", 1.0, ">="),
    Column("free_length", "free length [mm]", 1e3, "<="),
    Column("travel", "travel [mm]", 1e3, ">="),
    Column("length_max", "largest length [mm]", 1e3, ">="),
    Column("load_max", "largest load [N]", 1.0, ">="),
    Column("od", "OD [mm]", 1e3, "<="),
    Column("price", "pack price [USD]", 1.0, "<="),
)

#: The other columns' titles; the table's columns are these and :data:`NUMBERS`, in the order
#: of :func:`columns`.
TITLES = {"light": "", "part": "part", "verdict": "verdict", "reason": "reason"}

#: Significant digits of the numbers shown (the catalogue's inch values, converted to SI, carry
#: about four).
DIGITS = 4


def columns() -> list[str]:
    """The table's columns, in order: the light, the part, its verdict, the numbers, the reason."""
    return ["light", "part", "verdict", *(c.name for c in NUMBERS), "reason"]


def titles() -> dict[str, str]:
    """Every column's title."""
    return TITLES | {c.name: c.title for c in NUMBERS}


def significant(values, digits: int = DIGITS) -> np.ndarray:
    """``values`` rounded to ``digits`` significant digits (zeros and NaN kept)."""
    x = np.asarray(values, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):  # zero and NaN: kept by the where
        scale = 10.0 ** (digits - 1 - np.floor(np.log10(np.abs(x))))
        return np.where(np.isfinite(scale), np.round(x * scale) / scale, x)


def catalogue_numbers(catalogue: Catalogue) -> pd.DataFrame:
    """The columns of ``catalogue`` that no edit changes: the part and :data:`NUMBERS`, one row a
    spring, indexed by its row in the catalogue."""
    b = catalogue.body
    si = {"rate": b.rate, "initial_tension": b.preload, "free_length": b.free_length,
          "travel": catalogue.travel()[0], "length_max": b.length_max, "load_max": b.load_max,
          "od": b.coil_diameter + b.wire_diameter, "price": catalogue.pack_price}
    numbers = {c.name: significant(np.asarray(si[c.name]) * c.scale) for c in NUMBERS}
    return pd.DataFrame({"part": list(catalogue.parts), **numbers})


def table(numbers: pd.DataFrame, screened: Screen, designed: dict[str, tuple[str, str]]) -> pd.DataFrame:
    """The catalogue table (:func:`columns`) for one spring: ``numbers`` of
    :func:`catalogue_numbers`, each row lit by the verdict it was ``designed`` with (part →
    (verdict, reason)), else by the catalogue's screen ``screened`` for that spring."""
    words = np.where(screened.passed, "untried", "infeasible").astype(object)
    reasons = np.array(screened.reasons, dtype=object)
    rows = pd.Series(numbers.index, index=numbers["part"])
    for part, (word, reason) in designed.items():
        if part in rows.index:
            words[rows[part]], reasons[rows[part]] = word, reason
    order = list(LIGHTS)
    out = numbers.assign(light=[order.index(w) for w in words], verdict=words, reason=reasons)
    return out[columns()]


def count_line(rows: pd.DataFrame) -> str:
    """How many springs of the table have each light (``626 untried, 658 infeasible``)."""
    counts = rows["verdict"].value_counts()
    return ", ".join(f"{counts[w]} {w}" for w in LIGHTS if w in counts)


def part_lines(problem: Problem) -> list[str]:
    """A line for each spring of ``problem`` that is a catalogue part: the part, its catalogue and
    the numbers its row fills."""
    return [f"spring {j + 1} is part {s.part} of {load_catalogue(s.catalogue).origin}: rate {s.rate / 1e3:.4g} N/mm, "
            f"initial tension {s.preload:.4g} N, free length {1e3 * s.free_length:.4g} mm, "
            f"travel {1e3 * s.travel:.4g} mm"
            for j, s in enumerate(problem.springs) if s.part is not None and s.free_length is not None]


__all__ = ["LIGHTS", "NUMBERS", "Column", "Light", "catalogue_numbers", "columns", "count_line", "part_lines", "significant",
           "table", "titles"]
