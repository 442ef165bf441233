"""Generated malformed inputs against the command line's contract (issue 11, item 7).

Valid inputs (the shipped specs and studies, a design written by ``cadcam design``, Johnston2023's
Table 3 design, a target table) are mutated by hypothesis: keys deleted, renamed or added, values
replaced by wrong types, non-finite or extreme numbers, files truncated, non-UTF-8 bytes, byte
order marks, swapped files, broken flags. Whatever comes out, ``cadcam.cli.main`` must keep its
contract:

* bad input: exit code 2, exactly one line on stderr that starts with ``cadcam: error:`` and
  names the file (or flag) and, for a bad value, the key; no traceback; nothing created (no
  output folder or database, no hidden temporary file);
* exit code 0 or 1 only for input that is valid, and 0 never a false success: ``result.json``
  says ``success`` and its metrics are finite.

Each mutation is judged from the *original* value alone (a string replaced by a non-string is
bad, a required key deleted is bad, …); where that cannot decide, either outcome is allowed but
must still keep the contract. Inputs that turn out valid stay cheap: specs carry a 5-angle grid,
30 IPOPT iterations and a coarse re-check, spec, design and flag mutations run ``cadcam
evaluate`` (no solve), and ``cadcam design`` only sees inputs that are bad by construction, except
a few perturbations of the spec's numbers. Reproducible: ``derandomize=True``, no example database.
"""
from __future__ import annotations

import contextlib
import copy
import json
import math
import os
import sqlite3
import tempfile
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, note, settings
from hypothesis import strategies as st
from hypothesis.control import currently_in_test_context

from cadcam.cli import main
from cadcam.files import MANIFEST

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"
SPEC_1DOF = MODELS / "johnston2023_1dof.toml"
SPEC_RR = MODELS / "johnston2023_rr_arm.toml"
TABLE3 = MODELS / "johnston2023_table3_design.json"
STUDY_FILES = sorted((ROOT / "studies").glob("*.toml"))


def _settings(n: int):
    return settings(max_examples=n, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))


# -- the valid inputs, made cheap to solve -----------------------------------------------------
def fast_text(path: Path) -> str:
    """The spec's text with a 5-angle grid, 30 iterations and a re-check grid twice as fine."""
    text = path.read_text()
    fast = text.replace("grid = 46\n", "grid = 5\nmax_iter = 30\nrecheck_factor = 2\n", 1)
    assert fast != text
    return fast


FAST_1DOF = fast_text(SPEC_1DOF)
FAST_RR = fast_text(SPEC_RR)
TREE_1DOF = tomllib.loads(FAST_1DOF)
TREE_RR = tomllib.loads(FAST_RR)


# -- writing data as TOML (the standard library reads TOML but does not write it) ---------------
def toml_string(s: str) -> str:
    out = []
    for ch in s:
        o = ord(ch)
        if ch in '"\\':
            out.append("\\" + ch)
        elif 0x20 <= o < 0x7F:
            out.append(ch)
        else:
            out.append(f"\\u{o:04x}" if o <= 0xFFFF else f"\\U{o:08x}")
    return '"' + "".join(out) + '"'


def toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, str):
        return toml_string(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{toml_string(k)} = {toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def to_toml(data: dict) -> str:
    return "".join(f"{toml_string(k)} = {toml_value(v)}\n" for k, v in data.items())


# -- running the command and checking its contract ------------------------------------------------
@dataclass
class Run:
    argv: list
    code: int
    out: str
    err: str


def snapshot(root: Path) -> dict:
    """Every path under ``root`` (hidden ones included) with its size and modification time."""
    return {str(p.relative_to(root)): (p.stat().st_size, p.stat().st_mtime_ns) if p.is_file() else None
            for p in root.rglob("*")}


def cli(capfd, *argv, cwd: Path | None = None) -> Run:
    """``cadcam ARGV`` in this process; an exception escaping ``main`` is a contract failure."""
    argv = [str(a) for a in argv]
    if currently_in_test_context():
        note(f"cadcam {' '.join(argv)}")
    capfd.readouterr()
    with contextlib.chdir(cwd or Path.cwd()):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse
            code = exc.code
        except Exception as exc:
            out, err = capfd.readouterr()
            raise AssertionError(f"cadcam {' '.join(argv)}: {type(exc).__name__} escaped (a traceback): "
                                 f"{exc}\nstderr: {err}") from exc
    out, err = capfd.readouterr()
    return Run(argv, code, out, err)


def assert_refused(run: Run, names=(), keys=(), absent=(), root: Path | None = None, before=None):
    """Exit 2, one line ``cadcam: error: …`` naming one of ``names`` (files or flags) and, if
    given, one of ``keys``; every path in ``absent`` not created; ``root`` as it was."""
    assert run.code == 2, f"bad input accepted with exit code {run.code}: {run.err[-500:]}"
    assert "Traceback" not in run.err + run.out
    assert run.err.startswith("cadcam: error: ") and run.err.endswith("\n") and run.err.count("\n") == 1, \
        f"not one line: {run.err!r}"
    line = run.err.strip()
    assert len(line) > len("cadcam: error: ") + 10
    if names:
        assert any(str(n) in line for n in names), f"{line!r} names none of {names}"
    if keys:
        assert any(k in line for k in keys), f"{line!r} names none of the keys {keys}"
    for path in absent:
        assert not Path(path).exists(), f"{path} was created for refused input"
    assert not own_temporaries(), "temporary files of this process left in the system's temporary folder"
    if root is not None:
        after = snapshot(root)
        assert after == before, f"files changed: {set(after) ^ set(before) or 'contents'}"


def own_temporaries() -> list[str]:
    """Hidden temporary files or folders of this process (``.cadcam-<pid>-…``) in the system's
    temporary folder."""
    return [n for n in os.listdir(tempfile.gettempdir()) if n.startswith(f".cadcam-{os.getpid()}-")]


def finite_numbers(value) -> bool:
    if isinstance(value, dict):
        return all(finite_numbers(v) for v in value.values())
    if isinstance(value, list):
        return all(finite_numbers(v) for v in value)
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return math.isfinite(value)
    return True


def assert_design_outcome(run: Run, out: Path):
    """A design that ran: exit 0 only with a finite success in result.json, 1 otherwise."""
    assert run.code in (0, 1), run.err
    assert "Traceback" not in run.err + run.out
    result = json.loads((out / "result.json").read_text())
    assert not [p for p in out.iterdir() if p.name.startswith(".") and p.name != MANIFEST], \
        "temporary files left behind"
    assert not own_temporaries()
    if run.code == 0:
        assert result["status"] == "success"
        assert finite_numbers(result["metrics"]) and finite_numbers(result["recheck"])
        assert finite_numbers(result["design"])
    else:
        assert result["status"] != "success" or "workshop files cannot be made" in run.err


def assert_evaluated(run: Run):
    assert run.code == 0 and run.err.count("cadcam: error") == 0, run.err
    assert "Traceback" not in run.err + run.out
    printed = json.loads(run.out)
    assert set(printed) == {"torque_model", "design", "metrics"}


# -- judging a mutation from the original value ---------------------------------------------------
def norm(path) -> str:
    return ".".join("*" if isinstance(p, int) else p for p in path)


def is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def is_finite_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


@dataclass(frozen=True)
class Rules:
    """What makes a mutation of one kind of input bad for sure.

    ``required``: normalised paths (list indices as ``*``) whose deletion is bad; ``judged``:
    whether a path's value is checked at all (``None``: every path is); ``closed``: whether a
    table refuses unknown keys (normalised path of the table); ``optional``: keys a table may
    leave out, each with a valid value (its kind decides what is bad)."""

    required: frozenset
    judged: object = None
    closed: object = lambda table: True
    optional: dict = field(default_factory=dict)  # table → {optional key: a valid value}

    def is_judged(self, path) -> bool:
        return self.judged is None or self.judged(norm(path))


def replace_is_bad(old, new) -> bool:
    """A value of the old one's kind is needed: a string for a string, an integer for an
    integer, a finite number for a number, a list for a list, a table for a table."""
    if isinstance(old, bool):
        return not isinstance(new, bool)
    if isinstance(old, str):
        return not isinstance(new, str)
    if is_int(old):
        return not is_int(new)
    if isinstance(old, float):
        return not is_finite_number(new)
    if isinstance(old, list):
        return not isinstance(new, list)
    if isinstance(old, dict):
        return not isinstance(new, dict)
    return False


SPEC_REQUIRED = {"cams", "cams.*", "cams.*.theta_range_deg", "cams.*.theta_range_deg.*",
                 "cams.*.sensitivity_weights.*", "cams.*.rho_min", "cams.*.rho_max", "cams.*.mu",
                 "cams.*.idler", "cams.*.idler.radius", "cams.*.idler.offset", "cams.*.target",
                 "cams.*.target.kind", "springs", "springs.*", "springs.*.rate", "springs.*.travel",
                 "springs.*.ports"}
SPEC_OPTIONAL = {
    "solver": {"seed": 0, "multistart": 0, "convexity_points": 120, "convexity_epsilon": 1e-3,
               "limit_margin": 1e-4, "tol": 1e-8, "objective": "least_squares", "method": "nlp", "ipopt": {}},
    "cams.*": {"min_curvature_radius": 0.001, "acceptance": {"rmse": 0.01}},
    "cams.*.target": {"parameters": {"a": 1.0}},
    "springs.*": {"preload": 1.0, "free_length": 0.1, "preextension": 0.01},
    "arm": {"g": 9.81}}
RULES_1DOF = Rules(frozenset(SPEC_REQUIRED | {"cams.*.target.expression", "springs.*.ports.*"}),
                   optional=SPEC_OPTIONAL)
RULES_RR = Rules(frozenset(SPEC_REQUIRED | {"cams.*.target.joint", "arm", "arm.masses", "arm.lengths",
                                            "arm.com", "arm.masses.*", "arm.lengths.*", "arm.com.*"}),
                 judged=lambda p: not p.startswith("variants"), optional=SPEC_OPTIONAL)
RESULT_REQUIRED = {"problem." + p for p in (  # not its name and source: they have defaults
    "joints", "joints.*", "joints.*.theta_range_deg", "joints.*.theta_range_deg.*",
    "joints.*.sensitivity_weights.*", "joints.*.target", "joints.*.target.kind", "joints.*.target.expression",
    "mechanisms", "mechanisms.*", "mechanisms.*.kind", "mechanisms.*.joint", "mechanisms.*.rho_min",
    "mechanisms.*.rho_max", "mechanisms.*.mu", "mechanisms.*.idler", "mechanisms.*.idler.radius",
    "mechanisms.*.idler.offset", "springs", "springs.*", "springs.*.rate", "springs.*.travel", "springs.*.ports",
    "springs.*.ports.*")} | {"problem"}
RULES_RESULT_SPEC = Rules(
    frozenset(RESULT_REQUIRED),
    judged=lambda p: p == "problem" or p.startswith("problem."),
    closed=lambda t: t not in ("problem.solver.ipopt", "problem.joints.*.target.parameters"),
    optional={"problem.springs.*": {"free_length": 0.1, "preextension": 0.01},
              "problem.mechanisms.*": {"min_curvature_radius": 0.001},
              "problem.joints.*": {"acceptance": {"max_abs_error": 0.01}}})
DESIGN_PATHS = ("design", "design.cams", "design.cams.*", "design.cams.*.coefficients", "design.cams.*.domain",
                "design.preextension")
RULES_DESIGN = Rules(
    frozenset({"design", "design.cams", "design.cams.*", "design.preextension", "design.preextension.*",
               "design.cams.*.domain.*"}),
    judged=lambda p: p in DESIGN_PATHS or any(p.startswith(d + ".") for d in DESIGN_PATHS[3:]),
    closed=lambda t: False)
RULES_TABLE3 = Rules(
    frozenset({"design", "design.cams", "design.cams.*", "design.preextension", "design.preextension.*",
               "design.cams.*.monomial_coefficients_highest_first"}),
    judged=lambda p: p in ("design", "design.cams", "design.cams.*") or p.startswith(
        ("design.cams.*.monomial_coefficients_highest_first", "design.preextension")),
    closed=lambda t: False)
RULES_STUDY = Rules(
    frozenset({"name", "base", "parameters", "parameters.*.key", "parameters.*.values", "parameters.*.values.*",
               "parameters.*.catalogue"}),
    judged=lambda p: p != "notes")


# -- values and mutations -------------------------------------------------------------------------
NAN, INF = math.nan, math.inf
NUMBERS = st.sampled_from([0, -1, 1, 2, 0.0, -0.0, 0.5, 3.7, 1e-300, 5e-324, 1e300, -1e300, 1e9, 2**63 - 1,
                           -(2**63)]) | st.floats(-1e6, 1e6, allow_nan=False)
NON_FINITE = st.sampled_from([NAN, INF, -INF])
STRINGS = st.sampled_from(["", " ", "abc", "1100", "0.02", "nan", "true", "[1, 2]", "é", "\u00a0",
                           "cams.1.rate", "wire:1", "-platform:9"]) | st.text(max_size=8)
LISTS = st.sampled_from([[], [1], [1.0, 2.0, 3.0], ["a"], [[]], [{}], [True], [NAN, 1.0]])
TABLES = st.sampled_from([{}, {"x": 1}, {"rate": 1.0}, {"": ""}])
BOOLS = st.booleans()
EXPRESSIONS = st.sampled_from([
    "", " ", "theta**", "0.08*theta**2 +", "theta**1e10", "1e308*1e308*theta", "exp(1000*theta)",
    "exp(exp(exp(theta)))", "(" * 150 + "theta" + ")" * 150, "theta if theta else 0", "lambda: 0", "[theta]",
    "theta[0]", "sin(theta, theta)", "sin(theta=1)", "theta.__class__", "__import__('os').getcwd()",
    "0x10*theta", "1_000*theta", "theta @ theta", "theta // 2", "theta % 2", "not theta", "theta < 1", "θ",
    "Theta", "pi*theta", "e**theta", "sqrt(-1)", "log(0)", "1/0", "0/0", "0**-1", "theta**theta", "(-1)**theta",
    "0.08*theta**2\n", "0.08*\ntheta", "0.08*theta**2 # comment", "'0.08'", "theta1*theta2", "theta3",
    "atan2(theta, 0)", "asin(theta)", "1/(theta-1)", "tan(theta)", "1e400", "-" * 300 + "theta"])


def wrong_value(old, json_values: bool) -> st.SearchStrategy:
    """Values that :func:`replace_is_bad` calls bad for ``old``."""
    none = st.just(None) if json_values else st.nothing()
    if isinstance(old, bool):
        return NUMBERS | STRINGS | LISTS | TABLES | none
    if isinstance(old, str):
        return NUMBERS | NON_FINITE | BOOLS | LISTS | TABLES | none
    if is_int(old):
        return (STRINGS | BOOLS | LISTS | TABLES | NON_FINITE | none
                | st.sampled_from([0.5, 3.0, -1.5, 1e300]))
    if isinstance(old, float):
        return STRINGS | BOOLS | LISTS | TABLES | NON_FINITE | none
    if isinstance(old, list):
        return NUMBERS | STRINGS | BOOLS | TABLES | none
    return NUMBERS | STRINGS | BOOLS | LISTS | none


def any_value(old, json_values: bool) -> st.SearchStrategy:
    """Values of the old one's kind (valid or not), or anything at all."""
    if isinstance(old, str):
        return STRINGS | EXPRESSIONS
    if isinstance(old, (int, float)) and not isinstance(old, bool):
        return NUMBERS | st.just(old * 2) | st.just(-old)
    if isinstance(old, list):
        return LISTS | st.just(old[:1]) | st.just(old + old[-1:]) if old else LISTS
    if isinstance(old, dict):
        return TABLES
    return wrong_value(old, json_values)


UNKNOWN_KEYS = st.sampled_from(["colour", "Rate", "rate ", "idler_radius", "offest", "kind2", "", " ", "é",
                                "x.y", "__class__", "springs ", "cams_", "solver2", "0",
                                # keys of the other form, or the old name of one given
                                "joints", "mechanisms", "cams", "friction_model"])


def paths(tree, prefix=()):
    """Every (path, value) below ``tree``."""
    items = tree.items() if isinstance(tree, dict) else enumerate(tree) if isinstance(tree, list) else ()
    for k, v in items:
        yield prefix + (k,), v
        yield from paths(v, prefix + (k,))


def get(tree, path):
    for p in path:
        tree = tree[p]
    return tree


def under(path, other) -> bool:
    """Whether ``path`` is ``other`` or lies below it (or above it)."""
    n = min(len(path), len(other))
    return path[:n] == other[:n]


def key_of(path) -> str:
    return next((p for p in reversed(path) if isinstance(p, str)), "")


@dataclass
class Mutant:
    data: object
    bad: bool = False
    keys: list = field(default_factory=list)  # keys an error message may name
    ops: list = field(default_factory=list)
    precise: bool = True  # whether a bad input's message must name one of ``keys`` (all changes bad)


@st.composite
def mutate_tree(draw, base, rules: Rules, json_values: bool = False, max_ops: int = 3,
                only_bad: bool = False, scope=lambda path: True, kinds=None) -> Mutant:
    """1…``max_ops`` mutations of ``base`` at paths none of which lies below or above another,
    judged by ``rules``; ``only_bad`` draws only mutations that are bad for sure; only paths
    (normalised) for which ``scope`` holds are mutated, only by the operations in ``kinds``."""
    m = Mutant(copy.deepcopy(base))
    touched = []
    free = lambda p: not any(under(p, t) for t in touched)  # noqa: E731
    for _ in range(draw(st.integers(1, max_ops))):
        everything = [(p, v) for p, v in paths(m.data) if scope(norm(p))]
        judged = (lambda p: rules.is_judged(p)) if only_bad else (lambda p: True)
        pools = {
            "replace": [p for p, _ in everything if free(p) and judged(p)],
            # deleting a list element shifts its siblings: the whole list counts as touched
            "delete": [p for p, _ in everything if free(p[:-1] if isinstance(p[-1], int) else p) and judged(p)
                       and (not only_bad or norm(p) in rules.required)],
            "rename": [p for p, _ in everything if isinstance(p[-1], str) and free(p) and judged(p)
                       and (not only_bad or rules.closed(norm(p[:-1])))],
            "add": [t for t in [()] * scope("") + [p for p, v in everything if isinstance(v, dict)]
                    if free(t + ("\0",)) and judged(t + ("x",)) and (not only_bad or rules.closed(norm(t)))],
            "add_known": [t for t in [()] * scope("") + [p for p, v in everything if isinstance(v, dict)]
                          if free(t + ("\0",)) and set(rules.optional.get(norm(t), ())) - set(get(m.data, t))],
        }
        if not only_bad:
            pools["replace_any"] = pools["replace"]
        ops = sorted(k for k, v in pools.items() if v and (kinds is None or k in kinds))
        if not ops:
            break
        op = draw(st.sampled_from(ops))
        target = draw(st.sampled_from(pools[op]))
        if op in ("replace", "replace_any"):
            path, old = target, get(m.data, target)
            new = draw(wrong_value(old, json_values) if op == "replace" else any_value(old, json_values))
            get(m.data, path[:-1])[path[-1]] = new
            bad = rules.is_judged(path) and replace_is_bad(old, new)
            touched.append(path)
            m.keys.append(key_of(path))
        elif op == "delete":
            path, new = target, None
            del get(m.data, path[:-1])[path[-1]]
            bad = rules.is_judged(path) and norm(path) in rules.required
            touched.append(path[:-1] if isinstance(path[-1], int) else path)
            m.keys.append(key_of(path))
            # a missing list element or spring list is named where it no longer fits
            m.precise &= not (bad and (isinstance(path[-1], int) or key_of(path) == "springs"))
        elif op == "add":
            key = draw(UNKNOWN_KEYS.filter(lambda k: k not in get(m.data, target)))
            new = draw(NUMBERS | STRINGS | TABLES | LISTS)
            get(m.data, target)[key] = new
            path = target + (key,)
            bad = rules.is_judged(path) and rules.closed(norm(target))
            touched.append(path)
            m.keys.append(key)
        elif op == "add_known":  # an optional key the input leaves at its default
            known = rules.optional[norm(target)]
            key = draw(st.sampled_from(sorted(set(known) - set(get(m.data, target)))))
            default = known[key]
            new = draw(wrong_value(default, json_values) if only_bad else any_value(default, json_values)
                       if kinds is not None and "replace" not in kinds
                       else wrong_value(default, json_values) | any_value(default, json_values))
            get(m.data, target)[key] = new
            path = target + (key,)
            bad = rules.is_judged(path) and replace_is_bad(default, new)
            touched.append(path)
            m.keys.append(key)
        else:  # rename
            path = target
            parent = get(m.data, path[:-1])
            new = draw(st.sampled_from([path[-1] + "_", path[-1] + "s", path[-1] + " ", path[-1].upper(),
                                        path[-1][:-1], path[-1].replace("_", "-")]))
            if new in parent or new == path[-1]:
                new = path[-1] + "_x"
            parent[new] = parent.pop(path[-1])
            bad = rules.is_judged(path) and rules.closed(norm(path[:-1]))
            touched += [path, path[:-1] + (new,)]
            m.keys += [path[-1], new]
        m.bad |= bad
        m.precise &= bad  # a change that may be valid can still break something reported first
        m.ops.append((op, path, new, bad))
    note(f"mutations: {m.ops}")
    return m


# text-level mutations of a file's bytes: (name, function of bytes and a drawn position)
def _insert(b: bytes, at: int, what: bytes) -> bytes:
    return b[:at] + what + b[at:]


TEXT_OPS = {
    "truncate": lambda b, at: b[:at],
    "non-UTF-8 byte": lambda b, at: _insert(b, at, b"\xff"),
    "latin-1 e-acute": lambda b, at: _insert(b, at, b"\xe9t\xe9"),
    "NUL byte": lambda b, at: _insert(b, at, b"\x00"),
    "byte order mark": lambda b, at: b"\xef\xbb\xbf" + b,
    "UTF-16": lambda b, at: b.decode().encode("utf-16"),
    "CRLF line ends": lambda b, at: b.replace(b"\n", b"\r\n"),
    "line dropped": lambda b, at: b"\n".join(line for i, line in enumerate(b.split(b"\n"))
                                             if i != at % max(b.count(b"\n"), 1)),
    "line doubled": lambda b, at: b"\n".join(x for i, line in enumerate(b.split(b"\n"))
                                             for x in ([line, line] if i == at % max(b.count(b"\n"), 1) else [line])),
    "equals as colon": lambda b, at: b.replace(b" = ", b": ", 1 + at % 3),
    "empty": lambda b, at: b"",
    "blank": lambda b, at: b" \n\t\n",
    "decimal commas": lambda b, at: b.replace(b"0.0", b"0,0"),
}


@st.composite
def mutate_bytes(draw, text: str):
    raw = text.encode()
    name = draw(st.sampled_from(sorted(TEXT_OPS)))
    at = draw(st.integers(0, len(raw)))
    note(f"text mutation: {name} at {at}")
    return name, TEXT_OPS[name](raw, at)


def toml_verdict(raw: bytes) -> bool:
    """Whether ``raw`` is certainly bad as a TOML file: not UTF-8 or not TOML (a byte order
    mark may be taken or refused)."""
    try:
        tomllib.loads(raw.decode("utf-8").removeprefix("\ufeff"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError):
        return True
    return False


def json_verdict(raw: bytes) -> bool:
    """Whether ``raw`` is certainly bad as a JSON file."""
    try:
        json.loads(raw.decode("utf-8").removeprefix("\ufeff"))
    except (UnicodeDecodeError, ValueError):
        return True
    return False


# -- fixtures --------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def designed(tmp_path_factory):
    """``cadcam design`` of the fast 1-DOF spec: its folder (result.json is a valid design and a
    valid spec; no figures, which nothing here reads). Checked like every design: exit 0 only
    with a finite success."""
    root = tmp_path_factory.mktemp("designed")
    (root / "spec.toml").write_text(FAST_1DOF)
    with contextlib.redirect_stdout(open(os.devnull, "w")):
        code = main(["design", str(root / "spec.toml"), "-o", str(root / "out"), "--no-figures"])
    run = Run([], code, "", "")
    assert_design_outcome(run, root / "out")
    return root / "out"


class Scratch:
    """A fresh folder per example under the test's tmp_path."""

    def __init__(self, base: Path):
        self.base = base

    def __call__(self) -> Path:
        return Path(tempfile.mkdtemp(dir=self.base))


@pytest.fixture
def scratch(tmp_path):
    return Scratch(tmp_path)


# -- specs -----------------------------------------------------------------------------------------
SPECS = {"1dof": (TREE_1DOF, RULES_1DOF), "rr": (TREE_RR, RULES_RR)}


@st.composite
def spec_cases(draw):
    which = draw(st.sampled_from(sorted(SPECS)))
    base, rules = SPECS[which]
    return which, draw(mutate_tree(base, rules))


def _design_for(which: str, designed: Path) -> Path:
    return designed / "result.json" if which == "1dof" else TABLE3


@_settings(160)
@given(case=spec_cases())
@pytest.mark.slow  # dozens of generated specs evaluated: make test-slow
def test_mutated_specs_evaluate_or_are_refused_in_one_line(case, designed, scratch, capfd):
    which, m = case
    work = scratch()
    spec = work / "spec.toml"
    spec.write_text(to_toml(m.data))
    before = snapshot(work)
    design = _design_for(which, designed)
    run = cli(capfd, "evaluate", spec, "--design", design, "--grid", 5, cwd=work)
    event(f"spec {which}: {'bad' if m.bad else 'any'} -> exit {run.code}")
    if m.bad or run.code == 2:
        assert_refused(run, names=[spec, design], root=work, before=before,
                       keys=m.keys if m.bad and m.precise else ())
    else:
        assert_evaluated(run)


@_settings(60)
@given(case=st.sampled_from(sorted(SPECS)).flatmap(
    lambda w: st.tuples(st.just(w), mutate_bytes(FAST_1DOF if w == "1dof" else FAST_RR))))
@pytest.mark.slow  # dozens of damaged specs evaluated: make test-slow
def test_damaged_spec_files_evaluate_or_are_refused_in_one_line(case, designed, scratch, capfd):
    which, (name, raw) = case
    work = scratch()
    spec = work / "spec.toml"
    spec.write_bytes(raw)
    before = snapshot(work)
    run = cli(capfd, "evaluate", spec, "--design", _design_for(which, designed), "--grid", 5, cwd=work)
    bad = toml_verdict(raw)
    event(f"spec file {name}: {'bad' if bad else 'any'} -> exit {run.code}")
    if bad or run.code == 2:
        assert_refused(run, names=[spec], root=work, before=before)
    else:
        assert_evaluated(run)


@_settings(60)
@given(m=mutate_tree(TREE_1DOF, RULES_1DOF, only_bad=True))
def test_bad_specs_leave_no_design_folder(m, scratch, capfd):
    """``cadcam design`` on a spec that is bad for sure: refused before any work, no folder."""
    assert m.bad
    work = scratch()
    spec = work / "spec.toml"
    spec.write_text(to_toml(m.data))
    before = snapshot(work)
    out = work / "out" / "deeper"
    run = cli(capfd, "design", spec, "-o", out, "--grid", 5, cwd=work)
    assert_refused(run, names=[spec], keys=m.keys if m.precise else (), absent=[work / "out"], root=work,
                   before=before)


# -- a result.json as the spec -----------------------------------------------------------------------
@pytest.fixture(scope="module")
def result_tree(designed):
    return json.loads((designed / "result.json").read_text())


@_settings(50)
@given(data=st.data())
def test_mutated_result_json_as_spec_evaluates_or_is_refused(data, result_tree, designed, scratch, capfd):
    m = data.draw(mutate_tree({"problem": result_tree["problem"], "status": "success"}, RULES_RESULT_SPEC,
                              json_values=True))
    work = scratch()
    spec = work / "result.json"
    spec.write_text(json.dumps(m.data))
    before = snapshot(work)
    run = cli(capfd, "evaluate", spec, "--design", designed / "result.json", "--grid", 5, cwd=work)
    event(f"result as spec: {'bad' if m.bad else 'any'} -> exit {run.code}")
    if m.bad or run.code == 2:
        assert_refused(run, names=[spec, designed / "result.json"], root=work, before=before,
                       keys=m.keys + ["problem"] if m.bad and m.precise else ())
    else:
        assert_evaluated(run)


# -- designs -----------------------------------------------------------------------------------------
@_settings(90)
@given(data=st.data(), which=st.sampled_from(["result", "table3"]))
@pytest.mark.slow  # dozens of generated designs evaluated: make test-slow
def test_mutated_designs_evaluate_or_are_refused(data, which, result_tree, scratch, capfd):
    # the design and a few of the members around it that evaluate must ignore
    base = ({k: result_tree[k] for k in ("design", "status", "torque_model")} if which == "result"
            else json.loads(TABLE3.read_text()))
    rules = RULES_DESIGN if which == "result" else RULES_TABLE3
    m = data.draw(mutate_tree(base, rules, json_values=True, max_ops=1))
    work = scratch()
    design = work / "design.json"
    design.write_text(json.dumps(m.data))
    spec = work / "spec.toml"
    spec.write_text(FAST_1DOF if which == "result" else FAST_RR)
    before = snapshot(work)
    run = cli(capfd, "evaluate", spec, "--design", design, "--grid", 5, cwd=work)
    event(f"design {which}: {'bad' if m.bad else 'any'} -> exit {run.code}")
    if m.bad or run.code == 2:
        assert_refused(run, names=[design], root=work, before=before)
    else:
        assert_evaluated(run)


@_settings(40)
@given(data=st.data())
def test_damaged_design_files_are_refused_or_evaluate(data, designed, scratch, capfd):
    text = data.draw(st.sampled_from([(designed / "result.json").read_text(), TABLE3.read_text()]))
    name, raw = data.draw(mutate_bytes(text))
    work = scratch()
    design = work / "design.json"
    design.write_bytes(raw)
    spec = work / "spec.toml"
    spec.write_text(FAST_1DOF if '"problem"' in text else FAST_RR)
    before = snapshot(work)
    run = cli(capfd, "evaluate", spec, "--design", design, "--grid", 5, cwd=work)
    bad = json_verdict(raw)
    event(f"design file {name}: {'bad' if bad else 'any'} -> exit {run.code}")
    if bad or run.code == 2:
        assert_refused(run, names=[design], root=work, before=before)
    else:
        assert_evaluated(run)


# -- target tables (CSV) -------------------------------------------------------------------------------
TABLE_SPEC = FAST_1DOF.replace('kind = "expression"\nexpression = "0.08*theta**2"', 'kind = "table"\nfile = "{file}"')
assert TABLE_SPEC != FAST_1DOF
CELLS = st.sampled_from(["", " ", "nan", "inf", "-inf", "1e400", "abc", "0x10", "−1", "NaN", "Infinity",
                         "1.0.0", '"0.5"', "1e-300", "0,5", "١", "1 0"])


@st.composite
def target_tables(draw):
    """(spec's file key, CSV bytes): a table of 0.08 θ² over the joint's range, mutated."""
    often = lambda usual, *odd: st.sampled_from([usual] * (8 * len(odd)) + list(odd))  # noqa: E731
    angle = draw(often("theta_rad", "theta_deg", "theta", "Theta_rad", " theta_rad ", "angle"))
    value = draw(often("torque_Nm", "torque", "torque_Nmm", "x_m", ""))
    n = draw(often(10, 0, 1, 3, 4, 12))
    span = 90.0 if angle.strip() == "theta_deg" else math.pi / 2
    if draw(often(False, True)):  # angles in the other unit than the header says
        span = math.pi / 2 if span == 90.0 else 90.0
    lo, hi = draw(often((0.0, 1.0), (0.1, 1.0), (0.0, 0.9), (-0.5, 1.5)))
    theta = np.linspace(lo * span, hi * span, n)
    rows = [[repr(float(t)), repr(float(0.08 * t**2))] for t in theta]
    for _ in range(draw(often(0, 1, 2, 3))):
        kind = draw(st.sampled_from(["cell", "extra", "short", "blank", "duplicate", "shuffle", "none"]))
        if not rows:
            break
        k = draw(st.integers(0, len(rows) - 1))
        if kind == "cell":
            rows[k][draw(st.integers(0, 1))] = draw(CELLS)
        elif kind == "extra":
            rows[k] = rows[k] + ["1"]
        elif kind == "short":
            rows[k] = rows[k][:1]
        elif kind == "blank":
            rows.insert(k, [])
        elif kind == "duplicate":
            rows.insert(k, list(rows[k]))
        elif kind == "shuffle":
            rows = draw(st.permutations(rows))
    sep = draw(often(",", ";", "\t", ", "))
    eol = draw(often("\n", "\r\n"))
    text = eol.join(sep.join(r) for r in [[angle, value]] + rows) + draw(st.sampled_from([eol, ""]))
    raw = text.encode()
    damage = draw(often("none", "bom", "non-UTF-8", "NUL", "UTF-16", "empty"))
    raw = {"none": raw, "bom": b"\xef\xbb\xbf" + raw, "non-UTF-8": raw + b"\xff", "NUL": raw.replace(b"0", b"\x00", 1),
           "UTF-16": text.encode("utf-16"), "empty": b""}[damage]
    name = draw(often("t.csv", "./t.csv", "T.CSV", "t.csv ", "", ".", "spec.toml", "missing.csv", "{abs}"))
    note(f"table: header {angle!r},{value!r}, {len(rows)} rows, sep {sep!r}, {damage}, file {name!r}")
    return name, raw


def table_is_valid(work: Path, name: str) -> bool:
    """An oracle written from the README's format, without cadcam: a regular UTF-8 file (a byte
    order mark allowed) with header theta_rad or theta_deg and torque_Nm, at least 4 rows of two
    finite numbers, distinct angles covering [0, 90°]."""
    import csv
    import io
    path = work / name
    if not name or not path.is_file():
        return False
    try:
        text = path.read_bytes().decode("utf-8").removeprefix("\ufeff")
        rows = [r for r in csv.reader(io.StringIO(text, newline=""))]
    except (UnicodeDecodeError, csv.Error):
        return False
    if not rows or [h.strip() for h in rows[0]] not in (["theta_rad", "torque_Nm"], ["theta_deg", "torque_Nm"]):
        return False
    body = [r for r in rows[1:] if r]
    try:
        data = np.array([[float(v) for v in r] for r in body], dtype=float)
    except ValueError:
        return False
    if data.ndim != 2 or data.shape[0] < 4 or data.shape[1] != 2 or not np.all(np.isfinite(data)):
        return False
    angles = np.sort(np.radians(data[:, 0]) if rows[0][0].strip() == "theta_deg" else data[:, 0])
    return bool(np.all(np.diff(angles) > 0) and angles[0] <= 1e-12 and angles[-1] >= math.pi / 2 - 1e-12)


@_settings(60)
@given(table=target_tables())
def test_generated_target_tables_evaluate_exactly_when_valid(table, designed, scratch, capfd):
    name, raw = table
    work = scratch()
    (work / "t.csv").write_bytes(raw)
    name = name.replace("{abs}", str(work / "t.csv"))
    spec = work / "spec.toml"
    spec.write_text(TABLE_SPEC.replace("{file}", name.replace("\\", "\\\\")))
    before = snapshot(work)
    run = cli(capfd, "evaluate", spec, "--design", designed / "result.json", "--grid", 5, cwd=work)
    valid = table_is_valid(work, name)
    event(f"table: {'valid' if valid else 'bad'} -> exit {run.code}")
    if valid:
        assert_evaluated(run)
    else:
        assert_refused(run, names=[spec], keys=["file", "target"], root=work, before=before)


# -- studies -------------------------------------------------------------------------------------------
def _trimmed(study: dict) -> dict:
    """A shipped study with one value per parameter: any case it runs is one small solve."""
    out = copy.deepcopy(study)
    for p in out.get("parameters", []):
        if "values" in p:
            p["values"] = p["values"][:1]
    return out


STUDY_TREES = {p.stem: _trimmed(tomllib.loads(p.read_text())) for p in STUDY_FILES}


@pytest.fixture(scope="module")
def study_root(tmp_path_factory):
    """models/ (the fast specs, a one-spring catalogue) and studies/ (the shipped studies, one
    value per parameter) laid out as in the repository, so their relative paths hold."""
    root = tmp_path_factory.mktemp("studies")
    (root / "models").mkdir()
    (root / "studies").mkdir()
    (root / "out").mkdir()
    (root / "models" / SPEC_1DOF.name).write_text(FAST_1DOF)
    (root / "models" / SPEC_RR.name).write_text(FAST_RR)
    catalogue = (MODELS / "spring_catalogue.csv").read_text().splitlines()
    (root / "models" / "spring_catalogue.csv").write_text("\n".join(catalogue[:2]) + "\n")
    return root


def _sweep_contract(capfd, root: Path, study_text: bytes, bad: bool, keys=()):
    name = f"g{len(list((root / 'studies').iterdir()))}"
    study = root / "studies" / f"{name}.toml"
    study.write_bytes(study_text)
    db = root / "out" / f"{name}.db"
    before = snapshot(root)
    run = cli(capfd, "sweep", study, "-o", db, "--workers", 0, cwd=root)
    if currently_in_test_context():  # also called from a plain test
        event(f"study: {'bad' if bad else 'any'} -> exit {run.code}")
    if bad or run.code == 2:
        assert_refused(run, names=[study], keys=keys, root=root, before=before,
                       absent=[db, Path(f"{db}-wal"), Path(f"{db}-shm")])
        return
    assert run.code in (0, 1) and "Traceback" not in run.err + run.out, run.err
    with contextlib.closing(sqlite3.connect(db)) as con:
        statuses = [r[0] for r in con.execute("SELECT status FROM cases")]
    assert statuses, "a sweep that ran recorded no case"
    assert (run.code == 0) == all(s == "success" for s in statuses), statuses


@_settings(40)
@given(data=st.data(), which=st.sampled_from(sorted(STUDY_TREES)))
@pytest.mark.slow  # generated studies run: make test-slow
def test_mutated_studies_run_or_are_refused_before_any_case(data, which, study_root, capfd):
    m = data.draw(mutate_tree(STUDY_TREES[which], RULES_STUDY))
    _sweep_contract(capfd, study_root, to_toml(m.data).encode(), m.bad, m.keys if m.bad and m.precise else ())


@_settings(25)
@given(data=st.data(), which=st.sampled_from(sorted(STUDY_TREES)))
@pytest.mark.slow  # damaged studies run: make test-slow
def test_damaged_study_files_are_refused_or_run(data, which, study_root, capfd):
    name, raw = data.draw(mutate_bytes(to_toml(STUDY_TREES[which])))
    _sweep_contract(capfd, study_root, raw, toml_verdict(raw))


# -- command-line flags ----------------------------------------------------------------------------------
#: --set items: (text, bad for sure)
SET_ITEMS = [
    ("springs.1.rate=1200.0", False), ("cams.*.order=4", False), ("cams.1.idler.offset=0.01", False),
    ("solver.grid=7", False), ("springs.1={rate = 900.0}", False), ("solver={}", False), ("cams.1.idler={}", False),
    ("cams.1.target={kind=\"pendulum\", mass=1.0, length=0.1}", False), ("solver.tol=1e-6", False),
    ("", True), ("=", True), ("x", True), ("springs.1.rate", True), ("springs.1.rate=", True),
    ("springs.9.rate=1", True), ("springs.0.rate=1", True), ("springs.x.rate=1", True), ("springs..rate=1", True),
    (".=1", True), ("springs.1.rate=[", True), ("springs.1.rate=nan", True), ("springs.1.rate=inf", True),
    ("springs.1.rate=-1", True), ("springs.1.rate=true", True), ('springs.1.rate="1200"', True),
    ("cams.1.target.expression=1/theta", True), ("cams.1.target.expression=__import__('os')", True),
    ("nosuch.key=1", True), ("name.x=1", True), ("cams.*.rho_max=0.001", True), ("springs.*.ports=[]", True),
    ("solver.seed=-1", True), ("solver.seed=1.5", True), ("solver.grid=1", True), ('torque_model="coulomb"', True),
    ("cams=5", True), ("springs=[]", True), ("solver.ipopt={foo=1}", True), ("solver.ipopt={max_iter=10}", True),
    ("a=b=c", True), ("cams.1.name=5", True), ("cams.*.theta_range_deg=[0, 1e9]", True),
    ("cams.*.theta_range_deg=[-200, -100]", True), ("solver.recheck_factor=1000", True), ("solver.multistart=-1", True),
]
GRID_BAD = ["0", "1", "2", "-1", "-100", "2001", "1000000000", str(2**70)]
GRID_OK = ["3", "4", "7", "12"]
RANDOM_SET = st.builds(lambda k, v: f"{k}={v}", st.text("abcs.*1_ ", max_size=12), st.text(max_size=6))


@st.composite
def evaluate_argv(draw):
    """(which spec, edits): changes to ``cadcam evaluate SPEC --design D --grid 5``; each edit
    is (kind, value, bad for sure)."""
    which = draw(st.sampled_from(["1dof", "rr"]))
    edits = []
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["grid", "grid", "set", "set", "set", "random_set", "torque_model", "variant",
                                     "spec", "design"]))
        if kind == "grid":
            value = draw(st.sampled_from(GRID_BAD + GRID_OK))
            edits.append((kind, value, value in GRID_BAD))
        elif kind == "set":
            edits.append((kind, *draw(st.sampled_from(SET_ITEMS))))
        elif kind == "random_set":
            edits.append(("set", draw(RANDOM_SET), False))
        elif kind == "torque_model":
            edits.append((kind, draw(st.sampled_from(["energy", "force", "force-as-printed"])), False))
        elif kind == "variant":
            value = draw(st.sampled_from(["sec10_5", "nosuch", "", "SEC10_5"]))
            edits.append((kind, value, value != "sec10_5" or which == "1dof"))
        else:
            edits.append((kind, draw(st.sampled_from(["missing", "folder", "/dev/null", "empty", "swapped", "csv"])),
                          True))
    note(f"{which}: {edits}")
    return which, edits


def _path_for(kind: str, how: str, work: Path, designed: Path) -> Path:
    """A wrong file where a spec or design is expected."""
    if how == "missing":
        return work / "nope.toml"
    if how == "folder":
        return work
    if how == "/dev/null":
        return Path(os.devnull)
    if how == "empty":
        (work / "empty.json").write_text("")
        return work / "empty.json"
    if how == "csv":
        return MODELS / "spring_catalogue.csv"
    # swapped: a design where the spec belongs and a spec where the design belongs
    return TABLE3 if kind == "spec" else SPEC_1DOF


@_settings(70)
@given(case=evaluate_argv())
def test_generated_evaluate_flags(case, designed, scratch, capfd):
    which, edits = case
    work = scratch()
    spec = work / "spec.toml"
    spec.write_text(FAST_1DOF if which == "1dof" else FAST_RR)
    design = _design_for(which, designed)
    flags, names = ["--grid", "5"], [spec, design, "--grid", "--set", "--variant", "--torque-model"]
    last = {}  # of a repeated flag the last counts
    for kind, value, bad in edits:
        if kind in ("spec", "design"):
            path = _path_for(kind, value, work, designed)
            spec, design = (path, design) if kind == "spec" else (spec, path)
            names.append(path)
        else:
            flags += [f"--{kind.replace('_', '-')}", value]
        last[kind if kind != "set" else ("set", len(last))] = bad
    before = snapshot(work)
    run = cli(capfd, "evaluate", spec, "--design", design, *flags, cwd=work)
    bad = any(last.values())
    event(f"evaluate flags: {'bad' if bad else 'any'} -> exit {run.code}")
    if bad or run.code == 2:
        assert_refused(run, names=names, root=work, before=before)
    else:
        assert_evaluated(run)


WORKSHOP_BAD = {"--bore-diameter": ["0", "-1", "nan", "inf", "-inf", "1e9"],
                "--anchor-diameter": ["0", "-1", "nan", "inf", "1e9"],
                "--tolerance": ["0", "-1", "nan", "inf", "1e-300", "1"],
                "--stl": ["0", "-1", "nan", "inf", "1e9"],
                "--groove-depth": ["-1", "nan", "inf", "1e9"], "--groove-width": ["-1", "nan", "-inf", "1e9"],
                "--groove-pitch": ["0", "-1", "nan", "inf", "1e9"]}


@st.composite
def bad_design_argv(draw):
    """Edits of ``cadcam design SPEC -o OUT --grid 5`` of which at least one is bad for sure."""
    edits = []
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["grid", "multistart", "workshop", "workshop", "set", "variant", "output"]))
        if kind == "grid":
            edits.append(("--grid", draw(st.sampled_from(GRID_BAD))))
        elif kind == "multistart":
            edits.append(("--multistart", draw(st.sampled_from(["-1", "101", "1000000000"]))))
        elif kind == "workshop":
            flag = draw(st.sampled_from(sorted(WORKSHOP_BAD)))
            edits.append((flag, draw(st.sampled_from(WORKSHOP_BAD[flag]))))
        elif kind == "set":
            edits.append(("--set", draw(st.sampled_from([t for t, bad in SET_ITEMS if bad]))))
        elif kind == "variant":
            edits.append(("--variant", draw(st.sampled_from(["nosuch", "", "sec10_5"]))))
        else:
            edits.append(("-o", draw(st.sampled_from(["file", "under a file"]))))
    note(f"design edits: {edits}")
    return edits


