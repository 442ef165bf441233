"""The design page's form, generated from the spec reader's declarations.

Every field is a key the spec reader reads (:func:`cadcam.spec.read_keys`), labelled with its
last name and its declared unit (:class:`cadcam.keys.Key`), helped by the form it expects (the
words of its error message), and grouped by what it sets: the target and range, the springs,
the geometry, the solver, the workshop files. No label, unit or help is written here.
"""
from __future__ import annotations

import json
import re
from dataclasses import dataclass
from typing import Any

from ..spec import KeyRead, SpecError, parse_value

#: Groups of the form, in page order: (title, pattern of the dotted keys it holds).
GROUPS = (
    ("Target and range", re.compile(r"^(joints|cams)\.\d+\.(theta_range_deg|tracking_weight|sensitivity_weights"
                                    r"|band_weight|acceptance\.[a-z_]+|target\.(?!kind$)[a-z_]+)$|^arm\.")),
    ("Springs", re.compile(r"^springs\.\d+\.(rate|preload|travel|preextension|free_length)$")),
    ("Geometry", re.compile(r"^(mechanisms|cams)\.\d+\.(?!(kind|name|joint|target|theta_range_deg|tracking_weight"
                            r"|sensitivity_weights|band_weight|acceptance)\b)[a-z_.0-9]+$|^torque_model$")),
    ("Solver", re.compile(r"^solver\.(?!ipopt$)[a-z_]+$")),
    ("Workshop files", re.compile(r"^workshop\.[a-z_]+$")),
)

@dataclass(frozen=True)
class Field:
    """One field of the form.

    Attributes
    ----------
    key : str
        Dotted spec key (``springs.1.rate``), as ``--set`` takes it.
    group : str
        Title of its group (:data:`GROUPS`).
    label : str
        What the page writes beside it: the key within its table, and its unit.
    help : str
        The form the spec reader expects (its error messages' words).
    value : object
        The spec's value, or the default (None: cadcam's default, left out of the spec).
    """

    key: str
    group: str
    label: str
    help: str
    value: Any

    @property
    def text(self) -> str:
        """The value as the field shows it: strings bare, numbers and lists as TOML."""
        return value_text(self.value)

    def parse(self, text: str):
        """The value of the field's ``text``; None for an empty field (the default).

        Raises
        ------
        SpecError
            Text that is not a TOML value.
        """
        text = text.strip()
        if not text:
            return None
        if isinstance(self.value, str):  # an expression or a name stays a string
            return text
        return parse_value(text, self.key)


def value_text(value) -> str:
    """A spec value as a field shows it."""
    if value is None:
        return ""
    if isinstance(value, str):
        return value
    if isinstance(value, bool):
        return "true" if value else "false"
    return json.dumps(value, ensure_ascii=False)


def _editable(read: KeyRead) -> bool:
    """A number, a string or a list of numbers: what one text field edits."""
    v = read.value
    return (v is None or isinstance(v, (int, float, str))
            or (isinstance(v, list) and all(isinstance(x, (int, float)) for x in v)))


def _label(key: str, unit: str) -> str:
    """The key within its numbered table (``rate``, ``target.mass``, ``idler.radius``) and its
    unit, if it has one."""
    parts = key.split(".")
    numbered = [i for i, p in enumerate(parts) if p.isdigit()]
    name = ".".join(parts[numbered[0] + 1:] if numbered else parts[1:] or parts)
    return f"{name} [{unit}]" if unit else name


def fields_of(reads: list[KeyRead]) -> list[Field]:
    """The form's fields: each editable key read once, in its group, groups in page order and
    keys in reading order within each."""
    seen: dict[str, Field] = {}
    for read in reads:
        if read.key in seen or not _editable(read):
            continue
        group = next((title for title, pattern in GROUPS if pattern.search(read.key)), None)
        if group is not None:
            seen[read.key] = Field(read.key, group, _label(read.key, read.declaration.unit), read.form,
                                   read.value)
    order = [title for title, _ in GROUPS]
    return sorted(seen.values(), key=lambda f: order.index(f.group))


def table_title(key: str, names: dict[str, str]) -> str:
    """The numbered table a field belongs to, named (``spring 1 (…)``), or ""."""
    match = re.match(r"^([a-z_]+\.\d+)\.", key)
    return names.get(match.group(1), match.group(1)) if match else ""


def field_of_error(message: str, keys: list[str], edited: str | None) -> str | None:
    """The field a one-line spec error names (the longest key it names, written with dots or
    brackets), else the field just edited."""
    dotted = re.sub(r"\[(\d+)\]", r".\1", message)
    named = [k for k in keys if re.search(rf"(?<![\w.]){re.escape(k)}(?![\w])", dotted)]
    return max(named, key=len) if named else edited


__all__ = ["GROUPS", "Field", "SpecError", "field_of_error", "fields_of", "table_title", "value_text"]
