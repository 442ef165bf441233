"""The JSON Schema of ``result.json`` (``cadcam/result.schema.json``): its generic parts are
written in the file, and the parts that the declarations hold are generated from them — the
torque models, the design methods, the ``[solver]`` options, the target kinds and their keys
(:attr:`TargetKind.keys`), a joint's keys with its acceptance limits, the tolerances, the builds and
the adjustment, a spring's keys, the cable's, the friction's, the keys every mechanism has and each
mechanism's own (:attr:`Mechanism.spec_keys`).

``python -m cadcam.outputs.schema`` writes the file anew (``make generated``); the tests check that
the shipped file is what this module makes of it.
"""
from __future__ import annotations

import copy
import json
import re
import sys
from pathlib import Path

from ..files import atomic_path
from ..keys import KeyTable
from ..mechanisms.base import MECHANISM_KEYS, built_in_kinds, design_methods, mechanism_class, torque_models
from ..physics.cables import CABLE_KEYS, SAFETY_FACTORS
from ..physics.friction import BEARING_KEYS, FRICTION_KEYS, GUIDE_KEYS, IDLER_KEYS
from ..physics.springs import SPRING_KEYS
from ..problem import ADJUSTMENT_KEYS, BUILD_KEYS, JOINT_KEYS, SOLVER_KEYS, acceptance_keys, tolerance_keys
from ..targets import target_kind, target_kinds

#: The shipped schema.
SCHEMA_FILE = Path(__file__).resolve().parent.parent / "result.schema.json"
#: Keys whose schema is a reference to another definition of the file, not their own.
REFERENCES = {"target": {"$ref": "#/$defs/target"}, "output_target": {"$ref": "#/$defs/target"}}


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


def table_block(table: KeyTable, common: tuple[str, ...] = ("kind",)) -> dict:
    """The ``then`` block of a kind's table: its description, required keys, the names it may
    hold (the ``common`` ones and its own) and its keys' properties."""
    schema = table.schema()
    return {"description": plain(schema["description"]), "required": schema["required"],
            "propertyNames": {"enum": [*common, *table.names]},
            "properties": {k: REFERENCES.get(k, prop) for k, prop in schema["properties"].items()}}


def mechanism_schemas() -> dict[str, dict]:
    """Each registered mechanism's ``then`` block: its own keys, after those every mechanism has."""
    return {kind: table_block(mechanism_class(kind).spec_keys, MECHANISM_KEYS.names) for kind in built_in_kinds()}


def _properties(table: KeyTable) -> dict:
    """A table's keys as JSON Schema properties, descriptions in plain text."""
    out = {}
    for name, prop in table.schema()["properties"].items():
        out[name] = REFERENCES.get(name, {**prop, "description": plain(prop["description"])})
    return out


def result_schema(schema: dict) -> dict:
    """``schema`` (the shipped file's) with its declared parts made from the declarations."""
    out = copy.deepcopy(schema)
    defs = out["$defs"]
    defs["torque_model"]["enum"] = list(torque_models())
    options = defs["options"]["properties"]
    for name, prop in _properties(SOLVER_KEYS).items():
        options[name] = {**options.get(name, {}), **prop}
    options["method"]["enum"] = ["nlp", *design_methods()]
    defs["solver_run"]["properties"]["name"]["enum"] = ["ipopt", *design_methods()]
    kinds = list(dict.fromkeys(target_kinds() + target_kinds(output=True)))
    defs["target"]["properties"]["kind"]["enum"] = kinds
    defs["target"]["allOf"] = _declared(defs["target"]["allOf"], {
        k: table_block(target_kind(k).keys) for k in kinds if target_kind(k).keys is not None})
    defs["mechanism"]["allOf"] = _declared(defs["mechanism"]["allOf"], mechanism_schemas())
    defs["mechanism"]["properties"] = _properties(MECHANISM_KEYS)
    defs["spring"]["properties"] = _properties(SPRING_KEYS)
    joint = defs["joint"]["properties"]
    joint.update(_properties(JOINT_KEYS))
    joint["acceptance"]["properties"] = _properties(acceptance_keys())
    joint["acceptance"]["additionalProperties"] = False
    defs["problem"]["properties"]["tolerances"]["properties"] = _properties(tolerance_keys())
    defs["problem"]["properties"]["builds"]["properties"] = _properties(BUILD_KEYS)
    defs["problem"]["properties"]["adjustment"]["properties"] = _properties(ADJUSTMENT_KEYS)
    defs["problem"]["properties"]["cable"]["properties"] = _properties(CABLE_KEYS)
    out["properties"]["cable"]["properties"]["kind"]["enum"] = list(SAFETY_FACTORS)
    friction = defs["problem"]["properties"]["friction"]["properties"] = _properties(FRICTION_KEYS)
    for name, table in (("guides", GUIDE_KEYS), ("idlers", IDLER_KEYS), ("joints", BEARING_KEYS)):
        friction[name]["items"] = {"type": "object", "additionalProperties": False,
                                   "required": list(table.names), "properties": _properties(table)}
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
