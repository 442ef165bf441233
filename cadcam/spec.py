"""Read and validate problem specs (TOML, SI units) into a :class:`~cadcam.problem.Problem`.

Every defect is reported as one :class:`SpecError` line naming the file, the key and the form
expected. A spec is data: target expressions go through :func:`cadcam.targets.parse_expression`,
never ``eval``. A ``result.json`` written by cadcam is accepted too: its ``problem`` member is a
fully resolved spec.
"""
from __future__ import annotations

import contextlib
import contextvars
import functools
import json
import math
import os
import re
import sys
import tomllib
from dataclasses import dataclass, replace
from itertools import product
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from .mechanisms.base import (ENERGY, LINK_ANGLE, Profile, design_methods, legacy_torque_models, mechanism_class,
                              mechanism_kinds, torque_models)
from .physics.profile import BASES, Basis
from .physics.springs import Port, Spring
from .errors import SpecError
from .files import InputFileError, loads_toml, read_input, short_repr
from .problem import (ACCEPTANCE, BAND_WEIGHT, IPOPT_OPTIONS, SOLVER, TOLERANCES, WORKSHOP_LIMITS, Joint, Options, Problem, Workshop, count_error,
                      size_error)
from .targets import ExpressionError, Target, read_table, reserved_name, target_kind, target_kinds

_REQUIRED = object()
_PORT = re.compile(r"^(-?)([a-z][a-z0-9_]*):([1-9][0-9]*)$")


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _positive(v) -> bool:
    return _number(v) and v > 0


def _nonneg(v) -> bool:
    return _number(v) and v >= 0


