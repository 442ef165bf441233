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
import pickle
import re
import sys
import tomllib
from collections import OrderedDict
from dataclasses import dataclass, replace
from itertools import product
from pathlib import Path
from typing import Any, NoReturn

import casadi as ca
import numpy as np

from .errors import SpecError
from .files import InputFileError, loads_toml, read_input, short_repr
from .keys import REQUIRED, Key, KeyTable, is_real
from .library_files import ipopt_options
from .mechanisms.base import (ENERGY, LINK_ANGLE, MAX_ORDER, MECHANISM_KEYS, Profile, design_methods,
                              legacy_torque_models, mechanism_class, mechanism_kinds, torque_models)
from .physics.profile import Basis
from .physics.cables import CABLE_KEYS, FILLED_BY_NAME, Cable, shipped_cables
from .physics.catalogue import Catalogue, load_catalogue
from .physics.friction import BEARING_KEYS, FRICTION_KEYS, GUIDE_KEYS, IDLER_KEYS, Friction, Guide, Idler, JointBearing
from .physics.springs import SPRING_KEYS, Port, Spring, SpringBody
from .problem import (ADJUSTMENT_KEYS, BAND_WEIGHT, BUILD_KEYS, IPOPT_OPTIONS, JOINT_KEYS, SOLVER, SOLVER_KEYS,
                      WORKSHOP_KEYS, Joint, Options, Problem, Workshop, acceptance_keys, count_error, size_error,
                      tolerance_keys)
from .targets import (ANGLE_UNITS, ARM_JOINT, ARM_KEYS, EXPRESSION_KEYS, FIVE_BAR_KEYS, KIND, PENDULUM_KEYS,
                      TABLE_KEYS, ExpressionError, Target, read_table, target_kind, target_kinds)

#: ``default`` of :meth:`_Reader.read`: the key's declared default.
_DECLARED = object()
_PORT = re.compile(r"^(-?)([a-z][a-z0-9_]*):([1-9][0-9]*)$")

