"""`cadcam springs`: a spec's spring slot searched over a catalogue — every row screened (one
reason each), the survivors designed and given a verdict, the table ranked by the stated order
and written with text cells safe from spreadsheets, the best design's folder written; bad input
refused in one line with nothing written."""
from __future__ import annotations

import csv
import json
import math
import random
from pathlib import Path

import numpy as np
import pytest

from cadcam.cli import main
from cadcam.physics.catalogue import load_catalogue, screen
from cadcam.spec import FILLED_BY_PART, parse_spec, read_spec_data
from cadcam.sweep.springs import RANKS, TABLE_COLUMNS, VERDICTS, Search, part_spec, slot_need, verdict

#: `cadcam springs` designs catalogue springs through a process pool: the slow lane (make test-slow).
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parent.parent
TUTORIAL = ROOT / "docs" / "first_balancer.toml"
HEADER = "part_number,stiffness,load_min,length_natural,length_max,load_max,wire_dia,od,material,pkg_qty,pkg_cost"
#: Two springs that store the tutorial's 0.92 J (A1: 1.9 J, B2: 2.0 J, both with force and wire
#: stress to spare) and three that cannot (a few mJ), one named like a spreadsheet formula.
ROWS = ("A1,1000,2,0.05,0.11,62,0.0015,0.012,Music-Wire Steel,1,4.5",
        "C3,100,0.5,0.02,0.03,1.5,0.0005,0.004,Music-Wire Steel,5,3.0",
        "B2,800,1,0.06,0.13,57,0.0015,0.012,Spring-Tempered Steel,1,2.5",
        "=D4,5000,0,0.01,0.012,10,0.001,0.006,Music-Wire Steel,5,1.0",
        "E5,300,0,0.02,0.025,1.5,0.0006,0.005,Music-Wire Steel,5,2.0")


def _catalogue(folder: Path, rows=ROWS) -> Path:
    path = folder / "mine.csv"
    path.write_text("\n".join([HEADER, *rows]) + "\n")
    return path


