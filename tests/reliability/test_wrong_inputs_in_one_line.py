"""Inputs of the wrong kind end in one line, never a traceback (issue 48, "Tracebacks and wrong
exits"): the API's spec, problem and start of another type; a cap's environment variable that is
no whole number; a port out of TCP's range."""
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import cadcam
from cadcam.cli import PORTS, main
from cadcam.designs import DesignError
from cadcam.files import CAP_DIGITS, env_cap
from cadcam.problem import CAPS, cap

from ..conftest import SPEC_1DOF

#: Values of every kind but the ones expected (a path, a Problem, a Design).
others = st.one_of(st.none(), st.integers(), st.floats(), st.booleans(), st.binary(max_size=8),
                   st.lists(st.integers(), max_size=3), st.dictionaries(st.text(max_size=3), st.integers(), max_size=2),
                   st.tuples(st.integers()), st.sets(st.integers(), max_size=2), st.builds(object))


def _one_line(exc: BaseException) -> bool:
    return "\n" not in str(exc) and len(str(exc)) > 10


@settings(deadline=None)
@given(spec=others)
def test_load_spec_of_no_file_name_is_a_spec_error(spec):
    with pytest.raises(cadcam.SpecError, match=r"^spec: expected a file name") as refused:
        cadcam.load_spec(spec)
    assert _one_line(refused.value)


@settings(deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(problem=others)
@example(problem=None)
def test_optimize_of_no_problem_is_a_spec_error(problem):
    with pytest.raises(cadcam.SpecError, match=r"^problem: expected a Problem") as refused:
        cadcam.optimize(problem)
    assert _one_line(refused.value)


@settings(deadline=None)
@given(start=others.filter(lambda v: v is not None) | st.text(max_size=5))
@example(start="x")
def test_optimize_from_a_start_that_is_no_design_is_a_design_error(start, problem_1dof):
    with pytest.raises(DesignError, match=r"^start: expected a Design") as refused:
        cadcam.optimize(problem_1dof, start=start)
    assert _one_line(refused.value)


@settings(deadline=None)
@given(name=st.sampled_from(sorted(CAPS)),  # an environment variable holds no NUL
       text=st.text(st.characters(codec="utf-8", exclude_characters="\0"), max_size=25)
       | st.integers(-10, 10**30).map(str))
@example(name="grid", text="²")
@example(name="grid", text="9" * 5000)
def test_a_caps_variable_that_is_no_whole_number_leaves_the_cap_as_it_was(name, text):
    with pytest.MonkeyPatch.context() as env:
        env.setenv(f"CADCAM_CAP_{name.upper()}", text)
        value = cap(name)
    whole = text.isascii() and text.isdigit() and len(text) <= CAP_DIGITS and int(text) > 0
    assert value == (int(text) if whole else CAPS[name])


def test_a_cap_raised_by_a_variable_that_is_no_number_refuses_as_the_cap_does(tmp_path, monkeypatch, capsys):
    """``CADCAM_CAP_GRID=²``: the grid's cap stays 2000, and a grid over it is refused in one
    line naming the variable to raise."""
    monkeypatch.setenv("CADCAM_CAP_GRID", "²")
    assert env_cap("grid", CAPS["grid"]) == CAPS["grid"]
    assert main(["design", str(SPEC_1DOF), "--grid", str(CAPS["grid"] + 1), "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "CADCAM_CAP_GRID" in err and not (tmp_path / "o").exists()


@settings(deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(port=st.integers(max_value=PORTS[0] - 1) | st.integers(min_value=PORTS[1] + 1))
@example(port=70000)
def test_a_port_out_of_range_is_refused_in_one_line(port, capsys):
    assert main(["app", "--port", str(port), "--no-browser"]) == 2
    err = capsys.readouterr().err
    assert err == f"cadcam: error: --port {port}: expected a port from 1 to 65535\n"


@settings(deadline=None)
@given(name=st.text(max_size=8).map(lambda t: f"t{t}\0{t}.csv"))
def test_a_spec_naming_a_file_with_a_nul_character_is_one_line(name):
    """A TOML string may hold ``\\u0000``; the system takes no such file name."""
    with pytest.raises(cadcam.SpecError, match="a NUL character in its name") as refused:
        cadcam.load_problem(SPEC_1DOF, overrides={"cams.1.target": {"kind": "table", "file": name}})
    assert _one_line(refused.value)