#: A spec's top-level keys.
SPEC_KEYS = KeyTable("top level", "A spec file: its name and source, the joints, the mechanisms on them and the "
                     "springs joining their ports, and the tables of options.", (
    Key("name", "", "the design's name", "string", min_length=1, default=None,
        default_text="the spec file's name"),
    Key("source", "", "the source the spec cites", "string", default=""),
    Key("notes", "", "notes on the spec", "string", default=""),
    Key("torque_model", "", "how the springs' torque is computed: 'energy' (the derivative of their energy) or "
        "a mechanism's force model", "string", default=ENERGY),
    Key("friction_model", "", "the old name of torque_model (cadcam ≤ 0.1; 'exact' is now 'force')", "string",
        default=None, default_text="none"),
    Key("solver", "", "the solver's options (see [solver])", "table", default={}),
    Key("arm", "", "a planar serial arm the arm targets share (see [arm])", "table", default=None,
        default_text="none"),
    Key("joints", "", "the joints (or [[cams]], the wire cams' shorthand: a joint and its wire cam in one table)",
        "tables", min_length=1),
    Key("mechanisms", "", "the mechanisms on the joints", "tables", min_length=1),
    Key("springs", "", "the springs joining the mechanisms' ports", "tables", default=[]),
    Key("variants", "", "named tables of dotted-key overrides, chosen by --variant NAME", "table", default={}),
    Key("workshop", "", "sizes of the workshop files (see [workshop])", "table", default={}),
    Key("tolerances", "", "the tolerances of the built part (see [tolerances])", "table", default={}),
    Key("builds", "", "the builds simulated under the tolerances (see [builds])", "table", default={}),
    Key("adjustment", "", "what the builder sets after the build, and its range (see [adjustment])", "table",
        default={}),
    Key("cable", "", "the cable the profiles wrap, as a part (see [cable])", "table", default=None,
        default_text="none (a diameter alone: [workshop] cable_diameter)"),
    Key("friction", "", "friction where it acts: guides, idlers on bearings, joints' bearings (see [friction])",
        "table", default=None, default_text="none (frictionless)"),
))


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
    declaration : Key
        The key's declaration.
    """

    key: str
    form: str
    value: Any
    given: bool
    declaration: Key


#: While a list, every key a :class:`_Reader` reads is appended to it (:func:`read_keys`).
_READS: contextvars.ContextVar[list[KeyRead] | None] = contextvars.ContextVar("spec_reads", default=None)
#: While :func:`parse_spec` reads a spec, the line of every value it gives that its key finds
#: implausible (:meth:`cadcam.keys.Key.implausible`): the problem's :attr:`Problem.warnings`.
_WARNINGS: contextvars.ContextVar[list[str] | None] = contextvars.ContextVar("spec_warnings", default=None)


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

    def fail(self, key, value, form) -> NoReturn:
        raise SpecError(f"{self.origin}: {key} = {short_repr(value)}: expected {form}")

    def key(self, name: str) -> str:
        return f"{self.where}.{name}" if self.where else name

    def read(self, key: Key, default: Any = _DECLARED):
        """The value of ``key`` in the table, checked against its declaration; ``default``
        (else the declared one) where the table leaves it out.

        Raises
        ------
        SpecError
            A required key missing, or a value the key does not allow: one line naming the key
            and its form (:meth:`Key.form`).
        """
        name, form = key.name, key.form()
        self.seen.add(name)
        if default is _DECLARED:
            default = key.default
        reads = _READS.get()
        if reads is not None:
            reads.append(KeyRead(_dotted(self.key(name)), form, self.table.get(name, default),
                                 name in self.table, key))
        if name not in self.table:
            if default is REQUIRED:
                raise SpecError(f"{self.origin}: missing key '{self.key(name)}': expected {form}")
            return default
        value = self.table[name]
        if not key.ok(value):
            self.fail(self.key(name), value, form)
        warnings = _WARNINGS.get()
        if warnings is not None and (line := key.implausible(value, self.key(name))) is not None:
            warnings.append(line)
        return value

    def table_reader(self, key: Key) -> "_Reader":
        """A reader of the sub-table ``key`` (required)."""
        return _Reader(self.origin, self.read(key), self.key(key.name))

    def done(self):
        extra = sorted(set(self.table) - self.seen)
        if extra:
            raise SpecError(f"{self.origin}: unknown key '{self.key(extra[0])}'; allowed keys "
                            f"here: {', '.join(sorted(self.seen))}")


def _arm(r: _Reader, n_joints: int) -> dict:
    """An arm table (:data:`cadcam.targets.ARM_KEYS`): masses, lengths, com (one per joint) and g."""
    keys = ARM_KEYS
    masses = r.read(keys["masses"].within(check=lambda v: len(v) <= n_joints, words=f"at most {n_joints}"))
    n = len(masses)
    return {"masses": [float(v) for v in masses],
            "lengths": [float(v) for v in r.read(keys["lengths"].within(length=n))],
            "com": [float(v) for v in r.read(keys["com"].within(length=n))],
            "g": float(r.read(keys["g"]))}


def _five_bar(r: _Reader, n_joints: int) -> dict:
    """A ``five_bar`` target (Endo2010 Sec. III, :data:`cadcam.targets.FIVE_BAR_KEYS`)."""
    if n_joints != 2:
        r.fail(r.key("kind"), "five_bar", f"a five_bar target only in a problem of 2 joints "
               f"(theta1 = link 1, theta2 = crank); this one has {n_joints}")
    data = {k.name: r.read(k) for k in FIVE_BAR_KEYS.keys}
    return {k: ([float(x) for x in v] if isinstance(v, list) else (v if k == "joint" else float(v)))
            for k, v in data.items()}


def _acceptance(r: _Reader) -> tuple:
    """A joint's optional [joints.acceptance]: limits on its metrics of the fine re-check
    (:func:`cadcam.problem.acceptance_keys`); the ones it gives."""
    a = _Reader(r.origin, r.read(JOINT_KEYS["acceptance"]), r.key("acceptance"))
    given = {k.name: a.read(k, None) for k in acceptance_keys().keys}
    a.done()
    return tuple((k, float(v)) for k, v in given.items() if v is not None)


def _target(r: _Reader, base: Path, n_joints: int, arm: dict | None, output: bool = False,
            theta_range=None) -> Target:
    """A joint's torque law, or (``output``) a mechanism's output law x(θ) [m] over its
    joint's ``theta_range`` [rad]: its ``kind``, then the kind's declared keys."""
    kinds = target_kinds(output)
    kind = r.read(KIND.within(type="choice", choices=kinds))
    declared = target_kind(kind)
    if declared.read is not None:  # a kind that reads its own keys
        data = declared.read(r, theta_range)
    elif kind == "arm":
        data = _arm_target(r, n_joints, arm)
    elif kind == "five_bar":
        data = _five_bar(r, n_joints)
    elif kind == "table":
        data = _table(r, base, output)
    elif kind == "pendulum":
        data = _pendulum(r)
    elif kind == "expression":  # its value's unit is the law's: N·m for a torque, m for an output
        keys = EXPRESSION_KEYS
        data = {"expression": r.read(keys["expression"].within(unit="m" if output else "N·m")),
                "parameters": r.read(keys["parameters"])}
    else:
        data = {k.name: r.read(k) for k in (declared.keys.keys if declared.keys is not None else ())}
    r.done()
    return Target(kind, data)


def _pendulum(r: _Reader) -> dict:
    """A ``pendulum`` target's keys (:data:`cadcam.targets.PENDULUM_KEYS`), its ``mass_range``
    only where given, and holding its ``mass``: the design is for that mass."""
    data = {k.name: r.read(k) for k in PENDULUM_KEYS.keys if k.name != "mass_range"}
    if "mass_range" in r.table:
        low, high = data["mass_range"] = r.read(PENDULUM_KEYS["mass_range"])
        if not low <= data["mass"] <= high:
            r.fail(r.key("mass_range"), data["mass_range"], f"a range holding mass = {data['mass']:g}, the mass "
                   "the design is for")
    return data


def _arm_target(r: _Reader, n_joints: int, arm: dict | None) -> dict:
    """An ``arm`` target: its joint, and the arm's keys given inline or the spec's [arm]."""
    inline = {k for k in ARM_KEYS.names if k in r.table}
    if inline or arm is None:
        arm = _arm(r, n_joints)
    joint = r.read(ARM_JOINT.within(high=len(arm["masses"])))
    return {"joint": joint, **arm}


def _table(r: _Reader, base: Path, output: bool) -> dict:
    """A ``table`` target's samples [θ rad, value], inline in ``angle_unit`` or read from a
    CSV file whose header names the angles' unit."""
    column = "x_m" if output else "torque_Nm"
    keys = TABLE_KEYS
    unit = r.read(keys["angle_unit"])
    if "samples" in r.table:
        samples = np.array(r.read(keys["samples"]), dtype=float)
        samples[:, 0] *= ANGLE_UNITS[unit]
        return {"samples": samples.tolist()}
    if "angle_unit" in r.table:
        r.fail(r.key("angle_unit"), unit, "nothing beside a file: its header names the angles' unit "
               f"(theta_rad,{column} or theta_deg,{column})")
    name = r.read(keys["file"].within(default=REQUIRED))
    try:
        return {"samples": read_table(base / name, column)}
    except (OSError, ValueError) as exc:
        r.fail(r.key("file"), name, f"a readable target table ({exc})")


