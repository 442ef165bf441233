"""The blocks of the design NLP's decision vector x and parameter vector p, declared once: each
family's unit, description and role. The transcription names its blocks from these families
(:class:`cadcam.solve.transcription.Transcription`), and the export's manifest describes them
from here (``x_layout``, ``p_layout``).

A block is a family and an index: ``c`` of profile 2 is ``c1``, the departure unknown ``alpha``
of mechanism 1 is ``z0_alpha``. A description's fields ``{0}``, ``{1}``, … are the index's
entries, numbers shown 1-based.
"""
from __future__ import annotations

from dataclasses import dataclass

LENGTH_SCALE = 1e-3  # m: NLP lengths are in millimetres
TORQUE_SCALE = 1.0   # N·m: scale of lifted one-angle torque terms
FORCE_SCALE = 100.0  # N: scale of lifted coupling terms k_j a_ij
#: m²: scale of the sensitivities ∂τ/∂k = x·a in the NLP (a few hundred units at most). Measured
#: on the 60-case 1-DOF sweep of ``make bench`` against 1e-4 and 1e-3: the fewest iterations
#: (median 26 against 48 and 44); the local optimum IPOPT reaches changes with the scale.
SENSITIVITY_SCALE = 1e-5
#: N·m: scale of the tolerance band's parts ∂τ/∂p Δp in the NLP (a newton-millimetre, the
#: natural size of a balancer's torque errors).
BAND_SCALE = 1e-3


@dataclass(frozen=True)
class Block:
    """One family of blocks: ``unit`` (a function of the problem where it depends on it; None
    for a mechanism's unknowns, whose units the mechanism declares), ``description`` and
    ``role``."""

    unit: object
    description: str
    role: str


def _length() -> str:
    return "mm" if LENGTH_SCALE == 1e-3 else f"{LENGTH_SCALE:g} m"


def _rad(problem) -> str:
    """rad, rad², rad³, … (the trapezoidal weights of every joint's angle)."""
    power = len(problem.joints)
    return "rad" + ("" if power == 1 else "⁰¹²³⁴⁵⁶⁷⁸⁹"[power] if power < 10 else f"^{power}")


def _scaled(scale: float, unit: str) -> str:
    return unit if scale == 1 else f"{scale:g} {unit}"


def _minimax(problem) -> bool:
    return problem.options.objective == "minimax"


MM, FORCE, TORQUE = _length(), _scaled(FORCE_SCALE, "N"), _scaled(TORQUE_SCALE, "N·m")
SENSITIVITY = f"{SENSITIVITY_SCALE:g} m²"
BAND = _scaled(BAND_SCALE, "N·m")
_BAND_PARTS = {
    "bs": "over spring {1}'s rate, preload and end placements ((Δk·x̄ + ΔF0 + k·Δx₀)·a)",
    "bq": "over the placement of mechanism {1}'s {2}",
    "bf": "over a uniform offset of profile {1}",
}

