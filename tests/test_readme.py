"""Every command block of README.md and of the pages in :data:`PAGES` runs, in a copy of the repository, with .venv/bin first on
PATH: exit code 0 (or the one the block states) and the files it names with ``-o``/``--csv``
(or ``creates``) exist afterwards. Blocks run in the README's order in one working folder, so a
block may use what an earlier one wrote (the export reads the RR arm's design).

A command block is a fence with no language or ``sh``, ``bash``, ``shell``, ``console``. The
lines ``<!-- readme-test: ... -->`` right above a fence say how it is tested when not simply
run:

``skip because REASON``
    not run; the reason is required and shows in pytest's summary.
``skip-line "PREFIX" because REASON``
    the block runs without its lines starting with PREFIX.
``tested-by tests/FILE.py::TEST``
    another test runs this command (the test must exist).
``synopsis``
    a usage synopsis with placeholders: every ``cadcam`` command in it must exist and offer
    each ``--flag`` and ``a|b|c`` choice it shows (checked against its ``--help``, which
    :func:`cadcam.cli.main` prints in this process; the console script itself runs in the
    other blocks).
``prepare NAME because REASON``
    a cheaper equivalent: :data:`PREPARATIONS` [NAME] shrinks the inputs in the copy first (the
    same commands on a smaller problem); the reason says what the full run costs.
``slow because REASON``
    run by ``make test-slow`` (marked slow), not ``make test``: a block whose run alone would
    take a large share of the five minutes; a block using its outputs is marked so too.
``exit N``, ``creates PATH ...``, ``prints TEXT``
    the expected exit code, files, and text on stdout (with ``exit 2``, bad input, the files
    named by ``-o`` must not exist afterwards).

``make`` runs with the test's own virtual environment (``VENV=``, its install stamp taken as
up to date: the copy never reinstalls anything).

A block whose commands are those of a block run before it (the README and the tutorial both
show the first design's command) is not run again: its exit code, files and text are checked on
that run's, in the same working folder.
"""
from __future__ import annotations

import ast
import contextlib
import io
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
#: The pages whose command blocks run, in this order (README first: its ``make demo`` makes the venv).
PAGES = (README, ROOT / "docs" / "tutorial.md", ROOT / "docs" / "guide.md")
COMMAND_LANGUAGES = {"", "sh", "bash", "shell", "console"}
DIRECTIVE = re.compile(r"<!--\s*readme-test:\s*(.*?)\s*-->")
KINDS = ("skip", "skip-line", "tested-by", "synopsis", "prepare", "slow", "exit", "creates", "prints")
#: What one block may take [s]; the whole file stays within about a minute.
BLOCK_TIMEOUT = 240
VENV = Path(sys.executable).parent.parent
COPY_IGNORE = shutil.ignore_patterns(".git", ".venv", "out", "build", "*.egg-info", "__pycache__",
                                     ".pytest_cache", ".hypothesis", ".mypy_cache", ".ruff_cache")


@dataclass
class Block:
    line: int                 # 1-based line of the opening fence
    language: str
    text: str
    directives: list[tuple[str, str]] = field(default_factory=list)
    page: str = "README"

    @property
    def where(self) -> str:
        """The page and line, for messages."""
        return f"{self.page} line {self.line}"

    def get(self, kind: str) -> list[str]:
        return [arg for k, arg in self.directives if k == kind]

    @property
    def id(self) -> str:
        """The block's first line (stable while other parts of the README move)."""
        first = next((ln.strip() for ln in self.text.splitlines() if ln.strip()), "")
        return " ".join(first.split("#")[0].split())[:60]


def parse_readme(text: str, page: str = "README") -> list[Block]:
    """The fenced blocks of ``text`` whose language is a shell's (or none), with the
    readme-test directives on the lines right above each."""
    lines = text.splitlines()
    blocks, i = [], 0
    while i < len(lines):
        m = re.fullmatch(r"```(\w*)\s*", lines[i])
        if not m:
            i += 1
            continue
        end = next(j for j in range(i + 1, len(lines)) if lines[j].startswith("```"))
        if m[1] in COMMAND_LANGUAGES:
            directives, k = [], i - 1
            while k >= 0 and (d := DIRECTIVE.fullmatch(lines[k].strip())):
                kind, _, arg = d[1].partition(" ")
                directives.insert(0, (kind, arg.strip()))
                k -= 1
            blocks.append(Block(i + 1, m[1], "\n".join(lines[i + 1:end]) + "\n", directives, page))
        i = end + 1
    return blocks


def _reason(arg: str) -> str:
    return arg.partition("because")[2].strip()


BLOCKS = [b for page in PAGES
          for b in parse_readme(page.read_text(encoding="utf-8"), "README" if page == README else str(page.relative_to(ROOT)))]