#: Samples per angle at which a target expression's poles, domains and jumps are checked, by
#: number of joints (a tensor grid: 3 and more joints share the last entry).
GUARD_SAMPLES = {1: 4001, 2: 201, 3: 41}


#: How many targets that passed :func:`_check_target` it remembers (by their spec data, angle
#: ranges and joint), so as not to check them again: a design page parses its spec again at
#: every slider step, and the check (its guards and its poles sampled at thousands of angles)
#: took a tenth of the 1-DOF wire cam's step.
CHECKED_TARGETS = 64
_passed_targets: OrderedDict[str, None] = OrderedDict()


def _check_target(origin, where, target: Target, joint_ranges, joint: int, unit: str = "torque [N·m]"):
    """Refuse a target that is malformed or not finite over the angle ranges (one that passed
    with the same ranges is not checked again, :data:`CHECKED_TARGETS`)."""
    key = repr((target.to_dict(), [tuple(r) for r in joint_ranges], joint, unit))
    if key in _passed_targets:
        _passed_targets.move_to_end(key)
        return
    _checked_target(origin, where, target, joint_ranges, joint, unit)
    _passed_targets[key] = None
    while len(_passed_targets) > CHECKED_TARGETS:
        _passed_targets.popitem(last=False)


def _checked_target(origin, where, target: Target, joint_ranges, joint: int, unit: str) -> None:
    """:func:`_check_target`'s check itself."""
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
                              ipopt_options({f"ipopt.{name}": value, "error_on_fail": False}))
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
        legacy = top.read(SPEC_KEYS["friction_model"].within(type="choice", choices=tuple(legacy_torque_models())))
        return legacy_torque_models()[legacy]
    return top.read(SPEC_KEYS["torque_model"].within(type="choice", choices=torque_models()))


def parse_spec(data: dict, origin: str = "<spec>", base: Path = Path(".")) -> Problem:
    """Validate a spec dictionary and build the :class:`Problem`, with a warning for each value
    plausible only in another unit or outside every catalogue (:attr:`Problem.warnings`).

    Parameters
    ----------
    data : dict
        Parsed TOML (or the ``problem`` member of a result JSON).
    origin : str
        File name used in error messages.
    base : Path
        Folder against which table files are resolved.
    """
    token = _WARNINGS.set([])
    try:
        problem = _parsed(data, origin, base)
        return replace(problem, warnings=tuple(dict.fromkeys(_WARNINGS.get() or ())))
    finally:
        _WARNINGS.reset(token)


