"""The spring catalogue: the shipped one read into SI rows with its self-contradicting rows
handled by the stated rule, any malformed catalogue refused in one line naming file, row and
column, and the body formulas (EN 13906-2) checked against hand computations."""
from __future__ import annotations

import math
from dataclasses import replace
import time

import numpy as np
import pytest

from cadcam.physics.catalogue import (COLUMNS, CONSISTENCY_RTOL, MATERIALS, CatalogueError, Need,
                                      load_catalogue, material_of, parse_catalogue, room_arms, screen, shipped)
from cadcam.physics.springs import BODY_LIMITS, wahl_factor

HEADER = "length_natural,od,wire_dia,length_max,load_min,load_max,stiffness,material,pkg_qty,part_number,pkg_cost"
ROW = "0.02,0.008,0.001,0.05,2.0,32.0,1000.0,Music-Wire Steel,5,P1,9.5"


def _rows(*rows: str) -> str:
    return "\n".join([HEADER, *rows]) + "\n"


def test_the_shipped_catalogue_is_the_shared_data_in_si_units():
    cat = shipped()
    assert len(cat) == 1284 and len(set(cat.parts)) == 1284
    i = cat.index("5108N001")  # the file's first row
    b = cat.spring_body(i)
    assert (b.free_length, b.rate, b.preload, b.load_max) == (0.00635, 175.126771653543, 0.1334466, 1.4234304)
    assert b.coil_diameter == pytest.approx(0.0016002 - 0.0001778)
    assert cat.pack_quantity[i] == 5 and cat.pack_price[i] == 13.38


def test_contradicting_rows_are_counted_and_their_travel_exceeds_neither_limit():
    cat = shipped()
    b = cat.body
    bad = cat.contradictions()
    assert bad.size == 82  # the catalogue README's count
    implied = b.preload + b.rate * (b.length_max - b.free_length)
    assert np.all(np.abs(b.load_max[bad] - implied[bad]) > CONSISTENCY_RTOL * b.load_max[bad])
    travel, which = cat.travel()
    # the rule: the least extension the length, the load and the stress allow, so none is exceeded
    assert np.all(b.length(travel) <= b.length_max * (1 + 1e-12))
    assert np.all(b.force(travel) <= b.load_max * (1 + 1e-12))
    assert np.all(b.stress(travel) <= b.allowed_stress * (1 + 1e-12))
    limits = cat.extension_limits()
    assert np.array_equal(travel, np.minimum.reduce([limits[k] for k in BODY_LIMITS]))
    assert {BODY_LIMITS[k] for k in which[bad]} >= {"length", "load"}  # each binds some bad row
    assert "82 rows contradict themselves" in cat.summary()


@pytest.mark.parametrize("d_mm, D_mm, F", [(1.0, 7.0, 32.0), (0.5, 5.0, 3.0), (2.0, 10.0, 100.0)])
def test_the_wire_stress_is_en13906_corrected(d_mm, D_mm, F):
    """τ = 8·D·F·k/(π·d³), k = (w + 0.5)/(w − 0.75), w = D/d, by hand."""
    d, D = d_mm * 1e-3, D_mm * 1e-3
    od = D + d
    text = _rows(f"0.02,{od},{d},0.5,0.0,{10 * F},{F / 0.01},Music-Wire Steel,1,P1,1")
    b = parse_catalogue(text, "c.csv").spring_body(0)
    w = D / d
    assert wahl_factor(w) == pytest.approx((w + 0.5) / (w - 0.75))
    assert b.stress(0.01) == pytest.approx(8 * D * F * (w + 0.5) / (w - 0.75) / (math.pi * d**3))
    limit = b.extension_limits()["stress"]
    assert b.stress(limit) == pytest.approx(b.allowed_stress)


@pytest.mark.parametrize("material", MATERIALS, ids=lambda m: m.name)
def test_the_allowance_falls_with_wire_diameter_as_declared(material):
    d = np.array([0.2e-3, 1e-3, 5e-3])
    allowed = material.allowed_stress(d)
    assert allowed[1] == pytest.approx(material.fraction * material.strength)
    assert np.all(np.diff(allowed) < 0)
    assert material_of(material.name.upper()) is material


def _refusal(text: str) -> str:
    with pytest.raises(CatalogueError) as err:
        parse_catalogue(text, "mine.csv")
    message = str(err.value)
    assert message.startswith("mine.csv: ") and "\n" not in message
    return message


@pytest.mark.parametrize("column", [k.name for k in COLUMNS.keys if k.required])
def test_a_missing_column_is_named(column):
    head = HEADER.split(",")
    keep = [n for n in head if n != column]
    values = dict(zip(head, ROW.split(",")))
    text = ",".join(keep) + "\n" + ",".join(values[n] for n in keep) + "\n"
    assert f"row 1, column '{column}'" in _refusal(text)


@pytest.mark.parametrize("column", [k.name for k in COLUMNS.keys if k.type == "number"])
@pytest.mark.parametrize("bad", ["abc", "-1", "nan", "inf"])
def test_a_value_its_column_does_not_allow_is_named(column, bad):
    head = HEADER.split(",")
    values = ROW.split(",")
    values[head.index(column)] = bad
    message = _refusal(_rows(ROW.replace("P1", "P0"), ",".join(values)))
    assert f"row 3, column '{column}' = '{bad}'" in message and COLUMNS[column].unit in message