# -- cheaper equivalents ---------------------------------------------------------------------------
def _set_grid(path: Path, grid: int):
    """``[solver] grid`` of a spec in the copy set to ``grid`` (the spec must state it once)."""
    text = path.read_text()
    new, n = re.subn(r"(?m)^grid = \d+$", f"grid = {grid}", text)
    assert n == 1, f"{path.name}: expected one 'grid = N' line to shrink, found {n}"
    path.write_text(new)
    assert tomllib.loads(new)["solver"]["grid"] == grid


def _two_cases(path: Path):
    """A factorial study cut to two cases: its first parameter's first two values, every other
    parameter's first value (the ``values = [...]`` lines rewritten in place, nothing else)."""
    text = path.read_text()
    study = tomllib.loads(text)
    assert study.get("design", "factorial") == "factorial", path
    params = study["parameters"]
    assert all("values" in p for p in params), f"{path.name}: expected values lists only"
    pattern = re.compile(r"(?m)^values = \[.*\]$")
    assert len(pattern.findall(text)) == len(params), f"{path.name}: one 'values = [...]' line each"
    cut = iter(json.dumps(p["values"][:2 if k == 0 else 1]) for k, p in enumerate(params))
    new = pattern.sub(lambda m: f"values = {next(cut)}", text)
    cases = 1
    for p in tomllib.loads(new)["parameters"]:
        cases *= len(p["values"])
    assert cases == 2, path.name
    path.write_text(new)


#: name → function of the working copy that shrinks what a block's commands read
PREPARATIONS = {
    "rr-arm-grid-12": lambda root: _set_grid(root / "models" / "johnston2023_rr_arm.toml", 12),
    "two-case-idler-study": lambda root: _two_cases(root / "studies" / "idler_placement.toml"),
}


# -- running ----------------------------------------------------------------------------------------
def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PATH"] = f"{VENV / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    env["CADCAM_TEST_VENV"] = str(VENV)
    env.pop("MAKEFLAGS", None)
    env.pop("MFLAGS", None)
    env["MPLBACKEND"] = "Agg"
    return env


PRELUDE = """set -euo pipefail
make() { command make -o "$CADCAM_TEST_VENV/.installed-stamp" VENV="$CADCAM_TEST_VENV" "$@"; }
"""


def _commands(text: str) -> list[str]:
    """The block's command lines, continuation lines joined, comments and blank lines out."""
    out, current = [], ""
    for raw in text.splitlines():
        line = raw.rstrip()
        if not current and (not line.strip() or line.lstrip().startswith("#")):
            continue
        if line.endswith("\\"):
            current += line[:-1] + " "
            continue
        out.append(current + line)
        current = ""
    return out


def _outputs(command: str) -> list[str]:
    """Paths a cadcam command line names as its outputs (``-o``, ``--output``, ``--csv``)."""
    try:
        words = shlex.split(command, comments=True)
    except ValueError:
        return []
    return [words[i + 1] for i, w in enumerate(words[:-1])
            if w in ("-o", "--output", "--csv") and words[0] == "cadcam"]


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    """A copy of the repository (no .git, .venv, out): the README's commands run in it."""
    root = tmp_path_factory.mktemp("readme") / "cadcam"
    shutil.copytree(ROOT, root, symlinks=True, ignore=COPY_IGNORE)
    return root


@pytest.fixture(scope="module")
def runs():
    """The runs of the blocks so far, by the script run (the prelude and the commands)."""
    return {}


def test_the_first_design_shown_is_the_spec_file_it_names():
    """The README and the tutorial show docs/first_balancer.toml's spec; the file is what runs."""
    spec = (ROOT / "docs" / "first_balancer.toml").read_text(encoding="utf-8")
    body = spec[spec.index("\n\n") + 2:]  # below its header of comments
    for page in (README, ROOT / "docs" / "tutorial.md"):
        shown = re.search(r"```toml\n(.*?)```", page.read_text(encoding="utf-8"), re.S)[1]
        assert shown == body, f"{page.name} shows another spec than docs/first_balancer.toml"


def test_the_readme_has_command_blocks_and_each_is_run_or_says_why_not():
    assert len(BLOCKS) >= 5
    for b in BLOCKS:
        for kind, arg in b.directives:
            assert kind in KINDS, f"{b.where}: unknown readme-test directive {kind!r}"
            if kind in ("skip", "skip-line", "prepare", "slow"):
                assert _reason(arg), f"{b.where}: '{kind}' needs 'because <reason>'"
        if b.get("skip") or b.get("tested-by") or b.get("synopsis"):
            assert len({k for k, _ in b.directives} & {"skip", "tested-by", "synopsis"}) == 1, b.line
        assert not (b.get("prepare") and b.get("skip")), b.line
        for name in b.get("prepare"):
            assert name.split()[0] in PREPARATIONS, f"{b.where}: no preparation {name!r}"
    run = [b for b in BLOCKS if not (b.get("skip") or b.get("tested-by") or b.get("synopsis"))]
    assert len(run) >= 4, "most command blocks should really run"


@pytest.mark.parametrize("block", [pytest.param(b, marks=[pytest.mark.slow] if b.get("slow") else [])
                                   for b in BLOCKS], ids=[b.id for b in BLOCKS])  # pytest numbers repeats
def test_readme_block(block, workdir, runs):
    if block.get("skip"):
        pytest.skip(f"{block.where}: {_reason(block.get('skip')[0])}")
    if block.get("tested-by"):
        for target in block.get("tested-by"):
            _check_test_exists(target)
        return
    if block.get("synopsis"):
        _check_synopsis(block)
        return
    for name in block.get("prepare"):
        PREPARATIONS[name.split()[0]](workdir)
    skipped = [shlex.split(arg.partition("because")[0])[0] for arg in block.get("skip-line")]
    commands = [c for c in _commands(block.text)
                if not any(c.lstrip().startswith(prefix) for prefix in skipped)]
    assert commands, f"{block.where}: nothing left to run"
    script = PRELUDE + "\n".join(commands) + "\n"
    if block.get("prepare") or script not in runs:
        runs[script] = subprocess.run(["bash", "-c", script], cwd=workdir, env=_env(),
                                      capture_output=True, text=True, timeout=BLOCK_TIMEOUT)
    run = runs[script]
    expected = int(block.get("exit")[0]) if block.get("exit") else 0
    assert run.returncode == expected, (f"{block.where}: exit {run.returncode}, "
                                        f"expected {expected}\n{run.stdout[-2000:]}\n{run.stderr[-3000:]}")
    named = [p for c in commands for p in _outputs(c)]
    if expected == 2:  # bad input: refused before work, nothing written
        made = [p for p in named if (workdir / p).exists()]
        assert not made, f"{block.where}: a refused command wrote {made}"
        named = []
    named += [p for arg in block.get("creates") for p in shlex.split(arg)]
    missing = [p for p in named if not (workdir / p).exists()]
    assert not missing, f"{block.where}: the block did not create {missing}"
    for text in block.get("prints"):
        assert text in run.stdout, f"{block.where}: stdout lacks {text!r}\n{run.stdout[-2000:]}"


def _check_test_exists(target: str):
    path, _, name = target.partition("::")
    tree = ast.parse((ROOT / path).read_text())
    names = {n.name for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)}
    assert name in names, f"tested-by {target}: no such test"