@_settings(50)
@given(edits=bad_design_argv())
def test_bad_design_flags_are_refused_before_any_work(edits, scratch, capfd):
    work = scratch()
    spec = work / "spec.toml"
    spec.write_text(FAST_1DOF)
    (work / "f").write_text("a file, not a folder")
    out, flags = work / "out" / "sub", ["--grid", "5"]
    for flag, value in edits:
        if flag == "-o":
            out = work / "f" if value == "file" else work / "f" / "sub"
        else:
            flags += [flag, value]
    before = snapshot(work)
    run = cli(capfd, "design", spec, "-o", out, *flags, cwd=work)
    assert_refused(run, names=[spec, "-o", *{f for f, _ in edits}], absent=[work / "out"], root=work,
                   before=before)


# -- designs that run: a few perturbations of the 1-DOF spec's numbers and solver options ---------------------
def _solvable(path: str) -> bool:
    """Paths whose values change the numbers of a small solve, not its size (a joint's range and
    a profile's order are left alone: they make larger problems)."""
    return path in ("", "solver", "springs.*", "cams.*", "cams.*.idler") or path.startswith(
        ("solver.", "springs.*.rate", "springs.*.travel", "springs.*.preload", "springs.*.free_length",
         "springs.*.preextension", "cams.*.idler.", "cams.*.mu", "cams.*.rho_", "cams.*.tracking_weight",
         "cams.*.min_curvature_radius", "cams.*.acceptance"))


