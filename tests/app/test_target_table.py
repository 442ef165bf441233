"""The design page's table editor without a browser: a joint's table target read from its spec
(inline, or its CSV file in the unit of its header), rows pasted from a spreadsheet, cells
edited, and the spec written back with the table inline, which reads as the page's problem."""
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from cadcam import load_problem
from cadcam.app.state import DesignState
from cadcam.app.tables import LEAST_ROWS, pasted

ROOT = Path(__file__).resolve().parents[2]
KNEE = ROOT / "docs" / "knee_assist.toml"
KEY = "joints.1.target"


def knee_rows() -> list[list[float]]:
    """The knee assist's torque table, in degrees, as its spec gives it."""
    target = tomllib.loads(KNEE.read_text())["joints"][0]["target"]
    assert target["angle_unit"] == "deg"
    return target["samples"]


def knee_with_csv(folder: Path, inline: bool = False) -> Path:
    """The knee assist naming its table as ``tables/knee.csv`` (theta_deg), written to
    ``folder``; with ``inline`` its target an inline table (``target = {...}``)."""
    text = KNEE.read_text()
    start, end = text.index("[joints.target]"), text.index("[[mechanisms]]")
    target = ('target = { kind = "table", file = "tables/knee.csv" }\n\n' if inline else
              '[joints.target]   # the knee\'s torque, from the spreadsheet\nkind = "table"\nfile = "tables/knee.csv"\n\n')
    (folder / "tables").mkdir(exist_ok=True)
    (folder / "tables" / "knee.csv").write_text("theta_deg,torque_Nm\n" + "".join(f"{a},{t}\n" for a, t in knee_rows()))
    path = folder / "knee.toml"
    path.write_text(text[:start] + target + text[end:])
    return path


@pytest.mark.parametrize("text, chosen, unit, rows", [
    ("0\t0.5\n30\t4\n60\t6.7\n90\t8\n", "deg", "deg", [(0, 0.5), (30, 4), (60, 6.7), (90, 8)]),
    # a spreadsheet where the comma is the decimal mark: tabs between the cells, a blank line
    ("0\t0,5\n\n30\t4,25\t\n60\t6,7\n90\t8\n", "deg", "deg", [(0, 0.5), (30, 4.25), (60, 6.7), (90, 8)]),
    # a CSV, its rows in no order, its header naming radians over the unit chosen
    ("theta_rad,torque_Nm\n1.5,8\n0,0.5\n0.5,4\n1,6.7\n", "deg", "rad", [(0, 0.5), (0.5, 4), (1, 6.7), (1.5, 8)]),
    ("angle;torque\n0;0,5\n30;4\n60;6,7\n90;8\n", "deg", "deg", [(0, 0.5), (30, 4), (60, 6.7), (90, 8)]),
    ("  0 0.5\n 0.5 4\n 1 6.7\n 1.5 8\n", "rad", "rad", [(0, 0.5), (0.5, 4), (1, 6.7), (1.5, 8)]),
])
def test_rows_pasted_from_a_spreadsheet_or_a_csv_are_read_in_the_unit_chosen_or_their_headers(text, chosen, unit, rows):
    table = pasted(text, chosen, "joints[1].target")
    assert table.unit == unit and table.rows == tuple((float(a), float(t)) for a, t in rows)


@pytest.mark.parametrize("header, unit", [("angle [deg]\ttorque", "deg"), ("θ (°)\tτ", "deg"), ("theta_deg,torque_Nm", "deg"),
                                          ("angle in radians\ttorque", "rad"), ("angle\ttorque [N·m]", "rad")])
def test_a_header_sets_the_unit_only_where_it_names_one(header, unit):
    sep = "," if "," in header else "\t"
    table = pasted(header + "\n" + "".join(f"{a}{sep}{a}\n" for a in range(4)), "rad", "joints[1].target")
    assert table.unit == unit


@pytest.mark.parametrize("text, words", [
    ("0\t1\n1\t2\n2\t3\n", f"3 rows; a table takes at least {LEAST_ROWS} (angle, torque) rows"),
    ("0\t1\n1\tx\n2\t3\n3\t4\n", "line 2 '1\\tx' is not two numbers"),
    ("angle\ttorque\n0\t1\t7\n1\t2\n2\t3\n3\t4\n", "line 2 holds 3 cells; paste two columns"),
    ("0\t1\n1\t2\n1\t3\n3\t4\n", "two rows at 1 deg; give each angle once"),
    ("0\t1\n1\tnan\n2\t3\n3\t4\n", "line 2: '1\\tnan' is not two finite numbers"),
    ("0\t1\n1\t1e999\n2\t3\n3\t4\n", "line 2: '1\\t1e999' is not two finite numbers"),
    ("", "0 rows; a table takes at least"),
])
def test_a_paste_that_is_no_table_is_one_line_naming_the_line_wrong(text, words):
    state = DesignState(KNEE)
    error = state.paste_table(KEY, text, "deg")
    assert error.startswith("joints[1].target: ") and words in error and "\n" not in error
    assert state.table_edits == {}


