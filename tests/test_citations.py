"""Citations name registered papers, and the repository stands on its own."""
import re
from pathlib import Path

from cadcam.citations import PAPERS, cited
from cadcam.mechanisms.base import mechanism_kinds, mechanism_class

ROOT = Path(__file__).resolve().parents[1]
TAG = re.compile(r"\b([A-Z][a-z]+(?:19|20)\d\d)\b")
SOURCES = [p for d in ("cadcam", "tests", "studies", "models", "benchmarks", "docs")
           for p in (ROOT / d).rglob("*") if p.suffix in (".py", ".toml", ".md", ".json", ".csv")]


def test_every_cited_tag_is_registered():
    unknown = {(p.name, t) for p in SOURCES for t in TAG.findall(p.read_text()) if t not in PAPERS}
    assert not unknown


def test_every_mechanism_cites_a_registered_paper():
    for kind in mechanism_kinds():
        assert cited([mechanism_class(kind).citation])[0]["key"] in PAPERS


def test_nothing_cites_a_file_outside_the_repository():
    outside = ("REFERENCE" + ".md", "../" + "shared")  # spelt apart so this file does not match
    files = SOURCES + [ROOT / "README.md", ROOT / "Makefile", *sorted((ROOT / "docs").glob("*.md"))]
    assert not [p.name for p in files if any(s in p.read_text() for s in outside)]
