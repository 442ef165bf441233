"""``docs/spec_reference.md``: the spec keys that cadcam declares in one place, as tables —
the ``[solver]`` options (:data:`cadcam.problem.SOLVER`) and the IPOPT options cadcam passes on
(:data:`cadcam.problem.IPOPT_OPTIONS`), the ``[workshop]`` sizes
(:class:`cadcam.problem.Workshop`, :data:`cadcam.problem.WORKSHOP_LIMITS`), the acceptance
limits (:data:`cadcam.problem.ACCEPTANCE`), the tolerances (:data:`cadcam.problem.TOLERANCES`) and a joint's
band weight (:data:`cadcam.problem.BAND_WEIGHT`), the target kinds
(:func:`cadcam.targets.target_kinds`) and each mechanism's own keys (the ``spec.schema.json``
beside its model, with its ports, parameters and limits).

``python -m cadcam.outputs.spec_reference`` writes it (``make generated``); the tests check
that the committed page is what this module makes.
"""
from __future__ import annotations

import json
import sys
from dataclasses import fields
from pathlib import Path

from ..files import atomic_path
from ..mechanisms.base import LINK_ANGLE, mechanism_class
from ..problem import ACCEPTANCE, BAND_WEIGHT, IPOPT_OPTIONS, TOLERANCES, SOLVER, WORKSHOP_LIMITS, Workshop
from ..targets import target_kinds
from .schema import mechanism_schemas

#: The page, in the repository's docs folder.
REFERENCE_FILE = Path(__file__).resolve().parents[2] / "docs" / "spec_reference.md"

HEADER = """# Spec reference (generated)

This page is written by `make generated` from the declarations in the code; do not edit it by
hand. Every quantity is in SI units (lengths m, angles rad, forces N, rates N/m) except
`theta_range_deg`. The README's [spec section](../README.md#spec-format-toml-si-units) explains
the layout of a spec; `models/` holds one spec per seed case.
"""


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _solver() -> list[str]:
    rows = ["## `[solver]`", "", "| key | default | values | meaning |", "|---|---|---|---|"]
    for name, s in SOLVER.items():
        rows.append(f"| `{name}` | `{s.default!r}` | {_cell(s.form)} | {_cell(s.description)} |")
    return rows


def _ipopt() -> list[str]:
    rows = ["## `[solver.ipopt]`", "", "The IPOPT options cadcam passes on, and the values it allows (IPOPT's own "
            "documentation describes each; IPOPT's default applies where one is not given). Any other option is "
            "refused before work, those naming files or libraries among them; `max_iter` and `tol` are "
            "`[solver]` keys. A stop at IPOPT's acceptable level has its own status, `acceptable`.", "",
            "| option | values |", "|---|---|"]
    return rows + [f"| `{name}` | {_cell(s.form)} |" for name, s in IPOPT_OPTIONS.items()]


def _workshop() -> list[str]:
    rows = ["## `[workshop]`", "", "Sizes of the workshop files [m]; each `cadcam design` flag of the same name "
            "(`--bore-diameter` …) overrides the spec's.", "", "| key | default [m] | range [m] |", "|---|---|---|"]
    for f in fields(Workshop):
        lo, hi = WORKSHOP_LIMITS[f.name]
        rows.append(f"| `{f.name}` | `{f.default!r}` | {lo:g} to {hi:g} |")
    return rows


def _acceptance() -> list[str]:
    rows = ["## `[joints.acceptance]`", "", "What a design must meet on the fine re-check to be a `success` "
            "(else its status is `target_missed` and `cadcam design` exits 1); a limit with a default applies "
            "to every joint with a torque target unless its spec sets another.", "",
            "| key | unit | default | limits |", "|---|---|---|---|"]
    return rows + [f"| `{key}` | {a.unit} | {'–' if a.default is None else f'`{a.default!r}`'} | {_cell(a.description)} |"
                   for key, a in ACCEPTANCE.items()]


def _tolerances() -> list[str]:
    rows = ["## `[tolerances]`", "", "How far a built part may be from its design, ± around each nominal value: "
            "every design reports the torque band they give (`tolerance_band` in `result.json`, the summary, the "
            "shaded band of `torque.png`).", "", "| key | unit | default | tolerance on |", "|---|---|---|---|"]
    rows += [f"| `{key}` | {t.unit} | `{t.default!r}` | {_cell(t.description)} |" for key, t in TOLERANCES.items()]
    return rows + ["", f"A joint's `{BAND_WEIGHT.name}` [{BAND_WEIGHT.unit}] (`[[joints]]`, default 0): "
                   f"{_cell(BAND_WEIGHT.description)}."]


def _targets() -> list[str]:
    return ["## Target kinds", "",
            "A joint's `[joints.target]` (a torque law [N·m]): " + ", ".join(f"`{k}`" for k in target_kinds()) + ".",
            "",
            "A mechanism's `[mechanisms.output_target]` (an output law [m]): "
            + ", ".join(f"`{k}`" for k in target_kinds(output=True)) + "."]


def _kind_of(prop: dict) -> str:
    """The JSON type of a key, in words."""
    if "enum" in prop:
        return "one of " + ", ".join(f"`{json.dumps(v)}`" for v in prop["enum"])
    if "properties" in prop:
        return "table"
    if prop.get("$ref", "").endswith("/numbers") or "items" in prop:
        return "array"
    return prop.get("type", "value")


def _mechanism(kind: str, schema: dict) -> list[str]:
    cls = mechanism_class(kind)
    rows = [f"### `kind = \"{kind}\"`", "", _cell(schema.get("description", "")), "",
            f"Ports: {', '.join(f'`{p}`' for p in cls.ports)}. "
            f"Unknowns per angle: {', '.join(f'`{q.name}` [{q.unit}]' for q in cls.per_angle)}."]
    if cls.limits:
        rows[-1] += " Limits: " + ", ".join(f"{lim.what} (`{lim.bound}`)" for lim in cls.limits) + "."
    required = set(schema.get("required", ()))
    rows += ["", "| key | required | type | meaning |", "|---|---|---|---|"]
    for key, prop in schema.get("properties", {}).items():
        rows.append(f"| `{key}` | {'yes' if key in required else 'no'} | {_kind_of(prop)} | "
                    f"{_cell(prop.get('description', ''))} |")
    return rows


def reference() -> str:
    """The page's text."""
    rows = [HEADER, *_solver(), "", *_ipopt(), "", *_workshop(), "", *_acceptance(), "", *_tolerances(), "", *_targets(), "", "## Mechanisms", "",
            "Keys every `[[mechanisms]]` table has: `kind`, `name`, `joint` (1-based), the profile's "
            "`basis`, `order`, `rho_min`, `rho_max`, optional `min_curvature_radius` and optional "
            f"`{LINK_ANGLE.name}` [{LINK_ANGLE.unit}] ({_cell(LINK_ANGLE.description)}); then its own:"]
    for kind, schema in mechanism_schemas().items():
        rows += ["", *_mechanism(kind, schema)]
    return "\n".join(rows) + "\n"


def main() -> int:
    """Write the page."""
    with atomic_path(REFERENCE_FILE) as tmp:
        tmp.write_text(reference(), encoding="utf-8")
    print(f"wrote {REFERENCE_FILE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
