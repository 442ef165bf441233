"""`cadcam springs` made fast: a part swapped into the parsed spec is the problem its spec parses
to; a profile that broke its shape between the NLP's check points is mended by raising its
margins in the same NLP; a spring starts from a solved neighbour, the same on any workers; every
feasible row's design re-checks on its own; the table ranks by the tolerance band; the search
runs on a Dask cluster; and the whole tutorial catalogue (slow lane) finds its feasible springs."""
from __future__ import annotations

import csv
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from cadcam.cli import main
from cadcam.designs import Design
from cadcam.errors import SpecError
from cadcam.optimize import MARGIN_STEP, _raised_margins, optimize, solve, start_design, warm_optimize
from cadcam.physics.catalogue import load_catalogue
from cadcam.solve.builds import built_for
from cadcam.spec import parse_spec, read_spec_data
from cadcam.solve.blocks import LENGTH_SCALE
from cadcam.solve.ipopt import Multipliers
from cadcam.solve.variables import _Vars
from cadcam.sweep.springs import (TABLE_COLUMNS, StartTree, _spec_problem, design_part, force_matched,
                                  matched_point, part_spec, search, spring_gaps, verdict, with_part)
from cadcam.verify.evaluate import evaluate

ROOT = Path(__file__).resolve().parent.parent
TUTORIAL = ROOT / "docs" / "first_balancer.toml"
SPEC = (read_spec_data(TUTORIAL), str(TUTORIAL), str(TUTORIAL.parent))
#: A part whose design with the spec's own margins breaks its profile's convexity between the
#: NLP's check points, and one that fits at once (each free length fits the spring's room).
BROKEN, FITS = "9654K244", "5108N446"
#: How many springs the shared search designs (those nearest the tutorial's rate).
LIMIT = 6


@pytest.fixture(scope="module")
def found():
    """The tutorial's search of the shipped catalogue, its first springs, designed serially."""
    return search(SPEC, 0, load_catalogue(None), None, 0, LIMIT)


@pytest.mark.parametrize("part", [BROKEN, "9654K908", "5108N001"])
def test_a_part_swapped_in_is_the_problem_its_spec_parses_to(part):
    data, origin, base = SPEC
    parsed = parse_spec(part_spec(data, 0, part, None), origin, Path(base))
    swapped = with_part(parse_spec(data, origin, Path(base)), 0, part, None)
    assert swapped.springs == parsed.springs and swapped.to_dict() == parsed.to_dict()


def test_a_part_from_a_user_catalogue_names_its_file(tmp_path):
    path = tmp_path / "mine.csv"
    path.write_text("part_number,stiffness,load_min,length_natural,length_max,load_max,wire_dia,od,material\n"
                    "A1,1000,2,0.05,0.11,62,0.0015,0.012,Music-Wire Steel\n")
    data, origin, base = SPEC
    parsed = parse_spec(part_spec(data, 0, "A1", str(path)), origin, Path(base))
    assert with_part(parse_spec(data, origin, Path(base)), 0, "A1", str(path)).springs == parsed.springs


@pytest.mark.parametrize("part, pre, words", [("nope", None, "no part 'nope'"),
                                              (FITS, 0.5, "preextension 0.5 m is beyond its travel")])
def test_a_part_that_cannot_be_swapped_in_is_one_line(part, pre, words):
    problem = _spec_problem(SPEC)
    problem = replace(problem, springs=(replace(problem.springs[0], preextension=pre),))
    with pytest.raises(SpecError, match=words) as err:
        with_part(problem, 0, part, None)
    assert "\n" not in str(err.value)


#: Five springs (rate k [N/m], initial tension F0 [N]) and the spans of log k and F0 their gaps are
#: measured over: two pairs of neighbours and one between them.
FIVE = np.array([[1000.0, 5.0], [3000.0, 40.0], [1100.0, 6.0], [2900.0, 41.0], [1000.0, 30.0]])
FIVE_SCALES = (2.0, 50.0)


