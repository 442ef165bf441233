"""CasADi's warnings during a solve are kept in the result, counted in its summary and written in
result.json, and never reach stderr: for expanded and compiled functions, and only the solving
thread's writes are taken."""
import json
import shutil
import sys
import threading
from importlib.resources import files

import casadi as ca
import numpy as np
import pytest
from jsonschema import Draft202012Validator

from cadcam import load_spec
from cadcam.optimize import optimize, random_start
from cadcam.problem import Options
from cadcam.solve import compiled
from cadcam.solve.messages import count, kept_warnings, merged, parse_warnings
from cadcam.solve.ipopt import _ipopt_solver

from ..conftest import SPEC_1DOF

needs_cc = pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None,
                              reason="no C compiler on this machine")


def test_a_solve_that_meets_a_nan_keeps_casadis_warnings_in_its_result_not_on_stderr(capfd):
    """The idler study's case r = 5 mm, a0 = 25 mm from its first random start (solver.seed 0):
    the wire finds no departure on that cam, so the NLP's functions are NaN at the start."""
    problem = load_spec(SPEC_1DOF, overrides=[("cams.1.idler.radius", 0.005), ("cams.1.idler.offset", 0.025)])
    problem = problem.with_options(grid=8, convexity_points=12)
    result = optimize(problem, start=random_start(problem, np.random.default_rng(problem.options.seed)))
    out, err = capfd.readouterr()
    assert "NaN detected" not in err + out and "CasADi" not in err + out
    nan = [w for w in result.warnings if "NaN detected" in w["message"]]
    assert nan and all(w["message"].startswith("cadcam:nlp_") for w in nan)  # CasADi's date and source dropped
    n = count(result.warnings)
    (trial,) = result.solve.trials
    assert trial["warnings"] == n >= len(result.warnings)
    line = f"  CasADi warned {n} times during the solve, {len(result.warnings)} distinct (kept in solver.warnings), " \
           f"first: {result.warnings[0]['message']}"
    assert line in result.summary().splitlines()
    assert result.band is None  # no pose on the grid: no band (its least squares would fail on NaN)
    written = json.loads(json.dumps(result.to_dict()))
    assert written["solver"]["warnings"] == result.warnings
    schema = json.loads((files("cadcam") / "result.schema.json").read_text(encoding="utf-8"))
    Draft202012Validator(schema).validate(written)


def _nan_nlp():
    """An NLP whose constraint √(x₀ − 0.001) is NaN at a trial point of IPOPT's from x = (1, 5)."""
    x, p = ca.MX.sym("x", 2), ca.MX.sym("p")
    g = ca.vertcat(ca.sqrt(x[0] - 0.001) + x[1], x[0] * x[1] ** 3)
    return {"x": x, "p": p, "f": p * (x[0] - 0.01) ** 2 + (x[1] - 1) ** 2, "g": g}


@pytest.mark.parametrize("functions", ["expanded", pytest.param("compiled", marks=needs_cc)])
def test_warnings_are_kept_for_expanded_and_compiled_functions(functions, tmp_path, monkeypatch, capfd):
    monkeypatch.setenv("CADCAM_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(compiled, "CFLAGS", ("-O0", "-fPIC"))
    solver, _ = _ipopt_solver(_nan_nlp(), Options(functions=functions))
    with kept_warnings() as kept:
        solver(x0=[1, 5], p=1e4, lbg=[2, 3], ubg=[2.5, 4])
    assert solver.stats()["return_status"] == "Solve_Succeeded"  # IPOPT stepped back from the NaN
    (nan,) = kept
    assert nan["message"] == "cadcam:nlp_g failed: NaN detected for output g, at (row 0, col 0)." and nan["count"] >= 1
    assert capfd.readouterr().err == ""


def test_only_the_capturing_threads_writes_are_kept(capsys):
    before = sys.stderr
    with kept_warnings() as kept:
        assert (sys.stderr.encoding, sys.stderr.isatty()) == (before.encoding, before.isatty())  # the stream's
        other = threading.Thread(target=lambda: print("the server's log line", file=sys.stderr))
        other.start()
        other.join()
        print("CasADi - 2026-01-02 03:04:05 WARNING(\"f: NaN detected\") [.../oracle_function.cpp:411]",
              file=sys.stderr)
    assert sys.stderr is before
    assert kept == [{"message": "f: NaN detected", "count": 1}]
    assert capsys.readouterr().err == "the server's log line\n"


def test_repeated_messages_are_counted_once_each_in_their_first_order():
    text = ('CasADi - 2026-01-02 03:04:05 WARNING("a: NaN detected") [x.cpp:1]\n'
            "Failed to calculate multipliers\n"
            'CasADi - 2026-01-02 03:04:06 WARNING("a: NaN detected") [x.cpp:1]\n\n')
    kept = parse_warnings(text)
    assert kept == [{"message": "a: NaN detected", "count": 2}, {"message": "Failed to calculate multipliers", "count": 1}]
    assert count(kept) == 3
    assert merged([kept, [{"message": "b", "count": 4}, {"message": "a: NaN detected", "count": 1}]]) == \
        [{"message": "a: NaN detected", "count": 3}, {"message": "Failed to calculate multipliers", "count": 1},
         {"message": "b", "count": 4}]