def _posint(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and v >= 1


def _list_of(ok, n=None):
    return lambda v: isinstance(v, list) and (n is None or len(v) == n) and all(ok(x) for x in v)


@dataclass(frozen=True)
class KeyRead:
    """One key a spec's reader read, with the form it expects: what a form for the spec shows
    (:func:`read_keys`).

    Attributes
    ----------
    key : str
        The dotted key as ``--set`` takes it (``springs.1.rate``, ``cams.1.idler.radius``).
    form : str
        The form expected, as the error message words it, its unit in brackets where it has one
        (``a positive spring rate [N/m]``).
    value : object
        The spec's value, or the default where the spec leaves the key out.
    given : bool
        Whether the spec gives the key.
    """

    key: str
    form: str
    value: Any
    given: bool


#: While a list, every key a :class:`_Reader` reads is appended to it (:func:`read_keys`).
_READS: contextvars.ContextVar[list[KeyRead] | None] = contextvars.ContextVar("spec_reads", default=None)


def _dotted(key: str) -> str:
    """A reader's key (``springs[1].rate``) as a dotted override key (``springs.1.rate``)."""
    return re.sub(r"\[(\d+)\]", r".\1", key)


def read_keys(data: dict, origin: str = "<spec>", base: Path = Path(".")) -> tuple[Problem, list[KeyRead]]:
    """:func:`parse_spec` of ``data``, and every key it read, in reading order, with the form
    each expects (the declarations a form for the spec is generated from).

    Raises
    ------
    SpecError
        As :func:`parse_spec`.
    """
    token = _READS.set([])
    try:
        problem = parse_spec(data, origin, base)
        reads = _READS.get() or []
    finally:
        _READS.reset(token)
    return problem, reads


class _Reader:
    """Reads one table of a spec, remembering which keys it took, to refuse unknown ones."""

    def __init__(self, origin: str, table, where: str):
        self.origin, self.where = origin, where
        if not isinstance(table, dict):
            self.fail(where or "spec", table, "a table")
        self.table, self.seen = table, set[str]()

    def fail(self, key, value, form):
        raise SpecError(f"{self.origin}: {key} = {short_repr(value)}: expected {form}")

    def key(self, name: str) -> str:
        return f"{self.where}.{name}" if self.where else name

    def get(self, name, ok, form, default=_REQUIRED):
        self.seen.add(name)
        reads = _READS.get()
        if reads is not None:
            reads.append(KeyRead(_dotted(self.key(name)), form, self.table.get(name, default),
                                 name in self.table))
        if name not in self.table:
            if default is _REQUIRED:
                raise SpecError(f"{self.origin}: missing key '{self.key(name)}': expected {form}")
            return default
        value = self.table[name]
        if not ok(value):
            self.fail(self.key(name), value, form)
        return value

    def table_reader(self, name: str, form: str) -> "_Reader":
        """A reader of the sub-table ``name`` (required)."""
        return _Reader(self.origin, self.get(name, lambda v: isinstance(v, dict), form),
                       self.key(name))

    number = staticmethod(_number)
    positive = staticmethod(_positive)
    nonneg = staticmethod(_nonneg)
    list_of = staticmethod(_list_of)

    def done(self):
        extra = sorted(set(self.table) - self.seen)
        if extra:
            raise SpecError(f"{self.origin}: unknown key '{self.key(extra[0])}'; allowed keys "
                            f"here: {', '.join(sorted(self.seen))}")


def _arm(r: _Reader, n_joints: int) -> dict:
    """An arm table: masses, lengths, com (one per joint) and g."""
    n = r.get("masses", lambda v: isinstance(v, list) and 1 <= len(v) <= n_joints and all(
        _positive(x) for x in v), f"a list of 1…{n_joints} positive link masses [kg]")
    arm = {"masses": [float(v) for v in n],
           "lengths": [float(v) for v in r.get("lengths", _list_of(_nonneg, len(n)),
                                               f"a list of {len(n)} link lengths ≥ 0 [m]")],
           "com": [float(v) for v in r.get("com", _list_of(_number, len(n)),
                                           f"a list of {len(n)} centre-of-mass distances [m]")],
           "g": float(r.get("g", _positive, "a positive gravity [m/s²]", 9.81))}
    return arm


def _five_bar(r: _Reader, n_joints: int) -> dict:
    """A ``five_bar`` target (Endo2010 Sec. III): joint, six masses, upper, crank, fore, com, g."""
    if n_joints != 2:
        r.fail(r.key("kind"), "five_bar", f"a five_bar target only in a problem of 2 joints "
               f"(theta1 = link 1, theta2 = crank); this one has {n_joints}")
    return {"joint": r.get("joint", lambda v: _posint(v) and v <= 2,
                           "1 (link 1, theta1) or 2 (crank, theta2)"),
            "masses": [float(v) for v in r.get("masses", _list_of(_positive, 6),
                                               "a list of 6 positive point masses m1…m6 [kg]")],
            "upper": float(r.get("upper", _positive, "a positive upper-arm length l_u [m]")),
            "crank": float(r.get("crank", _positive, "a positive crank length l_c [m]")),
            "fore": float(r.get("fore", _nonneg, "a forearm length l_a ≥ 0, elbow to tip [m]")),
            "com": [float(v) for v in r.get("com", _list_of(_nonneg, 4),
                                            "a list [l1, l2, l3, l5] of 4 distances ≥ 0 [m]")],
            "g": float(r.get("g", _positive, "a positive gravity [m/s²]", 9.81))}


#: Largest span of a joint's angle range [deg]: cables may wrap helical grooves, but not without end.
MAX_JOINT_SPAN_DEG = 3600.0


def _acceptance(r: _Reader) -> tuple:
    """A joint's optional [joints.acceptance]: limits on its metrics of the fine re-check
    (:data:`cadcam.problem.ACCEPTANCE`)."""
    table = r.get("acceptance", lambda v: isinstance(v, dict) and v, "a table of "
                  + " and/or ".join(ACCEPTANCE), {})
    a = _Reader(r.origin, table, r.key("acceptance"))
    given = {k: a.get(k, _positive, f"a positive limit on {ACCEPTANCE[k].description} [{ACCEPTANCE[k].unit}]", None)
             for k in ACCEPTANCE}
    a.done()
    return tuple((k, float(v)) for k, v in given.items() if v is not None)


def _target(r: _Reader, base: Path, n_joints: int, arm: dict | None, output: bool = False,
            theta_range=None) -> Target:
    """A joint's torque law, or (``output``) a mechanism's output law x(θ) [m] over its
    joint's ``theta_range`` [rad]."""
    kinds = target_kinds(output)
    unit, column = ("m", "x_m") if output else ("N·m", "torque_Nm")
    kind = r.get("kind", lambda v: v in kinds, f"one of {kinds}")
    read = target_kind(kind).read
    if read is not None:  # a kind a mechanism brings reads its own keys
        data = read(r, theta_range)
    elif kind == "expression":
        example = "'0.15 + 0.01*cos(theta)'" if output else "'0.08*theta**2'"
        data = {"expression": r.get("expression", lambda v: isinstance(v, str) and v.strip(),
                                    f"an expression of theta such as {example} [{unit}]"),
                "parameters": r.get("parameters", lambda v: isinstance(v, dict) and all(
                    isinstance(k, str) and k.isidentifier() and not reserved_name(k) and _number(x)
                    for k, x in v.items()),
                    "a table of name = number, the names other than functions, pi, e and "
                    "theta, theta1, theta2…", {})}
    elif kind == "pendulum":
        data = {"mass": r.get("mass", _positive, "a positive mass [kg]"),
                "length": r.get("length", _positive, "a positive length to the centre of mass [m]"),
                "g": r.get("g", _positive, "a positive gravity [m/s²]", 9.81),
                "phase": r.get("phase", _number, "a phase angle [rad]", 0.0)}
    elif kind == "arm":
        inline = {k: r.table[k] for k in ("masses", "lengths", "com", "g") if k in r.table}
        if inline or arm is None:
            arm = _arm(r, n_joints)
        joint = r.get("joint", lambda v: _posint(v) and v <= len(arm["masses"]),
                      f"a joint number between 1 and {len(arm['masses'])}")
        data = {"joint": joint, **arm}
    elif kind == "five_bar":
        data = _five_bar(r, n_joints)
    elif kind == "none":
        data = {}
    else:
        if "samples" in r.table:
            samples = r.get("samples", lambda v: _list_of(_list_of(_number, 2))(v) and len(v) >= 4
                            and all(b[0] > a[0] for a, b in zip(v, v[1:])),
                            f"a list of at least 4 [theta_rad, {column}] pairs, angles increasing")
        else:
            name = r.get("file", lambda v: isinstance(v, str) and v,
                         f"a CSV file (relative to the spec) with header theta_rad,{column}")
            try:
                samples = read_table(base / name, column)
            except (OSError, ValueError) as exc:
                r.fail(r.key("file"), name, f"a readable target table ({exc})")
        data = {"samples": [list(map(float, s)) for s in samples]}
    r.done()
    return Target(kind, data)


#: Samples per angle at which a target expression's poles, domains and jumps are checked, by
#: number of joints (a tensor grid: 3 and more joints share the last entry).
GUARD_SAMPLES = {1: 4001, 2: 201, 3: 41}


def _check_target(origin, where, target: Target, joint_ranges, joint: int, unit: str = "torque [N·m]"):
    """Refuse a target that is malformed or not finite over the angle ranges."""
    try:
        f = target.function(len(joint_ranges), joint)
    except ExpressionError as exc:
        raise SpecError(f"{origin}: {where}.expression: {exc}") from None
    if target.kind == "table":
        s = np.asarray(target.data["samples"])
        lo, hi = joint_ranges[joint]
        if s[0, 0] > lo + 1e-12 or s[-1, 0] < hi - 1e-12:
            raise SpecError(f"{origin}: {where}: the table covers [{s[0, 0]:.4g}, "
                            f"{s[-1, 0]:.4g}] rad but the joint turns over [{lo:.4g}, {hi:.4g}] rad")
    fine = GUARD_SAMPLES.get(len(joint_ranges), GUARD_SAMPLES[3])
    failure = target.guard_failure([np.linspace(lo, hi, fine) for lo, hi in joint_ranges], joint)
    if failure:
        raise SpecError(f"{origin}: {where}.expression: {failure}; expected a {unit} that is finite "
                        "and continuous over the whole angle range (change the expression or the range)")
    axes = [np.linspace(lo, hi, 41 if len(joint_ranges) < 3 else 9) for lo, hi in joint_ranges]
    pts = np.array(list(product(*axes))).T
    values = np.asarray(f.map(pts.shape[1])(pts)).ravel()
    if not np.all(np.isfinite(values)):
        bad = pts[:, np.argmin(np.isfinite(values))]
        raise SpecError(f"{origin}: {where} is not finite at theta = "
                        f"{np.round(np.degrees(bad), 3).tolist()} deg; expected a finite {unit} "
                        f"over the whole angle range")
    pole = _pole(f, joint_ranges)
    if pole is not None:
        raise SpecError(f"{origin}: {where} has a pole or a jump near theta = {np.round(np.degrees(pole), 3).tolist()} "
                        f"deg (its slope grows without bound as the samples get finer); expected a {unit} that is "
                        "finite and continuous over the whole angle range (change the expression or the range)")


#: Samples along each joint's range at which a target's slope is taken for :func:`_pole`, and by
#: how much the largest slope between neighbours may grow when the samples double: it
#: converges for a smooth law, doubles across a jump and grows faster near a pole.
POLE_SAMPLES = 2001
POLE_GROWTH = 1.8


def _pole(f, joint_ranges) -> np.ndarray | None:
    """The angles [rad] near which the target ``f`` has a pole or a jump along one joint's
    range (the others at their mid-range), judged by its evaluated values, not its form; else
    None."""
    middle = np.array([(lo + hi) / 2 for lo, hi in joint_ranges])
    for axis, (lo, hi) in enumerate(joint_ranges):
        steepest = []
        for n in (POLE_SAMPLES, 2 * POLE_SAMPLES - 1):
            pts = np.tile(middle[:, None], (1, n))
            pts[axis] = np.linspace(lo, hi, n)
            with np.errstate(all="ignore"):
                slope = np.abs(np.diff(np.asarray(f.map(n)(pts)).ravel())) / np.diff(pts[axis])
            k = int(np.argmax(slope))
            steepest.append((slope[k], pts[:, k]))
        (coarse, _), (fine, where) = steepest
        if fine > POLE_GROWTH * coarse and fine > 0:
            return where
    return None


#: IPOPT options cadcam sets from [solver], under its caps.
IPOPT_FROM_SOLVER = {"max_iter": "solver.max_iter", "tol": "solver.tol"}


def _ipopt_options(sol: "_Reader", options: dict) -> tuple:
    """[solver.ipopt] as sorted (name, value) pairs: each an option of
    :data:`cadcam.problem.IPOPT_OPTIONS` with a value it allows, then tried on IPOPT itself, so
    that anything else is one line now, not a failure (or a library loaded) after the build."""
    key = sol.key("ipopt")
    for name, value in sorted(options.items()):
        if name in IPOPT_FROM_SOLVER:
            sol.fail(f"{key}.{name}", value, f"nothing: give {IPOPT_FROM_SOLVER[name]} instead (it has a cap)")
        if name not in IPOPT_OPTIONS:
            sol.fail(f"{key}.{name}", value, "one of the IPOPT options cadcam passes on ("
                     + ", ".join(IPOPT_OPTIONS) + "); options that name files or libraries never are")
        if not IPOPT_OPTIONS[name].ok(value):
            sol.fail(f"{key}.{name}", value, IPOPT_OPTIONS[name].form)
        reason = _ipopt_refusal(name, value)
        if reason:
            sol.fail(f"{key}.{name}", value, f"an IPOPT option with a valid value ({reason}; see the "
                     "IPOPT documentation of options)")
    return tuple(sorted(options.items()))


@functools.lru_cache(maxsize=256)
def _ipopt_refusal(name: str, value) -> str | None:
    """Why IPOPT refuses option ``name`` = ``value``, or None: asked once per pair (a study
    parses its spec for every case). A linear solver is tried on a small problem: one that is
    not installed fails only when it solves."""
    x = ca.SX.sym("x")
    try:
        with _quiet_stdout():  # IPOPT prints its option documentation for a bad value
            probe = ca.nlpsol("probe", "ipopt", {"x": x, "f": (x - 1) ** 2},
                              {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
                               f"ipopt.{name}": value, "error_on_fail": False})
            if name == "linear_solver":
                probe(x0=0)
    except RuntimeError as exc:
        lines = str(exc).strip().splitlines()
        return "no such IPOPT option" if "No such IPOPT option" in str(exc) else (
            "a value of another type" if "type mismatch" in lines[-1] else "a value IPOPT refuses")
    if name == "linear_solver" and probe.stats()["return_status"] != "Solve_Succeeded":
        return "a linear solver that is not installed here"
    return None


@contextlib.contextmanager
def _quiet_stdout():
    """Standard output (file descriptor 1, where C libraries print) sent to /dev/null."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def _torque_model(top: "_Reader", data: dict) -> str:
    """``torque_model`` (default ``energy``), or a legacy ``friction_model`` of cadcam ≤ 0.1
    (``exact`` was the force model with the corrected capstan: now ``force``)."""
    if "torque_model" in data and "friction_model" in data:
        top.fail("friction_model", data["friction_model"],
                 "nothing: it is the old name of torque_model; give only torque_model")
    if "friction_model" in data:
        legacy = top.get("friction_model", lambda v: v in legacy_torque_models(),
                         f"one of {tuple(legacy_torque_models())} (old name of torque_model)")
        return legacy_torque_models()[legacy]
    return top.get("torque_model", lambda v: v in torque_models(), f"one of {torque_models()}",
                   ENERGY)


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
    table = _shorthand_table(data)
    if table:  # errors in a shorthand name the user's own tables, not the general form
        _check_shorthand(origin, data, table)
        data = _from_shorthand(data, table)
    joint_label, mech_label = (table, table) if table else ("joints", "mechanisms")
    top = _Reader(origin, data, "")
    default_name = Path(origin).stem if origin.endswith(".toml") else "design"
    name = top.get("name", lambda v: isinstance(v, str) and v, "a non-empty string", default_name)
    source = top.get("source", lambda v: isinstance(v, str), "a string citing the source", "")
    notes = top.get("notes", lambda v: isinstance(v, str), "a string", "")
    torque_model = _torque_model(top, data)
    options = _options(_Reader(origin, top.get("solver", lambda v: isinstance(v, dict), "a table", {}),
                               "solver"))
    n_joints = len(data["joints"]) if isinstance(data.get("joints"), list) else 0
    for what, key, count in (("joints", joint_label, n_joints),
                             ("springs", "springs", len(data["springs"]) if isinstance(data.get("springs"), list) else 0)):
        too_many = count_error(what, count)
        if too_many:
            raise SpecError(f"{origin}: {key}: {too_many}")
    too_big = size_error(options, max(n_joints, 1))
    if too_big:
        raise SpecError(f"{origin}: solver.{too_big[0]}: {too_big[1]}")
    arm = _top_arm(top, data, n_joints)
    raw_joints = top.get("joints", lambda v: isinstance(v, list) and v,
                         "a non-empty array of [[joints]] tables (or of [[cams]], the wire cams' shorthand)")
    raw_mechs = top.get("mechanisms", lambda v: isinstance(v, list) and v,
                        "a non-empty array of [[mechanisms]] tables")
    raw_springs = top.get("springs", lambda v: isinstance(v, list), "an array of [[springs]] tables", [])
    top.get("variants", lambda v: isinstance(v, dict), "a table of named override tables", {})
    workshop = _workshop(_Reader(origin, top.get("workshop", lambda v: isinstance(v, dict),
                                                 "a [workshop] table of lengths [m]", {}), "workshop"))
    tolerances = _tolerances(_Reader(origin, top.get("tolerances", lambda v: isinstance(v, dict),
                                                     "a [tolerances] table", {}), "tolerances"))
    top.done()

    read = [_joint(_Reader(origin, raw, f"{joint_label}[{i + 1}]"), i, len(raw_springs), n_joints, arm,
                   base, joint_label) for i, raw in enumerate(raw_joints)]
    joints, targets = [joint for joint, _ in read], [target for _, target in read]
    mechanisms = _mechanisms(origin, raw_mechs, joints, base, mech_label)
    for i in range(len(joints)):
        too_many = count_error("mechanisms_per_joint", sum(m.joint == i for m in mechanisms))
        if too_many:
            raise SpecError(f"{origin}: {mech_label}: the mechanisms on {joint_label}[{i + 1}]: {too_many}")
    _check_spans(origin, joints, mechanisms, joint_label)
    springs = [_spring(_Reader(origin, raw, f"springs[{j + 1}]"), j, mechanisms)
               for j, raw in enumerate(raw_springs)]
    _check_output_laws(origin, mechanisms)
    _check_method(origin, options.method, mechanisms)
    if not springs and any(c["tracking_weight"] > 0 for c in joints):
        raise SpecError(f"{origin}: missing key 'springs': a torque target needs [[springs]] "
                        "tables (or kind = \"none\" on every joint's target, for output laws only)")
    ranges = [c["theta_range"] for c in joints]
    for i, t in enumerate(targets):
        _check_target(origin, f"{joint_label}[{i + 1}].target", t, ranges, i)
    try:
        return Problem(name=name, source=source, notes=notes, torque_model=torque_model,
                       options=options, workshop=workshop, tolerances=tolerances, springs=tuple(springs),
                       mechanisms=tuple(mechanisms),
                       joints=tuple(Joint(target=t, **c) for c, t in zip(joints, targets)))
    except ValueError as exc:
        raise SpecError(f"{origin}: torque_model: {exc}") from None


def _options(sol: _Reader) -> Options:
    """The ``[solver]`` table as :class:`Options`, each key read as :data:`SOLVER` declares it
    (its default where it is missing)."""
    values: dict[str, Any] = {}
    for name, setting in SOLVER.items():
        if name == "ipopt":
            values[name] = _ipopt_options(sol, sol.get("ipopt", lambda v: isinstance(v, dict) and all(
                re.fullmatch(r"[a-z][a-z0-9_]*", k) and (_number(x) or isinstance(x, str))
                for k, x in v.items()), "a table of IPOPT options such as mu_init = 1e-6 (names as "
                "in the IPOPT documentation, numbers or strings)", {}))
        elif name == "method":
            values[name] = sol.get("method", lambda v: v in _methods(), f"one of {_methods()}", setting.default)
        else:
            values[name] = sol.get(name, setting.ok, setting.form, setting.default)
    sol.done()
    return Options(**values)


def _top_arm(top: _Reader, data: dict, n_joints: int) -> dict | None:
    """The spec's shared ``[arm]`` table (what an ``arm`` target uses unless it gives its own),
    or None."""
    if "arm" not in data:
        return None
    ra = _Reader(top.origin, top.get("arm", lambda v: isinstance(v, dict), "an [arm] table"), "arm")
    arm = _arm(ra, max(n_joints, 1))
    ra.done()
    return arm


def _theta_range(r: _Reader) -> tuple[float, float]:
    """A joint's ``theta_range_deg`` as (min, max) [rad]: a non-empty range at most
    :data:`MAX_JOINT_SPAN_DEG` wide, within ±:data:`MAX_JOINT_SPAN_DEG` of the reference pose."""
    rng = r.get("theta_range_deg", _list_of(_number, 2), "[min, max] joint angles [deg]")
    if not 0 < rng[1] - rng[0] <= MAX_JOINT_SPAN_DEG:
        r.fail(r.key("theta_range_deg"), rng, f"[min, max], a non-empty range with max − min ≤ "
               f"{MAX_JOINT_SPAN_DEG:g}° (ten turns of a helical groove)")
    if not max(abs(rng[0]), abs(rng[1])) <= MAX_JOINT_SPAN_DEG:
        r.fail(r.key("theta_range_deg"), rng, f"[min, max] joint angles within ±{MAX_JOINT_SPAN_DEG:g}° "
               "(ten turns either way from the reference pose)")
    return math.radians(rng[0]), math.radians(rng[1])


def _joint(r: _Reader, i: int, n_springs: int, n_joints: int, arm: dict | None, base: Path,
           label: str) -> tuple[dict, Target]:
    """One [[joints]] table: the keyword arguments of its :class:`Joint` but the target, and its
    target (a joint without a torque goal weighs no tracking error)."""
    theta_range = _theta_range(r)
    sens = r.get("sensitivity_weights", _list_of(_nonneg, n_springs),
                 f"a list of {n_springs} weights ≥ 0, one per spring", [0.0] * n_springs)
    joint = dict(
        name=r.get("name", lambda v: isinstance(v, str), "a string", f"joint {i + 1}"),
        theta_range=theta_range,
        tracking_weight=float(r.get("tracking_weight", _nonneg, "a weight ≥ 0", 1.0)),
        sensitivity_weights=tuple(float(w) for w in sens),
        acceptance=_acceptance(r),
        band_weight=float(r.get(BAND_WEIGHT.name, _nonneg, f"a weight ≥ 0 [{BAND_WEIGHT.unit}]", 0.0)))
    target = _target(_Reader(r.origin, r.get("target", lambda v: isinstance(v, dict),
                                             f"a [{label}.target] table"), r.key("target")),
                     base, n_joints, arm)
    if target.kind == "none":  # no torque goal: nothing to weigh, nothing to accept
        joint["tracking_weight"] = 0.0
        if joint["acceptance"]:
            r.fail(r.key("acceptance"), r.table["acceptance"], 'nothing: a joint whose target is kind = "none" '
                   "has no torque to accept; remove the table or give the joint a torque target")
    r.done()
    return joint, target


def _mechanisms(origin, raw_mechs: list, joints: list[dict], base: Path, label: str) -> list:
    """The [[mechanisms]] tables, refusing a joint that no mechanism turns with."""
    mechanisms = [_mechanism(_Reader(origin, raw, f"{label}[{u + 1}]"), u, joints, base)
                  for u, raw in enumerate(raw_mechs)]
    on_joint = {m.joint for m in mechanisms}
    for i in range(len(joints)):
        if i not in on_joint:
            raise SpecError(f"{origin}: joints[{i + 1}] has no mechanism; expected a "
                            f"[[mechanisms]] table with joint = {i + 1}")
    return mechanisms


def _check_spans(origin, joints: list[dict], mechanisms, label: str) -> None:
    """Refuse a joint range wider than a mechanism on it allows (:meth:`Mechanism.max_span`):
    a planar profile holds one turn."""
    for m in mechanisms:
        lo, hi = joints[m.joint]["theta_range"]
        if hi - lo > m.max_span() * (1 + 1e-12):
            raise SpecError(f"{origin}: {label}[{m.joint + 1}].theta_range_deg = [{math.degrees(lo):g}, "
                            f"{math.degrees(hi):g}]: expected a span of at most {math.degrees(m.max_span()):g}°: "
                            f"mechanism {m.name!r} ({m.kind}) runs on a planar profile, which holds one turn")


def _check_output_laws(origin, mechanisms) -> None:
    """Refuse output laws that contradict each other (:attr:`TargetKind.check`): the cables of
    one cable robot follow one path."""
    laws: dict[str, list] = {}
    for m in mechanisms:
        if m.output_target is not None:
            laws.setdefault(m.output_target.kind, []).append(m.output_target.data)
    for kind, datas in laws.items():
        check = target_kind(kind).check
        problem = check(datas) if check is not None else None
        if problem:
            raise SpecError(f"{origin}: mechanisms' output_target.{problem}")


def _methods() -> tuple[str, ...]:
    """Design methods: cadcam's NLP, and those the registered mechanisms bring."""
    return ("nlp", *design_methods())


def _check_method(origin, method: str, mechanisms) -> None:
    """Refuse a mechanism's own design method where not every mechanism offers it."""
    if method != "nlp" and not all(m.offers(method) for m in mechanisms):
        m = design_methods()[method]
        raise SpecError(f"{origin}: solver.method: {method!r} designs {m.scope}: give every mechanism "
                        f"{m.requirement}, or use method = \"nlp\"")


def _tolerances(r: _Reader) -> tuple:
    """The ``[tolerances]`` table: ± how far a built part may be from its design, each key as
    :data:`cadcam.problem.TOLERANCES` declares it (its default where it is missing)."""
    out = tuple((name, float(r.get(name, _nonneg, f"a number ≥ 0 [{t.unit}]: {t.description}")))
                for name, t in TOLERANCES.items() if name in r.table)
    r.done()
    return out


def _workshop(r: _Reader) -> Workshop:
    """The ``[workshop]`` table: sizes of the workshop files [m], each checked by
    :class:`cadcam.problem.Workshop` against :data:`cadcam.problem.WORKSHOP_LIMITS`; its
    defaults where a key is missing."""
    sizes = {}
    for name, (lo, hi) in WORKSHOP_LIMITS.items():
        value = r.get(name, _number, f"a length from {lo:g} to {hi:g} m", None)
        if value is not None:
            sizes[name] = float(value)
    r.done()
    try:
        return Workshop(**sizes)
    except ValueError as exc:  # a size beyond its limits, named as Workshop names it
        raise SpecError(f"{r.origin}: {r.key(str(exc))}") from None


#: Highest polynomial degree per basis: monomials are ill-conditioned beyond 15; Chebyshev
#: polynomials stay well-conditioned, and a multi-turn spiral needs the degree.
MAX_ORDER = {"monomial": 15, "chebyshev": 40}


def _mechanism(r: "_Reader", u: int, joints: list[dict], base: Path = Path(".")):
    """One [[mechanisms]] table: kind, name, joint, its profiles (one basis and one set of
    limits for all), its output law if it has an output, and the mechanism's own keys."""
    kinds = mechanism_kinds()
    cls = mechanism_class(r.get("kind", lambda v: v in kinds, f"one of {kinds}"))
    name = r.get("name", lambda v: isinstance(v, str), "a string", f"mechanism {u + 1}")
    joint = r.get("joint", lambda v: _posint(v) and v <= len(joints),
                  f"a joint number between 1 and {len(joints)}") - 1
    basis_name = r.get("basis", lambda v: v in BASES, f"one of {BASES}", "chebyshev")
    cap = MAX_ORDER[basis_name]
    order = r.get("order", lambda v: _posint(v) and v <= cap, f"an integer 1…{cap} (the cap of "
                  f"the {basis_name} basis; {MAX_ORDER})", 3)
    rho_min = float(r.get("rho_min", _positive, "a positive minimum profile radius [m]"))
    rho_max = float(r.get("rho_max", _positive, "a positive maximum profile radius [m]"))
    if rho_min >= rho_max:
        r.fail(r.key("rho_max"), rho_max, f"a radius greater than rho_min = {rho_min} [m]")
    curvature = float(r.get("min_curvature_radius", _nonneg,
                            "a minimum radius of curvature ≥ 0 of the profile [m]", 0.0))
    theta_range = joints[joint]["theta_range"]
    domain = cls.profile_domain(theta_range)
    if not domain[1] > domain[0]:
        raise SpecError(f"{r.origin}: {r.where}: its joint's theta_range_deg = [{math.degrees(theta_range[0]):g}, "
                        f"{math.degrees(theta_range[1]):g}] leaves its profiles an empty design interval "
                        f"[{domain[0]:.4g}, {domain[1]:.4g}] rad; expected a range over which a {cls.kind} wraps "
                        "its cable")
    names = [name] if cls.n_profiles == 1 else [f"{name} {k + 1}" for k in range(cls.n_profiles)]
    profiles = tuple(Profile(n, Basis(basis_name, order, domain), rho_min, rho_max, curvature)
                     for n in names)
    mech = cls.from_spec(r, name=name, joint=joint, profiles=profiles, theta_range=theta_range)
    link = r.get(LINK_ANGLE.name, _number, f"{LINK_ANGLE.description} [{LINK_ANGLE.unit}]", None)
    if link is not None:
        mech = replace(mech, link_angle=float(link))
    if cls.output and "output_target" in r.table:
        where = r.key("output_target")
        target = _target(_Reader(r.origin, r.get("output_target", lambda v: isinstance(v, dict),
                                                 "a table"), where), base, 1, None, output=True,
                         theta_range=theta_range)
        _check_target(r.origin, where, target, [theta_range], 0, f"{cls.output} [m]")
        mech = replace(mech, output_target=target)
    r.done()
    return mech


def _spring(r: "_Reader", j: int, mechanisms) -> Spring:
    """One [[springs]] table; ports name a mechanism's ports as 'port:mechanism'."""
    ports = []
    raw = r.get("ports", lambda v: isinstance(v, list) and v and all(
        isinstance(x, str) and _PORT.match(x) for x in v),
        "a non-empty list of ports such as 'wire:1' or '-platform:2' (port:mechanism number)")
    for p in raw:
        match = _PORT.match(p)
        assert match is not None  # checked by r.get above
        sign, port, number = match.groups()
        u = int(number) - 1
        if u >= len(mechanisms):
            r.fail(r.key("ports"), p, f"a mechanism number between 1 and {len(mechanisms)}")
        if port not in mechanisms[u].ports:
            r.fail(r.key("ports"), p, f"a port of mechanism {u + 1} ({mechanisms[u].kind}): "
                                      f"{', '.join(mechanisms[u].ports)}")
        ports.append(Port(u, port, -1.0 if sign else 1.0))
    travel = float(r.get("travel", _positive, "a positive maximum extension [m]"))
    pre = r.get("preextension", lambda v: _nonneg(v) and v <= travel,
                f"a fixed pre-extension in [0, travel = {travel}] [m]", None)
    spring = Spring(
        name=r.get("name", lambda v: isinstance(v, str), "a string", f"spring {j + 1}"),
        rate=float(r.get("rate", _positive, "a positive spring rate [N/m]")),
        travel=travel, ports=tuple(ports),
        preload=float(r.get("preload", _nonneg, "an initial tension F0 ≥ 0 [N]", 0.0)),
        free_length=_optional_float(r.get("free_length", _positive,
                                          "a positive free (unloaded) length [m]", None)),
        preextension=_optional_float(pre))
    r.done()
    return spring


def _optional_float(v):
    return None if v is None else float(v)


def _shorthand_table(data) -> str:
    """The mechanism shorthand (:attr:`Mechanism.shorthand`: ``[[cams]]`` for the wire joint,
    cadcam ≤ 0.1) a spec is written in, or ""."""
    if not isinstance(data, dict):
        return ""
    tables = [mechanism_class(kind).shorthand for kind in mechanism_kinds()]
    return next((t for t in tables if t and t in data), "")


def _check_shorthand(origin, data: dict, table: str) -> None:
    """Refuse a shorthand beside the general form, or one that is not a list of tables."""
    for general in ("joints", "mechanisms"):
        if general in data:
            raise SpecError(f"{origin}: unknown key '{general}' beside '{table}'; expected either [[{table}]] "
                            "tables or [[joints]] and [[mechanisms]] tables")
    if not isinstance(data[table], list) or not data[table]:
        raise SpecError(f"{origin}: {table} = {data[table]!r}: expected a non-empty array of [[{table}]] tables")
    for i, entry in enumerate(data[table]):
        if not isinstance(entry, dict):
            raise SpecError(f"{origin}: {table}[{i + 1}] = {entry!r}: expected a [[{table}]] table")


def _from_shorthand(data: dict, table: str) -> dict:
    """``data`` in the general form: each entry of its shorthand list ``table`` becomes joint i
    and mechanism i of the kind whose shorthand it is, so its ports and every number keep their
    meaning."""
    kind = next(k for k in mechanism_kinds() if mechanism_class(k).shorthand == table)
    out = {k: v for k, v in data.items() if k != table}
    joint_keys = ("name", "theta_range_deg", "tracking_weight", "sensitivity_weights", "target",
                  "acceptance", BAND_WEIGHT.name)
    out["joints"], out["mechanisms"] = [], []
    for i, entry in enumerate(data[table]):
        out["joints"].append({k: entry[k] for k in joint_keys if k in entry})
        out["mechanisms"].append({"kind": kind, "joint": i + 1,
                                  **{k: v for k, v in entry.items() if k not in joint_keys[1:]}})
    return out


def parse_value(text: str, origin: str = "--set"):
    """A TOML value written on the command line (``1.5``, ``[1, 2]``, ``"exact"``)."""
    try:
        return loads_toml(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        try:  # a bare word is a string
            return loads_toml(f'v = "{text}"')["v"]
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
                targets = list(range(len(node)))
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
    try:  # a byte order mark (some editors write one) is not part of the spec
        text = read_input(path).removeprefix("\ufeff")
    except InputFileError as exc:
        raise SpecError(f"{path}: the spec: {exc}") from None
    if path.suffix == ".json":
        try:
            data = json.loads(text)["problem"]
        except (ValueError, KeyError, TypeError, RecursionError):
            raise SpecError(f"{path}: expected a cadcam result JSON with a 'problem' member") from None
        if not isinstance(data, dict):
            raise SpecError(f"{path}: the result's 'problem' must be a JSON object (a spec), "
                            f"not {type(data).__name__}")
    else:
        try:
            data = loads_toml(text)
        except tomllib.TOMLDecodeError as exc:
            raise SpecError(f"{path}: not valid TOML ({exc})") from None
    return with_overrides(data, str(path), variant, overrides)


def with_overrides(data: dict, origin: str, variant: str | None = None, overrides=()) -> dict:
    """Spec ``data`` with the dotted-key overrides of its ``[variants.NAME]`` table ``variant``
    and then ``overrides`` ((key, value) pairs) applied in place, without its variants."""
    if not isinstance(data, dict):
        raise SpecError(f"{origin}: a spec must be a table (a dict), not {type(data).__name__}")
    if variant is not None:
        variants = data.get("variants", {})
        if not isinstance(variants, dict) or not isinstance(variants.get(variant, {}), dict):
            raise SpecError(f"{origin}: variants.{variant}: expected a table of overrides")
        if variant not in variants:
            raise SpecError(f"{origin}: no variant {variant!r}; the spec defines "
                            f"{sorted(variants) or 'none'}")
        for key, value in variants[variant].items():
            apply_override(data, key, value, f"{origin}: variants.{variant}")
    for key, value in overrides:
        apply_override(data, key, value, origin)
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