def test_the_tree_grows_from_the_first_spring_to_the_nearest_next():
    """Each spring's parent is the nearest of those before it, rate counting more than initial
    tension (TENSION_WEIGHT): 2 beside 0; 4, of 0's rate, nearer 0 than 1 and 3 are to either;
    3 nearer 2 than 4, whose tension is nearer but whose rate is not; 1 beside 3."""
    tree = StartTree(FIVE, FIVE_SCALES)
    assert tree.order == [0, 2, 4, 3, 1]
    assert list(tree.parent) == [-1, 3, 0, 2, 0]
    assert tree.children == [[2, 4], [], [3], [1], []]
    assert list(tree.rank) == [0, 4, 1, 3, 2]


def test_the_tree_is_prims_over_the_spring_gaps():
    """On random springs: each spring added is the one nearest to those before it, and its parent
    the nearest of them, as a brute-force search over every pair's gap finds."""
    rng = np.random.default_rng(7)
    springs = np.c_[np.exp(rng.uniform(5.0, 9.0, 40)), rng.uniform(0.0, 60.0, 40)]
    scales = (4.0, 60.0)
    gap = np.array([spring_gaps(springs, tuple(s), scales) for s in springs])
    tree = StartTree(springs, scales)
    assert sorted(tree.order) == list(range(40)) and tree.order[0] == 0
    for t in range(1, 40):
        before, after = tree.order[:t], tree.order[t:]
        nearest = gap[np.ix_(after, before)].min(axis=1)
        assert tree.order[t] == after[int(np.argmin(nearest))]
        assert tree.parent[tree.order[t]] == before[int(np.argmin(gap[tree.order[t], before]))]


def test_a_spring_starts_from_its_nearest_solved_ancestor():
    tree = StartTree(FIVE, FIVE_SCALES)
    assert tree.start_of(2, {0: "a"}) == "a"
    assert tree.start_of(3, {0: "a", 2: "b"}) == "b"
    assert tree.start_of(3, {0: "a", 2: None}) == "a"  # its parent failed: the one before that
    assert tree.start_of(1, {0: "a", 2: None, 3: "c"}) == "c"
    assert tree.start_of(2, {0: None}) is None  # none solved: the default start
    assert tree.start_of(0, {}) is None


@pytest.mark.slow  # a second search of the shared springs, on two workers: make test-slow
def test_a_search_gives_the_same_rows_on_any_number_of_workers(found):
    """Each spring's start is fixed by the tree and the verdicts of the springs before it, not by
    which worker ends first: two workers design every spring as one process does."""
    pooled = search(SPEC, 0, load_catalogue(None), None, 2, LIMIT)
    assert pooled.designed.keys() == found.designed.keys()
    for part, row in found.designed.items():
        other = pooled.designed[part]
        assert (other["status"], other["iterations"], other["rmse"]) == (row["status"], row["iterations"], row["rmse"])
    assert pooled.table("error") == found.table("error")


def test_a_neighbours_nlp_point_starts_with_the_matched_pre_extension():
    """The warm start's point is where IPOPT starts: the pre-extension force_matched moved is
    put there, and nothing else in the point changes."""
    problem = with_part(_spec_problem(SPEC), 0, FITS, None)
    design = start_design(problem)[1]
    v = _Vars("w")
    v.add("c", 3, 0), v.add("x", 1, 0)
    warm = Multipliers(np.zeros(4), np.zeros(2), False, np.array([1.0, 2.0, 3.0, 4.0]))
    tr = SimpleNamespace(v=v)
    spring = problem.springs[0]
    # a neighbour of the same rate and 1 N less initial tension: the part pulls as hard 1/k earlier
    neighbour = replace(design, preextension=np.array([4.0 * LENGTH_SCALE]))
    moved = force_matched(neighbour, 0, (spring.rate, spring.preload - 1.0), spring, 0.01)
    assert moved.preextension[0] == pytest.approx(4.0 * LENGTH_SCALE - 1.0 / spring.rate)
    matched = matched_point(tr, warm, moved, 0)
    assert list(matched.x) == [1.0, 2.0, 3.0, pytest.approx(moved.preextension[0] / LENGTH_SCALE)]
    assert list(warm.x) == [1.0, 2.0, 3.0, 4.0]  # the neighbour's own is kept as it was
    assert matched_point(tr, warm, neighbour, 0) is warm  # nothing moved
    assert matched_point(tr, None, moved, 0) is None