@_settings(4)
@given(m=mutate_tree(TREE_1DOF, RULES_1DOF, max_ops=2, scope=_solvable, kinds=("replace_any", "add_known")))
@pytest.mark.slow  # seconds of designs: make test-slow
def test_designs_succeed_only_when_the_recheck_says_so(m, scratch, capfd):
    work = scratch()
    spec = work / "spec.toml"
    spec.write_text(to_toml(m.data))
    before = snapshot(work)
    out = work / "out"
    run = cli(capfd, "design", spec, "-o", out, "--grid", 5, "--multistart", 0, cwd=work)
    event(f"design: {'bad' if m.bad else 'any'} -> exit {run.code}")
    if m.bad or run.code == 2:
        assert_refused(run, names=[spec], absent=[out], root=work, before=before)
    else:
        assert_design_outcome(run, out)


# -- sweep, sweep-export and plot-study flags ---------------------------------------------------------------
@pytest.fixture(scope="module")
def swept(study_root, tmp_path_factory):
    """A study database from one small case of the trimmed basis_order study."""
    study = study_root / "studies" / "basis_order.toml"
    study.write_text(to_toml(STUDY_TREES["basis_order"]))
    db = tmp_path_factory.mktemp("swept") / "s.db"
    with contextlib.redirect_stdout(open(os.devnull, "w")), contextlib.redirect_stderr(open(os.devnull, "w")):
        assert main(["sweep", str(study), "-o", str(db), "--workers", "0"]) in (0, 1)
    return study, db