def test_a_csv_table_target_opens_in_its_unit_and_reads_as_the_same_table_inline(tmp_path):
    """The CSV's rows in degrees, as its header says; no field for the file or the unit (the
    editor holds them); the problem the same as the spec giving the rows inline."""
    state = DesignState(knee_with_csv(tmp_path))
    table = state.table(KEY)
    assert (table.unit, table.file) == ("deg", "tables/knee.csv")
    assert [list(r) for r in table.rows] == knee_rows()
    assert not any(f.key.startswith(f"{KEY}.") for f in state.fields)
    assert state.problem().to_dict()["joints"] == load_problem(KNEE).to_dict()["joints"]


def test_a_table_pasted_is_the_problems_target_and_the_spec_written_carries_it_inline(tmp_path):
    """Rows pasted replace the CSV file: the problem's samples are their angles in radians; the
    spec written has them inline (the file gone, the spec's comments kept, the CSV named in a
    comment) and reads as the page's problem."""
    state = DesignState(knee_with_csv(tmp_path))
    rows = [(0.0, 0.6), (20.0, 3.0), (40.0, 5.2), (60.0, 6.9), (90.0, 8.2)]
    assert state.paste_table(KEY, "".join(f"{a}\t{t}\n" for a, t in rows), "deg") is None
    samples = np.array(state.problem().joints[0].target.data["samples"])
    np.testing.assert_array_equal(samples, [(math.radians(a), t) for a, t in rows])
    written = tmp_path / "out" / "knee.toml"  # a folder without the CSV: the spec needs none
    written.parent.mkdir()
    written.write_text(state.spec_toml())
    text = written.read_text()
    target = tomllib.loads(text)["joints"][0]["target"]
    assert target == {"kind": "table", "angle_unit": "deg", "samples": [list(r) for r in rows]}
    assert "# A knee assist: a cam on the shank" in text and "# the knee's torque, from the spreadsheet" in text
    assert "# the rows the design page had, in place of knee.csv" in text
    assert load_problem(written).to_dict() == state.problem().to_dict()


def test_a_csv_table_not_edited_is_written_inline_too_and_an_inline_table_stays_on_its_line(tmp_path):
    for inline in (False, True):
        folder = tmp_path / str(inline)
        folder.mkdir()
        state = DesignState(knee_with_csv(folder, inline=inline))
        assert state.table_edits == {}
        written = tmp_path / f"written_{inline}" / "knee.toml"  # a folder without the CSV
        written.parent.mkdir()
        written.write_text(state.spec_toml())
        assert load_problem(written).to_dict() == load_problem(KNEE).to_dict() | {"name": "knee"}
        assert ("target = {" in written.read_text()) == inline


def test_an_edited_cell_designs_and_a_cell_that_is_no_number_is_one_line(tmp_path):
    state = DesignState(KNEE)
    rows = [list(r) for r in state.table(KEY).rows]
    rows[2][1] = 4.4
    assert state.edit_table(KEY, rows) is None
    assert state.problem().joints[0].target.data["samples"][2] == [math.radians(rows[2][0]), 4.4]
    rows[3][0] = float("nan")
    assert state.edit_table(KEY, rows) == "joints[1].target: row 4: the angle is nan; give a finite number"
    assert state.table(KEY).rows[2] == (30.0, 4.4)  # the last table stands
    rows[3][0] = 45.0
    rows[2][1] = 4.0  # the spec's rows again: no edit
    assert state.edit_table(KEY, rows) is None and state.table_edits == {} and state.override_pairs() == []


def test_the_unit_chosen_says_what_the_angles_are_and_an_edit_names_the_catalogue_context():
    """A unit chosen reads the same numbers in it (the angles are not converted); a table edit is
    one of the edits a catalogue part's verdict depends on."""
    state = DesignState(KNEE)
    before = state._context(1)
    rows = state.table(KEY).rows
    assert state.edit_table(KEY, [(a / 50, t) for a, t in rows], unit="rad") is None
    assert state.problem().joints[0].target.data["samples"] == [[a / 50, t] for a, t in rows]
    assert state._context(1) != before


def test_a_table_that_misses_the_joints_range_is_the_editors_error():
    state = DesignState(KNEE)
    assert state.paste_table(KEY, "0\t0.5\n20\t2.6\n40\t4.6\n60\t6.7\n", "deg") is None
    outcome = state.design()
    assert outcome.result is None and outcome.field == KEY
    assert "the table covers" in outcome.error and "\n" not in outcome.error