#: The decision vector's families.
X_BLOCKS = {
    "c": Block(MM, "ρ coefficients of profile {0} in its basis", "design"),
    "x0": Block(MM, "spring pre-extensions at the reference pose, one per spring", "design"),
    "mount": Block(f"{MM}, rad", "mechanism {0}'s parameters placed within the spec's region (its spring end: "
                   "lengths in mm, angles in rad)", "design"),
    "z": Block(None, "departure unknown {1} of mechanism {0} at each grid angle of its joint", "departure"),
    "ref": Block(None, "departure unknowns of mechanism {0} at its reference angle", "departure"),
    "len": Block(MM, "wrapped length of profile {0} at each grid angle (Johnston2023 Eq. 10)", "auxiliary"),
    "rho": Block(MM, "ρ of profile {0} at its convexity check points (Johnston2023 Eq. 38)", "auxiliary"),
    "drho": Block(f"{MM}/rad", "ρ′ of profile {0} at its convexity check points", "auxiliary"),
    "ddrho": Block(f"{MM}/rad²", "ρ″ of profile {0} at its convexity check points", "auxiliary"),
    "wound": Block(MM, "length wound from each anchor of mechanism {0} at its reference pose", "auxiliary"),
    "e": Block(MM, "share of spring {0}'s extension from joint {1}'s angle, at each of its grid angles",
               "auxiliary"),
    "hi": Block(MM, "largest share of spring {0}'s extension from each of its joints", "auxiliary"),
    "lo": Block(MM, "smallest share of spring {0}'s extension from each of its joints", "auxiliary"),
    "U": Block(TORQUE, "joint {0}'s torque terms that depend on its own angle only, at each grid angle",
               "auxiliary"),
    "V": Block(FORCE, "joint {0}'s torque per unit of spring {1}'s extension share from joint {2} (k·a, "
               "the coupling term), at each grid angle", "auxiliary"),
    "t": Block(TORQUE, "bound on joint {0}'s largest |τ − τ_d| (minimax epigraph)", "auxiliary"),
    "sp": Block(SENSITIVITY, "positive part of joint {0}'s torque per unit of spring {1}'s rate (∂τ/∂k = "
                "x·a, x averaged over the other joints' angles), at each grid angle", "auxiliary"),
    "sn": Block(SENSITIVITY, "negative part of joint {0}'s torque per unit of spring {1}'s rate, at each "
                "grid angle", "auxiliary"),
    "to": Block(MM, "bound on mechanism {0}'s largest |x − x_d| (minimax epigraph)", "auxiliary"),
    **{family + sign: Block(BAND, f"{part} part of joint {{0}}'s torque change {what} at the tolerance's "
                            "step, at each grid angle (its tolerance band)", "auxiliary")
       for family, what in _BAND_PARTS.items() for sign, part in (("p", "positive"), ("n", "negative"))},
    "bz": Block("SI/mm", "change of mechanism {0}'s unknowns per millimetre of {1} (its tolerance band), at each "
                "grid angle (unknowns × angles, column-major; lengths in mm/mm)", "auxiliary"),
    "bzr": Block("SI/mm", "change of mechanism {0}'s unknowns at its reference angle per millimetre of {1}",
                 "auxiliary"),
    "bl": Block("1", "change of mechanism {0}'s wrapped length per millimetre of {1}, its ends held, at each grid "
                "angle", "auxiliary"),
    "mom": Block(f"{MM}·rad", "∫ of spring {1}'s share from joint {2} over that joint's angle (in joint "
                 "{0}'s squared error)", "auxiliary"),
    "Me": Block(lambda p: f"N·m·{MM}·{_rad(p)}", "target marginal of joint {0} times spring {1}'s share "
                "from joint {2} (in joint {0}'s squared error)", "auxiliary"),
    "UV": Block("N²·m·rad", "∫ U·V of joint {0} for spring {1}'s share from joint {2} (in its squared "
                "error)", "auxiliary"),
    "VV": Block(f"({FORCE})²·rad", "∫ V·V of joint {0} for the shares ({1}, {2}) and ({3}, {4}) (spring, "
                "joint) (in its squared error)", "auxiliary"),
    "ee": Block(f"{MM}²·rad", "∫ of the product of the shares ({1}, {2}) and ({3}, {4}) (spring, joint) "
                "(in joint {0}'s squared error)", "auxiliary"),
    "rd": Block(MM, "joint {0}'s port displacements at its grid angles (ports × angles, column-major), for the "
                "robust objective's scenarios", "scenario"),
    "rarm": Block(MM, "joint {0}'s port moment arms at its grid angles (ports × angles, column-major)", "scenario"),
    "rdd": Block("1", "change of joint {0}'s port displacements per millimetre of the tolerance column {1} "
                 "{2} (bq: a placed number of mechanism {2}, bf: an offset of profile {2}) (ports × angles, "
                 "column-major)", "scenario"),
    "rdarm": Block("1", "change of joint {0}'s port moment arms per millimetre of the tolerance column {1} {2}",
                   "scenario"),
    "ra": Block("1", "each scenario's adjustment settings (settings × scenarios, column-major), each a share of its "
                "range", "scenario"),
    "rmax": Block("%", "the design's largest |τ − τ_d| over its goal joints' grids, then each scenario's after its "
                  "settings, a share of its joint's peak target (epigraph)", "scenario"),
    "rvar": Block("%", "the level the worst tail share of the scenarios' largest errors exceeds (its value at "
                  "risk, at the optimum)", "scenario"),
    "rexc": Block("%", "each scenario's largest error above that level, or 0", "scenario"),
}