def _table(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def searched(tmp_path_factory):
    folder = tmp_path_factory.mktemp("search")
    cat = _catalogue(folder)
    code = main(["springs", str(TUTORIAL), "--catalogue", str(cat), "-o", str(folder / "out"),
                 "--workers", "0", "--rank", "error", "--no-figures"])
    return code, folder / "out", load_catalogue(cat)


def test_every_row_is_screened_and_the_survivors_designed(searched):
    code, out, cat = searched
    rows = _table(out / "springs.csv")
    assert code == 0 and list(rows[0]) == list(TABLE_COLUMNS)
    assert sorted(r["part_number"] for r in rows) == sorted(["A1", "B2", "C3", "'=D4", "E5"])
    screened = screen(cat, slot_need(parse_spec(read_spec_data(TUTORIAL)), 0))
    by_part = {r["part_number"].removeprefix("'"): r for r in rows}
    for part, passed, reason in zip(cat.parts, screened.passed, screened.reasons):
        row = by_part[part]
        if passed:
            assert row["verdict"] == "feasible" and float(row["rmse"]) < 1e-3 * 0.981, row
            assert float(row["peak_force"]) <= cat.spring_body(cat.index(part)).load_max
        else:
            assert row["verdict"] == "infeasible" and row["reason"] == f"screen: {reason}" and row["rmse"] == ""
    assert sum(screened.passed) == 2


def test_the_table_is_ranked_feasible_first_by_rmse(searched):
    _, out, _ = searched
    rows = _table(out / "springs.csv")
    words = [r["verdict"] for r in rows]
    assert words == sorted(words, key=list(VERDICTS).index)
    feasible = [float(r["rmse"]) for r in rows if r["verdict"] == "feasible"]
    assert feasible == sorted(feasible) and len(feasible) == 2


def test_the_best_design_is_written_with_its_part(searched):
    _, out, _ = searched
    best = _table(out / "springs.csv")[0]
    result = json.loads((out / "best" / "result.json").read_text())
    assert result["status"] == "success"
    (body,) = result["spring_bodies"]
    assert body["part"] == best["part_number"]
    assert body["peak_force"] == pytest.approx(float(best["peak_force"]), rel=1e-3)
    assert (out / "best" / "cam1.dxf").is_file()
    assert not (out / "catalogue.png").exists() and not (out / "best" / "torque.png").exists()  # --no-figures


def test_a_limit_designs_the_nearest_rate_only(tmp_path, capsys):
    cat = _catalogue(tmp_path)
    assert main(["springs", str(TUTORIAL), "--catalogue", str(cat), "-o", str(tmp_path / "out"),
                 "--workers", "0", "--limit", "1", "--rank", "cost", "--no-figures"]) == 0
    rows = {r["part_number"]: r for r in _table(tmp_path / "out" / "springs.csv")}
    # the tutorial's nominal rate is 1000 N/m: A1 (1000) is designed, B2 (800) is not
    assert rows["A1"]["verdict"] == "feasible" and rows["B2"]["verdict"] == "not_designed"
    out, err = capsys.readouterr()
    assert "[1/1] A1: feasible" in err and "the best: A1" in out and "1 designed, 1 feasible" in out


def _fake_search(seed: int) -> Search:
    """A search of the shipped catalogue's first 40 rows with made-up designs: the ranking alone."""
    rng, bands = random.Random(seed), random.Random(-1 - seed)
    cat = load_catalogue(None)
    need = slot_need(parse_spec(read_spec_data(TUTORIAL)), 0)
    screened = screen(cat, need)
    designed = {}
    for part in rng.sample(cat.parts, 30):
        b = cat.spring_body(cat.index(part))
        status = rng.choice(["success", "recheck_failed", "max_iterations"])
        designed[part] = {"part": part, "status": status, "message": "m", "violations": ["v"],
                          "rmse": rng.choice([1e-6, 2e-6, rng.uniform(0, 1e-3)]), "relative_rmse": 0.1,
                          "band": bands.choice([None, 1e-4, bands.uniform(0, 1e-3)]),
                          "body": {"max_length": b.length_max * 0.9, "length_max": b.length_max,
                                   "peak_force": b.load_max * 0.5, "load_max": b.load_max,
                                   "peak_stress": b.allowed_stress * 0.5, "allowed_stress": b.allowed_stress}}
    return Search(cat, screened, designed, len(designed))


@pytest.mark.parametrize("rank", list(RANKS))
@pytest.mark.parametrize("seed", range(3))
def test_every_rank_orders_verdicts_then_its_key_then_rmse(rank, seed):
    found = _fake_search(seed)
    table = found.table(rank)
    assert len(table) == len(found.catalogue)
    col = dict(zip(TABLE_COLUMNS, range(len(TABLE_COLUMNS))))

    def key(row):
        value = {"error": row[col["rmse"]], "band": row[col["band"]],
                 "size": row[col["od"]] * row[col["free_length"]], "cost": row[col["pack_price"]]}[rank]
        return value if value is not None else math.inf
    for a, b in zip(table, table[1:]):
        va, vb = list(VERDICTS).index(a[1]), list(VERDICTS).index(b[1])
        assert va <= vb
        if va == vb:
            assert key(a) <= key(b)
            if key(a) == key(b) and a[3] is not None and b[3] is not None:
                assert a[3] <= b[3]
    feasible = [p for p, r in found.designed.items() if verdict(r)[0] == "feasible"]
    assert found.best() == (min(feasible, key=lambda p: found.designed[p]["rmse"]) if feasible else None)


def test_the_best_so_far_follows_the_rows_as_they_come_and_as_they_are_replaced():
    """As the progress line asks it after every spring: each answer the feasible row of least
    rmse among those designed so far, a row replaced judged again."""
    whole = _fake_search(1)
    found = Search(whole.catalogue, whole.screened, {}, whole.planned)
    for part, row in whole.designed.items():
        found.designed[part] = row
        feasible = [p for p, r in found.designed.items() if verdict(r)[0] == "feasible"]
        assert found.best() == (min(feasible, key=lambda p: found.designed[p]["rmse"]) if feasible else None)
    best = found.best()
    found.designed[best] = {**found.designed[best], "status": "max_iterations"}  # no longer feasible
    assert found.best() != best


def test_a_near_row_names_the_limit_passed_and_by_how_much():
    body = {"max_length": 0.103, "length_max": 0.1, "peak_force": 5.0, "load_max": 10.0,
            "peak_stress": 1.0, "allowed_stress": 2.0}
    row = {"status": "recheck_failed", "message": "m", "violations": ["x"], "body": body}
    assert verdict(row) == ("near", "its largest length passed by 3 %")


def test_the_part_spec_drops_every_key_the_part_fills():
    data = read_spec_data(TUTORIAL)
    data["springs"][0].update(preload=1.0, free_length=0.05, catalogue="x.csv")
    spring = part_spec(data, 0, "P1", None)["springs"][0]
    assert spring == {"ports": ["cable:1"], "part": "P1"}
    assert not set(FILLED_BY_PART) & set(spring) and data["springs"][0]["rate"] == 1000.0


@pytest.mark.parametrize("rows, words", [
    (("A1,1000,2,0.05,0.11,62,0.0015,0.012,Music-Wire Steel,1",), "fields, expected"),
    (("A1,1000,2,0.05,0.04,62,0.0015,0.012,Music-Wire Steel,1,4.5",), "length_max"),
    (("A1,-1,2,0.05,0.11,62,0.0015,0.012,Music-Wire Steel,1,4.5",), "stiffness"),
    ((), "no springs"),
])
def test_a_bad_catalogue_is_one_line_exit_2_and_nothing_written(tmp_path, capsys, rows, words):
    cat = _catalogue(tmp_path, rows)
    out = tmp_path / "out"
    assert main(["springs", str(TUTORIAL), "--catalogue", str(cat), "-o", str(out), "--workers", "0"]) == 2
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1 and not out.exists()


@pytest.mark.parametrize("flags, words", [
    (["--slot", "2"], "--slot 2: the spec has 1 spring"),
    (["--limit", "0"], "--limit 0: expected 1 to"),
    (["--workers", "-1"], "--workers -1: expected 0 to"),
    (["--rank", "volume"], "invalid choice: 'volume'"),
    (["--dask", "::x"], "--dask '::x': expected 'local' or a scheduler address"),
])
def test_bad_flags_are_one_line_exit_2_and_nothing_written(tmp_path, capsys, flags, words):
    out = tmp_path / "out"
    assert main(["springs", str(TUTORIAL), "-o", str(out), *flags]) == 2
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1 and not out.exists()


def test_no_feasible_spring_exits_1_with_its_summary(tmp_path, capsys):
    cat = _catalogue(tmp_path, [r for r in ROWS if r[:2] not in ("A1", "B2")])
    assert main(["springs", str(TUTORIAL), "--catalogue", str(cat), "-o", str(tmp_path / "out"),
                 "--workers", "0"]) == 1
    assert "3 screened out, 0 designed, 0 feasible" in capsys.readouterr().out
    assert [r["verdict"] for r in _table(tmp_path / "out" / "springs.csv")] == ["infeasible"] * 3
    assert not (tmp_path / "out" / "best").exists()
    assert (tmp_path / "out" / "catalogue.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"  # the figure all the same


def test_text_cells_that_look_like_formulas_are_escaped(tmp_path):
    from cadcam.files import write_csv

    write_csv(tmp_path / "t.csv", ["a", "b"], [["=1+1", -2.5], ["-x", None], ["a,b", np.float64(3)]])
    assert (tmp_path / "t.csv").read_text() == "a,b\n'=1+1,-2.5\n'-x,\n\"a,b\",3.0\n"
