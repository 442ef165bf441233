"""``--set`` (and a variant's or the API's overrides) adds a table the spec leaves out where its
table declares it — ``--set solver.convexity_points=400`` on a spec without ``[solver]`` — and
still refuses, in one line, a table or a key that is not declared."""
import contextlib
import io

import pytest

import cadcam
from cadcam import SpecError
from cadcam.cli import main
from cadcam.problem import SOLVER_KEYS, WORKSHOP_KEYS, acceptance_keys, tolerance_keys
from cadcam.spec import read_spec_data

from .conftest import ROOT, SPEC_1DOF

FIRST = ROOT / "docs" / "first_balancer.toml"


def _bare(tmp_path):
    """The tutorial's spec without its [workshop]: a spec with no optional table at all."""
    text = FIRST.read_text()
    bare = tmp_path / "bare.toml"
    bare.write_text(text[:text.index("[workshop]")])
    assert not {"solver", "workshop", "tolerances", "arm"} & set(read_spec_data(bare))
    return bare


def _other(key):
    """A value ``key`` allows other than its default."""
    default = key.default
    candidates = ([default + 1, default * 2, default // 2] if key.type == "integer"
                  else [default * 1.5, default / 2, (key.high or 1.0) / 4])
    return next(v for v in candidates if key.ok(v) and v != default)


def _numbers(table):
    return [k for k in table.keys if k.type in ("number", "integer") and isinstance(k.default, (int, float))]


CREATED = ([("solver", k, lambda p, n: getattr(p.options, n)) for k in _numbers(SOLVER_KEYS)]
           + [("workshop", k, lambda p, n: getattr(p.workshop, n)) for k in _numbers(WORKSHOP_KEYS)]
           + [("tolerances", k, lambda p, n: dict(p.tolerances)[n]) for k in _numbers(tolerance_keys())]
           + [("joints.1.acceptance", k, lambda p, n: dict(p.joints[0].acceptance)[n])
              for k in _numbers(acceptance_keys())])


@pytest.mark.parametrize("table,key,read", CREATED, ids=lambda v: getattr(v, "name", v if isinstance(v, str) else ""))
def test_a_key_of_a_declared_table_the_spec_leaves_out_is_set(tmp_path, table, key, read):
    value = _other(key)
    problem = cadcam.load_problem(_bare(tmp_path), overrides={f"{table}.{key.name}": value})
    assert read(problem, key.name) == value


def test_nested_tables_are_added_and_a_shorthand_entry_takes_its_joints_tables():
    problem = cadcam.load_problem(FIRST, overrides={"solver.ipopt.mu_init": 1e-6})
    assert problem.options.ipopt == (("mu_init", 1e-6),)
    problem = cadcam.load_problem(SPEC_1DOF, overrides={"cams.1.acceptance.rmse": 0.01})
    assert problem.joints[0].acceptance == (("rmse", 0.01),)


@pytest.mark.parametrize("key,words", [
    ("solvr.convexity_points", "the spec has no 'solvr' at the top level, and no table of that name is declared "
                               "there; the tables --set may add there: solver, arm, variants, workshop, tolerances"),
    ("joints.1.colour.x", "the spec has no 'colour' in 'joints.1', and no table of that name is declared there; "
                          "the tables --set may add there: acceptance, target"),
    ("springs.1.end.x", "the spec has no 'end' in 'springs.1', and no table of that name is declared there"),
    ("solver.convexity_pointz", "unknown key 'solver.convexity_pointz'; allowed keys here: convexity_epsilon, "
                                "convexity_points,"),
    ("solver.ipopt.nope", "solver.ipopt.nope = 1: expected one of the IPOPT options cadcam passes on"),
])
def test_a_table_or_key_that_is_not_declared_is_refused_in_one_line(key, words):
    with pytest.raises(SpecError) as err:
        cadcam.load_problem(FIRST, overrides={key: 1})
    assert words in str(err.value) and "\n" not in str(err.value)


def test_cadcam_design_refuses_an_undeclared_key_with_exit_2_before_any_work(tmp_path):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["design", str(FIRST), "-o", str(tmp_path / "o"), "--set", "solver.convexity_pointz=400"])
    assert code == 2 and err.getvalue().count("\n") == 1
    assert "unknown key 'solver.convexity_pointz'" in err.getvalue()
    assert not (tmp_path / "o").exists()