def _parsed(data: dict, origin: str, base: Path) -> Problem:
    """:func:`parse_spec`'s problem, without its warnings."""
    table = _shorthand_table(data)
    if table:  # errors in a shorthand name the user's own tables, not the general form
        _check_shorthand(origin, data, table)
        data = _from_shorthand(data, table)
    joint_label, mech_label = (table, table) if table else ("joints", "mechanisms")
    top = _Reader(origin, data, "")
    keys = SPEC_KEYS
    name = top.read(keys["name"], Path(origin).stem if origin.endswith(".toml") else "design")
    source, notes = top.read(keys["source"]), top.read(keys["notes"])
    torque_model = _torque_model(top, data)
    options = _options(_Reader(origin, top.read(keys["solver"]), "solver"))
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
    raw_joints, raw_mechs, raw_springs = (top.read(keys[k]) for k in ("joints", "mechanisms", "springs"))
    top.read(keys["variants"])
    workshop = _workshop(_Reader(origin, top.read(keys["workshop"]), "workshop"))
    tolerances = _tolerances(_Reader(origin, top.read(keys["tolerances"]), "tolerances"))
    builds = _given(_Reader(origin, top.read(keys["builds"]), "builds"), BUILD_KEYS)
    adjustment = _Reader(origin, top.read(keys["adjustment"]), "adjustment")
    adjustments = _given(adjustment, ADJUSTMENT_KEYS)
    raw_cable = top.read(keys["cable"])
    cable = None if raw_cable is None else _cable(_Reader(origin, raw_cable, "cable"))
    if cable is not None:
        workshop = _cable_workshop(origin, data, workshop, cable)
    raw_friction = top.read(keys["friction"])
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
    _check_slot(adjustment, dict(adjustments).get("slot", ""), mechanisms)
    springs = [_spring(_Reader(origin, raw, f"springs[{j + 1}]"), j, mechanisms, base)
               for j, raw in enumerate(raw_springs)]
    _check_output_laws(origin, mechanisms)
    _check_method(origin, options.method, mechanisms)
    friction = None if raw_friction is None else _friction(_Reader(origin, raw_friction, "friction"), springs,
                                                           len(joints))
    if not springs and any(c["tracking_weight"] > 0 for c in joints):
        raise SpecError(f"{origin}: missing key 'springs': a torque target needs [[springs]] "
                        "tables (or kind = \"none\" on every joint's target, for output laws only)")
    ranges = [c["theta_range"] for c in joints]
    for i, t in enumerate(targets):
        _check_target(origin, f"{joint_label}[{i + 1}].target", t, ranges, i)
    try:
        return Problem(name=name, source=source, notes=notes, torque_model=torque_model,
                       options=options, workshop=workshop, tolerances=tolerances, cable=cable, builds=builds,
                       adjustments=adjustments, friction=friction, springs=tuple(springs), mechanisms=tuple(mechanisms),
                       joints=tuple(Joint(target=t, **c) for c, t in zip(joints, targets)))
    except ValueError as exc:
        raise SpecError(f"{origin}: torque_model: {exc}") from None


def _options(sol: _Reader) -> Options:
    """The ``[solver]`` table as :class:`Options`, each key read as :data:`SOLVER` declares it
    (its default where it is missing)."""
    values: dict[str, Any] = {}
    for name, key in SOLVER.items():
        if name == "ipopt":
            values[name] = _ipopt_options(sol, sol.read(key, {}))
        elif name == "method":
            values[name] = sol.read(key.within(type="choice", choices=_methods()))
        else:
            values[name] = sol.read(key)
    sol.done()
    return Options(**values)


def _top_arm(top: _Reader, data: dict, n_joints: int) -> dict | None:
    """The spec's shared ``[arm]`` table (what an ``arm`` target uses unless it gives its own),
    or None."""
    if "arm" not in data:
        return None
    ra = _Reader(top.origin, top.read(SPEC_KEYS["arm"]), "arm")
    arm = _arm(ra, max(n_joints, 1))
    ra.done()
    return arm


def _theta_range(r: _Reader) -> tuple[float, float]:
    """A joint's ``theta_range_deg`` as (min, max) [rad] (:data:`cadcam.problem.JOINT_KEYS`)."""
    rng = r.read(JOINT_KEYS["theta_range_deg"])
    return math.radians(rng[0]), math.radians(rng[1])


