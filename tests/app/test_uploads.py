"""A spec uploaded with the CSV files it names, without a browser: the names the spec gives are
looked up among the files uploaded (never on the server's disk), each file is written under a
name of the page's own, a file missing is one line naming it; and the page that opens them
(its design stubbed: nothing here solves)."""
import json
import tomllib
from pathlib import Path

import pytest

from cadcam import load_problem
from cadcam.app.state import DesignState
from cadcam.app.uploads import save
from cadcam.physics.catalogue import SHIPPED
from cadcam.spec import SpecError

from .test_target_table import KEY, KNEE, knee_rows, knee_with_csv

ROOT = Path(__file__).resolve().parents[2]
#: A part of the shipped catalogue whose travel the knee's cam needs no more of.
PART = "8594N109"


def files_of(*paths: Path, names=None) -> list[tuple[str, bytes]]:
    """``paths`` as the browser uploads them: (its name for each, the content)."""
    return [(name, p.read_bytes()) for name, p in zip(names or [p.name for p in paths], paths)]


def opened(up) -> DesignState:
    return DesignState(up.path, original=up.original, aliases=up.aliases)


def test_a_spec_and_its_csv_open_as_the_spec_in_its_own_folder(tmp_path):
    """The spec names tables/knee.csv; the browser sends knee.csv: the page's copies, the table
    in the editor, the problem of the spec read where it lies, the spec written as uploaded."""
    spec = knee_with_csv(tmp_path)
    folder = tmp_path / "upload"
    folder.mkdir()
    up = save(files_of(spec, tmp_path / "tables" / "knee.csv"), folder)
    assert sorted(p.name for p in folder.iterdir()) == ["given.toml", "table1.csv", "upload.toml"]
    assert (up.name, up.tables) == ("knee.toml", ("knee.csv",)) and up.original.read_bytes() == spec.read_bytes()
    state = opened(up)
    assert [list(r) for r in state.table(KEY).rows] == knee_rows()
    assert state.problem().to_dict() == load_problem(spec).to_dict()  # named knee, as the file is
    written = tomllib.loads(state.spec_toml())
    assert "name" not in written and written["joints"][0]["target"]["samples"] == knee_rows()


def test_a_name_the_spec_gives_is_found_among_the_files_uploaded_by_its_last_part(tmp_path):
    """A spec naming its table by a path of this machine opens the table uploaded under that
    name (other rows than the file on the disk), and a browser's name with folders is cut to
    its last part."""
    spec = knee_with_csv(tmp_path)
    on_disk = tmp_path / "tables" / "knee.csv"
    spec.write_text(spec.read_text().replace('"tables/knee.csv"', json.dumps(str(on_disk))))
    uploaded = tmp_path / "other.csv"
    rows = [[a, 2 * t] for a, t in knee_rows()]
    uploaded.write_text("theta_deg,torque_Nm\n" + "".join(f"{a},{t}\n" for a, t in rows))
    folder = tmp_path / "upload"
    folder.mkdir()
    up = save(files_of(spec, uploaded, names=["knee.toml", "../../a/knee.csv"]), folder)
    assert [list(r) for r in opened(up).table(KEY).rows] == rows
    assert sorted(p.name for p in folder.iterdir()) == ["given.toml", "table1.csv", "upload.toml"]


@pytest.mark.parametrize("name", ["/etc/hostname", "../../../../etc/hostname", "C:\\Windows\\win.ini", "knee.csv"])
def test_a_file_the_spec_names_that_was_not_uploaded_is_one_line_naming_it(tmp_path, name):
    spec = knee_with_csv(tmp_path)
    spec.write_text(spec.read_text().replace('"tables/knee.csv"', json.dumps(name)))
    folder = tmp_path / "upload"
    folder.mkdir()
    last = name.replace("\\", "/").rsplit("/", 1)[-1]
    for files in (files_of(spec), files_of(spec, KNEE, names=["knee.toml", "notes.txt.csv"])):
        with pytest.raises(SpecError) as info:
            save(files, folder)
        message = str(info.value)
        assert message.startswith(f"'knee.toml': joints[1].target.file = {name!r}: {last!r} is not among the files opened")
        assert "\n" not in message


@pytest.mark.parametrize("names, words", [
    (["a.toml", "b.toml"], "2 of these files are specs ('a.toml', 'b.toml')"),
    (["a.csv", "b.CSV"], "none of these 2 files is a spec"),
    (["a.toml", "x/knee.csv", "knee.csv"], "two files named 'knee.csv'"),
])
def test_files_that_are_not_one_spec_and_its_tables_are_one_line(tmp_path, names, words):
    with pytest.raises(SpecError) as info:
        save([(n, KNEE.read_bytes()) for n in names], tmp_path)
    assert str(info.value).startswith(words) and "\n" not in str(info.value)


