"""A design whose written files fail their verification is not a success of the command:
``cadcam design`` exits 1 and says where the report is, although the design itself passed."""
from __future__ import annotations

from pathlib import Path

import pytest

from cadcam import cli
from cadcam.outputs import verification

SPEC = Path(__file__).resolve().parents[2] / "docs" / "first_balancer.toml"


@pytest.mark.parametrize("verdict, code", [(False, 1), pytest.param(True, 0, marks=pytest.mark.slow)])
def test_the_exit_follows_the_files_verification(tmp_path, monkeypatch, capsys, verdict, code):
    monkeypatch.setattr(verification, "passed", lambda checks, cams, files=(): verdict)
    out = tmp_path / "out"
    assert cli.main(["design", str(SPEC), "-o", str(out), "--no-figures"]) == code
    captured = capsys.readouterr()
    assert captured.out.startswith("success:")
    assert ("the written files miss what the design claims" in captured.err) is (not verdict)
    assert (out / "verification.md").read_text().startswith(
        f"# Workshop files against the design: {'PASSED' if verdict else 'FAILED'}")