def _database(how: str, work: Path, db: Path) -> Path:
    """A database argument: the real one or something else."""
    if how == "real":
        return db
    path = work / f"{how}.db"
    if how == "folder":
        path.mkdir()
    elif how == "text":
        path.write_text("not sqlite at all\n" * 50)
    elif how == "empty":
        path.write_bytes(b"")
    elif how == "other sqlite":
        with contextlib.closing(sqlite3.connect(path)) as con:
            con.execute("CREATE TABLE t (x)")
            con.commit()
    return path  # "missing": never made


@st.composite
def post_argv(draw):
    """(command, database, flags, bad for sure) for sweep-export and plot-study."""
    command = draw(st.sampled_from(["sweep-export", "plot-study"]))
    how = draw(st.sampled_from(["real"] * 5 + ["missing", "text", "empty", "other sqlite"]))
    bad = how != "real"
    if command == "sweep-export":
        out = draw(st.sampled_from(["new.csv", "new.csv", "sub/new.csv", "f", "f/x.csv", "."]))
        bad |= out in ("f/x.csv", ".")
        flags = ["--csv", out]
    else:
        x = draw(st.sampled_from(["cams.1.basis", "rmse_1", "objective", "nosuch"]))
        y = draw(st.sampled_from(["rmse_1", "objective", "RMSE_1", "x"]))
        out = draw(st.sampled_from(["p.png", "p.png", "sub/p.png", "f/p.png", "."]))
        bad |= x == "nosuch" or y in ("RMSE_1", "x") or out in ("f/p.png", ".")
        flags = ["--x", x, "--y", y, "-o", out] + draw(st.sampled_from([[], ["--pareto"], ["--color", "nosuch"]]))
        bad |= "nosuch" in flags[6:]
    note(f"{command} {how} {flags}")
    return command, how, flags, bad