@pytest.mark.parametrize("text, words", [
    ("", "empty"),
    ("\n\n", "empty"),
    (HEADER + "\n", "no springs"),
    (_rows(ROW, ROW), "row 3, column 'part_number' = 'P1': expected a part number not already on row 2"),
    (_rows(ROW, "0.02,0.008,0.001"), "row 3: 3 fields, expected 11"),
    (_rows(ROW, ROW.replace("P1", '"P2')), "not readable CSV"),
    (_rows(ROW.replace("1000.0", "-1000.0")), "row 2, column 'stiffness' = '-1000.0'"),
    (_rows(ROW.replace("0.05,", "0.01,")), "row 2, column 'length_max' = '0.01': expected a value above the free length"),
    (_rows(ROW.replace("32.0", "1.0")), "column 'load_max' = '1.0': expected a value above the initial tension"),
    (_rows(ROW.replace("Music-Wire Steel", "Bronze")), "column 'material' = 'Bronze'"),
])
def test_a_malformed_catalogue_is_one_line(text, words):
    assert words in _refusal(text)


def test_a_user_catalogue_loads_like_the_shipped_one_with_optional_price_columns(tmp_path):
    path = tmp_path / "mine.csv"
    head = [n for n in HEADER.split(",") if n not in ("pkg_qty", "pkg_cost")]
    values = dict(zip(HEADER.split(","), ROW.split(",")))
    path.write_text(",".join(head) + ",notes\n" + ",".join(values[n] for n in head) + ",a note\n")
    cat = load_catalogue(path)
    assert cat.parts == ("P1",) and np.isnan(cat.pack_price[0])
    assert cat.extension_limits()["length"][0] == pytest.approx(0.03)
    assert cat.extension_limits()["load"][0] == pytest.approx(0.03)
    with pytest.raises(CatalogueError, match="mine-not-there.csv: cannot read it"):
        load_catalogue(tmp_path / "mine-not-there.csv")


def test_an_unknown_part_names_the_nearest():
    with pytest.raises(KeyError, match="no part '5108N0233'.*nearest: 5108N233"):
        shipped().index("5108N0233")


def test_the_screen_of_the_whole_catalogue_is_fast_and_gives_one_reason_each():
    cat = shipped()
    need = Need(energy=0.92, torque=0.98, arm=0.06, angle=1.22)
    screen(cat, need)
    start = time.perf_counter()
    result = screen(cat, need)
    assert time.perf_counter() - start < 0.1
    b = cat.body
    energy = 0.5 * b.rate * result.travel**2 + b.preload * result.travel
    np.testing.assert_allclose(result.energy, energy)
    short = energy < need.energy
    assert np.all(~result.passed[short])
    assert all(result.reasons[i].startswith("energy:") for i in np.flatnonzero(short))
    weak = ~short & (b.force(result.travel) * need.arm < need.torque)
    assert weak.any() and all(result.reasons[i].startswith("force:") for i in np.flatnonzero(weak))
    assert all(bool(r) != p for r, p in zip(result.reasons, result.passed))
    assert np.all(screen(cat, Need()).passed)  # no need asked: nothing rejected


def test_a_spring_too_long_for_its_mount_at_every_arm_is_screened_out_for_room():
    """The room test against a brute-force maximum over moment arms h of the longest line from
    a mount at reach ℓ to a cable of arm h leaving a profile within r_max (the anchored pulley's
    room), less the stretch at which the spring pulls the peak torque over h: a free length
    2 mm shorter than that passes, 2 mm longer fails, and the one with the reason "room"."""
    reach, arm = 0.2, 0.06

    def room(h):
        return np.sqrt(reach**2 - h**2) + np.sqrt(arm**2 - h**2)
    need = Need(torque=0.98, arm=arm, rooms=tuple(room(room_arms(arm))))
    k, f0 = 1000.0, 20.0
    h = np.linspace(1e-6, need.arm, 200_001)
    line = room(h)
    longest = np.max(line - np.maximum((need.torque / h - f0) / k, 0.0))
    rows = [f"{length:.6f},0.012,0.0015,{length + 0.2:.6f},{f0},{f0 + 0.2 * k},{k},Music-Wire Steel,5,{name},9.5"
            for name, length in (("SHORT", longest - 0.002), ("LONG", longest + 0.002))]
    cat = parse_catalogue(_rows(*rows), "mine.csv")
    result = screen(cat, need)
    assert result.passed.tolist() == [True, False]
    assert result.reasons[1].startswith("room:")
    assert np.all(screen(cat, replace(need, rooms=None)).passed)  # no mount: no test


def test_the_room_test_rejects_no_spring_that_fits_at_some_arm_between_those_tried():
    """Every shipped spring against a brute-force search over 4,001 moment arms (63 between each
    two the test bounds over) for the tutorial's mount 0.2 m away and r_max = 60 mm: none that
    fits at one of them is screened out for room, and each screened out for room fits at none."""
    reach, arm, torque = 0.2, 0.06, 0.98

    def room(h):
        return np.sqrt(reach**2 - h**2) + np.sqrt(arm**2 - h**2)
    cat = shipped()
    b = cat.body
    result = screen(cat, Need(torque=torque, arm=arm, rooms=tuple(room(room_arms(arm)))))
    h = np.linspace(arm / 4000, arm, 4000)
    spare = (room(h)[None, :] - b.free_length[:, None]
             - np.maximum((torque / h[None, :] - b.preload[:, None]) / b.rate[:, None], 0.0)).max(axis=1)
    for_room = np.array([r.startswith("room:") for r in result.reasons])
    assert for_room.sum() > 50 and np.all(spare[for_room] < 0)
    assert np.all(result.passed[spare >= 0] | ~for_room[spare >= 0])
