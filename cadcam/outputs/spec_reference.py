"""``docs/spec_reference.md``: every key a spec may hold, as tables generated from their
declarations (:class:`cadcam.keys.KeyTable`) — the top level, ``[[joints]]`` with their
acceptance limits and every target kind, ``[arm]``, ``[[mechanisms]]`` with each mechanism's
own keys and output laws, ``[[springs]]``, ``[solver]`` with the IPOPT options cadcam passes
on, ``[workshop]``, ``[cable]``, ``[tolerances]``, ``[builds]``, ``[adjustment]`` and
``[friction]`` with its guides, idlers and joints' bearings.

``python -m cadcam.outputs.spec_reference`` writes it (``make generated``); the tests check
that the committed page is what this module makes, and that every key the reader reads of any
shipped spec is on it.
"""
from __future__ import annotations

import sys
from pathlib import Path

from ..files import atomic_path
from ..keys import Key, KeyTable
from ..mechanisms.base import MECHANISM_KEYS, built_in_kinds, mechanism_class
from ..physics.cables import CABLE_KEYS
from ..physics.friction import BEARING_KEYS, FRICTION_KEYS, GUIDE_KEYS, IDLER_KEYS
from ..physics.springs import SPRING_KEYS
from ..problem import (ADJUSTMENT_KEYS, BUILD_KEYS, IPOPT_OPTIONS, JOINT_KEYS, SOLVER_KEYS, WORKSHOP_KEYS, acceptance_keys,
                       tolerance_keys)
from ..spec import SPEC_KEYS
from ..targets import ARM_KEYS, target_kind, target_kinds

#: The page, in the repository's docs folder.
REFERENCE_FILE = Path(__file__).resolve().parents[2] / "docs" / "spec_reference.md"

HEADER = """# Spec reference (generated)

This page is written by `make generated` from the declarations in the code; do not edit it by
hand. Every quantity is in SI units (lengths m, angles rad, forces N, rates N/m) except
`theta_range_deg` and the angles of a table whose `angle_unit` (or CSV header) says `deg`.
The [guide](guide.md) explains the layout of a spec; `models/` holds one spec per seed case.
A key whose default is "required" must be given.
"""


#: The tables of ``[friction]``'s arrays, each under its own heading.
FRICTION_TABLES = (GUIDE_KEYS, IDLER_KEYS, BEARING_KEYS)


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _rows(keys, prefix: str = "") -> list[str]:
    """One row per key (a declared sub-table's keys after it, as ``table.key``)."""
    rows = []
    for k in keys:
        rows.append(f"| `{prefix}{k.name}` | {_cell(k.constraint())} | {k.unit or '–'} | "
                    f"{_cell(k.default_words())} | {_cell(k.description + (f'. {k.details}' if k.details else ''))} |")
        if k.fields is not None:
            rows += _rows(k.fields.keys, f"{prefix}{k.name}.")
    return rows


def _table(table: KeyTable, heading: str = "##", title: str | None = None) -> list[str]:
    """A section: the table's name, what it sets, and its keys."""
    head = [f"{heading} `{title or table.path}`", "", _cell(table.description), ""]
    if not table.keys:
        return head[:-1] + ["", "No keys but `kind`."]
    return head + ["| key | value | unit | default | meaning |", "|---|---|---|---|---|", *_rows(table.keys)]


def _targets(output: bool) -> list[str]:
    """A section per target kind: a joint's torque laws, or a mechanism's output laws."""
    rows = []
    for kind in target_kinds(output):
        if output and kind in target_kinds():
            continue  # listed with the torque laws
        table = target_kind(kind).keys
        where = "[mechanisms.output_target]" if output else "[joints.target]"
        rows += ["", *_table(table, "###", f'{where} kind = "{kind}"')]
    return rows


def _mechanism(kind: str) -> list[str]:
    cls = mechanism_class(kind)
    rows = _table(cls.spec_keys, "###")
    rows[3:3] = [f"Ports: {', '.join(f'`{p}`' for p in cls.ports)}. "
                 f"Unknowns per angle: {', '.join(f'`{q.name}` [{q.unit}]' for q in cls.per_angle)}."
                 + (" Limits: " + ", ".join(f"{lim.what} (`{lim.bound}`)" for lim in cls.limits) + "."
                    if cls.limits else ""), ""]
    return rows


def _ipopt() -> list[str]:
    rows = ["### `[solver.ipopt]`", "", "The IPOPT options cadcam passes on, and the values it allows (IPOPT's own "
            "documentation describes each; IPOPT's default applies where one is not given). Any other option is "
            "refused before work, those naming files or libraries among them; `max_iter` and `tol` are "
            "`[solver]` keys. A stop at IPOPT's acceptable level has its own status, `acceptable`.", "",
            "| option | values |", "|---|---|"]
    return rows + [f"| `{name}` | {_cell(s.form)} |" for name, s in IPOPT_OPTIONS.items()]


def reference() -> str:
    """The page's text."""
    rows = [HEADER, *_table(SPEC_KEYS, title="top level"), "", *_table(JOINT_KEYS), "",
            *_table(acceptance_keys(), "###"), "", "## Target kinds", "",
            "A joint's `[joints.target]` is a torque law [N·m] of its angle (`kind` and the kind's keys); "
            "`expression` and `table` may also be a mechanism's `[mechanisms.output_target]`, a law [m].",
            *_targets(output=False), "", *_table(ARM_KEYS), "", *_table(MECHANISM_KEYS)]
    for kind in built_in_kinds():
        rows += ["", *_mechanism(kind)]
    rows += ["", "### Output laws a mechanism brings", "",
             "Kinds of `[mechanisms.output_target]` beside `expression` and `table`.", *_targets(output=True),
             "", *_table(SPRING_KEYS), "", *_table(SOLVER_KEYS), "", *_ipopt(), "", *_table(WORKSHOP_KEYS), "",
             *_table(CABLE_KEYS), "", *_table(tolerance_keys()), "", *_table(BUILD_KEYS), "", *_table(ADJUSTMENT_KEYS),
             "", *_table(FRICTION_KEYS), *[row for table in FRICTION_TABLES for row in ("", *_table(table, "###"))]]
    return "\n".join(rows) + "\n"


def declared_keys() -> set[tuple[str, str]]:
    """(table path, key name) of every key on the page: what a test holds the reader's keys
    against."""
    tables = [SPEC_KEYS, JOINT_KEYS, acceptance_keys(), ARM_KEYS, MECHANISM_KEYS, SPRING_KEYS, WORKSHOP_KEYS,
              CABLE_KEYS, tolerance_keys(), BUILD_KEYS, ADJUSTMENT_KEYS, SOLVER_KEYS, FRICTION_KEYS, *FRICTION_TABLES]
    tables += [mechanism_class(k).spec_keys for k in built_in_kinds()]
    tables += [target_kind(k).keys for k in dict.fromkeys(target_kinds() + target_kinds(output=True))]
    out = set()

    def add(path: str, keys: tuple[Key, ...]):
        for k in keys:
            out.add((path, k.name))
            if k.fields is not None:
                add(f"{path}.{k.name}", k.fields.keys)
    for table in tables:
        add(table.path, table.keys)
    return out


def main() -> int:
    """Write the page."""
    with atomic_path(REFERENCE_FILE) as tmp:
        tmp.write_text(reference(), encoding="utf-8")
    print(f"wrote {REFERENCE_FILE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