def _joint(r: _Reader, i: int, n_springs: int, n_joints: int, arm: dict | None, base: Path,
           label: str) -> tuple[dict, Target]:
    """One [[joints]] table: the keyword arguments of its :class:`Joint` but the target, and its
    target (a joint without a torque goal weighs no tracking error)."""
    theta_range = _theta_range(r)
    keys = JOINT_KEYS
    sens = r.read(keys["sensitivity_weights"].within(length=n_springs), [0.0] * n_springs)
    joint = dict(
        name=r.read(keys["name"], f"joint {i + 1}"),
        theta_range=theta_range,
        tracking_weight=float(r.read(keys["tracking_weight"])),
        sensitivity_weights=tuple(float(w) for w in sens),
        acceptance=_acceptance(r),
        band_weight=float(r.read(BAND_WEIGHT)))
    target = _target(_Reader(r.origin, r.read(keys["target"]), r.key("target")), base, n_joints, arm)
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
    :func:`cadcam.problem.tolerance_keys` declares it; the ones it gives."""
    out = tuple((k.name, float(r.read(k))) for k in tolerance_keys().keys if k.name in r.table)
    r.done()
    return out


def _given(r: _Reader, table: KeyTable) -> tuple:
    """The keys of ``table`` (``[builds]``, ``[adjustment]``) the spec gives, as pairs (key,
    value), each read as its declaration says."""
    out = tuple((k.name, r.read(k)) for k in table.keys if k.name in r.table)
    r.done()
    return out


def _check_slot(r: _Reader, slot: str, mechanisms) -> None:
    """Refuse an ``[adjustment] slot`` that no mechanism of the problem places
    (:attr:`cadcam.mechanisms.base.Quantity.placed`) and can move (:meth:`Mechanism.placed`)."""
    placed = list(dict.fromkeys(q.name for m in mechanisms for q in m.parameters if q.placed and _movable(m, q.name)))
    options = (f"one of {', '.join(repr(name) for name in placed)}" if placed
               else "but no mechanism here has one: leave the slot out")
    if slot and slot not in placed:
        r.fail(r.key("slot"), slot, f"a parameter the problem's mechanisms place and can move, {options}")
    if not slot and r.table.get("slot_travel", 0.0) > 0:
        r.fail(r.key("slot_travel"), r.table["slot_travel"], "0 without a slot: name the parameter it moves, "
               f"[adjustment] slot, {options}")


def _movable(mech, name: str) -> bool:
    """Whether ``mech`` moves its parameter ``name`` when asked to (:meth:`Mechanism.placed`):
    a slot must move what it names."""
    value = dict(zip(mech.parameter_names, mech.parameter_values()))[name]
    moved = mech.placed({name: value + 1e-3})
    return dict(zip(moved.parameter_names, moved.parameter_values()))[name] != value


def _workshop(r: _Reader) -> Workshop:
    """The ``[workshop]`` table: sizes of the workshop files [m], each key as
    :data:`cadcam.problem.WORKSHOP_KEYS` declares it; its defaults where a key is missing."""
    sizes = {k.name: r.read(k, None) for k in WORKSHOP_KEYS.keys}
    r.done()
    return Workshop(**{name: float(v) for name, v in sizes.items() if v is not None})


def _cable(r: _Reader) -> Cable:
    """The ``[cable]`` table (:data:`cadcam.physics.cables.CABLE_KEYS`): a cable of the shipped
    table by name, or one given in full. A resolved problem (:meth:`Problem.to_dict`) gives
    the values a name fills beside it: they are accepted where they are the row's own."""
    keys = CABLE_KEYS
    name = r.read(keys["name"])
    if name is None:
        diameter, bend, load = (float(r.read(keys[k].within(default=REQUIRED)))
                                for k in ("diameter", "min_bend_radius", "breaking_load"))
        kind = r.read(keys["kind"])
        r.done()
        return Cable(diameter=diameter, min_bend_radius=bend, breaking_load=load, kind=kind)
    try:
        cable = shipped_cables().cable(name)
    except KeyError as exc:
        raise SpecError(f"{r.origin}: {r.key('name')} = {short_repr(name)}: {exc.args[0]}") from None
    for k in FILLED_BY_NAME:
        if r.read(keys[k], getattr(cable, k)) != getattr(cable, k):
            raise SpecError(f"{r.origin}: {r.key(k)} = {short_repr(r.table[k])}: cable {name!r} sets {k} "
                            f"({getattr(cable, k)!r} {keys[k].unit} from its row); give the name or {k}, not both")
    r.done()
    return cable


def _cable_workshop(origin: str, data: dict, workshop: Workshop, cable: Cable) -> Workshop:
    """``workshop`` with the cable's diameter; SpecError where ``[workshop]`` gives another."""
    given = data.get("workshop", {}).get("cable_diameter")
    if given is not None and given != cable.diameter:
        raise SpecError(f"{origin}: workshop.cable_diameter = {short_repr(given)}: the [cable] sets the "
                        f"diameter ({cable.diameter:g} m, {cable.label()}); remove workshop.cable_diameter")
    return replace(workshop, cable_diameter=cable.diameter)


