"""docs/mechanisms.md's checklist is the interface's declaration of its hooks in words: every
hook (HOOKS) under its group with its 'required' mark, nothing else; and every member of the
base class is a hook or provided by the base (PROVIDED), so a member added to the class without
a line in the checklist fails here."""
import re
from dataclasses import fields
from pathlib import Path

from cadcam.mechanisms.base import HOOKS, PROVIDED, Mechanism, mechanism_class, mechanism_kinds, missing_hooks

DOC = Path(__file__).resolve().parents[2] / "docs" / "mechanisms.md"


def _checklist() -> list[tuple[str, str, bool]]:
    """(group, hook, required) of every checklist line of the doc."""
    text = DOC.read_text(encoding="utf-8")
    section = text[text.index("## Checklist"):]
    section = section[:section.index("\n## ", 1)] if "\n## " in section[1:] else section
    out, group = [], None
    for line in section.splitlines():
        heading = re.match(r"^### (.+)$", line)
        if heading:
            group = heading.group(1).strip()
        item = re.match(r"^- \[ \] `(\w+)`( \(required\))?:", line)
        if item:
            out.append((group, item.group(1), bool(item.group(2))))
    return out


def test_the_checklist_lists_every_hook_under_its_group_with_its_mark():
    assert _checklist() == [(h.group, h.name, h.required) for h in HOOKS]


def test_every_member_of_the_base_class_is_a_hook_or_provided():
    members = {n for n in vars(Mechanism) if not n.startswith("_")} | {f.name for f in fields(Mechanism)}
    declared = {h.name for h in HOOKS} | set(PROVIDED)
    assert members - declared == set(), "a new member: add it to HOOKS (and the checklist) or PROVIDED"
    assert declared - members == set(), "a hook or provided member the class no longer has"


def test_every_built_in_mechanism_provides_its_required_hooks():
    for kind in mechanism_kinds():
        assert missing_hooks(mechanism_class(kind)) == [], kind
