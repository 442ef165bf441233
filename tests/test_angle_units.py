"""Angles in a table say their unit (`angle_unit` inline, the header of a CSV), and an angle
plausible only in the other unit gets a one-line note before the solve."""
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cadcam import SpecError
from cadcam.spec import implausible_units, parse_spec

ROOT = Path(__file__).resolve().parents[1]


def _spec(theta_range_deg, target: dict) -> dict:
    return {"joints": [{"theta_range_deg": list(theta_range_deg), "target": target}],
            "mechanisms": [{"kind": "anchored_pulley", "joint": 1, "order": 5, "rho_min": 0.005, "rho_max": 0.06,
                            "spring_end": [0.0, -0.2], "turning": "pulley", "winding": "cw"}],
            "springs": [{"ports": ["cable:1"], "rate": 1000.0, "travel": 0.06}]}


@settings(max_examples=20, deadline=None)
@given(st.lists(st.floats(1.0, 170.0), min_size=4, max_size=8, unique=True))
def test_samples_in_degrees_are_the_samples_in_radians(degrees):
    degrees = sorted(degrees)
    rows = [[a, 0.01 * k] for k, a in enumerate(degrees)]
    lo, hi = degrees[0], degrees[-1]
    in_deg = parse_spec(_spec((lo, hi), {"kind": "table", "samples": rows, "angle_unit": "deg"}))
    in_rad = parse_spec(_spec((lo, hi), {"kind": "table", "samples": [[math.radians(a), v] for a, v in rows]}))
    assert np.allclose(in_deg.joints[0].target.data["samples"], in_rad.joints[0].target.data["samples"],
                       rtol=0, atol=1e-15)


def test_an_angle_unit_beside_a_csv_file_is_refused_since_its_header_names_the_unit():
    spec = _spec((20, 90), {"kind": "table", "file": "table.csv", "angle_unit": "deg"})
    with pytest.raises(SpecError, match=r"angle_unit = 'deg': expected nothing beside a file"):
        parse_spec(spec, "s.toml", ROOT)


def test_degrees_typed_as_radians_in_a_table_get_a_note_naming_the_fix():
    rows = [[0, 0.1], [30, 2.0], [60, 4.0], [90, 8.0], [120, 6.0]]  # degrees, read as radians
    notes = implausible_units(parse_spec(_spec((0, 120), {"kind": "table", "samples": rows})))
    assert len(notes) == 1 and 'angle_unit = "deg"' in notes[0] and "\n" not in notes[0]
    rows_deg = parse_spec(_spec((0, 120), {"kind": "table", "samples": rows, "angle_unit": "deg"}))
    assert implausible_units(rows_deg) == []


@settings(max_examples=20, deadline=None)
@given(st.floats(0.05, 3.0), st.floats(0.05, 3.0))
def test_radians_typed_as_degrees_in_a_range_get_a_note(lo, width):
    notes = implausible_units(parse_spec(_spec((lo, lo + width), {"kind": "pendulum", "mass": 1, "length": 0.1})))
    assert len(notes) == 1 and "theta_range_deg" in notes[0] and "write degrees" in notes[0]


@settings(max_examples=20, deadline=None)
@given(st.floats(-170, 100), st.floats(8.0, 180.0))
def test_a_range_in_degrees_gets_no_note(lo, width):
    problem = parse_spec(_spec((lo, lo + width), {"kind": "pendulum", "mass": 1, "length": 0.1}))
    assert implausible_units(problem) == []