def _friction(r: _Reader, springs: list[Spring], n_joints: int) -> Friction:
    """The ``[friction]`` table (:data:`cadcam.physics.friction.FRICTION_KEYS`): its guides and
    idlers, each on a spring's cable to one of its ports, and its joints' bearings, one a joint."""
    keys = FRICTION_KEYS
    centre = r.read(keys["centre"])
    tables = {name: [_Reader(r.origin, raw, f"{r.key(name)}[{n + 1}]") for n, raw in enumerate(r.read(keys[name]))]
              for name in ("guides", "idlers", "joints")}
    r.done()
    guides = []
    for g in tables["guides"]:
        spring, port = _cable_path(g, springs)
        guides.append(Guide(spring, port, float(g.read(GUIDE_KEYS["mu"])), math.radians(g.read(GUIDE_KEYS["wrap_deg"]))))
        g.done()
    idlers = []
    for i in tables["idlers"]:
        spring, port = _cable_path(i, springs)
        idlers.append(Idler(spring, port, float(i.read(IDLER_KEYS["coefficient"])),
                            math.radians(i.read(IDLER_KEYS["wrap_deg"]))))
        i.done()
    bearings: dict[int, JointBearing] = {}
    for b in tables["joints"]:
        joint = b.read(BEARING_KEYS["joint"].within(high=n_joints)) - 1
        if joint in bearings:
            b.fail(b.key("joint"), joint + 1, "one [[friction.joints]] table per joint (joint "
                   f"{joint + 1} has one already: add its torques in one table)")
        bearings[joint] = JointBearing(joint, *(float(b.read(BEARING_KEYS[k])) for k in ("torque", "coefficient",
                                                                                         "radius")))
        b.done()
    return Friction(tuple(guides), tuple(idlers), tuple(bearings.values()), centre)


def _cable_path(r: _Reader, springs: list[Spring]) -> tuple[int, Port]:
    """A guide's or idler's spring (0-based) and the port of its cable: the table's ``port`` as
    the spring's ports write it, with or without its sign, or the spring's only port."""
    j = r.read(GUIDE_KEYS["spring"].within(high=max(len(springs), 1))) - 1
    if not springs:
        r.fail(r.key("spring"), j + 1, "a spring's number, and the spec has no [[springs]]")
    ports = springs[j].ports
    given = r.read(GUIDE_KEYS["port"])
    labels = [p.label() for p in ports]
    if given is None:
        if len(ports) > 1:
            raise SpecError(f"{r.origin}: missing key '{r.key('port')}': spring {j + 1} joins several ports "
                            f"({', '.join(labels)}); name the one whose cable runs over it")
        return j, ports[0]
    match = next((p for p, label in zip(ports, labels) if given in (label, label.lstrip("-"))), None)
    if match is None:
        r.fail(r.key("port"), given, f"one of spring {j + 1}'s ports: {', '.join(labels)}")
    return j, match


def _mechanism(r: "_Reader", u: int, joints: list[dict], base: Path = Path(".")):
    """One [[mechanisms]] table: kind, name, joint, its profiles (one basis and one set of
    limits for all), its output law if it has an output, and the mechanism's own keys."""
    keys = MECHANISM_KEYS
    cls = mechanism_class(r.read(keys["kind"].within(type="choice", choices=mechanism_kinds())))
    name = r.read(keys["name"], f"mechanism {u + 1}")
    joint = r.read(keys["joint"].within(high=len(joints))) - 1
    basis_name = r.read(keys["basis"])
    order = r.read(keys["order"].within(high=MAX_ORDER[basis_name]))
    rho_min = float(r.read(keys["rho_min"]))
    rho_max = float(r.read(keys["rho_max"].within(low=rho_min, open_low=True)))
    curvature = float(r.read(keys["min_curvature_radius"]))
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
    link = r.read(LINK_ANGLE)
    if link is not None:
        mech = replace(mech, link_angle=float(link))
    if cls.output and "output_target" in r.table:
        where = r.key("output_target")
        target = _target(_Reader(r.origin, r.read(keys["output_target"]), where), base, 1, None, output=True,
                         theta_range=theta_range)
        _check_target(r.origin, where, target, [theta_range], 0, f"{cls.output} [m]")
        mech = replace(mech, output_target=target)
    r.done()
    return mech


def _spring(r: "_Reader", j: int, mechanisms, base: Path = Path(".")) -> Spring:
    """One [[springs]] table; ports name a mechanism's ports as 'port:mechanism'."""
    keys = SPRING_KEYS
    ports = []
    for p in r.read(keys["ports"].within(check=lambda v: all(_PORT.match(x) for x in v))):
        match = _PORT.match(p)
        assert match is not None  # checked by r.read above
        sign, port, number = match.groups()
        u = int(number) - 1
        if u >= len(mechanisms):
            r.fail(r.key("ports"), p, f"a mechanism number between 1 and {len(mechanisms)}")
        if port not in mechanisms[u].ports:
            r.fail(r.key("ports"), p, f"a port of mechanism {u + 1} ({mechanisms[u].kind}): "
                                      f"{', '.join(mechanisms[u].ports)}")
        ports.append(Port(u, port, -1.0 if sign else 1.0))
    part, filled = _part(r, base)
    numbers = {name: float(r.read(keys[name], filled.get(name, _DECLARED))) for name in ("rate", "travel", "preload")}
    free_length = _optional_float(r.read(keys["free_length"], filled.get("free_length", _DECLARED)))
    pre = r.read(keys["preextension"].within(high=numbers["travel"]))
    spring = Spring(name=r.read(keys["name"], f"spring {j + 1}"), rate=numbers["rate"], travel=numbers["travel"],
                    ports=tuple(ports), preload=numbers["preload"], free_length=free_length,
                    preextension=_optional_float(pre), **part)
    r.done()
    return spring


