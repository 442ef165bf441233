"""The cable table: the shipped one read into SI rows whose numbers follow its README's rules, a
malformed table refused in one line naming file, row and column, and a cable's limits
(working load, least profile radius, the extension a spring may reach) checked by hand."""
from __future__ import annotations

import math

import pytest

from cadcam.physics.cables import (COLUMNS, SAFETY_FACTORS, UNKNOWN_KIND, Cable, parse_cables,
                                   shipped_cables)
from cadcam.physics.catalogue import CatalogueError

HEADER = "name,construction,kind,material,diameter,bend_ratio,breaking_load"
ROW = "rope,7x19,wire rope,steel,0.002,12,2330"

#: The README's rule for stainless wire rope: (wires, wire diameter as d over it, spinning
#: factor); breaking load = wires × π/4 × (d/n)² × 1570 N/mm² × factor.
WIRE_RULE = {"1x19": (19, 5, 0.88), "7x7": (49, 9, 0.838), "7x19": (133, 15, 0.80)}


def _refusal(text: str) -> str:
    with pytest.raises(CatalogueError) as err:
        parse_cables(text, "mine.csv")
    message = str(err.value)
    assert message.startswith("mine.csv: ") and "\n" not in message
    return message


def _rows(*rows: str) -> str:
    return "\n".join([HEADER, *rows]) + "\n"


def test_the_shipped_table_has_each_construction_from_half_a_millimetre_to_three():
    table = shipped_cables()
    by = {}
    for c in table.cables:
        by.setdefault((c.construction, c.material), []).append(c.diameter)
        assert 0.5e-3 <= c.diameter <= 3e-3
    constructions = {construction for construction, _ in by}
    assert constructions == {"1x19", "7x7", "7x19", "braid"}
    assert {m for (k, m) in by if k == "braid"} == {"UHMWPE (Dyneema)", "polyester"}
    assert all(len(d) >= 4 for d in by.values())
    assert len(set(table.names)) == len(table.cables)


def test_a_named_cable_is_its_row_in_si_units():
    c = shipped_cables().cable("stainless 7x19 1.5 mm")
    assert (c.diameter, c.breaking_load, c.kind, c.construction) == (0.0015, 1310.0, "wire rope", "7x19")
    assert c.min_bend_radius == pytest.approx(12 * 0.0015)  # bend_ratio × d: the README's 24 d pulley, halved
    assert c.least_profile_radius == pytest.approx(0.018 + 0.00075)  # the centre line: plus its radius
    assert c.safety_factor == 5.0 and c.working_load == pytest.approx(262.0)


@pytest.mark.parametrize("construction", WIRE_RULE)
def test_stainless_breaking_loads_are_the_readme_rule_rounded_down(construction):
    wires, ratio, factor = WIRE_RULE[construction]
    rows = [c for c in shipped_cables().cables if c.construction == construction]
    assert rows
    for c in rows:
        d_mm = 1e3 * c.diameter
        rule = wires * math.pi / 4 * (d_mm / ratio) ** 2 * 1570 * factor
        assert 0.99 * rule <= c.breaking_load <= rule, c.name


def test_wire_rope_bends_less_tightly_the_coarser_its_wires_and_fibre_least():
    """At one diameter the least bend radius falls as the outer wires get finer (1x19 → 7x7 →
    7x19: d/5, d/9, d/15) and is least for a braid; fibre lines are held to the stricter
    safety factor."""
    table = shipped_cables()
    at = {c.construction + " " + c.material: c for c in table.cables if c.diameter == 0.0015}
    radii = [at[k].min_bend_radius for k in ("1x19 AISI 316 stainless steel", "7x7 AISI 316 stainless steel",
                                              "7x19 AISI 316 stainless steel", "braid UHMWPE (Dyneema)")]
    assert radii == sorted(radii, reverse=True)
    assert all(c.safety_factor == SAFETY_FACTORS["fibre rope"] > SAFETY_FACTORS["wire rope"]
               for c in table.cables if c.kind == "fibre rope")
    assert UNKNOWN_KIND == "fibre rope"


def test_a_spring_reaches_the_working_load_at_its_extension_limit():
    c = Cable(0.002, 0.01, 1400.0, "fibre rope")
    x = c.extension_limit(1000.0, 10.0)
    assert x == pytest.approx((200.0 - 10.0) / 1000.0)
    assert 10.0 + 1000.0 * x == pytest.approx(c.working_load)
    assert c.extension_limit(1000.0, 250.0) < 0  # the initial tension alone is beyond it


def test_the_spec_form_reads_back_as_the_same_cable():
    c = shipped_cables().cable("Dyneema braid 1 mm")
    assert c.to_dict() == {"name": "Dyneema braid 1 mm", "diameter": 0.001, "min_bend_radius": c.min_bend_radius,
                           "breaking_load": 1000.0, "kind": "fibre rope"}
    assert Cable(**{k: v for k, v in c.to_dict().items() if k != "name"}).working_load == c.working_load


@pytest.mark.parametrize("text, words", [
    ("", "empty"),
    (HEADER + "\n", "no cables: expected a row per cable"),
    (_rows(ROW, ROW), "row 3, column 'name' = 'rope': expected a name not already on row 2"),
    (_rows(ROW, "x,7x7,wire rope"), "row 3: 3 fields, expected 7"),
    (_rows(ROW.replace("wire rope", "chain")), "row 2, column 'kind' = 'chain': expected its kind"),
    (_rows(ROW.replace("0.002", "-0.002")), "row 2, column 'diameter' = '-0.002': expected its nominal diameter d"),
    (_rows(ROW.replace("0.002", "0.05")), "row 2, column 'diameter' = '0.05'"),
    (_rows(ROW.replace(",12,", ",0,")), "row 2, column 'bend_ratio' = '0': expected its least bend radius"),
    (_rows(ROW.replace("2330", "strong")), "row 2, column 'breaking_load' = 'strong'"),
    (_rows(ROW.replace("steel", " ")), "row 2, column 'material'"),
])
def test_a_malformed_table_is_one_line(text, words):
    assert words in _refusal(text)


@pytest.mark.parametrize("column", [k.name for k in COLUMNS.keys])
def test_a_missing_column_is_named(column):
    head = HEADER.split(",")
    keep = [i for i, n in enumerate(head) if n != column]
    values = ROW.split(",")
    text = ",".join(head[i] for i in keep) + "\n" + ",".join(values[i] for i in keep) + "\n"
    assert f"row 1, column '{column}'" in _refusal(text)


def test_an_unknown_name_names_the_nearest():
    with pytest.raises(KeyError, match="no cable 'stainless 7x19 1.6 mm'.*nearest: stainless 7x19 1.5 mm"):
        shipped_cables().cable("stainless 7x19 1.6 mm")
