"""Tests that would catch a broken verdict (issue 11, item 6).

Each test here fails when the code it guards is broken: the fine re-check that turns a converged
solve into ``recheck_failed`` (exit 1, ``result.json`` still written), every violation detector
on a design made by hand, atomic writes that fail midway, sweep cases solved through a reused
NLP, warm starts and their fallback, the ``zip``/Latin-hypercube/``log``/``integer`` study
designs, and the exit code of a sweep with a failing case.

The premises are asserted too (the coarse grid misses what the fine grid finds, a violation lies
between the design grid's contact points, …), so a test cannot pass for the wrong reason.
"""
import contextlib
import errno
import io
import json
import os
import pathlib
import shutil
import sys

import numpy as np
import pytest
from numpy.polynomial import Polynomial

from cadcam import Design, load_spec
from cadcam.verify.evaluate import LENGTH_TOL, evaluate
from cadcam.cli import main
from cadcam.files import MANIFEST, atomic_path, write_csv, write_json, write_text
from cadcam.solve.ipopt import Solve
from cadcam.optimize import WARM_GUARD, verdict
from cadcam.solve import builds
from cadcam.physics.profile import Basis
from cadcam.sweep import runner as sweep
from cadcam.sweep.study import Parameter, Study, StudyError, load_study

from ..conftest import SPEC_1DOF, circle_design


def _cli(*argv):
    """Run the command line in this process: (exit code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv])
    return code, out.getvalue(), err.getvalue()


def _column(path, name):
    """One column of a CSV file cadcam wrote, as floats."""
    lines = path.read_text().splitlines()
    k = lines[0].split(",").index(name)
    return np.array([float(line.split(",")[k]) for line in lines[1:]])


# -- 1. a converged solve whose fine re-check finds a violation --------------------------------
# With a design grid of 3 angles and spring 2's pre-extension fixed at 0, IPOPT converges to a
# design whose platform spring is slack (x = 0) at the three grid angles but in compression
# between them: only the fine re-check grid (recheck_factor × 2 + 1 = 21 angles) sees it.
RECHECK_ARGS = ("--grid", "3", "--set", "springs.2.preextension=0.0")


@pytest.fixture(scope="module")
def recheck_failed_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("recheck") / "out"
    code, stdout, stderr = _cli("design", SPEC_1DOF, "-o", out, *RECHECK_ARGS)
    return code, stdout, stderr, out


def test_a_violation_only_the_fine_grid_sees_is_recheck_failed_with_exit_1(recheck_failed_run):
    code, stdout, _, out = recheck_failed_run
    assert code == 1
    result = json.loads((out / "result.json").read_text())
    assert result["status"] == "recheck_failed"
    assert stdout.startswith("recheck_failed: converged, but it violates constraints on the fine re-check grid")
    # IPOPT did converge: the failure is the re-check's
    assert result["solver"]["return_status"] in ("Solve_Succeeded", "Solved_To_Acceptable_Level")
    assert result["violations"] and result["violations"] == result["recheck"]["violations"]
    assert all(v.startswith("spring in compression: spring 2") for v in result["violations"])
    # the premise: the design grid (3 angles) is clean, the re-check grid is 10× finer
    factor = load_spec(SPEC_1DOF).options.recheck_factor
    assert result["metrics"]["grid"] == 3 and result["recheck"]["grid"] == factor * 2 + 1
    assert result["metrics"]["violations"] == []
    x2_coarse = _column(out / "torque.csv", "x2_m")
    x2_fine = _column(out / "torque_recheck.csv", "x2_m")
    assert x2_coarse.size == 3 and x2_fine.size == result["recheck"]["grid"]
    assert x2_coarse.min() >= -LENGTH_TOL
    assert x2_fine.min() < -10 * LENGTH_TOL  # well beyond the check's tolerance
    assert result["recheck"]["extension_min"][1] == pytest.approx(x2_fine.min(), rel=1e-12)
    # the rest of the set is written too
    for name in ("torque.csv", "torque_recheck.csv", "profile.csv", "profile.png"):
        assert (out / name).is_file()


def test_a_write_failing_midway_in_design_leaves_the_previous_outputs(recheck_failed_run, tmp_path,
                                                                     monkeypatch):
    """``cadcam design`` into a folder holding a previous set, with the disk filling up while
    ``torque_recheck.csv`` is half written: exit 1 with one line, the previous files byte for
    byte, and no temporary or staging file left."""
    out = tmp_path / "out"
    shutil.copytree(recheck_failed_run[3], out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    real = pathlib.Path.write_text
    hits = []

    def disk_full(self, data, *args, **kw):
        if "torque_recheck" not in self.name:
            return real(self, data, *args, **kw)
        hits.append(self)
        with open(self, "w") as fh:
            fh.write(data[: len(data) // 2])
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self))

    monkeypatch.setattr(pathlib.Path, "write_text", disk_full)
    code, _, stderr = _cli("design", SPEC_1DOF, "-o", out, *RECHECK_ARGS)
    monkeypatch.undo()
    assert hits, "the write that should fail was never made"
    assert code == 1
    assert os.strerror(errno.ENOSPC) in stderr and stderr.count("\n") == 1
    after = {p.name: p.read_bytes() for p in out.iterdir()}
    assert after.keys() == before.keys()
    assert all(after[k] == before[k] for k in before)
    assert not [p for p in tmp_path.rglob(".*") if p.name != MANIFEST]  # the set's own record stays


# -- 2. every violation detector on a design made by hand --------------------------------------
def _monomial_design(problem, m, x0):
    """ρ(φ) = Σ m_k φ^k [m] in the problem's basis, with pre-extensions ``x0`` [m]."""
    b = problem.profiles[0].basis
    m = np.pad(np.asarray(m, dtype=float), (0, b.size - len(m)))
    return Design([b], [b.from_monomial(m)], np.asarray(x0, dtype=float))


