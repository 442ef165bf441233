"""A value plausible only in another unit or outside every catalogue (a 500 kg mass, a 1e9 N/m
spring, a range of 1.75°) is designed as given, with one line saying so and what to write: on
standard error before the solve, in the summary, in ``result.json``'s ``warnings`` and on the
design page. The plausible ranges are the keys' own (:attr:`cadcam.keys.Key.plausible`); no
shipped spec prints a warning."""
import contextlib
import copy
import io
import json
import re
import tomllib
from pathlib import Path
from types import SimpleNamespace

import pytest
from jsonschema import Draft202012Validator

import cadcam
from cadcam.cli import main
from cadcam.designs import Design
from cadcam.keys import UNIT_SLIPS
from cadcam.mechanisms.base import MECHANISM_KEYS, built_in_kinds, mechanism_class
from cadcam.optimize import start_design
from cadcam.physics.catalogue import shipped
from cadcam.physics.springs import SPRING_KEYS
from cadcam.problem import JOINT_KEYS, SOLVER_KEYS, WORKSHOP_KEYS, acceptance_keys, tolerance_keys
from cadcam.result import Result
from cadcam.spec import SPEC_KEYS, implausible_units, parse_spec, read_keys, read_spec_data, with_overrides
from cadcam.targets import ARM_KEYS, target_kind, target_kinds
from cadcam.verify.evaluate import evaluate
from cadcam.verify.reachable import advice

ROOT = Path(__file__).resolve().parents[1]
FIRST = ROOT / "docs" / "first_balancer.toml"
SHIPPED = sorted((ROOT / "models").glob("*.toml")) + sorted((ROOT / "docs").glob("*.toml"))


def _declared():
    """(table path, key) of every declared key with a plausible range, sub-tables' keys too."""
    tables = [SPEC_KEYS, JOINT_KEYS, acceptance_keys(), ARM_KEYS, MECHANISM_KEYS, SPRING_KEYS, WORKSHOP_KEYS,
              tolerance_keys(), SOLVER_KEYS, *(mechanism_class(k).spec_keys for k in built_in_kinds()),
              *(target_kind(k).keys for k in dict.fromkeys(target_kinds() + target_kinds(output=True)))]

    def keys(path, table):
        for k in table:
            yield path, k
            if k.fields is not None:
                yield from keys(f"{path}.{k.name}", k.fields.keys)
    return [(path, k) for table in tables if table is not None for path, k in keys(table.path, table.keys)
            if k.plausible is not None]


PLAUSIBLE = _declared()


def _range(key):
    return key.plausible() if callable(key.plausible) else key.plausible


def _value(key, number):
    """A value of ``key`` whose one implausible number is ``number``, the others plausible."""
    if key.type != "numbers":
        return number
    inside = _inside(_range(key))
    return [inside] * ((key.length or 2) - 1) + [number]


def _inside(p):
    """A magnitude inside the range ``p``."""
    if p.low is not None and p.high is not None:
        return (p.low * p.high) ** 0.5
    return p.high / 2 if p.high is not None else 2 * p.low


def test_the_keys_with_plausible_ranges_cover_the_issues_examples():
    names = {(path, k.name) for path, k in PLAUSIBLE}
    assert {("[[springs]]", "rate"), ("[[springs]]", "travel"), ('kind = "pendulum"', "mass"),
            ("[[mechanisms]]", "rho_max"), ('[arm] (or kind = "arm")', "masses")} <= names
    rate = _range(SPRING_KEYS["rate"])
    body = shipped().body
    assert (rate.low, rate.high) == (body.rate.min(), body.rate.max())


@pytest.mark.parametrize("path,key", PLAUSIBLE, ids=lambda v: getattr(v, "name", v))
def test_a_number_beyond_its_keys_plausible_range_is_one_line_naming_it(path, key):
    p = _range(key)
    outside = 10 * p.high if p.high is not None else p.low / 10
    value = _value(key, outside)
    assert key.ok(value), "the key's own bounds refuse every implausible value: no need of a range"
    line = key.implausible(value, "t.k")
    assert line.startswith("t.k") and f"{outside:.6g}" in line and p.what in line and "\n" not in line
    assert key.implausible(_value(key, _inside(p)), "t.k") is None
    assert key.implausible(_value(key, 0.0), "t.k") is None  # zero is zero in every unit
    assert key.implausible(_value(key, -_inside(p)), "t.k") is None  # a magnitude: a signed place is in range