def _fine(convexity=0.0, rho_min=0.0, rho_max=0.0):
    """A stand-in fine re-check of one profile with its margins."""
    return SimpleNamespace(metrics=SimpleNamespace(margins={
        "convexity": [convexity], "rho_min": [rho_min], "rho_max": [rho_max], "curvature_radius": [0.0]}))


def test_a_broken_margin_is_raised_by_its_depth_times_the_step():
    problem = _spec_problem(SPEC)
    prof, o = problem.profiles[0], problem.options
    raised = _raised_margins(problem, problem, _fine(convexity=-2e-7, rho_min=-1e-6))
    assert raised.options.convexity_epsilon == pytest.approx(o.convexity_epsilon + MARGIN_STEP * 2e-7 / prof.rho_min**2)
    assert raised.options.limit_margin == pytest.approx(o.limit_margin + MARGIN_STEP * 1e-6 / prof.rho_min)
    # from the last raise, not the spec's: a second raise adds to the first
    again = _raised_margins(problem, raised, _fine(convexity=-1e-7))
    assert again.options.convexity_epsilon == pytest.approx(raised.options.convexity_epsilon
                                                            + MARGIN_STEP * 1e-7 / prof.rho_min**2)
    assert _raised_margins(problem, problem, _fine(convexity=1e-9, rho_max=1e-6)) is None
    assert _raised_margins(problem, problem, _fine(rho_max=-0.1 * prof.rho_max)) is None  # past the cap


@pytest.mark.slow  # a design mended twice: make test-slow
def test_a_profile_broken_between_check_points_is_mended_by_its_margins():
    problem = with_part(_spec_problem(SPEC), 0, BROKEN, None)
    tr, _ = built_for(problem)
    mended = optimize(problem, tr, refine="margin")
    assert mended.status == "success" and "its margins raised" in mended.message
    assert mended.solve.margins["convexity_epsilon"] > problem.options.convexity_epsilon
    # the NLP's own optimum breaks the shape between its check points; the mended design does
    # not, re-checked against the spec's own problem on its fine grid by a separate evaluation,
    # and costs next to nothing in objective
    first = solve(tr, problem, start_design(problem)[1])
    grid = problem.options.recheck_grid
    assert min(evaluate(problem, first.design, grid=grid).metrics.convexity_min) < 0
    fine = evaluate(problem, mended.design, grid=grid)
    assert not fine.violations and min(fine.metrics.convexity_min) >= 0
    assert mended.solve.objective == pytest.approx(first.objective, rel=1e-3)
    # a start that needed the raise is solved with it at once, without breaking first
    warm = optimize(problem, tr, start=mended.design, warm=mended.solve.multipliers, refine="margin",
                    margins=mended.solve.margins)
    assert warm.status == "success" and "its margins raised" not in warm.message
    assert "solved with the convexity margin" in warm.message and warm.solve.margins == mended.solve.margins


@pytest.mark.slow  # a search of a few dozen springs: make test-slow
def test_every_feasible_row_re_checks_on_its_own(found):
    rows = [r for r in found.designed.values() if verdict(r)[0] == "feasible"]
    assert len(found.designed) == LIMIT and len(rows) >= LIMIT - 1
    spec = _spec_problem(SPEC)
    for row in rows:
        problem = with_part(spec, 0, row["part"], None)
        fine = evaluate(problem, Design.from_dict(row["design"], problem), grid=problem.options.recheck_grid)
        body = problem.springs[0].body
        x = fine.metrics.extension_max[0]
        assert not fine.violations, (row["part"], fine.violations)
        assert body.force(x) <= body.load_max and body.length(x) <= body.length_max
        assert body.stress(x) <= body.allowed_stress
        assert fine.metrics.relative_rmse[0] <= spec.joints[0].limits["relative_rmse"]


@pytest.mark.slow  # a search of a few dozen springs: make test-slow
def test_a_spring_starts_from_its_solved_neighbour_with_its_multipliers(found):
    messages = [r["message"] for r in found.designed.values()]
    assert sum("warm start from part" in m for m in messages) >= LIMIT // 2
    first = next(iter(found.designed.values()))
    assert "warm start" not in first["message"]  # nothing solved before the first


