"""Issue 48: a spring catalogue (CSV) with a short row, an unclosed quote or a number that is not
one is bad input — one line, exit 2, nothing created — never a traceback.

The shipped catalogue is mutated by hypothesis: cells dropped or added, quotes opened or left
stray, numbers replaced by words, NaN, infinities, overflowing or huge ones, a byte order mark,
blank lines, CRLF line ends, the file emptied or cut to its header. Each mutation says whether
it leaves a readable catalogue; a readable one gives one spring per data row with the numbers
written, an unreadable one is refused by ``cadcam sweep`` before any database exists.
"""
from __future__ import annotations

import csv
import io

from hypothesis import HealthCheck, given, note, settings
from hypothesis import strategies as st

from cadcam.cli import main
from cadcam.sweep.study import StudyError, load_study

from ..conftest import ROOT

CATALOGUE = ROOT / "models" / "spring_catalogue.csv"
NUMBERS = ("rate_N_per_m", "travel_m", "pretension_N")
#: Replacements of a number cell: (text, readable as a number of a spring). A blank
#: pretension is no preload; a blank rate or travel is not a number.
NOT_NUMBERS = ["abc", "1,5", "nan", "NaN", "inf", "-inf", "1e400", "-1e999", "0x10", "1e", "--1"]
NUMBERS_OK = ["1e300", "-0.0", "5e-324", " 12.5 ", "1_000"]


def _rows() -> list[list[str]]:
    return list(csv.reader(io.StringIO(CATALOGUE.read_text(), newline="")))


@st.composite
def mutated(draw) -> tuple[str, bool]:
    """(catalogue text, whether it stays readable) after one to three mutations."""
    rows, readable, prefix, newline, broken = _rows(), True, "", "\n", set()
    header = rows[0]
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["drop_cell", "add_cell", "open_quote", "stray_quote", "number",
                                     "bom", "blank_line", "crlf", "empty", "header_only"]))
        # a row broken once is not changed again (a cell added, then one dropped, is a whole row)
        data = [k for k in range(1, len(rows)) if rows[k] and k not in broken]
        if kind in ("drop_cell", "add_cell", "open_quote", "stray_quote", "number") and not data:
            continue  # no data row left to change
        row = draw(st.sampled_from(data)) if data else 0
        if kind in ("drop_cell", "add_cell", "open_quote", "stray_quote"):
            broken.add(row)
        if kind == "drop_cell":
            rows[row].pop(draw(st.integers(0, len(rows[row]) - 1)))
            readable = False
        elif kind == "add_cell":
            rows[row].insert(draw(st.integers(0, len(rows[row]))), draw(st.sampled_from(["", "x", "1"])))
            readable = False
        elif kind == "open_quote":  # a quoted cell that never closes (no other quote in the file)
            cell = draw(st.integers(0, len(rows[row]) - 1))
            rows[row][cell] = '"' + rows[row][cell]
            readable = False
        elif kind == "stray_quote":  # a quoted cell with text after its closing quote
            cell = draw(st.integers(0, len(rows[row]) - 1))
            rows[row][cell] = f'"{rows[row][cell]}"x'
            readable = False
        elif kind == "number" and len(rows[row]) == len(header):
            column = header.index(draw(st.sampled_from(NUMBERS)))
            text = draw(st.sampled_from(NOT_NUMBERS + NUMBERS_OK + [""]))
            rows[row][column] = text
            blank_preload = text == "" and header[column] == "pretension_N"
            readable &= text in NUMBERS_OK or blank_preload
        elif kind == "bom":
            prefix = "\ufeff"
        elif kind == "blank_line" and rows:
            at = draw(st.integers(1, len(rows)))
            rows.insert(at, [])
            broken = {k + (k >= at) for k in broken}
        elif kind == "crlf":
            newline = "\r\n"
        elif kind == "empty":
            rows, readable, broken = [], False, set()
        elif kind == "header_only":
            rows, readable, broken = rows[:1], False, set()
    # written cell by cell: csv.writer would quote the very quotes that make a row malformed
    return prefix + "".join(",".join(r) + newline for r in rows), readable


def _study(folder, catalogue: str):
    (folder / "springs.csv").write_text(catalogue, encoding="utf-8", newline="")
    study = folder / "study.toml"
    study.write_text(f'name = "c"\nbase = "{ROOT / "models" / "johnston2023_rr_arm.toml"}"\n'
                     '[[parameters]]\nkey = "springs.1"\ncatalogue = "springs.csv"\n')
    return study


@settings(max_examples=120, deadline=None, derandomize=True, database=None, suppress_health_check=list(HealthCheck))
@given(case=mutated())
def test_a_mutated_catalogue_is_read_whole_or_refused_in_one_line(tmp_path_factory, capsys, case):
    text, readable = case
    note(repr(text[:400]))
    folder = tmp_path_factory.mktemp("catalogue")
    study = _study(folder, text)
    if readable:
        springs = load_study(study).parameters[0].values
        rows = [r for r in csv.reader(io.StringIO(text.removeprefix("\ufeff"), newline=""))][1:]
        rows = [r for r in rows if r]
        assert [s["rate"] for s in springs] == [float(r[2]) for r in rows]
        assert [s["preload"] for s in springs] == [float(r[4].strip() or 0.0) for r in rows]
        return
    code = main(["sweep", str(study), "-o", str(folder / "s.db"), "--workers", "0"])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith(f"cadcam: error: {study}: parameters[1].catalogue: "), err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not (folder / "s.db").exists()


def test_the_shipped_catalogue_is_read_whole():
    springs = load_study(ROOT / "studies" / "spring_catalogue.toml").parameters[0].values
    assert [s["name"].split(" (")[0] for s in springs] == [r[0] for r in _rows()[1:]]


def test_a_short_row_and_an_unclosed_quote_name_the_row_or_the_quote(tmp_path):
    rows = _rows()
    short = "\n".join(",".join(r) for r in rows[:2] + [rows[2][:3]] + rows[3:]) + "\n"
    for text, words in [(short, "data row 2 has 3 cells and the header 6"),
                        (CATALOGUE.read_text().replace("1100,", '"1100,', 1), "close every quote")]:
        try:
            load_study(_study(tmp_path, text))
        except StudyError as exc:
            assert words in str(exc) and "\n" not in str(exc)
        else:
            raise AssertionError(f"{words}: read")