def _only_violation(ev, start):
    """The one violation of ``ev``, which must start with ``start``; and the verdict of a
    converged solve with this re-check is ``recheck_failed``."""
    assert len(ev.violations) == 1 and ev.violations[0].startswith(start), ev.violations
    solve = Solve(design=ev.design, status="converged", return_status="Solve_Succeeded", iterations=1,
                  solve_time_s=0.0, objective=0.0, z=[])
    assert verdict(ev.problem, solve, ev, "converged")[0] == "recheck_failed"


def _dense_rho(m, alpha_max, n=200_001):
    """ρ and the Eq. 40 convexity margin over the wrapped range [0, α_max], by numpy."""
    rho = Polynomial(m)
    phi = np.linspace(0.0, alpha_max, n)
    r, dr, ddr = rho(phi), rho.deriv(1)(phi), rho.deriv(2)(phi)
    return phi, r, r**2 + 2 * dr**2 - r * ddr


def test_the_travel_detector_uses_the_largest_extension(problem_1dof):
    """A circle wound from x₀ = 40 mm: spring 1 starts inside its 57.66 mm travel and ends
    beyond it, so a margin taken at the smallest extension would pass."""
    ev = evaluate(problem_1dof, circle_design(problem_1dof, 0.02, [0.04, 0.01]))
    travel = problem_1dof.springs[0].travel
    x1 = ev.x[0]
    assert x1.min() < travel - 0.01 and x1.max() > travel + 0.01  # premise
    assert ev.metrics.margins["travel"][0] == pytest.approx(travel - x1.max(), rel=1e-12)
    assert ev.metrics.extension_max[0] == pytest.approx(x1.max(), rel=1e-12)
    _only_violation(ev, f"spring above its travel: {problem_1dof.springs[0].name}")


def test_the_compression_detector_uses_the_smallest_extension(problem_1dof):
    """A shrinking spiral pulls the idler platform in: spring 2 starts stretched (5 mm) and
    ends compressed, so a margin taken at the largest extension would pass."""
    ev = evaluate(problem_1dof, _monomial_design(problem_1dof, [0.025, -0.005], [0.01, 0.005]))
    x2 = ev.x[1]
    assert x2.max() > 0.004 and x2.min() < -0.001  # premise
    assert ev.metrics.margins["extension_lower"][1] == pytest.approx(x2.min(), rel=1e-12)
    assert np.all(ev.design.preextension >= 0)  # not the pre-extension detector
    _only_violation(ev, f"spring in compression: {problem_1dof.springs[1].name}")


