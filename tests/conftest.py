"""Shared fixtures: the 1-DOF model spec and the RR-arm problem with Johnston2023's Table 3 design."""
import json
from pathlib import Path

import numpy as np
import pytest

from cadcam import Design, load_spec

ROOT = Path(__file__).resolve().parents[1]
SPEC_1DOF = ROOT / "models" / "johnston2023_1dof.toml"

SPEC_RR = ROOT / "models" / "johnston2023_rr_arm.toml"
TABLE3 = ROOT / "models" / "johnston2023_table3_design.json"
TABLE4 = ROOT / "models" / "johnston2023_table4_design.json"


@pytest.fixture(scope="session")
def problem_1dof():
    return load_spec(SPEC_1DOF)


@pytest.fixture(scope="session")
def rr_problem():
    return load_spec(SPEC_RR)


@pytest.fixture(scope="session")
def table3(rr_problem):
    return Design.from_dict(json.loads(TABLE3.read_text()), rr_problem)


def circle_design(problem, radius, x0):
    """A circular cam of ``radius`` [m] in the problem's basis."""
    b = problem.profiles[0].basis
    m = np.zeros(b.size)
    m[0] = radius
    return Design([b], [b.from_monomial(m)], np.asarray(x0, dtype=float))