@pytest.mark.parametrize("path,key", [(p, k) for p, k in PLAUSIBLE if k.unit in UNIT_SLIPS],
                         ids=lambda v: getattr(v, "name", v))
def test_a_value_typed_in_another_unit_is_told_what_to_write(path, key):
    p, (unit, size) = _range(key), UNIT_SLIPS[key.unit]
    meant = p.high / 2 if size < 1 else 2 * p.low  # typed in a smaller (larger) unit, it reads larger (smaller)
    typed = meant / size
    assert p.holds(meant) and not p.holds(typed)  # premise
    line = key.implausible(_value(key, typed), "t.k")
    assert f"if it is in {unit}, write {meant:.6g}" in line


def _groups(reads):
    """The numbers a spec gives to keys with a plausible range, grouped by table pattern
    (array entries as *) and range: {(pattern, range id): [(key pattern, KeyRead)]}."""
    groups = {}
    for r in reads:
        numbers = r.value if isinstance(r.value, list) else [r.value]
        if r.declaration.plausible is None or not r.given or not any(numbers):
            continue
        pattern = re.sub(r"\.\d+(?=\.|$)", ".*", r.key)
        groups.setdefault((pattern.rsplit(".", 1)[0], id(r.declaration.plausible)), []).append((pattern, r))
    return groups


@pytest.mark.parametrize("spec", SHIPPED, ids=lambda p: p.stem)
def test_every_number_a_shipped_spec_gives_warns_once_out_of_its_range(spec):
    """Each group of numbers of one table and one range (a mechanism's sizes, its tables in
    every mechanism), scaled together beyond the range so that the spec stays one the reader
    accepts (its sizes keep their ratios): one warning per key, in the reader's words."""
    data = read_spec_data(spec)
    _, reads = read_keys(copy.deepcopy(data), str(spec), spec.parent)
    groups = _groups(reads)
    assert groups
    for rs in groups.values():
        p = _range(rs[0][1].declaration)
        numbers = [abs(v) for _, r in rs for v in (r.value if isinstance(r.value, list) else [r.value]) if v]
        factor = 10 * p.high / min(numbers) if p.high is not None else p.low / (10 * max(numbers))
        scaled = [(r.key, [v * factor for v in r.value] if isinstance(r.value, list) else r.value * factor)
                  for _, r in rs]
        problem = parse_spec(with_overrides(copy.deepcopy(data), str(spec), None, scaled), str(spec), spec.parent)
        for key, _ in scaled:
            where = re.sub(r"\.(\d+)", r"[\1]", key)
            assert sum(w.startswith(f"{where} ") or w.startswith(f"{where}:") for w in problem.warnings) == 1, \
                (where, problem.warnings)
        assert len(problem.warnings) == len(scaled)


#: The issue's cases on the tutorial's spec: (override, words the warning must hold).
CASES = {
    "radians typed as degrees": (("joints.1.theta_range_deg", [0.0, 1.75]), "write degrees ([0, 100.3])"),
    "a 1e9 N/m spring": (("springs.1.rate", 1e9), "springs[1].rate = 1e+09 N/m is outside the shipped "
                                                  "catalogue's rates"),
    "N/mm typed as N/m": (("springs.1.rate", 0.5), "if it is in N/mm, write 500"),
    "a 500 kg mass": (("joints.1.target.mass", 500.0), "joints[1].target.mass = 500 kg is outside the masses a "
                                                       "spring balancer carries (up to 50 kg): if it is in g, "
                                                       "write 0.5"),
    "millimetres typed as metres": (("springs.1.travel", 60.0), "if it is in mm, write 0.06"),
    "a percentage typed as a share": (("tolerances.rate", 10.0), "tolerances.rate = 10 is outside the shares of a "
                                                                 "whole (up to 1): if it is in %, write 0.1"),
}