def _check_synopsis(block: Block):
    """Each ``cadcam`` line of a synopsis names a command that exists, and every ``--flag`` and
    ``a|b`` choice shown is in that command's ``--help``."""
    lines = []
    for raw in block.text.splitlines():
        if raw.startswith("cadcam"):
            lines.append(raw)
        elif lines and raw.strip():
            lines[-1] += " " + raw.strip()
    assert lines, f"{block.where}: a synopsis without cadcam commands"
    from cadcam.cli import main

    for line in lines:
        words = line.split()
        sub = [] if words[1].startswith("-") else [words[1]]
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            try:  # in this process: the console script costs a second per call
                code = main([*sub, "--help"])
            except SystemExit as stop:
                code = stop.code
        assert code in (0, None), f"{line}: cadcam {' '.join(sub)} --help failed (exit {code})"
        helptext = out.getvalue()
        for flag in re.findall(r"(?<![\w-])(--?[a-z][\w-]*)", line):
            assert re.search(rf"(?<![\w-]){re.escape(flag)}\b", helptext), f"{line}: {flag} not in --help"
        for choices in re.findall(r"\w[\w-]*(?:\|\w[\w-]*)+", line):
            for choice in choices.split("|"):
                assert choice in helptext, f"{line}: choice {choice!r} not in --help"


def test_make_targets_the_readme_names_exist(workdir):
    """Every ``make TARGET`` in the README is a Makefile target, and the scripts it runs exist
    (a dry run: nothing is built)."""
    targets = sorted(set(re.findall(r"(?m)(?:`|^)make ([a-z][\w-]*)", README.read_text())))
    assert {"demo", "test", "lint"} <= set(targets), targets
    run = subprocess.run(["make", "-n", "-o", f"{VENV}/.installed-stamp", f"VENV={VENV}", *targets],
                         cwd=workdir, env=_env(), capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    scripts = re.findall(r"python (\S+\.py)", run.stdout)
    assert scripts, run.stdout
    assert [s for s in scripts if not (workdir / s).is_file()] == []