def test_the_rho_min_detector_finds_an_interior_minimum(problem_1dof):
    """ρ = 9.5 mm + 2 mm·(φ − 1)²: above ρ_min = 10 mm at both ends of the wrapped range, below
    it around φ = 1."""
    m = [0.0095 + 0.002, -0.004, 0.002]
    ev = evaluate(problem_1dof, _monomial_design(problem_1dof, m, [0.005, 0.01]))
    alpha_max = ev.metrics.alpha_max[0]
    phi, rho, _ = _dense_rho(m, alpha_max)
    rho_min = problem_1dof.profiles[0].rho_min
    assert rho[0] > rho_min and rho[-1] > rho_min and rho.min() < rho_min - 1e-4  # premise
    assert ev.metrics.rho_min[0] == pytest.approx(rho.min(), abs=1e-9)
    assert ev.metrics.margins["rho_min"][0] == pytest.approx(rho.min() - rho_min, abs=1e-9)
    _only_violation(ev, "radius below rho_min: cam")


def test_the_rho_max_detector_scans_to_the_end_of_the_wrap():
    """ρ = 90 mm + 10 mm/rad·φ crosses ρ_max = 100 mm inside the wrapped range (spring 1's
    travel raised so that only ρ is violated)."""
    problem = load_spec(SPEC_1DOF, None, [("springs.1.travel", 0.5)])
    m = [0.09, 0.01]
    ev = evaluate(problem, _monomial_design(problem, m, [0.005, 0.01]))
    alpha_max = ev.metrics.alpha_max[0]
    phi, rho, _ = _dense_rho(m, alpha_max)
    rho_max = problem.profiles[0].rho_max
    assert rho[0] < rho_max < rho.max() - 1e-3  # premise
    assert ev.metrics.rho_max[0] == pytest.approx(rho.max(), abs=1e-9)
    assert ev.metrics.margins["rho_max"][0] == pytest.approx(rho_max - rho.max(), abs=1e-9)
    _only_violation(ev, "radius above rho_max: cam")


@pytest.mark.parametrize("m,coarse_scan_misses", [
    # 20 mm + 11 mm·(φ − 0.75)²: not convex where ρρ″ > ρ² + 2ρ′², |φ − 0.75| ≲ 0.18
    ([0.02 + 0.011 * 0.75**2, -2 * 0.011 * 0.75, 0.011], False),
    # a quintic not convex on φ ≈ 1.61…2.14, whose margin at φ = 0 is the lowest of φ = 0,
    # α_max/2, α_max: a scan with as few samples as the design grid, refined around its lowest
    # sample, would not see it
    ([0.0307, -0.0083, 0.0065, 0.0119, -0.0184, 0.0057], True),
], ids=["parabola", "quintic"])
def test_the_convexity_detector_scans_between_the_contact_points(problem_1dof, m, coarse_scan_misses):
    """Profiles not convex only on an arc strictly between the contact points of two
    neighbouring angles of the design grid (3 angles), convex at every contact point."""
    problem = problem_1dof.with_options(grid=3)
    basis = Basis("monomial", len(m) - 1, problem.profiles[0].basis.domain)
    ev = evaluate(problem, Design([basis], [np.array(m)], np.array([0.005, 0.01])))
    prof = ev.profiles[0]
    contacts = np.sort(np.append(prof.alpha, prof.alpha_ref))
    alpha_max = ev.metrics.alpha_max[0]
    phi, _, conv = _dense_rho(m, alpha_max)
    bad = phi[conv < 0]
    # premise: convex at every contact point, not convex only strictly between two of them
    assert np.all(np.interp(contacts, phi, conv) > 1e-5)
    k = np.searchsorted(contacts, bad.min())
    assert 0 < k < contacts.size and contacts[k - 1] < bad.min() and bad.max() < contacts[k]
    if coarse_scan_misses:
        coarse = np.linspace(0.0, alpha_max, problem.options.grid)
        j = int(np.argmin(np.interp(coarse, phi, conv)))
        near = (phi >= coarse[max(j - 1, 0)]) & (phi <= coarse[min(j + 1, coarse.size - 1)])
        assert conv[near].min() > 1e-5
    assert ev.metrics.convexity_min[0] == pytest.approx(conv.min(), rel=1e-6)
    assert ev.metrics.convexity_min[0] < -1e-5
    _only_violation(ev, "profile not convex: cam")


# -- 3. atomic writes that fail midway ----------------------------------------------------------
PREVIOUS = b'{"status": "success", "previous": true}\n'


def _enospc(path):
    return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))


