"""The package's folders are layers: no module imports from a layer above its own, and sibling
layers of equal rank (the NLP and the re-check; the workshop part and the export) do not import each other."""
import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "cadcam"
#: Layer of each top-level module or folder of the package, lowest first.
RANK = {"files": 0, "keys": 0, "version": 0, "citations": 0, "examples": 0, "errors": 0, "interrupts": 0, "library_files": 0, "units": 0, "physics": 1, "targets": 2, "mechanisms": 3,
        "problem": 4, "designs": 5, "spec": 5, "variation": 5, "solve": 6, "verify": 6, "make": 7, "export": 7, "outputs": 8,
        "result": 9, "optimize": 10, "sweep": 11, "api": 12, "app": 13, "cli": 14, "__init__": 15, "__main__": 15}


def _layer(parts: tuple[str, ...]) -> str:
    return parts[0].removesuffix(".py")


def _imports(here: tuple[str, ...], source: str):
    """(line, imported layer) of every cadcam import in ``source`` of the module at path parts
    ``here`` inside the package, relative or absolute."""
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(here[:-1])[:len(here) - node.level]
                target = base + (node.module.split(".") if node.module else [])
            elif node.module and node.module.split(".")[0] == "cadcam":
                target = node.module.split(".")[1:]
            else:
                continue
            names = target or [a.name for a in node.names]
            yield node.lineno, names[0]


MODULES = sorted(p for p in PACKAGE.rglob("*.py"))


def _violations(here: tuple[str, ...], source: str) -> list[str]:
    own = _layer(here)
    assert own in RANK, f"{own}: give the new module or folder a layer in RANK"
    out = []
    for line, target in _imports(here, source):
        if target not in RANK:
            out.append(f"line {line}: unknown layer {target}")
        elif target != own and not RANK[target] < RANK[own]:
            out.append(f"line {line}: {own} (layer {RANK[own]}) imports {target} "
                       f"(layer {RANK[target]})")
    return out


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_import_from_a_higher_or_sibling_layer(path):
    here = path.relative_to(PACKAGE).parts
    assert _violations(here, path.read_text()) == []


@pytest.mark.parametrize("source", ["from ..solve.transcription import Transcription",
                                    "from cadcam.verify.evaluate import evaluate",
                                    "from .. import optimize"])
def test_the_rule_catches_upward_and_sibling_imports(source):
    assert _violations(("physics", "profile.py"), source)
    assert _violations(("solve", "transcription.py"), "from ..verify import evaluate")
    assert not _violations(("solve", "transcription.py"), "from ..physics.wrap import gauss_legendre")


def test_importing_cadcam_leaves_the_slow_libraries_unloaded():
    """Sweep workers and ``cadcam evaluate`` import cadcam without drawing anything: matplotlib,
    ezdxf and manifold3d load only when a figure or workshop file is written, and
    scipy.optimize (half a second) only where a target or a closed-form pulley needs it."""
    code = ("import sys, cadcam; print(sorted(m for m in ('matplotlib', 'ezdxf', 'manifold3d', 'scipy.optimize')"
            " if m in sys.modules))")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert run.stdout.strip() == "[]"