def knee_with_part(folder: Path) -> Path:
    """The knee (its table in a CSV) with part :data:`PART` of the catalogue ``cat/mine.csv``
    (the shipped catalogue's row of it) as its spring."""
    spec = knee_with_csv(folder)
    text = spec.read_text()
    start, end = text.index("[[springs]]"), text.index("[cable]")
    spec.write_text(text[:start] + f'[[springs]]\nports = ["cable:1"]\npart = "{PART}"\ncatalogue = "cat/mine.csv"\n\n'
                    + text[end:])
    rows = (ROOT / "cadcam" / SHIPPED).read_text().splitlines()
    (folder / "cat").mkdir()
    (folder / "cat" / "mine.csv").write_text("\n".join([rows[0], *(r for r in rows if f",{PART}," in r)]) + "\n")
    return spec


def test_a_springs_catalogue_is_an_upload_too_and_the_result_names_it_as_the_user_does(tmp_path):
    spec = knee_with_part(tmp_path)
    folder = tmp_path / "upload"
    folder.mkdir()
    up = save(files_of(spec, tmp_path / "tables" / "knee.csv", tmp_path / "cat" / "mine.csv"), folder)
    assert up.tables == ("knee.csv", "mine.csv")
    state = opened(up)
    problem = state.problem()
    assert Path(problem.springs[0].catalogue) == (folder / "table2.csv").resolve()
    assert problem.to_dict()["springs"][0] | {"catalogue": None} == \
        load_problem(spec).to_dict()["springs"][0] | {"catalogue": None}
    text = json.dumps({"problem": problem.to_dict()})
    assert json.loads(state.own_names(text))["problem"]["springs"][0]["catalogue"] == "mine.csv"
    assert str(folder) not in state.own_names(text)
    assert tomllib.loads(state.spec_toml())["springs"][0]["catalogue"] == "cat/mine.csv"  # the user's name


def test_a_result_json_naming_its_catalogue_by_its_path_opens_with_it(tmp_path):
    """A result.json names its spring's catalogue by the path it was read from (as cadcam design
    writes it): opened with that CSV, the page reads the CSV uploaded."""
    problem = load_problem(knee_with_part(tmp_path)).to_dict()
    assert Path(problem["springs"][0]["catalogue"]).is_absolute()
    result = tmp_path / "knee_result.json"
    result.write_text(json.dumps({"problem": problem}))
    folder = tmp_path / "upload"
    folder.mkdir()
    up = save(files_of(result, tmp_path / "cat" / "mine.csv"), folder)
    assert up.path.name == "upload.json" and up.tables == ("mine.csv",)
    state = opened(up)
    assert Path(state.problem().springs[0].catalogue) == (folder / "table1.csv").resolve()
    assert state.problem().springs[0].rate == load_problem(result).springs[0].rate


# -- the page ------------------------------------------------------------------------------------
@pytest.fixture
def page(tmp_path, monkeypatch):
    """The page's module, its uploads in a temporary folder of this test, its designs stubbed."""
    pytest.importorskip("panel", reason="Panel is the app extra's (make test installs it)")
    import tempfile

    from cadcam.app import page

    async def no_design(*args, **kwargs):
        """No design: the tests here are about what comes before the solver."""

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "temp"))
    (tmp_path / "temp").mkdir()
    monkeypatch.setattr(page.DesignPage, "design", no_design)
    return page


def leftovers(page, root: Path) -> list[Path]:
    page.WORKER.submit(lambda: None).result()
    return sorted(root.glob(f"{page.UPLOAD_PREFIX}*"))


def test_the_page_opens_a_spec_with_its_csv_names_them_and_downloads_under_its_name(page, tmp_path):
    spec = knee_with_csv(tmp_path)
    view = page.DesignPage(DesignState.template("johnston2023_1dof"))
    assert view.template.value == page.TEMPLATES[0].title
    view.upload.param.update(value=[spec.read_bytes()], filename=["knee.toml"])  # without its table
    assert "'tables/knee.csv': 'knee.csv' is not among the files opened" in view.open_error.object
    assert view.folder is None and leftovers(page, tmp_path / "temp") == []
    files = files_of(spec, tmp_path / "tables" / "knee.csv")
    view.upload.param.update(value=[d for _, d in files], filename=[n for n, _ in files])
    assert view.open_error.object == "" and view.given_tables == ("knee.csv",)
    assert "open knee.toml with 'knee.csv'" in view.opened.object
    assert view.template.value == "knee.toml (the file open)" and view.template.options[1:] == \
        [t.title for t in page.TEMPLATES]
    assert sorted(b.filename for b, _ in view._named)[:3] == ["knee.toml", "knee_dxf.zip", "knee_outputs.zip"]
    assert view.table_widgets[KEY][1].value.values.tolist() == knee_rows()
    assert leftovers(page, tmp_path / "temp") == [view.folder]
    view.template.value = page.TEMPLATES[1].title  # a template: its title, the file's choice gone
    assert view.template.options == [t.title for t in page.TEMPLATES]
    assert [b.filename for b, _ in view._named][0] == f"{page.TEMPLATES[1].spec}.toml"
    assert view.folder is None and leftovers(page, tmp_path / "temp") == []