#: The keys a catalogue part fills, which a spec naming a part does not give.
FILLED_BY_PART = ("rate", "preload", "free_length", "travel")


def filled_by_part(body: SpringBody) -> dict:
    """The values a catalogue part's body fills (:data:`FILLED_BY_PART`): its rate, initial
    tension and free length, and its travel, the least extension its limits allow."""
    return {"rate": body.rate, "preload": body.preload, "free_length": body.free_length,
            "travel": min(body.extension_limits().values())}


def part_values(catalogue: Catalogue, number: str) -> tuple[SpringBody, dict]:
    """The body of part ``number`` of ``catalogue`` and the values it fills
    (:func:`filled_by_part`).

    Raises
    ------
    KeyError
        No such part (the message names the nearest).
    ValueError
        A part whose initial tension already stresses its wire beyond its allowance.
    """
    body = catalogue.spring_body(catalogue.index(number))
    filled = filled_by_part(body)
    if not filled["travel"] > 0:
        raise ValueError("its initial tension already stresses the wire beyond its allowance; choose another part")
    return body, filled


def _part(r: "_Reader", base: Path) -> tuple[dict, dict]:
    """The part, catalogue and body of a spring that names a catalogue part, and the values its
    row fills; two empty dicts for one that does not.

    A resolved problem (:meth:`Problem.to_dict`) gives the filled values beside its part: they
    are accepted where they are the row's own.
    """
    keys = SPRING_KEYS
    number = r.read(keys["part"])
    given = r.read(keys["catalogue"])
    if number is None:
        if given is not None:
            raise SpecError(f"{r.origin}: {r.key('catalogue')} = {short_repr(given)}: a catalogue is read "
                            "only for a part; add part = \"...\" or remove catalogue")
        return {}, {}
    path = None if given is None else (Path(given) if Path(given).is_absolute() else base / given)
    try:
        body, filled = part_values(load_catalogue(path), number)
    except (KeyError, ValueError) as exc:
        raise SpecError(f"{r.origin}: {r.key('part')} = {short_repr(number)}: {exc.args[0]}") from None
    for name in FILLED_BY_PART:
        if name in r.table and not (is_real(r.table[name]) and float(r.table[name]) == filled[name]):
            raise SpecError(f"{r.origin}: {r.key(name)} = {short_repr(r.table[name])}: part {number!r} sets "
                            f"{name} ({filled[name]:.6g} {keys[name].unit} from its row); give the part or "
                            f"{name}, not both")
    where = None if path is None else str(path.resolve())
    return {"part": number, "catalogue": where, "body": body}, filled


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
    joint_keys = JOINT_KEYS.names
    out["joints"], out["mechanisms"] = [], []
    for i, entry in enumerate(data[table]):
        out["joints"].append({k: entry[k] for k in joint_keys if k in entry})
        out["mechanisms"].append({"kind": kind, "joint": i + 1,
                                  **{k: v for k, v in entry.items() if k == "name" or k not in joint_keys}})
    return out


#: A joint range [deg] at most this wide whose ends all lie within a turn reads as radians
#: typed as degrees; a table's angles spanning more than this many times its joint's range,
#: beyond a turn, read as degrees typed as radians.
NARROW_RANGE_DEG = 2 * math.pi
WIDE_TABLE_RATIO = 10.0