@pytest.mark.parametrize("case", CASES)
def test_the_issues_cases_warn_with_their_fix(case):
    override, words = CASES[case]
    notes = implausible_units(cadcam.load_problem(FIRST, overrides=[override]))
    assert len(notes) == 1 and words in notes[0] and "\n" not in notes[0]


@pytest.mark.parametrize("spec,variant", [(p, v) for p in SHIPPED
                                          for v in [None, *tomllib.loads(p.read_text()).get("variants", {})]],
                         ids=lambda v: getattr(v, "stem", str(v)))
def test_no_shipped_spec_prints_a_warning(spec, variant):
    """Not one of their values is implausible, as written or resolved into result.json's problem;
    as written, neither does any mechanism know a bound it cannot meet (the inverted pendulum's
    variant ``low`` starts below Endo2010's bound on purpose, and says so)."""
    problem = cadcam.load_problem(spec, variant=variant)
    assert problem.warnings == () and implausible_units(problem) == []
    assert parse_spec(problem.to_dict()).warnings == ()
    if variant is None:
        assert advice(problem) == []


@pytest.fixture(scope="module")
def warned():
    """The tutorial's spec with a 500 kg mass, its start design re-checked as a Result (no
    solve: what a result says of its spec does not depend on the design)."""
    problem, design = start_design(cadcam.load_problem(FIRST, overrides={"joints.1.target.mass": 500.0}))
    assert isinstance(design, Design)
    ev = evaluate(problem, design)
    return Result(status="success", message="made by hand", problem=problem, design=design, evaluation=ev,
                  recheck=ev)


def test_the_warnings_are_in_result_json_and_the_summary(warned):
    (line,) = warned.spec_warnings
    assert line.startswith("joints[1].target.mass = 500 kg")
    written = warned.to_dict()
    assert written["warnings"] == [line]
    schema = json.loads((Path(cadcam.__file__).parent / "result.schema.json").read_text(encoding="utf-8"))
    Draft202012Validator(schema).validate(json.loads(json.dumps(written)))
    assert f"  warning: {line}" in warned.summary().splitlines()


def test_the_design_page_shows_the_warnings(warned):
    """The page's details are the summary's lines after the verdict, made in the worker with the
    live view's frame, warnings among them (the page's panes stand in as plain objects: building
    a whole page takes seconds)."""
    pytest.importorskip("panel", reason="Panel is the app extra's (make test installs it)")
    from cadcam.app.page import DesignPage
    from cadcam.app.state import Outcome

    view = DesignPage.__new__(DesignPage)
    view.errors, view.state, view.name = {}, SimpleNamespace(path=FIRST, result=None, aliases={}), FIRST.name
    view._error_key = None  # no field shows an error
    view.verdict, view.details, view.lines, view.springs = (SimpleNamespace(object=None) for _ in range(4))
    outcome = Outcome(result=warned, seconds=1.0)
    _, details = DesignPage._drawn(outcome, 0, set())  # in the worker
    view._show(outcome, details)
    assert f"warning: {warned.spec_warnings[0]}" in view.details.object


def test_cadcam_design_warns_before_the_solve_and_in_its_summary_and_result_json(tmp_path):
    """Designed as given (a 500 % acceptance is met), with ``--set`` adding the tables the spec
    leaves out (``[solver]``, the joint's ``acceptance``)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["design", str(FIRST), "-o", str(tmp_path / "o"), "--no-figures", "--grid", "16",
                     "--set", "joints.1.acceptance.relative_rmse=5", "--set", "solver.convexity_points=150"])
    assert code == 0, out.getvalue()
    line = ("joints[1].acceptance.relative_rmse = 5 is outside the shares of a whole (up to 1): "
            "if it is in %, write 0.05")
    assert err.getvalue() == f"cadcam: warning: {line}\n"
    assert f"  warning: {line}" in out.getvalue().splitlines()
    written = json.loads((tmp_path / "o" / "result.json").read_text())
    assert written["warnings"] == [line]
    assert written["problem"]["solver"]["convexity_points"] == 150
    assert written["problem"]["joints"][0]["acceptance"] == {"relative_rmse": 5}
