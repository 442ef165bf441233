"""Shared fixtures: the 1-DOF model spec and the RR-arm problem with seed 003's Table 3 design."""
from pathlib import Path

import numpy as np
import pytest

from cadcam import Design, load_spec, parse_spec

ROOT = Path(__file__).resolve().parents[1]
SPEC_1DOF = ROOT / "models" / "johnston2023_1dof.toml"

# seed 003, Table 1 (arm) and Table 2 (springs, idlers, ρ bounds); target Eq. 49
ARM = {"m1": 0.5, "m2": 0.5, "lc1": 0.25, "l1": 0.5, "lc2": 0.25, "g": 9.81}


def _rr_cam(expr):
    return {"theta_range_deg": [0.0, 90.0], "basis": "monomial", "order": 3,
            "rho_min": 0.025, "rho_max": 0.5, "mu": 0.3273,
            "idler": {"radius": 0.020, "offset": 0.015},
            "target": {"kind": "expression", "expression": expr, "parameters": ARM}}


RR_SPEC = {
    "name": "rr-arm (test)", "source": "seed 003, Tables 1-2, Eq. 49",
    "cams": [_rr_cam("m1*g*lc1*sin(theta1) + m2*g*(l1*sin(theta1) + lc2*sin(theta1 + theta2))"),
             _rr_cam("m2*g*lc2*sin(theta1 + theta2)")],
    "springs": [{"rate": 1100.0, "travel": 0.05766, "ports": ["wire:1"]},
                {"rate": 7350.0, "travel": 0.032, "ports": ["platform:1", "platform:2"]},
                {"rate": 580.0, "travel": 0.105, "ports": ["wire:2"]}],
}

# seed 003, Table 3 (β highest power first, metres; x0 in mm)
TABLE3 = {"cams": [{"monomial_coefficients_highest_first": [-0.0052, 0.0133, 0.0046, 0.0250]},
                   {"monomial_coefficients_highest_first": [-0.0009, -0.0016, 0.0068, 0.0417]}],
          "preextension": [0.0, 9.33e-3, 0.0]}


@pytest.fixture(scope="session")
def problem_1dof():
    return load_spec(SPEC_1DOF)


@pytest.fixture(scope="session")
def rr_problem():
    return parse_spec(RR_SPEC)


@pytest.fixture(scope="session")
def table3(rr_problem):
    return Design.from_dict(TABLE3, rr_problem)


def circle_design(problem, radius, x0):
    """A circular cam of ``radius`` [m] in the problem's basis."""
    b = problem.cams[0].basis
    m = np.zeros(b.size)
    m[0] = radius
    return Design([b], [b.from_monomial(m)], np.asarray(x0, dtype=float))