@_settings(30)
@given(case=post_argv())
def test_generated_sweep_export_and_plot_study_flags(case, swept, scratch, capfd):
    command, how, flags, bad = case
    work = scratch()
    (work / "f").write_text("a file, not a folder")
    db = _database(how, work, swept[1])
    before = snapshot(work)
    run = cli(capfd, command, db, *flags, cwd=work)
    event(f"{command}: {'bad' if bad else 'any'} -> exit {run.code}")
    if bad or run.code == 2:
        assert_refused(run, names=[db, "--csv", "-o", "--x", "--y", "--color"], root=work, before=before)
    else:
        assert run.code == 0 and "Traceback" not in run.err + run.out, run.err
        written = work / flags[flags.index("--csv" if command == "sweep-export" else "-o") + 1]
        assert written.is_file() and written.stat().st_size > 0
        assert not [p for p in written.parent.iterdir() if p.name.startswith(".")]


@_settings(20)
@given(how=st.sampled_from(["folder", "text", "under a file", "real"]),
       workers=st.sampled_from(["0", "0", "-1", "257", "1000000000"]))
def test_generated_sweep_outputs_and_workers(how, workers, swept, scratch, capfd):
    """A valid study with a database path or worker count that may be wrong: refused before any
    case, or (the study's own database, already complete) nothing new to run."""
    work = scratch()
    (work / "f").write_text("a file, not a folder")
    db = {"folder": work, "text": work / "f", "under a file": work / "f" / "x.db", "real": swept[1]}[how]
    before = snapshot(work)
    run = cli(capfd, "sweep", swept[0], "-o", db, "--workers", workers, cwd=work)
    bad = how != "real" or workers != "0"
    event(f"sweep -o {how} --workers {workers}: exit {run.code}")
    if bad:
        assert_refused(run, names=[db, "-o", "--workers"], root=work, before=before)
    else:
        assert run.code in (0, 1) and "0 run now" in run.out and "Traceback" not in run.err


