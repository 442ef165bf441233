"""The design page's form, generated from the spec reader's declarations.

Every field is a key the spec reader reads (:func:`cadcam.spec.read_keys`), labelled with its
last name and its declared unit (:class:`cadcam.keys.Key`), helped by the form it expects (the
words of its error message), and grouped by what it sets: the target and range, the springs,
the tolerances, the geometry, the solver, the workshop files. No label, unit or help is written
here.

The quantities a designer turns (:data:`TURNED`) also get a slider beside their field
(:func:`slider_of`), its range, step and unit made from the key's declaration (its bounds, its
plausible range) and the value now.
"""
from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from typing import Any, NamedTuple

from ..keys import Key
from ..problem import tolerance_keys
from ..spec import KeyRead, SpecError, parse_value

#: Groups of the form, in page order: (title, pattern of the dotted keys it holds).
GROUPS = (
    ("Target and range", re.compile(r"^(joints|cams)\.\d+\.(theta_range_deg|tracking_weight|sensitivity_weights"
                                    r"|band_weight|acceptance\.[a-z_]+|target\.(?!kind$)[a-z_]+)$|^arm\.")),
    ("Springs", re.compile(r"^springs\.\d+\.(rate|preload|travel|preextension|free_length)$")),
    ("Tolerances", re.compile(r"^tolerances\.[a-z_]+$")),
    ("Geometry", re.compile(r"^(mechanisms|cams)\.\d+\.(?!(kind|name|joint|target|theta_range_deg|tracking_weight"
                            r"|sensitivity_weights|band_weight|acceptance)\b)[a-z_.0-9]+$|^torque_model$")),
    ("Solver", re.compile(r"^solver\.(?!ipopt$)[a-z_]+$")),
    ("Workshop files", re.compile(r"^workshop\.[a-z_]+$")),
)

#: The fields a designer turns, each with a slider beside it: a target's mass and length, a
#: joint's range, a spring's rate, preload and travel, a mechanism's spring end and profile order,
#: the tolerances of the built part.
TURNED = re.compile(r"^(joints|cams)\.\d+\.(theta_range_deg|target\.(mass|length))$"
                    r"|^springs\.\d+\.(rate|preload|travel)$"
                    r"|^(mechanisms|cams)\.\d+\.(order|spring_end)$|^tolerances\.[a-z_]+$")
#: A positive value v turns over [v / SPAN, v · SPAN] (from 0 where its key allows 0), an integer
#: up to SPAN · v + 1, within its key's bounds and plausible range.
SPAN = 2.0
#: A range [a, b] of angles turns each end over [a − w, b + w], w = b − a, times this.
RANGE_MARGIN = 1.0
#: A slider has at least this many steps over its span (each a power of ten of its unit).
STEPS = 200

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
    declaration : Key, optional
        The key's declaration: its unit, bounds and plausible range (a slider's, :func:`slider_of`).
    """

    key: str
    group: str
    label: str
    help: str
    value: Any
    declaration: Key | None = field(default=None, compare=False, repr=False)

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
                                   read.value, read.declaration)
    for key in tolerance_keys().keys:  # the spec's [tolerances] holds those it gives; the others are the defaults
        name = f"tolerances.{key.name}"
        if name not in seen:
            seen[name] = Field(name, "Tolerances", _label(name, key.unit), key.form(), key.default, key)
    order = [title for title, _ in GROUPS]
    return sorted(seen.values(), key=lambda f: order.index(f.group))


class Slider(NamedTuple):
    """A slider of a field a designer turns (:func:`slider_of`).

    Attributes
    ----------
    start, end, step : float
        Its span and step, in its unit.
    unit : str
        The key's unit, shown after the value.
    kind : str
        ``number``, ``integer``, ``range`` (two ends of one span: a joint's range) or ``point``
        (each coordinate a slider of its own: a spring end [x, y]).
    spans : tuple
        Per coordinate of a ``point`` its own (start, end); else one (start, end).
    """

    start: float
    end: float
    step: float
    unit: str
    kind: str
    spans: tuple = ()

    def snapped(self, value: float) -> float:
        """``value`` rounded to the decimals of the step (a slider's float has binary noise)."""
        return round(float(value), max(0, -math.floor(math.log10(self.step))))


def turned(key: str) -> bool:
    """Whether field ``key`` is one a designer turns: it has a slider (:data:`TURNED`)."""
    return TURNED.search(key) is not None


def slider_of(f: Field, value=None) -> Slider | None:
    """The slider of field ``f`` (one of :data:`TURNED`, with its declaration) about ``value``
    (default: the field's own), or None for a field without one or a value it cannot show
    (an expression, a list of another length)."""
    key, value = f.declaration, f.value if value is None else value
    if key is None or not turned(f.key):
        return None
    if key.type == "numbers" and isinstance(value, list) and len(value) == 2 and all(_real(v) for v in value):
        if key.unit == "deg":
            a, b = sorted(float(v) for v in value)
            margin = RANGE_MARGIN * max(b - a, 1.0)
            lo, hi = _bounded(key, a - margin, b + margin)
            return Slider(lo, hi, _step(hi - lo), key.unit, "range", ((lo, hi),))
        reach = max(math.hypot(*value), 1e-3)  # a point turns within its distance from the joint axis
        spans = tuple(_bounded(key, float(v) - reach, float(v) + reach) for v in value)
        return Slider(min(s[0] for s in spans), max(s[1] for s in spans), _step(reach), key.unit, "point", spans)
    if key.type not in ("number", "integer") or not _real(value):
        return None
    v = float(value)
    if key.type == "integer":
        lo, hi = _bounded(key, key.low if key.low is not None else 0.0, SPAN * abs(v) + 1)
        return Slider(math.ceil(lo), math.floor(hi), 1, key.unit, "integer", ((math.ceil(lo), math.floor(hi)),))
    zero_allowed = key.low is not None and key.low <= 0 and not (key.low == 0 and key.open_low)
    if v > 0:
        lo, hi = (0.0 if zero_allowed else v / SPAN), v * SPAN
    elif v < 0:
        lo, hi = v * SPAN, v / SPAN
    else:
        lo, hi = 0.0, _plausible_high(key)
    lo, hi = _bounded(key, lo, hi)
    return Slider(lo, hi, _step(hi - lo), key.unit, "number", ((lo, hi),))


def _real(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _plausible_high(key: Key) -> float:
    """The greatest plausible magnitude of ``key``'s values (1 where none is declared): a zero
    value's slider reaches it."""
    plausible = key.plausible() if callable(key.plausible) else key.plausible
    return plausible.high if plausible is not None and plausible.high is not None else 1.0


def _bounded(key: Key, lo: float, hi: float) -> tuple[float, float]:
    """[lo, hi] within ``key``'s bounds and the magnitudes it finds plausible."""
    plausible = key.plausible() if callable(key.plausible) else key.plausible
    if plausible is not None and plausible.high is not None:
        lo, hi = max(lo, -plausible.high), min(hi, plausible.high)
    if key.low is not None:
        lo = max(lo, key.low)
    if key.high is not None:
        hi = min(hi, key.high)
    return lo, max(hi, lo)


def _step(span: float) -> float:
    """The step of a slider over ``span``: the power of ten giving at least :data:`STEPS` steps."""
    return 10.0 ** math.floor(math.log10(span / STEPS)) if span > 0 else 1.0


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


__all__ = ["GROUPS", "TURNED", "Field", "Slider", "SpecError", "field_of_error", "fields_of", "slider_of", "table_title",
           "turned", "value_text"]
