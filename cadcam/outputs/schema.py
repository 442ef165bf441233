"""The JSON Schema of ``result.json`` (``cadcam/result.schema.json``): its generic parts are
written in the file, and the parts that the registries declare are generated from them — the
torque models, the design methods, the ``[solver]`` options' meanings, the target kinds, the acceptance limits, the tolerances, a joint's band weight, and each mechanism's own keys (the
``spec.schema.json`` beside its model) and each target kind's keys (:attr:`TargetKind.schema`).

``python -m cadcam.outputs.schema`` writes the file anew (``make generated``); the tests check that
the shipped file is what this module makes of it.
"""
from __future__ import annotations

import copy
import json
import re
import sys
from importlib import resources
from pathlib import Path

from ..files import atomic_path
from ..mechanisms.base import LINK_ANGLE, design_methods, mechanism_class, mechanism_kinds, torque_models
from ..problem import ACCEPTANCE, BAND_WEIGHT, FUNCTIONS, MAX_MOMENT_ARM_DEGREE, SOLVER, TOLERANCES
from ..targets import target_kind, target_kinds

#: The shipped schema.
SCHEMA_FILE = Path(__file__).resolve().parent.parent / "result.schema.json"
#: The file beside a mechanism's model that holds the JSON Schema of its own spec keys.
MECHANISM_SCHEMA = "spec.schema.json"


def _kind_block(kind: str, then: dict) -> dict:
    """``if kind == <kind> then <then>``."""
    return {"if": {"properties": {"kind": {"const": kind}}, "required": ["kind"]}, "then": then}


def _declared(blocks: list[dict], declared: dict[str, dict]) -> list[dict]:
    """``blocks`` (``if kind == … then …``) with the ``declared`` kinds' blocks made from their
    declarations: replaced where the file has one, appended where it has none."""
    kinds = [b["if"]["properties"]["kind"]["const"] for b in blocks]
    out = [_kind_block(k, declared[k]) if k in declared else b for k, b in zip(kinds, blocks)]
    return out + [_kind_block(k, then) for k, then in declared.items() if k not in kinds]


def plain(text: str) -> str:
    """A declaration's reStructuredText as plain text for a schema's description: a role
    (``:func:`~name```) keeps its target's name, literal text (````x````) its quotes."""
    return re.sub(r":\w+:`~?([^`]+)`", r"\1", text).replace("``", '"')


def mechanism_schemas() -> dict[str, dict]:
    """Each registered mechanism's schema of its own keys, read from its folder."""
    out = {}
    for kind in mechanism_kinds():
        package = mechanism_class(kind).__module__.rsplit(".", 1)[0]
        path = resources.files(package) / MECHANISM_SCHEMA
        if path.is_file():
            schema = json.loads(path.read_text(encoding="utf-8"))
            keys = schema.get("propertyNames", {}).get("enum")
            if keys is not None and LINK_ANGLE.name not in keys:  # every mechanism's optional key
                keys.append(LINK_ANGLE.name)
            out[kind] = schema
    return out


def result_schema(schema: dict) -> dict:
    """``schema`` (the shipped file's) with its declared parts made from the registries."""
    out = copy.deepcopy(schema)
    defs = out["$defs"]
    defs["torque_model"]["enum"] = list(torque_models())
    defs["options"]["properties"]["method"]["enum"] = ["nlp", *design_methods()]
    defs["options"]["properties"]["functions"]["enum"] = list(FUNCTIONS)
    defs["options"]["properties"]["moment_arm_degree"]["maximum"] = MAX_MOMENT_ARM_DEGREE
    for name, setting in SOLVER.items():
        defs["options"]["properties"][name]["description"] = plain(setting.description)
    defs["solver_run"]["properties"]["name"]["enum"] = ["ipopt", *design_methods()]
    kinds = list(dict.fromkeys(target_kinds() + target_kinds(output=True)))
    defs["target"]["properties"]["kind"]["enum"] = kinds
    defs["target"]["allOf"] = _declared(defs["target"]["allOf"], {
        k: target_kind(k).schema for k in kinds if target_kind(k).schema is not None})
    defs["mechanism"]["allOf"] = _declared(defs["mechanism"]["allOf"], mechanism_schemas())
    defs["mechanism"]["properties"][LINK_ANGLE.name] = {
        "description": f"{LINK_ANGLE.description} [{LINK_ANGLE.unit}].", "type": "number"}
    defs["joint"]["properties"]["acceptance"]["properties"] = {
        key: {"description": f"{a.description} [{a.unit}]", "type": "number", "exclusiveMinimum": 0}
        for key, a in ACCEPTANCE.items()}
    defs["joint"]["properties"][BAND_WEIGHT.name] = {
        "description": f"{BAND_WEIGHT.description} [{BAND_WEIGHT.unit}]", "type": "number", "minimum": 0}
    defs["problem"]["properties"]["tolerances"]["properties"] = {
        key: {"description": f"± {t.description} [{t.unit}] (default {t.default:g})", "type": "number", "minimum": 0}
        for key, t in TOLERANCES.items()}
    return out


def main() -> int:
    """Write ``result.schema.json`` anew from itself and the registries."""
    schema = json.loads(SCHEMA_FILE.read_text(encoding="utf-8"))
    with atomic_path(SCHEMA_FILE) as tmp:
        tmp.write_text(json.dumps(result_schema(schema), indent=2, ensure_ascii=False) + "\n", encoding="utf-8")
    print(f"wrote {SCHEMA_FILE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
