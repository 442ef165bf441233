"""Read and validate problem specs (TOML, SI units) into a :class:`~cadcam.problem.Problem`.

Every defect is reported as one :class:`SpecError` line naming the file, the key and the form
expected. A spec is data: target expressions go through :func:`cadcam.targets.parse_expression`,
never ``eval``. A ``result.json`` written by cadcam is accepted too: its ``problem`` member is a
fully resolved spec.
"""
from __future__ import annotations

import json
import math
import re
import tomllib
from itertools import product
from pathlib import Path

import numpy as np

from .physics.capstan import FRICTION_MODELS
from .problem import Cam, Options, Problem
from .physics.profile import BASES, Basis
from .physics.springs import PORT_KINDS, Port, Spring
from .targets import ExpressionError, Target, read_table

_REQUIRED = object()
_PORT = re.compile(r"^(-?)(wire|platform):([1-9][0-9]*)$")


class SpecError(ValueError):
    """A spec that cannot be used; the message is one line naming file, key and expected form."""


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _positive(v) -> bool:
    return _number(v) and v > 0


def _nonneg(v) -> bool:
    return _number(v) and v >= 0


def _posint(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and v >= 1


class _Reader:
    """Reads one table of a spec, remembering which keys it took, to refuse unknown ones."""

    def __init__(self, origin: str, table, where: str):
        self.origin, self.where = origin, where
        if not isinstance(table, dict):
            self.fail(where or "spec", table, "a table")
        self.table, self.seen = table, set()

    def fail(self, key, value, form):
        raise SpecError(f"{self.origin}: {key} = {value!r}: expected {form}")

    def key(self, name: str) -> str:
        return f"{self.where}.{name}" if self.where else name

    def get(self, name, ok, form, default=_REQUIRED):
        self.seen.add(name)
        if name not in self.table:
            if default is _REQUIRED:
                raise SpecError(f"{self.origin}: missing key '{self.key(name)}': expected {form}")
            return default
        value = self.table[name]
        if not ok(value):
            self.fail(self.key(name), value, form)
        return value

    def done(self):
        extra = sorted(set(self.table) - self.seen)
        if extra:
            raise SpecError(f"{self.origin}: unknown key '{self.key(extra[0])}'; allowed keys "
                            f"here: {', '.join(sorted(self.seen))}")


def _list_of(ok, n=None):
    return lambda v: isinstance(v, list) and (n is None or len(v) == n) and all(ok(x) for x in v)


def _arm(r: _Reader, n_cams: int) -> dict:
    """An arm table: masses, lengths, com (one per joint) and g."""
    n = r.get("masses", lambda v: isinstance(v, list) and 1 <= len(v) <= n_cams and all(
        _positive(x) for x in v), f"a list of 1…{n_cams} positive link masses [kg]")
    arm = {"masses": [float(v) for v in n],
           "lengths": [float(v) for v in r.get("lengths", _list_of(_nonneg, len(n)),
                                               f"a list of {len(n)} link lengths ≥ 0 [m]")],
           "com": [float(v) for v in r.get("com", _list_of(_number, len(n)),
                                           f"a list of {len(n)} centre-of-mass distances [m]")],
           "g": float(r.get("g", _positive, "a positive gravity [m/s²]", 9.81))}
    return arm


def _target(r: _Reader, base: Path, n_cams: int, arm: dict | None) -> Target:
    kinds = ("expression", "pendulum", "table", "arm")
    kind = r.get("kind", lambda v: v in kinds, f"one of {kinds}")
    if kind == "expression":
        data = {"expression": r.get("expression", lambda v: isinstance(v, str) and v.strip(),
                                    "an expression of theta such as '0.08*theta**2' [N·m]"),
                "parameters": r.get("parameters", lambda v: isinstance(v, dict) and all(
                    isinstance(k, str) and k.isidentifier() and _number(x) for k, x in v.items()),
                    "a table of name = number", {})}
    elif kind == "pendulum":
        data = {"mass": r.get("mass", _positive, "a positive mass [kg]"),
                "length": r.get("length", _positive, "a positive length to the centre of mass [m]"),
                "g": r.get("g", _positive, "a positive gravity [m/s²]", 9.81),
                "phase": r.get("phase", _number, "a phase angle [rad]", 0.0)}
    elif kind == "arm":
        inline = {k: r.table[k] for k in ("masses", "lengths", "com", "g") if k in r.table}
        if inline or arm is None:
            arm = _arm(r, n_cams)
        joint = r.get("joint", lambda v: _posint(v) and v <= len(arm["masses"]),
                      f"a joint number between 1 and {len(arm['masses'])}")
        data = {"joint": joint, **arm}
    else:
        if "samples" in r.table:
            samples = r.get("samples", lambda v: _list_of(_list_of(_number, 2))(v) and len(v) >= 4
                            and all(b[0] > a[0] for a, b in zip(v, v[1:])),
                            "a list of at least 4 [theta_rad, torque_Nm] pairs, angles increasing")
        else:
            name = r.get("file", lambda v: isinstance(v, str) and v,
                         "a CSV file (relative to the spec) with header theta_rad,torque_Nm")
            try:
                samples = read_table(base / name)
            except (OSError, ValueError) as exc:
                r.fail(r.key("file"), name, f"a readable target table ({exc})")
        data = {"samples": [list(map(float, s)) for s in samples]}
    r.done()
    return Target(kind, data)


def _check_target(origin, where, target: Target, cams_ranges, cam: int):
    """Refuse a target that is malformed or not finite over the angle ranges."""
    try:
        f = target.function(len(cams_ranges), cam)
    except ExpressionError as exc:
        raise SpecError(f"{origin}: {where}.target.expression: {exc}") from None
    if target.kind == "table":
        s = np.asarray(target.data["samples"])
        lo, hi = cams_ranges[cam]
        if s[0, 0] > lo + 1e-12 or s[-1, 0] < hi - 1e-12:
            raise SpecError(f"{origin}: {where}.target: the table covers [{s[0, 0]:.4g}, "
                            f"{s[-1, 0]:.4g}] rad but the cam turns over [{lo:.4g}, {hi:.4g}] rad")
    axes = [np.linspace(lo, hi, 41 if len(cams_ranges) < 3 else 9) for lo, hi in cams_ranges]
    pts = np.array(list(product(*axes))).T
    values = np.asarray(f.map(pts.shape[1])(pts)).ravel()
    if not np.all(np.isfinite(values)):
        bad = pts[:, np.argmin(np.isfinite(values))]
        raise SpecError(f"{origin}: {where}.target is not finite at theta = "
                        f"{np.round(np.degrees(bad), 3).tolist()} deg; expected a finite torque "
                        f"[N·m] over the whole angle range")


def parse_spec(data: dict, origin: str = "<spec>", base: Path = Path(".")) -> Problem:
    """Validate a spec dictionary and build the :class:`Problem`.

    Parameters
    ----------
    data : dict
        Parsed TOML (or the ``problem`` member of a result JSON).
    origin : str
        File name used in error messages.
    base : Path
        Folder against which table files are resolved.
    """
    top = _Reader(origin, data, "")
    name = top.get("name", lambda v: isinstance(v, str) and v, "a non-empty string")
    source = top.get("source", lambda v: isinstance(v, str), "a string citing the source")
    notes = top.get("notes", lambda v: isinstance(v, str), "a string", "")
    friction = top.get("friction_model", lambda v: v in FRICTION_MODELS,
                       f"one of {FRICTION_MODELS}", "exact")
    sol = _Reader(origin, top.get("solver", lambda v: isinstance(v, dict), "a table", {}), "solver")
    options = Options(
        grid=sol.get("grid", lambda v: _posint(v) and v >= 3, "an integer ≥ 3", 46),
        quadrature_order=sol.get("quadrature_order", _posint, "a positive integer", 2),
        convexity_points=sol.get("convexity_points", lambda v: _posint(v) and v >= 2,
                                 "an integer ≥ 2", 120),
        convexity_epsilon=sol.get("convexity_epsilon", _nonneg, "a number ≥ 0", 1e-3),
        limit_margin=sol.get("limit_margin", lambda v: _nonneg(v) and v < 0.1,
                              "a fraction in [0, 0.1)", 1e-4),
        multistart=sol.get("multistart", lambda v: isinstance(v, int) and v >= 0,
                           "an integer ≥ 0", 0),
        seed=sol.get("seed", lambda v: isinstance(v, int), "an integer", 0),
        max_iter=sol.get("max_iter", _posint, "a positive integer", 500),
        tol=sol.get("tol", _positive, "a positive number", 1e-8),
        recheck_factor=sol.get("recheck_factor", lambda v: _posint(v) and v >= 2,
                               "an integer ≥ 2", 10),
    )
    sol.done()

    raw_springs = top.get("springs", lambda v: isinstance(v, list) and v,
                          "a non-empty array of [[springs]] tables")
    raw_cams = top.get("cams", lambda v: isinstance(v, list) and v,
                       "a non-empty array of [[cams]] tables")
    n_cams, n_springs = len(raw_cams), len(raw_springs)
    arm = None
    if "arm" in data:
        ra = _Reader(origin, top.get("arm", lambda v: isinstance(v, dict), "an [arm] table"), "arm")
        arm = _arm(ra, n_cams)
        ra.done()
    top.get("variants", lambda v: isinstance(v, dict), "a table of named override tables", {})
    top.done()

    springs = []
    for j, raw in enumerate(raw_springs):
        r = _Reader(origin, raw, f"springs[{j + 1}]")
        ports = []
        for p in r.get("ports", lambda v: isinstance(v, list) and v and all(
                isinstance(x, str) and _PORT.match(x) for x in v),
                f"a non-empty list of ports such as 'wire:1' or '-platform:2' (kinds {PORT_KINDS})"):
            sign, kind, cam = _PORT.match(p).groups()
            if int(cam) > n_cams:
                r.fail(r.key("ports"), p, f"a cam number between 1 and {n_cams}")
            ports.append(Port(int(cam) - 1, kind, -1.0 if sign else 1.0))
        springs.append(Spring(
            name=r.get("name", lambda v: isinstance(v, str), "a string", f"spring {j + 1}"),
            rate=float(r.get("rate", _positive, "a positive spring rate [N/m]")),
            travel=float(r.get("travel", _positive, "a positive maximum extension [m]")),
            ports=tuple(ports)))
        r.done()

    cams, targets = [], []
    for i, raw in enumerate(raw_cams):
        where = f"cams[{i + 1}]"
        r = _Reader(origin, raw, where)
        rng = r.get("theta_range_deg", _list_of(_number, 2), "[min, max] cam angles [deg]")
        if not rng[1] > rng[0]:
            r.fail(r.key("theta_range_deg"), rng, "[min, max] with max > min (a non-empty range)")
        theta_range = (math.radians(rng[0]), math.radians(rng[1]))
        basis_name = r.get("basis", lambda v: v in BASES, f"one of {BASES}", "chebyshev")
        order = r.get("order", lambda v: _posint(v) and v <= 15, "an integer 1…15", 3)
        rho_min = float(r.get("rho_min", _positive, "a positive minimum cam radius [m]"))
        rho_max = float(r.get("rho_max", _positive, "a positive maximum cam radius [m]"))
        if rho_min >= rho_max:
            r.fail(r.key("rho_max"), rho_max, f"a radius greater than rho_min = {rho_min} [m]")
        idler = _Reader(origin, r.get("idler", lambda v: isinstance(v, dict),
                                      "a table with radius and offset [m]"), f"{where}.idler")
        radius = float(idler.get("radius", _positive, "a positive idler radius [m]"))
        offset = float(idler.get("offset", _number, "the idler's vertical offset a0 [m]"))
        idler.done()
        sens = r.get("sensitivity_weights", _list_of(_nonneg, n_springs),
                     f"a list of {n_springs} weights ≥ 0, one per spring", [0.0] * n_springs)
        cams.append(dict(
            name=r.get("name", lambda v: isinstance(v, str), "a string", f"cam {i + 1}"),
            # the design interval of the basis covers every contact angle α ≤ θ_max + π/2
            basis=Basis(basis_name, order, (0.0, theta_range[1] + math.pi / 2)),
            theta_range=theta_range, rho_min=rho_min, rho_max=rho_max,
            idler_radius=radius, idler_offset=offset,
            mu=float(r.get("mu", _nonneg, "a friction coefficient ≥ 0")),
            tracking_weight=float(r.get("tracking_weight", _nonneg, "a weight ≥ 0", 1.0)),
            sensitivity_weights=tuple(float(w) for w in sens)))
        targets.append(_target(_Reader(origin, r.get("target", lambda v: isinstance(v, dict),
                                                     "a [cams.target] table"), f"{where}.target"),
                               base, n_cams, arm))
        r.done()

    ranges = [c["theta_range"] for c in cams]
    for i, t in enumerate(targets):
        _check_target(origin, f"cams[{i + 1}]", t, ranges, i)
    return Problem(name=name, source=source, notes=notes, friction_model=friction,
                   options=options, springs=tuple(springs),
                   cams=tuple(Cam(target=t, **c) for c, t in zip(cams, targets)))


def parse_value(text: str, origin: str = "--set"):
    """A TOML value written on the command line (``1.5``, ``[1, 2]``, ``"exact"``)."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        try:  # a bare word is a string
            return tomllib.loads(f'v = "{text}"')["v"]
        except tomllib.TOMLDecodeError:
            raise SpecError(f"{origin}: {text!r} is not a TOML value") from None


def _merged(old, new):
    """A table assigned onto a table updates it (a catalogue spring keeps its ports)."""
    return {**old, **new} if isinstance(old, dict) and isinstance(new, dict) else new


def apply_override(data: dict, key: str, value, origin: str = "<spec>") -> None:
    """Set dotted ``key`` (``springs.1.rate``, ``cams.*.order``) to ``value`` in ``data``.

    Array elements are numbered from 1; ``*`` means every element; a table value updates the
    table at ``key`` rather than replacing it. Every table and array on
    the path must exist in the spec; the last part may name a key the spec leaves at its
    default (the spec's own validation then checks it).
    """
    parts = key.split(".")
    if not key or not all(parts):
        raise SpecError(f"{origin}: {key!r} is not a dotted key such as 'springs.1.rate'")

    def walk(node, i, path):
        part = parts[i]
        last = i == len(parts) - 1
        if isinstance(node, list):
            if part == "*":
                targets = range(len(node))
            elif part.isdigit() and 1 <= int(part) <= len(node):
                targets = [int(part) - 1]
            else:
                raise SpecError(f"{origin}: '{key}': '{path}' has {len(node)} entries; use "
                                f"1…{len(node)} or * for '{part}'")
            for t in targets:
                if last:
                    node[t] = _merged(node[t], value)
                else:
                    walk(node[t], i + 1, f"{path}.{t + 1}")
        elif isinstance(node, dict):
            if last:
                node[part] = _merged(node.get(part), value)
            elif part in node:
                walk(node[part], i + 1, f"{path}.{part}" if path else part)
            else:
                raise SpecError(f"{origin}: '{key}': the spec has no '{part}' in "
                                f"'{path or 'the top level'}'")
        else:
            raise SpecError(f"{origin}: '{key}': '{path}' is a value, not a table or array")

    walk(data, 0, "")


def read_spec_data(path, variant: str | None = None, overrides=()) -> dict:
    """The spec at ``path`` as data, with ``variant`` and ``overrides`` applied (not yet
    validated: :func:`parse_spec` does that)."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise SpecError(f"{path}: cannot read the spec ({exc.strerror})") from None
    if path.suffix == ".json":
        try:
            data = json.loads(text)["problem"]
        except (ValueError, KeyError, TypeError):
            raise SpecError(f"{path}: expected a cadcam result JSON with a 'problem' member") from None
    else:
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise SpecError(f"{path}: not valid TOML ({exc})") from None
    if variant is not None:
        variants = data.get("variants", {})
        if variant not in variants:
            raise SpecError(f"{path}: no variant {variant!r}; the spec defines "
                            f"{sorted(variants) or 'none'}")
        for key, value in variants[variant].items():
            apply_override(data, key, value, f"{path}: variants.{variant}")
    for key, value in overrides:
        apply_override(data, key, value, str(path))
    data.pop("variants", None)
    return data


def load_spec(path, variant: str | None = None, overrides=()) -> Problem:
    """Load a TOML spec, or the resolved problem inside a cadcam ``result.json``.

    ``variant`` applies the dotted-key overrides of ``[variants.NAME]`` in the spec;
    ``overrides`` are further (key, value) pairs applied after it.

    Raises
    ------
    SpecError
        One line naming the file, the key and the expected form.
    """
    path = Path(path)
    data = read_spec_data(path, variant, overrides)
    return parse_spec(data, str(path), path.parent)
