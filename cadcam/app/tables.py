"""The design page's editor of a tabulated torque target, without the page: the rows of a joint's
``kind = "table"`` target as its spec writes them (inline ``samples`` in their ``angle_unit``,
or the CSV ``file`` in the unit its header names), rows pasted from a spreadsheet, rows edited,
and the target written back inline (:meth:`TargetTable.target`), which the spec reader reads
to the same samples.
"""
from __future__ import annotations

import math
import numbers
import re
from dataclasses import dataclass
from pathlib import Path

from ..spec import SpecError
from ..targets import ANGLE_UNITS, TABLE_KEYS, read_table_rows

#: The CSV column of a torque target's values (:func:`cadcam.targets.read_table`).
TORQUE_COLUMN = "torque_Nm"
#: The unit of a torque target's values.
TORQUE_UNIT = "N·m"
#: The least rows a table target takes (its spec key ``samples``).
LEAST_ROWS = TABLE_KEYS["samples"].min_length
#: The cells of a pasted line are split at the first of these it holds (a spreadsheet's copy
#: separates them by tabs, a CSV by commas or, where the comma is the decimal mark, semicolons),
#: else at blanks.
SEPARATORS = ("\t", ";", ",")
#: A header line's angle cell naming its unit (``theta_deg`` as a CSV's header, ``angle [deg]``,
#: ``θ (°)``, ``angle_rad``), by unit (a key of :data:`cadcam.targets.ANGLE_UNITS`).
HEADER_UNITS = {"deg": re.compile(r"(?<![a-z])deg(rees?)?(?![a-z])|°"),
                "rad": re.compile(r"(?<![a-z])rad(ians?)?(?![a-z])")}


@dataclass(frozen=True)
class TargetTable:
    """A tabulated torque target as the editor shows it.

    Attributes
    ----------
    unit : str
        The angles' unit (a key of :data:`cadcam.targets.ANGLE_UNITS`).
    rows : tuple of (float, float)
        (angle [``unit``], torque [N·m]), angles increasing.
    file : str or None
        The CSV file the spec names for it, as the spec names it (None: the spec gives the rows
        inline, or they were edited).
    """

    unit: str
    rows: tuple[tuple[float, float], ...]
    file: str | None = None

    def target(self) -> dict:
        """The target as a spec gives it inline (``[joints.target]``'s keys)."""
        return {"kind": "table", "angle_unit": self.unit, "samples": [list(row) for row in self.rows]}

    def same(self, other: "TargetTable") -> bool:
        """Whether ``other`` is the same table (its file aside)."""
        return (self.unit, self.rows) == (other.unit, other.rows)


def spec_table(target: dict, base: Path) -> TargetTable:
    """The table of a spec's ``kind = "table"`` target ``target`` (read valid already), its
    ``file`` resolved against the spec's folder ``base``.

    Raises
    ------
    ValueError
        The file cannot be read (:func:`cadcam.targets.read_table_rows`).
    """
    if "samples" in target:
        unit, rows = target.get("angle_unit", TABLE_KEYS["angle_unit"].default), target["samples"]
    else:
        unit, rows = read_table_rows(base / target["file"], TORQUE_COLUMN)
    return TargetTable(unit, tuple((float(a), float(t)) for a, t in rows), target.get("file"))


def checked(rows, unit: str, where: str) -> TargetTable:
    """``rows`` of (angle [``unit``], torque [N·m]) as a table, sorted by angle: at least
    :data:`LEAST_ROWS`, every number finite, each angle once.

    Raises
    ------
    SpecError
        One line starting with ``where`` (``joints[1].target``), saying which row is wrong.
    """
    if unit not in ANGLE_UNITS:
        raise SpecError(f"{where}.angle_unit = {unit!r}: expected one of {', '.join(ANGLE_UNITS)}")
    table = []
    for n, row in enumerate(rows, 1):
        for what, x in zip(("angle", "torque"), row):
            if not (isinstance(x, numbers.Real) and not isinstance(x, bool) and math.isfinite(x)):
                raise SpecError(f"{where}: row {n}: the {what} is {_shown(x)}; give a finite number")
        table.append((float(row[0]), float(row[1])))
    if len(table) < LEAST_ROWS:
        raise SpecError(f"{where}: {len(table)} rows; a table takes at least {LEAST_ROWS} (angle, torque) rows")
    table.sort()
    twice = next((a for (a, _), (b, _) in zip(table, table[1:]) if a == b), None)
    if twice is not None:
        raise SpecError(f"{where}: two rows at {twice:g} {unit}; give each angle once")
    return TargetTable(unit, tuple(table))


def pasted(text: str, unit: str, where: str) -> TargetTable:
    """The table of ``text`` pasted from a spreadsheet or a CSV: a line per row, two cells each
    (angle, torque [N·m]; a decimal comma is read where the cells are not split at commas), an
    optional header line first; the angles in the unit that header names, else in ``unit``.

    Raises
    ------
    SpecError
        As :func:`checked`, or a line that is not two finite numbers (named by its number).
    """
    lines = [(n, line) for n, line in enumerate(text.splitlines(), 1) if line.strip()]
    if lines and _numbers(lines[0][1]) is None:
        unit = header_unit(lines[0][1]) or unit
        lines = lines[1:]
    rows = []
    for n, line in lines:
        numbers = _numbers(line)
        if numbers is None or len(numbers) != 2:
            cells = len(_cells(line))
            said = f"holds {cells} cells" if numbers is not None else f"{_shown(line.strip())} is not two numbers"
            raise SpecError(f"{where}: line {n} {said}; paste two columns: the angle [{unit}] and the torque "
                            f"[{TORQUE_UNIT}]")
        if not all(map(math.isfinite, numbers)):
            raise SpecError(f"{where}: line {n}: {_shown(line.strip())} is not two finite numbers")
        rows.append(numbers)
    return checked(rows, unit, where)


def header_unit(line: str) -> str | None:
    """The angles' unit a header line's first cell names (:data:`HEADER_UNITS`), or None."""
    first = _cells(line)[0].lower()
    named = [unit for unit, pattern in HEADER_UNITS.items() if pattern.search(first)]
    return named[0] if len(named) == 1 else None


def _separator(line: str) -> str | None:
    """The separator of a pasted line's cells (:data:`SEPARATORS`), or None: blanks."""
    return next((s for s in SEPARATORS if s in line), None)


def _cells(line: str) -> list[str]:
    """The cells of a pasted line, the empty ones a spreadsheet leaves at its end dropped."""
    separator = _separator(line)
    cells = [c.strip() for c in (line.split(separator) if separator else line.split())]
    while len(cells) > 1 and not cells[-1]:
        cells.pop()
    return cells or [""]


def _numbers(line: str) -> list[float] | None:
    """The numbers of a pasted line's cells, or None where a cell is no number (a header); a
    comma that does not separate the cells is a decimal mark."""
    decimal_comma = _separator(line) != ","
    numbers = []
    for cell in _cells(line):
        try:
            numbers.append(float(cell.replace(",", ".") if decimal_comma else cell))
        except ValueError:
            return None
    return numbers


def _shown(value) -> str:
    """A cell as a message quotes it (short)."""
    text = repr(value)
    return text if len(text) <= 40 else text[:39] + "…"


__all__ = ["LEAST_ROWS", "TargetTable", "checked", "header_unit", "pasted", "spec_table"]
