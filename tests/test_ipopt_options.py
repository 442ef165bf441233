"""IPOPT options from data are an allow-list (cadcam.problem.IPOPT_OPTIONS): an option that names
a library or a file, a linear solver that is not installed, or a tolerance looser than IPOPT's
own, is refused in one line with exit 2 before any work, from a spec, a flag or the API; a stop
at IPOPT's acceptable level is its own status, never success."""
import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import cadcam
from cadcam.cli import main
from cadcam.problem import IPOPT_OPTIONS

from .conftest import SPEC_1DOF


@pytest.mark.parametrize("options", [
    ["linear_solver=ma27", "hsllib={lib}"],
    ["linear_solver=ma57", "hsllib={lib}"],
    ["linear_solver=pardiso", "pardisolib={lib}"],
    ["hsllib={lib}"],
])
def test_a_library_named_by_data_is_never_loaded(planted, options, tmp_path, capsys):
    argv = ["design", str(SPEC_1DOF), "-o", str(tmp_path / "out")]
    for option in options:
        argv += ["--ipopt", option.format(lib=planted)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "solver.ipopt." in err
    assert not (planted.parent / "loaded").exists()
    assert not (tmp_path / "out").exists()


def test_the_spec_and_the_api_refuse_it_the_same_way(planted, tmp_path):
    spec = tmp_path / "s.toml"
    spec.write_text(SPEC_1DOF.read_text() + f'\n[solver.ipopt]\nlinear_solver = "ma27"\nhsllib = "{planted}"\n')
    with pytest.raises(cadcam.SpecError, match=r"solver\.ipopt\.(hsllib|linear_solver)"):
        cadcam.load_problem(spec)
    with pytest.raises(cadcam.SpecError, match=r"solver\.ipopt\.hsllib"):
        cadcam.load_problem(SPEC_1DOF, ipopt={"hsllib": str(planted)})
    assert not (planted.parent / "loaded").exists()


@pytest.mark.parametrize("name, value, words", [
    ("linear_solver", "ma57", 'one of "mumps", "spral"'),
    ("dual_inf_tol", 1e10, "a number in (0, 1]"),
    ("constr_viol_tol", 1.0, "a number in (0, 0.0001]"),
    ("output_file", "ipopt.out", "options that name files or libraries never are"),
    ("option_file_name", "ipopt.opt", "options that name files or libraries never are"),
    ("tol", 1e-3, "give solver.tol instead"),
    ("print_level", 99, "an integer from 0 to 12"),
])
def test_each_refusal_names_the_option_and_what_it_may_be(name, value, words):
    with pytest.raises(cadcam.SpecError, match=r"solver\.ipopt\." + name) as refused:
        cadcam.load_problem(SPEC_1DOF, ipopt={name: value})
    assert words in str(refused.value) and "\n" not in str(refused.value)


def test_a_loose_solver_tolerance_is_refused():
    with pytest.raises(cadcam.SpecError, match=r"solver\.tol = 0\.1: expected IPOPT's tolerance: a number in \(0, 0\.0001\]"):
        cadcam.load_problem(SPEC_1DOF, tol=0.1)


def test_every_allowed_option_is_one_ipopt_knows():
    """The allow-list names real IPOPT options (a typo would refuse every value of it)."""
    from cadcam.spec import _ipopt_refusal

    samples = {"print_level": 0, "limited_memory_max_history": 6, "acceptable_iter": 15}
    for name, setting in IPOPT_OPTIONS.items():
        value = samples.get(name)
        if value is None:  # the first of a choice, or a small number inside a range
            value = setting.form.split('"')[1] if setting.form.startswith("one of") else 1e-5
        assert setting.ok(value), (name, value)
        assert _ipopt_refusal(name, value) is None, (name, value)


def test_an_acceptable_level_stop_is_its_own_status_not_success(tmp_path, capsys):
    loose = {"acceptable_tol": 1e10, "acceptable_iter": 1, "acceptable_dual_inf_tol": 1e10,
             "acceptable_constr_viol_tol": 1e10, "acceptable_compl_inf_tol": 1e10,
             "acceptable_obj_change_tol": 1e10}
    argv = ["design", str(SPEC_1DOF), "--grid", "12", "-o", str(tmp_path / "out"), "--no-figures"]
    for name, value in loose.items():
        argv += ["--ipopt", f"{name}={value}"]
    assert main(argv) == 1
    out = capsys.readouterr().out
    assert out.startswith("acceptable: IPOPT stopped at its acceptable level")
    result = json.loads((tmp_path / "out" / "result.json").read_text())
    assert result["status"] == "acceptable" and result["solver"]["trials"][0]["status"] == "acceptable"


#: Names a spec may try: the allowed ones, and others IPOPT knows (files, libraries, checks).
TRIED = [*IPOPT_OPTIONS, "hsllib", "pardisolib", "output_file", "option_file_name", "file_print_level",
         "print_user_options", "derivative_test", "linear_system_scaling", "max_iter", "tol", "no_such_option"]


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(name=st.sampled_from(TRIED),
       value=st.one_of(st.text(max_size=20), st.floats(allow_nan=True, allow_infinity=True),
                       st.integers(min_value=-10**12, max_value=10**12), st.booleans(),
                       st.sampled_from(["mumps", "spral", "ma27", "ma57", "pardiso", "yes", "no", "exact"])))
def test_any_ipopt_option_is_passed_on_only_if_allowed(name, value):
    try:
        problem = cadcam.load_problem(SPEC_1DOF, ipopt={name: value})
    except cadcam.SpecError as refused:
        message = str(refused)  # the option, or the table holding a value of no IPOPT type
        assert "solver.ipopt" in message and name in message and "\n" not in message
        return
    assert name in IPOPT_OPTIONS and IPOPT_OPTIONS[name].ok(value)
    assert (name, value) in problem.options.ipopt