# -- what the generators found, fixed in spec.py, design.py and targets.py: kept as examples -------------
def _spec_with(**solver):
    tree = copy.deepcopy(TREE_1DOF)
    tree["solver"].update(solver)
    return tree


def _cam_with(**keys):
    tree = copy.deepcopy(TREE_1DOF)
    tree["cams"][0].update(keys)
    return tree


def _design_with(change):
    def make(designed):
        tree = json.loads((designed / "result.json").read_text())
        change(tree["design"]["cams"][0])
        return tree
    return make


FOUND = {  # name: (spec tree or None for the fast 1-DOF spec, design maker or None, key the message names)
    "a negative seed (numpy raised after the spec was accepted)": (_spec_with(seed=-1), None, "seed"),
    "a boolean seed": (_spec_with(seed=True), None, "seed"),
    "an unknown IPOPT option (CasADi raised at the build)": (_spec_with(ipopt={"foo": 1}), None, "foo"),
    "an IPOPT value out of range": (_spec_with(ipopt={"mu_init": -1.0}), None, "mu_init"),
    "an IPOPT iteration limit past the cap": (_spec_with(ipopt={"max_iter": 10**9}), None, "max_iter"),
    "an IPOPT output file": (_spec_with(ipopt={"output_file": "ipopt.out"}), None, "output_file"),
    "an HSL library named by the spec (IPOPT loaded it)": (
        _spec_with(ipopt={"linear_solver": "ma27", "hsllib": "libcoinhsl.so"}), None, "hsllib"),
    "a linear solver that is not installed (valid, failed after the build)": (
        _spec_with(ipopt={"linear_solver": "ma57"}), None, "linear_solver"),
    "a dual infeasibility tolerance of 1e10 (success far from the optimum)": (
        _spec_with(ipopt={"dual_inf_tol": 1e10}), None, "dual_inf_tol"),
    "a solver tolerance of 1 (success far from the optimum)": (_spec_with(tol=1.0), None, "tol"),
    "a wire cam whose profile interval is empty": (_cam_with(theta_range_deg=[-200.0, -100.0]), None,
                                                   "theta_range_deg"),
    "a joint range a million degrees out": (_cam_with(theta_range_deg=[1e6, 1e6 + 90]), None, "theta_range_deg"),
    "cams that are not an array of tables (named 'joints')": ({**TREE_1DOF, "cams": 5}, None, "cams"),
    "cams beside mechanisms (named 'joints')": ({**TREE_1DOF, "mechanisms": []}, None, "mechanisms"),
    "a design domain ending at infinity (OverflowError)": (None, _design_with(lambda c: c.update(domain=[0, 1e300])),
                                                          "domain"),
    "highest-first coefficients that are not a list (IndexError)": (
        None, _design_with(lambda c: [c.clear(), c.update(monomial_coefficients_highest_first=None)]),
        "monomial_coefficients_highest_first"),
    "coefficients as strings of digits (taken as numbers)": (
        None, _design_with(lambda c: c.update(coefficients=[str(v) for v in c["coefficients"]])), "coefficients"),
    "coefficients true and false (taken as 1 and 0)": (
        None, _design_with(lambda c: c.update(coefficients=[True, False])), "coefficients"),
    "a domain that is a string (named the coefficients)": (None, _design_with(lambda c: c.update(domain="ab")),
                                                           "domain"),
}


@pytest.mark.parametrize("name", sorted(FOUND))
def test_what_the_generators_found_is_refused_in_one_line(name, designed, tmp_path, capfd):
    tree, make_design, key = FOUND[name]
    spec = tmp_path / "spec.toml"
    spec.write_text(to_toml(tree) if tree is not None else FAST_1DOF)
    if make_design is None:  # through the solve's path: nothing may start
        run = cli(capfd, "design", spec, "-o", tmp_path / "out", "--grid", 5, cwd=tmp_path)
        names = [spec]
    else:
        design = tmp_path / "design.json"
        design.write_text(json.dumps(make_design(designed)))
        run = cli(capfd, "evaluate", spec, "--design", design, cwd=tmp_path)
        names = [design]
    assert_refused(run, names=names, keys=[key], absent=[tmp_path / "out"])


@pytest.mark.parametrize("where", ["spec", "table"])
def test_a_byte_order_mark_is_not_part_of_a_spec_or_table(where, designed, tmp_path, capfd):
    """Editors and spreadsheets write one; it used to make the first key or the header wrong."""
    angles = [float(t) for t in np.linspace(0, math.pi / 2, 9)]
    table = "theta_rad,torque_Nm\n" + "".join(f"{t!r},{0.08 * t * t!r}\n" for t in angles)
    (tmp_path / "t.csv").write_bytes((b"\xef\xbb\xbf" if where == "table" else b"") + table.encode())
    text = TABLE_SPEC.replace("{file}", "t.csv")
    (tmp_path / "spec.toml").write_bytes((b"\xef\xbb\xbf" if where == "spec" else b"") + text.encode())
    assert_evaluated(cli(capfd, "evaluate", tmp_path / "spec.toml", "--design", designed / "result.json",
                         "--grid", 5, cwd=tmp_path))