def test_atomic_path_failing_midway_keeps_the_previous_file(tmp_path):
    target = tmp_path / "result.json"
    target.write_bytes(PREVIOUS)
    with pytest.raises(OSError) as err:
        with atomic_path(target) as tmp:
            assert tmp != target and tmp.parent == target.parent
            tmp.write_bytes(b'{"status": "half')
            assert tmp.read_bytes() == b'{"status": "half'  # partly written…
            raise _enospc(tmp)  # …then the disk is full
    assert err.value.errno == errno.ENOSPC
    assert target.read_bytes() == PREVIOUS
    assert sorted(os.listdir(tmp_path)) == ["result.json"]


@pytest.mark.parametrize("write", [
    lambda p: write_text(p, "new text " * 1000),
    lambda p: write_json(p, {"status": "recheck_failed", "values": list(range(1000))}),
    lambda p: write_csv(p, ["a", "b"], [[i, 2.0 * i] for i in range(1000)]),
], ids=["write_text", "write_json", "write_csv"])
def test_a_writer_failing_midway_keeps_the_previous_file(tmp_path, monkeypatch, write):
    target = tmp_path / "out.txt"
    target.write_bytes(PREVIOUS)
    written = []

    def half_then_full(self, data, *args, **kw):
        with open(self, "w") as fh:
            fh.write(data[: len(data) // 2])
        written.append(os.path.getsize(self))
        raise _enospc(self)

    monkeypatch.setattr(pathlib.Path, "write_text", half_then_full)
    with pytest.raises(OSError):
        write(target)
    monkeypatch.undo()
    assert written and written[0] > 0  # the temporary file was partly written
    assert target.read_bytes() == PREVIOUS
    assert sorted(os.listdir(tmp_path)) == ["out.txt"]


def test_a_rename_that_fails_keeps_the_previous_file(tmp_path, monkeypatch):
    target = tmp_path / "out.json"
    target.write_bytes(PREVIOUS)

    def no_rename(src, dst, *args, **kw):
        assert os.path.getsize(src) > 0  # the whole new file is there, under its temporary name
        raise OSError(errno.EIO, os.strerror(errno.EIO), str(dst))

    monkeypatch.setattr(os, "replace", no_rename)
    with pytest.raises(OSError):
        write_json(target, {"new": list(range(100))})
    monkeypatch.undo()
    assert target.read_bytes() == PREVIOUS
    assert sorted(os.listdir(tmp_path)) == ["out.json"]


def test_a_successful_write_replaces_the_file_and_leaves_nothing_else(tmp_path):
    """The other half of the contract: the new content arrives whole, under the final name."""
    target = tmp_path / "out.json"
    target.write_bytes(PREVIOUS)
    write_json(target, {"new": list(range(100))})
    assert json.loads(target.read_text()) == {"new": list(range(100))}
    assert sorted(os.listdir(tmp_path)) == ["out.json"]


# -- 4., 5. sweep cases: a reused NLP, warm starts ----------------------------------------------
def _zip_study(rates, offsets, rho_min=None, grid=12, warm_start=False):
    params = [Parameter("springs.1.rate", tuple(rates)), Parameter("cams.1.idler.offset", tuple(offsets)),
              Parameter("solver.grid", (grid,) * len(rates))]
    if rho_min:
        params.append(Parameter("cams.1.rho_min", tuple(rho_min)))
    return Study("cases", SPEC_1DOF, params, design="zip", warm_start=warm_start)


def _numbers(value):
    """Every number in a nested JSON value, in order (for a tolerance comparison)."""
    if isinstance(value, dict):
        return [x for k in sorted(value) for x in _numbers(value[k])]
    if isinstance(value, list):
        return [x for v in value for x in _numbers(v)]
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return []
    return [float(value)]


def _same_row(a, b, rtol=1e-10):
    assert a["status"] == b["status"] == "success"
    assert a["iterations"] == b["iterations"]
    for key in ("design", "metrics", "recheck"):
        va, vb = json.loads(a[key]), json.loads(b[key])
        np.testing.assert_allclose(_numbers(va), _numbers(vb), rtol=rtol, atol=1e-300, err_msg=key)


@pytest.fixture(scope="module")
def solved_cases():
    """Two cases of one structure solved in a row (the second through the first's NLP), and
    the second again through a freshly built NLP."""
    study = _zip_study([1000.0, 1200.0], [0.012, 0.015], [0.010, 0.011]).to_dict()
    first, second = Study.from_dict(study).cases()
    saved = dict(builds._BUILDS)
    try:
        builds.forget_builds()
        row_first = sweep.run_case(study, first)
        (built,) = builds._BUILDS.values()
        row_reused = sweep.run_case(study, second)
        reused = list(builds._BUILDS.values())
        builds.forget_builds()
        row_fresh = sweep.run_case(study, second)
        fresh = list(builds._BUILDS.values())
    finally:
        builds.forget_builds()
        builds._BUILDS.update(saved)
    return dict(study=study, case=second, first=row_first, reused=row_reused, fresh=row_fresh,
                built=built, reused_nlp=reused, fresh_nlp=fresh)


def test_a_case_through_a_reused_nlp_equals_a_freshly_built_one(solved_cases):
    s = solved_cases
    # premise: the second case went through the first case's NLP, the third through a new one
    assert s["reused_nlp"] == [s["built"]] and s["reused"]["build_time_s"] == 0.0
    assert s["fresh_nlp"][0] is not s["built"] and s["fresh"]["build_time_s"] > 0.0
    assert s["first"]["build_time_s"] > 0.0
    _same_row(s["reused"], s["fresh"])
    # and the two cases are different problems with different answers (else reuse of stale
    # numbers would go unnoticed)
    d1 = json.loads(s["first"]["design"])["cams"][0]["coefficients"]
    d2 = json.loads(s["reused"]["design"])["cams"][0]["coefficients"]
    assert np.max(np.abs(np.subtract(d1, d2))) > 1e-4


def test_a_warm_start_from_the_optimum_is_used(solved_cases):
    s = solved_cases
    cold = s["fresh"]
    warm = sweep.run_case(s["study"], s["case"], start=json.loads(cold["design"]))
    assert warm["status"] == "success" and "failed warm start" not in warm["message"]
    assert warm["iterations"] <= cold["iterations"] // 3  # it started at the answer
    # and stayed there: the same objective, the same profile to 0.1 µm (the objective is flat
    # to IPOPT's tolerance along some directions, so not to the last digit)
    assert json.loads(warm["metrics"])["objective"] == pytest.approx(json.loads(cold["metrics"])["objective"],
                                                                     rel=1e-6)
    np.testing.assert_allclose(json.loads(warm["design"])["cams"][0]["coefficients"],
                               json.loads(cold["design"])["cams"][0]["coefficients"], rtol=0, atol=1e-7)


def test_a_failed_warm_start_falls_back_to_the_default_start(solved_cases):
    """A start with a negative radius cannot be solved from; the case is solved again from
    the default start, says so, and gives the cold answer."""
    s = solved_cases
    nonsense = {"cams": [{"monomial_coefficients": [-0.02, 0.0, 0.0, 0.0]}], "preextension": [0.0, 0.0]}
    row = sweep.run_case(s["study"], s["case"], start=nonsense)
    assert row["status"] == "success"
    assert row["message"].endswith("(from the default start, after a failed warm start)")
    _same_row(row, s["fresh"])


def test_a_warm_start_that_ends_much_worse_than_its_start_case_is_compared_with_a_cold_one(solved_cases):
    """The guard against a worse basin: a warm start whose objective is more than WARM_GUARD
    above its start case's is solved again from the default start and the better one kept."""
    s = solved_cases
    cold = s["fresh"]
    objective = json.loads(cold["metrics"])["objective"]
    design = json.loads(cold["design"])
    quiet = sweep.run_case(s["study"], s["case"], design, objective, "c0")  # no worse: no second solve
    assert quiet["message"] == cold["message"] + " (warm start from case c0)"
    guarded = sweep.run_case(s["study"], s["case"], design, objective / (1 + 2 * WARM_GUARD), "c0")
    assert guarded["status"] == "success"
    assert "(warm start from case c0 kept: the default start did no better)" in guarded["message"] or \
        "(from the default start: the warm start from case c0 reached a worse objective" in guarded["message"]
    assert json.loads(guarded["metrics"])["objective"] <= json.loads(quiet["metrics"])["objective"]


@pytest.fixture(scope="module")
def warm_sweep(tmp_path_factory):
    """A serial warm-started sweep of three cases (rates 1000, 1100, 1300 N/m), with the start
    every case was given."""
    real, calls = sweep.run_case, []

    def spy(study, case, *warm):
        calls.append((case["springs.1.rate"], warm[0] if warm else None))
        return real(study, case, *warm)

    db = tmp_path_factory.mktemp("warm") / "w.db"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(sweep, "run_case", spy)
        sweep.run_sweep(_zip_study([1000.0, 1100.0, 1300.0], [0.015] * 3, warm_start=True), db,
                        workers=0, progress=False)
    _, rows = sweep.read_rows(db)
    assert [r["status"] for r in rows] == ["success"] * 3
    return dict(calls), {r["params"]["springs.1.rate"]: r["design"] for r in rows}


def test_a_warm_started_sweep_starts_a_case_from_the_nearest_solved_one(warm_sweep):
    starts, designs = warm_sweep
    assert sorted(starts) == [1000.0, 1100.0, 1300.0]
    assert starts[1000.0] is None  # nothing solved yet
    assert starts[1300.0] == designs[1100.0]  # the nearer of 1000 and 1100 to 1300


def test_a_serial_warm_started_sweep_starts_the_second_case_from_the_first(warm_sweep):
    starts, designs = warm_sweep
    assert starts[1100.0] == designs[1000.0]  # the only solved case when it starts


# -- 6. study designs ---------------------------------------------------------------------------
def _load(tmp_path, body, name="s.toml"):
    path = tmp_path / name
    path.write_text(f'name = "s"\nbase = "{SPEC_1DOF}"\n' + body)
    return load_study(path)


def test_zip_pairs_the_ith_values(tmp_path):
    study = _load(tmp_path, 'design = "zip"\n'
                  '[[parameters]]\nkey = "springs.1.rate"\nvalues = [900.0, 1000.0, 1100.0]\n'
                  '[[parameters]]\nkey = "cams.1.idler.offset"\nrange = [0.010, 0.020]\nnum = 3\n'
                  '[[parameters]]\nkey = "solver.grid"\nrange = [6, 12]\nnum = 3\ninteger = true\n')
    cases = study.validate()
    assert study.n_cases() == len(cases) == 3
    assert [c["springs.1.rate"] for c in cases] == [900.0, 1000.0, 1100.0]
    assert [c["cams.1.idler.offset"] for c in cases] == pytest.approx([0.010, 0.015, 0.020], rel=1e-12)
    assert [c["solver.grid"] for c in cases] == [6, 9, 12]
    assert all(type(c["solver.grid"]) is int for c in cases)
    # each case reaches its problem
    for c in cases:
        p = study.problem(c)
        assert (p.springs[0].rate, p.mechanisms[0].idler_offset, p.options.grid) == \
            (c["springs.1.rate"], c["cams.1.idler.offset"], c["solver.grid"])


def test_zip_refuses_parameters_of_different_lengths(tmp_path):
    study = _load(tmp_path, 'design = "zip"\n'
                  '[[parameters]]\nkey = "springs.1.rate"\nvalues = [900.0, 1000.0, 1100.0]\n'
                  '[[parameters]]\nkey = "solver.grid"\nvalues = [6, 12]\n')
    with pytest.raises(StudyError, match="same number of values"):
        study.validate()


def test_log_ranges_are_geometric(tmp_path):
    study = _load(tmp_path, '[[parameters]]\nkey = "springs.1.rate"\nrange = [100.0, 10000.0]\nnum = 5\n'
                  'log = true\n')
    rates = [c["springs.1.rate"] for c in study.validate()]
    assert len(rates) == study.n_cases() == 5
    assert rates[0] == pytest.approx(100.0, rel=1e-12) and rates[-1] == pytest.approx(10000.0, rel=1e-12)
    np.testing.assert_allclose(np.diff(np.log10(rates)), 0.5, rtol=1e-12)


@pytest.mark.parametrize("spec,expected", [
    ("range = [4, 64]\nnum = 5\nlog = true", [4, 8, 16, 32, 64]),
    ("range = [3, 10]\nnum = 4", [3, 5, 8, 10]),  # 3, 5.33, 7.67, 10 rounded
], ids=["log", "linear"])
def test_integer_ranges_give_python_ints(tmp_path, spec, expected):
    study = _load(tmp_path, f'[[parameters]]\nkey = "solver.grid"\n{spec}\ninteger = true\n')
    grids = [c["solver.grid"] for c in study.validate()]
    assert grids == expected and all(type(g) is int for g in grids)
    assert [study.problem(c).options.grid for c in study.cases()] == expected


LHS = '''design = "latin_hypercube"
samples = 8
seed = {seed}
[[parameters]]
key = "springs.1.rate"
range = [800.0, 1600.0]
[[parameters]]
key = "springs.2.rate"
range = [1000.0, 100000.0]
log = true
[[parameters]]
key = "cams.1.idler.offset"
values = [0.010, 0.012, 0.014, 0.016]
[[parameters]]
key = "solver.grid"
range = [5, 40]
integer = {integer}
'''


def _strata(u, n):
    """Which of n equal strata of [0, 1] each unit coordinate falls in."""
    return sorted(np.minimum(np.floor(np.asarray(u) * n), n - 1).astype(int).tolist())


def test_latin_hypercube_is_stratified_bounded_and_reproducible(tmp_path):
    study = _load(tmp_path, LHS.format(seed=7, integer="true"))
    cases = study.validate()
    n = 8
    assert study.n_cases() == len(cases) == n
    rate = np.array([c["springs.1.rate"] for c in cases])
    rate2 = np.array([c["springs.2.rate"] for c in cases])
    offsets = [c["cams.1.idler.offset"] for c in cases]
    grids = [c["solver.grid"] for c in cases]
    # one sample per stratum in every dimension: linear, logarithmic, and an index into values
    assert np.all((800 <= rate) & (rate <= 1600)) and _strata((rate - 800) / 800, n) == list(range(n))
    assert np.all((1000 <= rate2) & (rate2 <= 100000))
    assert _strata(np.log(rate2 / 1000) / np.log(100), n) == list(range(n))
    assert sorted(offsets) == [0.010, 0.010, 0.012, 0.012, 0.014, 0.014, 0.016, 0.016]
    # integers: Python ints in range, the rounding of the same design without integer = true
    assert all(type(g) is int and 5 <= g <= 40 for g in grids)
    twin = _load(tmp_path, LHS.format(seed=7, integer="false"), "twin.toml").cases()
    assert grids == [int(round(c["solver.grid"])) for c in twin]
    assert _strata((np.array([c["solver.grid"] for c in twin]) - 5) / 35, n) == list(range(n))
    # reproducible with its seed, different with another
    assert _load(tmp_path, LHS.format(seed=7, integer="true"), "again.toml").cases() == cases
    other = _load(tmp_path, LHS.format(seed=8, integer="true"), "other.toml").cases()
    assert [c["springs.1.rate"] for c in other] != rate.tolist()
    assert study.problem(cases[0]).springs[1].rate == cases[0]["springs.2.rate"]


# -- 7. a sweep with a failing case exits 1 -----------------------------------------------------
SWEEP = f'''name = "exit"
base = "{SPEC_1DOF}"
[[parameters]]
key = "springs.1.rate"
values = [1000.0, 1200.0]
[[parameters]]
key = "solver.grid"
values = [12]
'''


def test_a_sweep_with_a_case_that_raises_exits_1(tmp_path, monkeypatch):
    (tmp_path / "s.toml").write_text(SWEEP)
    code, _, _ = _cli("sweep", tmp_path / "s.toml", "-o", tmp_path / "ok.db", "--workers", "0")
    assert code == 0  # the control: every case succeeds
    module = sys.modules["cadcam.optimize"]
    real = module.optimize

    def flaky(problem, **kw):
        if problem.springs[0].rate == 1200.0:
            raise RuntimeError("boom")
        return real(problem, **kw)

    monkeypatch.setattr(module, "optimize", flaky)
    code, stdout, _ = _cli("sweep", tmp_path / "s.toml", "-o", tmp_path / "bad.db", "--workers", "0")
    assert code == 1
    _, rows = sweep.read_rows(tmp_path / "bad.db")
    assert sorted(r["status"] for r in rows) == ["error", "success"]
    # resumed, nothing runs, and the recorded failure still fails the sweep
    code, stdout, _ = _cli("sweep", tmp_path / "s.toml", "-o", tmp_path / "bad.db", "--workers", "0")
    assert code == 1 and "0 run now" in stdout


def test_a_sweep_with_a_case_that_fails_its_recheck_exits_1(tmp_path):
    (tmp_path / "s.toml").write_text(f'''name = "recheck"
base = "{SPEC_1DOF}"
[[parameters]]
key = "springs.2.preextension"
values = [0.0]
[[parameters]]
key = "solver.grid"
values = [3]
''')
    code, _, _ = _cli("sweep", tmp_path / "s.toml", "-o", tmp_path / "r.db", "--workers", "0")
    _, rows = sweep.read_rows(tmp_path / "r.db")
    assert [r["status"] for r in rows] == ["recheck_failed"]
    assert code == 1