#: The parameter vector's families.
P_BLOCKS = {
    "theta": Block("rad", "grid angles of joint {0}", "grid"),
    "weights": Block("1", "tracking weight of joint {0}", "weights"),
    "wsens": Block("1", "sensitivity weights of joint {0}, one per spring", "weights"),
    "rt": Block(lambda p: f"N·m·{_rad(p)}", "joint {0}'s target summed over the other joints' angles with "
                "the quadrature weights, at each of its grid angles", "target"),
    "td2": Block(lambda p: f"N²·m²·{_rad(p)}", "∫τ_d² of joint {0} over the grid", "target"),
    "td": Block("N·m", "joint {0}'s target at each of its grid angles (minimax, robust)", "target"),
    "Mt": Block(lambda p: f"N·m·{_rad(p)}", "joint {0}'s target summed over all but joints {0} and {1}, "
                "with the quadrature weights (rows joint {0}'s angles, column-major)", "target"),
    "q": Block("SI", "mechanism {0}'s parameters", "mechanism"),
    "xd": Block("m", "mechanism {0}'s output law x_d at each grid angle", "target"),
    "xs": Block(lambda p: "1/mm" if _minimax(p) else "1/(mm²·rad)",
                "scale of mechanism {0}'s output error in the objective", "weights"),
    "rc": Block("m", "smallest radius of curvature of profile {0}, with the limit margin", "limits"),
    "wc": Block("rad", "end of profile {0}'s check range (a high-degree profile's convexity, ρ and curvature "
                "rows hold at fixed angles up to it): its start's most-wound departure plus one grid step's "
                "wrap", "limits"),
    "k": Block("N/m", "spring rates", "springs"),
    "F0": Block("N", "spring preloads", "springs"),
    "wband": Block("N·m", "band weight of joint {0}", "weights"),
    "dk": Block("N/m", "the rate tolerance's step of each spring rate", "tolerances"),
    "dF": Block("N", "the force step of each spring's preload and end-placement tolerances", "tolerances"),
    "dq": Block("SI/mm", "the step of each of mechanism {0}'s parameters per millimetre of misplacement "
                "(0: not placed)", "tolerances"),
    "tol": Block("mm", "the placement and profile tolerances (a part's misplacement, a uniform offset of ρ)",
                 "tolerances"),
    "rsteps": Block("SI", "each scenario's step of the design's parameters p = [c; k; x0; F0; q] (parameters × "
                    "scenarios, column-major)", "tolerances"),
    "rbound": Block("SI", "the range ± of each adjustment setting in its parameter's units", "tolerances"),
    "rw": Block("1/(N·m)", "one over each joint's scale (its peak target; 0: no torque goal)", "weights"),
    "rtail": Block("1", "one over the number of the robust objective's tail (the design and its scenarios)",
                   "weights"),
    "obj_scale": Block(lambda p: "1/(N·m)" if _minimax(p) else f"1/(N²·m²·{_rad(p)})",
                       "scale of the torque objective (OBJECTIVE_SCALE over its value at zero torque)",
                       "weights"),
}


def block_name(family: str, index: tuple) -> str:
    """The name of a block: its family followed by its index joined by ``_`` (``V0_1_0``)."""
    return family + "_".join(str(i) for i in index)


def describe(families: dict[str, Block], family: str, index: tuple, problem) -> tuple[str, str, str]:
    """(unit, description, role) of the block ``family`` + ``index`` of ``problem``."""
    block = families[family]
    shown = [i + 1 if isinstance(i, int) else i for i in index]
    text, unit = block.description.format(*shown), block.unit
    if family in ("z", "ref"):  # a mechanism's unknowns: the units and names it declares
        mech = problem.mechanisms[index[0]]
        units = dict(zip(mech.unknowns, mech.unknown_units))
        if family == "z":
            unit = units[index[1]]
        else:
            unit = (next(iter(units.values())) if len(set(units.values())) == 1
                    else "; ".join(f"{k} {u}" for k, u in units.items()))
    elif family == "q":
        text += f" ({', '.join(problem.mechanisms[index[0]].parameter_names)})"
    return (unit(problem) if callable(unit) else unit), text, block.role