def test_a_spring_that_cannot_be_designed_is_a_row():
    row = design_part(SPEC, 0, "nope", None, None)
    assert row["status"] == "unusable" and row["message"].startswith("part 'nope': no part")
    assert verdict(row) == ("infeasible", f"unusable: {row['message']}")


@pytest.mark.parametrize("status", ["max_iterations", "infeasible", "restoration_failed", "error"])
def test_a_design_that_did_not_converge_is_undecided_not_infeasible(status):
    row = {"part": "P", "status": status, "message": "IPOPT stopped"}
    assert verdict(row) == ("undecided", f"not finished: {status}: IPOPT stopped")


def test_a_failed_warm_start_is_not_tried_again_when_told():
    """A search's spring whose warm start fails ends there, undecided, at the cost of one solve;
    ``cadcam design``'s warm starts still try the default start after it."""
    problem = with_part(_spec_problem(SPEC), 0, FITS, None).with_options(max_iter=3)
    tr, _ = built_for(problem)
    far = start_design(with_part(_spec_problem(SPEC), 0, "9654K908", None))[1]
    once = warm_optimize(problem, tr, far, None, "part X", retry=False)
    assert once.status == "max_iterations" and once.solve.iterations <= 3
    assert once.message.endswith("(warm start from part X; not tried again from the default start)")
    twice = warm_optimize(problem, tr, far, None, "part X")
    assert twice.message.endswith("(from the default start, after a failed warm start)")
    assert verdict({"status": once.status, "message": once.message})[0] == "undecided"


@pytest.mark.slow  # a search with each design's band: make test-slow
def test_the_table_ranks_by_the_tolerance_band(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["springs", str(TUTORIAL), "-o", str(out), "--workers", "0", "--limit", "3", "--rank", "band",
                 "--no-figures"]) == 0
    with open(out / "springs.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == list(TABLE_COLUMNS)
    designed = [r for r in rows if r["verdict"] in ("feasible", "near")]
    bands = [float(r["band"]) for r in designed if r["verdict"] == "feasible"]
    assert len(designed) == 3 and bands == sorted(bands) and all(b > 0 for b in bands)
    assert all(r["band"] == "" for r in rows if r["verdict"] not in ("feasible", "near"))
    err = capsys.readouterr().err.splitlines()
    assert [line.split("]")[0] for line in err] == ["[1/3", "[2/3", "[3/3"]
    assert all("; best so far: " in line and " s, ETA " in line for line in err)


@pytest.mark.slow  # two searches, one starting a LocalCluster: some 15 s
def test_a_search_on_a_dask_cluster_gives_the_rows_of_a_local_pool(tmp_path):
    pytest.importorskip("dask.distributed")
    tables = {}
    for how in (["--workers", "1"], ["--dask", "local", "--workers", "1"]):
        out = tmp_path / how[1]
        assert main(["springs", str(TUTORIAL), "-o", str(out), "--limit", "2", "--no-figures", *how]) == 0
        tables[how[1]] = (out / "springs.csv").read_text()
    assert tables["1"] == tables["local"]


@pytest.mark.slow  # the whole catalogue: about a minute on 2 cores (benchmarks/bench_springs.py times it)
def test_the_whole_catalogue_finds_feasible_springs_for_the_tutorial():
    cat = load_catalogue(None)
    whole = search(SPEC, 0, cat, None, 2)
    spec = _spec_problem(SPEC)
    assert len(whole.designed) == int(whole.screened.passed.sum()) == whole.planned
    feasible = {p: r for p, r in whole.designed.items() if verdict(r)[0] == "feasible"}
    assert len(feasible) >= 10
    best = whole.best()
    assert feasible[best]["relative_rmse"] <= spec.joints[0].limits["relative_rmse"]
    for row in feasible.values():
        b = row["body"]
        assert b["peak_force"] <= b["load_max"] and b["max_length"] <= b["length_max"]
        assert b["peak_stress"] <= b["allowed_stress"]
    assert whole.table("error")[0][0] == best