# -- more examples the suite found breaking the contract, since fixed ----------------------------------------
@pytest.mark.parametrize("argv", [
    ["evaluate", "{spec}", "--design", "{design}", "--grid", "abc"],
    ["evaluate", "{spec}", "--design", "{design}", "--grid", "1.5"],
    ["evaluate", "{spec}", "--design", "{design}", "--torque-model", "coulomb"],
    ["evaluate", "{spec}"],
    ["design", "{spec}", "-o", "{out}", "--gird", "5"],
    ["design", "{spec}", "-o", "{out}", "--tolerance", "1mm"],
])
def test_flags_argparse_refuses(argv, designed, tmp_path, capfd):
    argv = [a.format(spec=SPEC_1DOF, design=designed / "result.json", out=tmp_path / "out") for a in argv]
    assert_refused(cli(capfd, *argv, cwd=tmp_path), names=["--", "-o"], absent=[tmp_path / "out"])


@pytest.mark.parametrize("flag", ["--x", "--y", "--color"])
def test_an_empty_plot_column_is_refused(flag, swept, tmp_path, capfd):
    flags = {"--x": "rmse_1", "--y": "objective", "--color": "rmse_1", flag: ""}
    run = cli(capfd, "plot-study", swept[1], *[x for kv in flags.items() for x in kv], "-o", tmp_path / "p.png",
              cwd=tmp_path)
    assert_refused(run, names=[flag], absent=[tmp_path / "p.png"])


def test_a_design_nested_too_deep_is_one_line(tmp_path, capfd):
    design = tmp_path / "deep.json"
    design.write_text("[" * 100_000 + "]" * 100_000)
    run = cli(capfd, "evaluate", SPEC_1DOF, "--design", design, cwd=tmp_path)
    assert_refused(run, names=[design])


def test_a_catalogue_that_is_not_a_file_name_is_one_line(study_root, capfd):
    tree = copy.deepcopy(STUDY_TREES["spring_catalogue"])
    tree["parameters"][0]["catalogue"] = 5
    _sweep_contract(capfd, study_root, to_toml(tree).encode(), True, ["catalogue"])


@pytest.mark.parametrize("command,make", [
    pytest.param(command, make, id=f"{command}: {name}") for name, make, commands in [
        ("a folder", lambda path: path.mkdir(), ("sweep-export", "plot-study")),
        ("definition not JSON", lambda path: _study_table(path, "not json"), ("sweep-export", "plot-study")),
        ("definition a list", lambda path: _study_table(path, "[1]"), ("sweep-export",)),
        ("definition without record", lambda path: _study_table(path, "{}", cases=True),
         ("sweep-export", "plot-study"))]
    for command in commands])
def test_databases_that_are_not_study_databases_are_one_line(command, make, tmp_path, capfd):
    db = tmp_path / "x.db"
    make(db)
    flags = ["--csv", tmp_path / "o.csv"] if command == "sweep-export" else \
        ["--x", "a", "--y", "b", "-o", tmp_path / "o.png"]
    assert_refused(cli(capfd, command, db, *flags, cwd=tmp_path), names=[db])


def _study_table(path: Path, definition: str, cases: bool = False) -> None:
    with contextlib.closing(sqlite3.connect(path)) as con:
        con.execute("CREATE TABLE study (id INTEGER PRIMARY KEY, definition TEXT)")
        con.execute("INSERT INTO study VALUES (1, ?)", (definition,))
        con.execute("CREATE TABLE cases (case_id, idx, params, status, message, metrics, recheck, design, "
                    "iterations, solve_time_s, build_time_s, wall_time_s, error, cadcam_version, torque_model, "
                    "finished)")
        if cases:
            con.execute("INSERT INTO cases VALUES ('a', 0, '{}', 'success', NULL, NULL, NULL, NULL, 0, 0, 0, 0, "
                        "NULL, 'x', 'energy', 0)")
        con.commit()


@pytest.mark.slow  # a design far from its reference: make test-slow
def test_a_narrow_range_far_from_the_reference_is_bounded_work(tmp_path):
    """In a child process with 8 GB of address space, so that the failure is quick everywhere."""
    import resource
    import subprocess
    import sys
    spec = tmp_path / "spec.toml"
    spec.write_text(FAST_1DOF.replace("theta_range_deg = [0.0, 90.0]", "theta_range_deg = [89.99, 90.0]"))
    limit = lambda: resource.setrlimit(resource.RLIMIT_AS, (8 << 30, 8 << 30))  # noqa: E731
    p = subprocess.run([sys.executable, "-m", "cadcam", "design", str(spec), "-o", str(tmp_path / "o")],
                       capture_output=True, text=True, preexec_fn=limit, timeout=120, cwd=ROOT,
                       env={**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"})
    assert "Traceback" not in p.stderr and p.returncode in (0, 1, 2)
    assert p.returncode != 2 or p.stderr.count("\n") == 1


def test_an_empty_output_folder_is_refused(tmp_path, capfd):
    (tmp_path / "spec.toml").write_text(FAST_1DOF)
    run = cli(capfd, "design", "spec.toml", "-o", "", "--grid", 5, cwd=tmp_path)
    assert_refused(run, names=["-o"], absent=[tmp_path / "result.json"])


# -- output folders that already hold things (issue 29, item 3; issue 48) ---------------------------
#: Entries an output folder may already hold: names this run writes, and names it does not (a
#: 3-cam design's and an STL run's among them). tests/reliability/test_output_manifest.py
#: holds the folders of cadcam's own earlier sets, recorded in its manifest.
OUTPUT_NAMES = ("result.json", "torque.csv", "profile.csv", "cam1.dxf")
OTHER_NAMES = ("notes.txt", "data", "cam1_notes.txt", "cam3.dxf", "cam1.step")
ENTRY_KINDS = ("file", "folder", "link to a folder", "link to nothing")


@st.composite
def folder_contents(draw):
    """{name: kind} of what stands in the output folder before the run; ``result.json`` as a
    file is a user's, or one of a cadcam that kept no manifest of its files."""
    names = draw(st.lists(st.sampled_from(OUTPUT_NAMES + OTHER_NAMES), unique=True, max_size=5))
    contents = {n: draw(st.sampled_from(ENTRY_KINDS)) for n in names}
    if contents.get("result.json") == "file":
        contents["result.json"] = draw(st.sampled_from(["cadcam's result.json", "a user's result.json"]))
    return contents


def _fill(folder: Path, contents: dict) -> None:
    folder.mkdir()
    for name, kind in contents.items():
        path = folder / name
        if kind == "folder":
            path.mkdir()
            (path / "mine.txt").write_text("the user's")
        elif kind == "link to a folder":
            (folder.parent / f"target-{name}").mkdir()
            path.symlink_to(folder.parent / f"target-{name}")
        elif kind == "link to nothing":
            path.symlink_to(folder.parent / "nothing")
        elif kind == "cadcam's result.json":
            path.write_text(json.dumps({"cadcam_version": "0.1.0", "status": "success"}))
        else:
            path.write_text("the user's")


def _refused_for(contents: dict) -> bool:
    """Whether cadcam must refuse the folder: anything where an output of this run goes, for
    without a manifest no file there is recorded as cadcam's (not even an earlier cadcam's
    result.json: its other files may have been edited since)."""
    return any(n in contents for n in OUTPUT_NAMES)


@_settings(24)
@given(contents=folder_contents())
@pytest.mark.slow  # a design into each generated folder: make test-slow
def test_a_design_into_a_folder_that_holds_things_replaces_only_cadcams_files(contents, scratch, capfd):
    """Refused before any work (nothing touched) when the folder holds the user's things where
    outputs go; otherwise the design is written and every other entry is left as it was."""
    work = scratch()
    spec = work / "spec.toml"
    spec.write_text(FAST_1DOF)
    out = work / "out"
    _fill(out, contents)
    before = snapshot(work)
    run = cli(capfd, "design", spec, "-o", out, "--no-figures", "--multistart", 0, cwd=work)
    event(f"folder: {'refused' if _refused_for(contents) else 'written'} -> exit {run.code}")
    if _refused_for(contents):
        assert_refused(run, names=[out], root=work, before=before)
        return
    assert_design_outcome(run, out)
    after = snapshot(work)
    kept = [n for n in contents if n not in OUTPUT_NAMES]
    for name in kept:  # what is not an output file of cadcam's is left as it was
        changed = [p for p in set(before) | set(after)
                   if (p == f"out/{name}" or p.startswith(f"out/{name}/")) and before.get(p) != after.get(p)]
        assert not changed, f"{name} ({contents[name]}) was changed"