def implausible_units(problem: Problem) -> list[str]:
    """One line per value that is plausible only in another unit or outside every catalogue,
    with how to write it: those its reader found (:attr:`Problem.warnings`: a 1e9 N/m spring,
    a 500 kg mass), then the angles: a joint range of a few degrees whose ends are
    radian-sized, a table's angles far wider than its joint's range."""
    notes = list(problem.warnings)
    for i, joint in enumerate(problem.joints):
        lo, hi = (math.degrees(a) for a in joint.theta_range)
        if hi - lo <= NARROW_RANGE_DEG and max(abs(lo), abs(hi)) <= NARROW_RANGE_DEG:
            notes.append(f"joints[{i + 1}].theta_range_deg = [{lo:.4g}, {hi:.4g}] spans {hi - lo:.3g}°: if these "
                         f"are radians, write degrees ([{math.degrees(lo):.4g}, {math.degrees(hi):.4g}])")
        if joint.target.kind == "table":
            angles = np.asarray(joint.target.data["samples"])[:, 0]
            span = angles[-1] - angles[0]
            if span > 2 * math.pi and span > WIDE_TABLE_RATIO * (joint.theta_range[1] - joint.theta_range[0]):
                notes.append(f"joints[{i + 1}].target: the table's angles span {span:.4g} rad, {span / (2 * math.pi):.3g} "
                             f"turns, against a joint range of {hi - lo:.4g}°: if they are degrees, write "
                             'angle_unit = "deg" (or a CSV header theta_deg)')
    return notes


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
    table at ``key`` rather than replacing it. Every array on the path must exist in the spec,
    and every table too unless its table declares it (:func:`_declared_keys`: ``solver`` in a
    spec without ``[solver]``, a joint's ``acceptance``), which is then created; the last part
    may name a key the spec leaves at its default (the spec's own validation then checks it,
    and refuses a key that is not declared).
    """
    parts = key.split(".")
    if not key or not all(parts):
        raise SpecError(f"{origin}: {key!r} is not a dotted key such as 'springs.1.rate'")

    def walk(node, i, trail: tuple[str, ...]):
        part, path = parts[i], ".".join(trail)
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
                    walk(node[t], i + 1, (*trail, str(t + 1)))
        elif isinstance(node, dict):
            if last:
                node[part] = _merged(node.get(part), value)
                return
            if part not in node:
                node[part] = _created_table(node, trail, part, f"{origin}: '{key}'")
            walk(node[part], i + 1, (*trail, part))
        else:
            raise SpecError(f"{origin}: '{key}': '{path}' is a value, not a table or array")

    walk(data, 0, ())


def _created_table(node: dict, trail: tuple[str, ...], part: str, where: str) -> dict:
    """An empty table ``part`` for the spec table ``node`` at ``trail`` that lacks it, where
    its declared keys (:func:`_declared_keys`) name ``part`` a table.

    Raises
    ------
    SpecError
        ``part`` is no table declared there: one line naming the tables that are.
    """
    declared = _declared_keys(node, trail)
    tables = [k.name for k in declared or () if k.type == "table"]
    if part in tables:
        return {}
    inside = f"in '{'.'.join(trail)}'" if trail else "at the top level"
    can = f"; the tables --set may add there: {', '.join(tables)}" if tables else ""
    raise SpecError(f"{where}: the spec has no '{part}' {inside}, and no table of that name is declared there{can}")


def _declared_keys(node: dict, trail: tuple[str, ...]) -> tuple[Key, ...] | None:
    """The keys declared for the spec table ``node`` at ``trail`` (dotted parts, an array's
    entries by number), where ``--set`` may create a missing table: the top level's, the
    ``[solver]`` table's, a joint's, and a mechanism's (every mechanism's keys and its kind's,
    with a joint's in a shorthand entry such as ``[[cams]]``); None elsewhere."""
    if len(trail) < 2:
        return {(): SPEC_KEYS.keys, ("solver",): SOLVER_KEYS.keys}.get(trail)
    if len(trail) > 2:
        return None
    if trail[0] == "joints":
        return JOINT_KEYS.keys
    kinds = mechanism_kinds()
    kind = node.get("kind") if trail[0] == "mechanisms" else next(
        (k for k in kinds if mechanism_class(k).shorthand == trail[0]), None)
    if kind not in kinds:
        return None
    cls = mechanism_class(kind)
    return MECHANISM_KEYS.keys + cls.spec_keys.keys + (JOINT_KEYS.keys if cls.shorthand == trail[0] else ())


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
            data = pickle.loads(_document(text))
        except tomllib.TOMLDecodeError as exc:
            raise SpecError(f"{path}: not valid TOML ({exc})") from None
    return with_overrides(data, str(path), variant, overrides)


#: How many specs' TOML documents are kept parsed, by their text (:func:`_document`).
KEPT_DOCUMENTS = 16


@functools.lru_cache(maxsize=KEPT_DOCUMENTS)
def _document(text: str) -> bytes:
    """The TOML document ``text`` parsed (:func:`cadcam.files.loads_toml`), pickled: each read
    unpickles a copy of its own to apply its overrides to. A design page reads its spec again
    at every step of a slider, and parsing the TOML cost more than a copy."""
    return pickle.dumps(loads_toml(text))


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
    if not isinstance(path, (str, os.PathLike)):
        raise SpecError(f"spec: expected a file name (str or Path), not {type(path).__name__}")
    path = Path(path)
    data = read_spec_data(path, variant, overrides)
    return parse_spec(data, str(path), path.parent)
