"""The resolved design problem: joints, mechanisms, springs, targets and options, in SI units.

A :class:`Problem` is what a spec file (:mod:`cadcam.spec`) becomes after validation; its
:meth:`Problem.to_dict` is a spec again, with tables inlined, so that every result carries the
problem it solved and can be re-evaluated without the original file.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from typing import Any, Callable

import numpy as np

from .files import env_cap
from .keys import PART_SIZE, SHARE, Key, KeyTable, Plausible, is_real
from .mechanisms.base import ENERGY, Mechanism, Profile
from .physics.cables import MAX_DIAMETER, Cable
from .physics.friction import Friction
from .physics.springs import Network, Spring, SpringParameters
from .targets import Target


#: Tracking objectives of the NLP (:attr:`Options.objective`): the design's own error (nominal),
#: or its builds' after adjusting (``robust``, :mod:`cadcam.solve.robust`).
OBJECTIVES = ("least_squares", "minimax", "robust")
#: How IPOPT's functions are evaluated (:attr:`Options.functions`).
FUNCTIONS = ("auto", "expanded", "mapped", "compiled")
#: Loosest IPOPT tolerance ``[solver] tol`` may set.
TOL_CAP = 1e-4


#: Caps on every size a spec, study or flag controls, checked before any work. Raise one
#: deliberately with the environment variable ``CADCAM_CAP_<NAME>`` (e.g. ``CADCAM_CAP_GRID=4000``).
#: ``grid_points`` caps the design grid's tensor grid grid^joints, whose values are held in
#: memory (the NLP's target marginals, torque.csv, the plots); ``recheck_points`` caps the fine
#: re-check's tensor grid and that of ``cadcam evaluate --grid`` (:func:`evaluation_size_error`),
#: which are streamed in bounded memory (:mod:`cadcam.verify.evaluate`) but whose time still
#: grows with their size.
CAPS = {"grid": 2000, "quadrature_order": 16, "convexity_points": 5000, "multistart": 100,
        "recheck_factor": 100, "max_iter": 100_000, "grid_points": 20_000_000,
        "recheck_points": 1_000_000_000, "cases": 10_000, "workers": 256,
        "joints": 16, "mechanisms_per_joint": 8, "springs": 128}


def count_error(what: str, count: int) -> str | None:
    """One-line reason why ``count`` tables of ``what`` (a cap of :data:`CAPS`: ``joints``,
    ``mechanisms_per_joint``, ``springs``) are beyond their cap, or None."""
    if count <= cap(what):
        return None
    return (f"{count} exceed the cap {cap(what)} (raise it deliberately with the environment variable "
            f"CADCAM_CAP_{what.upper()})")


def cap(name: str) -> int:
    """The cap ``name`` of :data:`CAPS`, or its ``CADCAM_CAP_<NAME>`` override (a positive
    integer)."""
    return env_cap(name, CAPS[name])


def _how_many(n: int) -> str:
    """A count in three digits, also one too large for a float (a grid to the power of many
    joints)."""
    return f"{n:.3g}" if n < 1e300 else f"about 10^{len(str(n)) - 1}"


def size_error(options: "Options", n_joints: int) -> tuple[str, str] | None:
    """(option name, one-line reason) for the first size of ``options`` beyond its cap, counting
    the design grid's tensor grid grid^n_joints (held in memory) and the fine re-check's
    ((grid − 1)·recheck_factor + 1)^n_joints (streamed: a cap on time); None if all fit."""
    for name in ("grid", "quadrature_order", "convexity_points", "multistart", "recheck_factor", "max_iter"):
        value = getattr(options, name)
        if value > cap(name):
            return name, (f"{value} exceeds the cap {cap(name)} (raise it deliberately with the "
                          f"environment variable CADCAM_CAP_{name.upper()})")
    points = options.grid ** n_joints
    if points > cap("grid_points"):
        return "grid", (f"the design grid would hold {_how_many(points)} points (grid^{n_joints}) in memory, "
                        f"beyond the cap {cap('grid_points'):.3g}: lower grid, or raise the cap "
                        "deliberately with CADCAM_CAP_GRID_POINTS")
    points = options.recheck_grid ** n_joints
    if points > cap("recheck_points"):
        return "grid", (f"the fine re-check would evaluate {_how_many(points)} points "
                        f"(((grid − 1)·recheck_factor + 1)^{n_joints}, streamed), beyond the cap "
                        f"{cap('recheck_points'):.3g}: lower grid or recheck_factor, or raise the cap "
                        "deliberately with CADCAM_CAP_RECHECK_POINTS")
    return None


def evaluation_size_error(grid: int, n_joints: int) -> str | None:
    """One-line reason why evaluating a design on ``grid`` angles per joint
    (:func:`cadcam.verify.evaluate.evaluate`, ``cadcam evaluate --grid``) is beyond its caps, or
    None if it fits.

    The evaluation streams its tensor grid grid^n_joints in bounded memory and holds nothing
    of that size, like the fine re-check, so it is capped like the re-check: grid^n_joints by
    ``recheck_points`` (a cap on time), and the angles per joint, whose samples it does hold
    (the departure at each angle, the profile scan), by the re-check's largest at the caps,
    (``grid`` − 1)·``recheck_factor`` + 1.
    """
    per_joint = (cap("grid") - 1) * cap("recheck_factor") + 1
    if grid > per_joint:
        return (f"{grid} angles per joint exceed the cap {per_joint} (the fine re-check's largest, "
                "(grid − 1)·recheck_factor + 1 at their caps): lower grid, or raise the cap deliberately "
                "with CADCAM_CAP_GRID or CADCAM_CAP_RECHECK_FACTOR")
    points = grid**n_joints
    if points > cap("recheck_points"):
        return (f"the evaluation would stream {points:,} points (grid^{n_joints}), beyond the cap "
                f"{cap('recheck_points'):,}: lower grid, or raise the cap deliberately with "
                "CADCAM_CAP_RECHECK_POINTS")
    return None


def _integer(v, least: int) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and v >= least


@dataclass(frozen=True)
class Setting:
    """One IPOPT option cadcam passes on (:data:`IPOPT_OPTIONS`), declared once: the values it
    may take (``ok``, and ``form`` in words)."""

    default: Any
    ok: Callable[[Any], bool] | None
    form: str
    description: str


#: Highest degree of a moment arm r_m(θ) in the ``moment_arm`` design method: the minimax NLP
#: in its coefficients is dense, and Ludovico2021 reaches its accuracy at 5 to 7.
MAX_MOMENT_ARM_DEGREE = 20

#: The ``[solver]`` options, in the order a spec's table is read: each declared once (the spec
#: reader, the CLI's flags, the API and :class:`Options` read it).
SOLVER = {k.name: k for k in (
    Key("grid", "", "angles per joint on the uniform design grid (including both ends)", "integer", 46, low=3),
    Key("quadrature_order", "", "Gauss–Legendre points per segment of the wrapped length between neighbouring grid "
        "contacts, and 8× that over the whole wrap for the as-printed friction integral", "integer", 2, low=1),
    Key("convexity_points", "", "profile samples, spread over the whole wrapped range [0, α(θ_max)], at which "
        "convexity and ρ bounds are imposed", "integer", 120, low=2),
    Key("convexity_epsilon", "", "the required convexity margin as a fraction of ρ_min² (Eq. 40 asks for > 0)",
        "number", 1e-3, low=0),
    Key("limit_margin", "", "the fraction of every limit (spring travel, ρ_min, ρ_max) the NLP keeps in reserve, so "
        "that what happens between grid points stays inside the limit on the re-check", "number", 1e-4, low=0,
        high=0.1, open_high=True),
    Key("multistart", "", "extra randomised starts besides the default one", "integer", 0, low=0,
        details="0: a single start"),
    Key("seed", "", "the seed of the multistart generator", "integer", 0, low=0, high=2**32, open_high=True),
    Key("max_iter", "", "IPOPT's iteration limit", "integer", 500, low=1),
    Key("tol", "", "IPOPT's tolerance", "number", 1e-8, low=0, high=TOL_CAP, open_low=True,
        details="a looser one would stop short of the optimum and call it converged"),
    Key("recheck_factor", "", "how many times finer than the design grid the re-check grid is", "integer", 10, low=2),
    Key("objective", "", "the tracking objective", "choice", "least_squares", choices=OBJECTIVES,
        details="``least_squares``: the tracking term is ∫(τ − τ_d)² (Johnston2023 Eq. 46/47); ``minimax``: the "
        "largest |τ − τ_d| over the grid, by an epigraph variable per joint (for problems whose joint torques and "
        "targets each depend on their own joint's angle); ``robust``: the builds' error after adjusting, not the "
        "design's — the mean of the worst ``[builds] tail`` of ``[builds] scenarios`` builds and the design itself "
        "(each build's parts drawn within its [tolerances] and set by its own [adjustment] settings, variables of the "
        "NLP) of each one's largest |τ − τ_d| as a share of its joint's peak target, with the adjustment's ranges as "
        "limits, solved from the least-squares optimum (for problems with springs whose joint torques and targets "
        "each depend on their own joint's angle, on mechanisms without a constant cable length; :mod:"
        "`cadcam.solve.robust`)"),
    Key("ipopt", "", "further IPOPT options (name without the ``ipopt.`` prefix = value), each one of "
        ":data:`IPOPT_OPTIONS`, e.g. a warm start (``mu_init``, ``bound_push``, ``warm_start_init_point``) from a "
        "start that is already close to the optimum", "table", (), check=lambda v: all(
            re.fullmatch(r"[a-z][a-z0-9_]*", k) and (is_real(x) or isinstance(x, str)) for k, x in v.items()),
        words="of IPOPT option names = numbers or strings, such as mu_init = 1e-6"),
    Key("method", "", "the design method", "string", "nlp", min_length=1,
        details="``nlp``: cadcam's NLP from the start design; a mechanism's own method "
        "(:func:`cadcam.mechanisms.base.design_methods`): its start design itself, re-checked like an optimum (no NLP "
        "is built)"),
    Key("moment_arm_degree", "", "the degree of each anchored pulley's moment arm r_m(θ), a Chebyshev series in its "
        "joint's angle, in the ``moment_arm`` design method (Ludovico2021 Sec. III; its Table III uses 5); the "
        "pulleys it gives are fitted as profiles of their mechanisms' own ``order``", "integer", 5, low=1,
        high=MAX_MOMENT_ARM_DEGREE),
    Key("functions", "", "how IPOPT's functions of the NLP are evaluated", "choice", "auto", choices=FUNCTIONS,
        details="``expanded``: expanded into scalar (SX) "
        "graphs when the solver is built, whose time grows with the grid; ``mapped``: the graph of mapped per-angle "
        "functions as built, flat in the grid, evaluated more slowly; ``compiled``: that graph as C, compiled once "
        "per problem structure and cached on disk (:mod:`cadcam.solve.compiled`; needs a C compiler): slow the "
        "first time, then the fastest to build and to solve; ``auto``: compiled where the structure's library is in "
        "the cache, else expanded while a C compiler (where one exists) compiles the library in the background for "
        "the next build of the same structure. They give the same optimum up to rounding (the iteration count may "
        "differ by a few) where the optimum is isolated; where it is not (an output law met exactly, as by "
        "Fedorov2018's balancer) rounding can lead IPOPT to another of its optima, in other iterations. The summary "
        "and ``result.json``'s ``solver.functions`` say which were used"),
)}

#: The ``[solver]`` table, its keys :data:`SOLVER`'s (the reference and the schema list it).
SOLVER_KEYS = KeyTable("[solver]", "How the design is transcribed and solved.", tuple(SOLVER.values()))


def _choice(*values):
    return Setting(None, lambda v: v in values, "one of " + ", ".join(f'"{v}"' for v in values), "")


def _between(lo: float, hi: float, open_lo: bool = True, text: str = "") -> Setting:
    above = (lambda v: v > lo) if open_lo else (lambda v: v >= lo)
    return Setting(None, lambda v: is_real(v) and above(v) and v <= hi,
                   text or f"a number in {'(' if open_lo else '['}{lo:g}, {hi:g}]", "")


def _count(hi: int) -> Setting:
    return Setting(None, lambda v: _integer(v, 0) and v <= hi, f"an integer from 0 to {hi}", "")


#: The IPOPT options a spec's ``[solver.ipopt]``, ``--ipopt`` or ``ipopt=`` may set, each with
#: the values cadcam passes on (IPOPT's defaults apply where one is not given). Nothing else
#: reaches IPOPT: not the options that name files or libraries (``output_file``,
#: ``option_file_name``, ``hsllib``, ``pardisolib``, …), not a linear solver that is not
#: installed, and not a tolerance looser than IPOPT's own default (``tol`` and ``max_iter`` are
#: ``[solver]`` keys with caps). A stop at IPOPT's acceptable level has its own status
#: (``acceptable``), never ``success``.
IPOPT_OPTIONS = {
    "print_level": _count(12),
    "sb": _choice("yes", "no"),
    "print_timing_statistics": _choice("yes", "no"),
    "mu_strategy": _choice("monotone", "adaptive"),
    "mu_oracle": _choice("quality-function", "probing", "loqo"),
    "mu_init": _between(0, 1e3),
    "mu_max": _between(0, 1e10),
    "bound_push": _between(0, 1),
    "bound_frac": _between(0, 0.5),
    "bound_mult_init_val": _between(0, 1e3),
    "warm_start_init_point": _choice("yes", "no"),
    "warm_start_bound_push": _between(0, 1),
    "warm_start_bound_frac": _between(0, 0.5),
    "warm_start_mult_bound_push": _between(0, 1),
    "warm_start_slack_bound_push": _between(0, 1),
    "warm_start_slack_bound_frac": _between(0, 0.5),
    "nlp_scaling_method": _choice("none", "gradient-based"),
    "nlp_scaling_max_gradient": _between(0, 1e10),
    "hessian_approximation": _choice("exact", "limited-memory"),
    "limited_memory_max_history": _count(1000),
    "linear_solver": _choice("mumps", "spral"),
    "dual_inf_tol": _between(0, 1),
    "constr_viol_tol": _between(0, 1e-4),
    "compl_inf_tol": _between(0, 1e-4),
    "acceptable_tol": _between(0, 1e10),
    "acceptable_iter": _count(1000),
    "acceptable_dual_inf_tol": _between(0, 1e10),
    "acceptable_constr_viol_tol": _between(0, 1e10),
    "acceptable_compl_inf_tol": _between(0, 1e10),
    "acceptable_obj_change_tol": _between(0, 1e10, open_lo=False),
    "max_cpu_time": _between(0, 1e6),
    "max_wall_time": _between(0, 1e6),
}


@dataclass(frozen=True)
class Options:
    """Transcription and solver options: each field is a ``[solver]`` key of :data:`SOLVER`,
    which declares its default, its values and its meaning."""

    grid: int = SOLVER["grid"].default
    quadrature_order: int = SOLVER["quadrature_order"].default
    convexity_points: int = SOLVER["convexity_points"].default
    convexity_epsilon: float = SOLVER["convexity_epsilon"].default
    limit_margin: float = SOLVER["limit_margin"].default
    multistart: int = SOLVER["multistart"].default
    seed: int = SOLVER["seed"].default
    max_iter: int = SOLVER["max_iter"].default
    tol: float = SOLVER["tol"].default
    recheck_factor: int = SOLVER["recheck_factor"].default
    objective: str = SOLVER["objective"].default
    ipopt: tuple = SOLVER["ipopt"].default
    method: str = SOLVER["method"].default
    moment_arm_degree: int = SOLVER["moment_arm_degree"].default
    functions: str = SOLVER["functions"].default

    @property
    def recheck_grid(self) -> int:
        """Angles per joint of the fine re-check grid: (grid − 1)·recheck_factor + 1."""
        return (self.grid - 1) * self.recheck_factor + 1


MIN_WALL = 1e-3
"""Least material [m] left between the bore, the anchor hole, the groove and the profile."""
MIN_CUT_RADIUS = 5e-4
"""Least radius of curvature [m] of a cut outline under a cable of some diameter: the designed
centre line's, less the cable's radius (a cutter's radius, and no cusp in the offset)."""

#: The ``[workshop]`` table: sizes of the workshop files [m] a spec or a ``cadcam design`` flag
#: of the same name may set, each with its smallest and largest value; a chordal tolerance below
#: 0.1 µm would make polygons of unbounded size.
WORKSHOP_KEYS = KeyTable("[workshop]", "Sizes of the workshop files; each `cadcam design` flag of the same name "
                         "(`--bore-diameter` …) overrides the spec's.", (
    Key("bore_diameter", "m", "the shaft bore of every planar outline", low=1e-4, high=1.0, default=0.006),
    Key("anchor_diameter", "m", "the cable-anchor hole near φ = 0", low=1e-4, high=0.1, default=0.0025),
    Key("cable_diameter", "m", "the cable's diameter (0: an ideal thread); the designed profile is the cable's "
        "centre line, the cut outline lies its radius inside (a [cable] table sets it)", low=0.0, high=MAX_DIAMETER,
        default=0.0),
    Key("tolerance", "m", "the loosest fit of the DXF and SVG arcs and the CSV and STL polygons (the files are "
        "fitted tighter where the design's accuracy asks)", low=1e-7, high=1e-3, default=1e-5),
    Key("stl", "m", "the thickness of camN.stl", low=1e-4, high=1.0, default=None, default_text="none: no STL"),
    Key("groove_depth", "m", "the depth of the cable groove cut around the STL (0: none)", low=0.0, high=0.1,
        default=0.0),
    Key("groove_width", "m", "the width of the cable groove cut around the STL (0: none)", low=0.0, high=0.1,
        default=0.0),
    Key("groove_pitch", "m", "the rise per turn of a helical groove's centre line", low=1e-4, high=0.1,
        default=0.004),
))
#: (smallest, largest) of each workshop size [m] (:data:`WORKSHOP_KEYS`).
WORKSHOP_LIMITS = {k.name: (k.low, k.high) for k in WORKSHOP_KEYS.keys}


#: Thickness [m] of the solids (STL, STEP) the design page offers for a spec that sets no
#: ``[workshop] stl``: a 5 mm plate, a common stock for laser-cut or printed pulleys and cams.
SOLID_THICKNESS = 0.005


@dataclass(frozen=True)
class Workshop:
    """Sizes of the workshop files [m]: a spec's ``[workshop]`` table, each key as
    :data:`WORKSHOP_KEYS` declares it, each overridden by the ``cadcam design`` flag of the same
    name (``--bore-diameter`` …)."""

    bore_diameter: float = WORKSHOP_KEYS["bore_diameter"].default
    anchor_diameter: float = WORKSHOP_KEYS["anchor_diameter"].default
    cable_diameter: float = WORKSHOP_KEYS["cable_diameter"].default
    tolerance: float = WORKSHOP_KEYS["tolerance"].default
    stl: float | None = WORKSHOP_KEYS["stl"].default
    groove_depth: float = WORKSHOP_KEYS["groove_depth"].default
    groove_width: float = WORKSHOP_KEYS["groove_width"].default
    groove_pitch: float = WORKSHOP_KEYS["groove_pitch"].default

    def __post_init__(self):
        for name, (lo, hi) in WORKSHOP_LIMITS.items():
            value = getattr(self, name)
            if value is not None and not lo <= value <= hi:
                raise ValueError(f"{name} = {value!r}: expected a length from {lo:g} to {hi:g} m")

    @property
    def hub_radius(self) -> float:
        """Radius [m] of the hub every cut outline closes around: the bore's, a wall, and the
        depth of a groove cut round the outline (:func:`cadcam.make.workshop.write_stl`)."""
        return self.bore_diameter / 2 + MIN_WALL + self.groove_depth

    @property
    def cable_radius(self) -> float:
        """Half the cable's diameter [m]: how far the cut outline lies inside the designed one."""
        return self.cable_diameter / 2

    @property
    def greatest_curvature(self) -> float:
        """Greatest curvature [1/m] of a designed profile, the cable's centre line, where the
        cable has a diameter: one over its radius and MIN_CUT_RADIUS (inf without one)."""
        return 1 / (self.cable_radius + MIN_CUT_RADIUS) if self.cable_diameter > 0 else np.inf

    @property
    def anchor_radius(self) -> float:
        """Least radius [m] of an outline's anchor φ = 0: the hub, the anchor hole and a wall
        between the hole and the profile (the hole's centre lies a wall and its radius inside
        the outline, :func:`cadcam.make.workshop.anchor_centre`)."""
        return self.hub_radius + self.anchor_diameter + MIN_WALL

    def with_solids(self) -> "Workshop":
        """These sizes with a solid's thickness: ``stl``'s, else :data:`SOLID_THICKNESS`."""
        return self if self.stl is not None else replace(self, stl=SOLID_THICKNESS)

    def to_dict(self) -> dict:
        """The sizes as a spec's ``[workshop]`` table (no ``stl`` without one)."""
        return {k: v for k, v in vars(self).items() if v is not None}


@dataclass(frozen=True)
class Acceptance:
    """One ``[joints.acceptance]`` key: a limit on the joint's metric of that name on the fine
    re-check (:data:`cadcam.verify.evaluate.METRICS`), with the metric's short label, its unit,
    meaning and default limit (``None``: no limit unless the spec gives one)."""

    label: str
    unit: str
    description: str
    default: float | None = None


#: The torque floor of a joint's ``relative_rmse``, as a share of its springs' torque scale
#: (:meth:`Problem.spring_torque_scale`) [ratio]: the relative RMSE is a share of the larger of
#: the target's RMS and this floor, so that a zero or vanishing target, whose relative RMSE
#: divides by (nearly) zero, is met only by an RMSE within ``relative_rmse`` × the floor [N·m].
#: A target below 1 % of the torque its springs can hold is, for them, nil. Every shipped
#: spec's target is above its floor (the nearest, johnston2023_1dof's, at 2.5 % of its springs'
#: torque scale), so none of their verdicts rests on it.
TORQUE_FLOOR = 0.01

#: The ``[joints.acceptance]`` keys: what a design must meet on the fine re-check to be a
#: success (status ``target_missed`` otherwise). The relative RMSE has a default, so that
#: success means the target was met: a spring too weak for its load converges to a design
#: that holds every constraint, and only this limit tells that it does not do the job.
ACCEPTANCE = {
    "relative_rmse": Acceptance("RMSE / target RMS", "ratio",
                                "the torque's RMSE over the range as a share of the target's RMS, or of the joint's "
                                f"torque floor where the target's RMS is below it ({100 * TORQUE_FLOOR:.3g} % of its "
                                "springs' torque scale: the energy they store within their travel over the range's "
                                "span), so that a zero target is met only within that share of the floor", 0.05),
    "rmse": Acceptance("RMSE", "N·m", "the torque's RMSE over the range"),
    "max_abs_error": Acceptance("max |τ − τ_d|", "N·m", "the largest torque error over the range"),
}


def acceptance_keys() -> KeyTable:
    """The ``[joints.acceptance]`` keys, from :data:`ACCEPTANCE`: each a positive limit, its
    default that of its metric."""
    return KeyTable("[joints.acceptance]", "What a design must meet on the fine re-check to be a `success` (else "
                    "its status is `target_missed` and `cadcam design` exits 1); a limit with a default applies to "
                    "every joint with a torque target unless its spec sets another.",
                    tuple(Key(name, a.unit, f"a limit on {a.description}", low=0, open_low=True, default=a.default,
                              default_text="" if a.default is not None else "none",
                              plausible=SHARE if a.unit == "ratio" else None)
                          for name, a in ACCEPTANCE.items()))


@dataclass(frozen=True)
class Tolerance:
    """One ``[tolerances]`` key: how far a built part may be from its design, ± around the
    nominal value, for the tolerance band (:mod:`cadcam.verify.tolerance`)."""

    unit: str
    description: str
    default: float
    plausible: Plausible


#: How far [m] a workshop's part plausibly is from its drawing: a value beyond reads as
#: millimetres typed as metres.
WORKSHOP_TOLERANCE = Plausible(high=0.01, what="a workshop's tolerances")

#: The ``[tolerances]`` keys and their defaults: a catalogue spring's rate and initial tension
#: are sold at about ±10 %, a hole drilled by hand lands within about 0.5 mm, a profile
#: cut by a CNC mill or a laser within about 0.05 mm, and a friction coefficient is known to
#: about ±30 % (one pair of materials spans that in handbooks, and wear, dirt and humidity move it).
TOLERANCES = {
    "rate": Tolerance("ratio", "each spring's rate k, as a share of it", 0.10, SHARE),
    "preload": Tolerance("ratio", "each spring's preload F0 (initial tension), as a share of it", 0.10, SHARE),
    "placement": Tolerance("m", "where a spring's ends and the idlers are placed (each spring's "
                                "pre-extension, and each mechanism's placed parameters)", 0.5e-3, WORKSHOP_TOLERANCE),
    "profile": Tolerance("m", "each profile's radius ρ, as a uniform offset of the cut outline", 0.05e-3,
                         WORKSHOP_TOLERANCE),
    "friction": Tolerance("ratio", "each friction coefficient of [friction] that moves the friction band's centre "
                                   "(a guide's mu, an idler's coefficient), as a share of it: the simulated builds "
                                   "draw it, the first-order band leaves it out", 0.30, SHARE),
}

def tolerance_keys() -> KeyTable:
    """The ``[tolerances]`` keys, from :data:`TOLERANCES`: each ± a number ≥ 0."""
    return KeyTable("[tolerances]", "How far a built part may be from its design, ± around each nominal value: "
                    "every design reports the torque band they give (`tolerance_band` in `result.json`, the "
                    "summary, the shaded band of `torque.png`).",
                    tuple(Key(name, t.unit, t.description, low=0, default=t.default, plausible=t.plausible)
                          for name, t in TOLERANCES.items()))


#: How a built part's deviation is drawn within its ± tolerance (``[builds] distribution``).
DISTRIBUTIONS = {
    "uniform": "uniform within ± the tolerance: a tolerance is a limit, and nothing says where within it a part "
               "falls (a batch of springs is often all off the same way), so no value inside is likelier than "
               "another",
    "normal": "normal with the tolerance as 3σ, cut at ± the tolerance: a centred process whose parts outside the "
              "limit are rejected",
}
#: Most builds ``[builds] count`` may ask for.
MAX_BUILDS = 1_000_000
#: Most scenarios ``[builds] scenarios`` may ask for: each adds its settings and its torque at
#: every grid angle to the robust objective's NLP.
MAX_SCENARIOS = 256

#: The ``[builds]`` keys: the Monte Carlo of built devices (:mod:`cadcam.verify.builds`).
BUILD_KEYS = KeyTable("[builds]", "Builds, not corners: every design with springs simulates this many devices, each "
                      "part drawn within its [tolerances], and reports the P50 and P95 of each joint's largest "
                      "torque error (`builds` in `result.json`, the summary).", (
    Key("count", "", "the number of builds simulated", "integer", low=0, high=MAX_BUILDS, default=10_000,
        details="0 simulates none"),
    Key("seed", "", "the seed of the random draws: the same seed draws the same builds", "integer", low=0,
        default=0),
    Key("distribution", "", "how each part's deviation is drawn within its ± tolerance", "choice",
        choices=tuple(DISTRIBUTIONS), default="uniform",
        details="; ".join(f"{name}: {words}" for name, words in DISTRIBUTIONS.items())),
    Key("scenarios", "", "the builds the robust objective (solver.objective = 'robust') designs for, drawn like the "
        "simulated ones from a stream of their own (seeded by seed), each with its own adjustment settings in the "
        "NLP", "integer", low=1, high=MAX_SCENARIOS, default=32),
    Key("tail", "", "the share of the scenarios and the design itself, the worst, whose mean largest error after "
        "adjusting the robust objective minimises (their conditional value at risk: a smooth stand-in for a high "
        "percentile)", low=0, high=1, open_low=True, default=0.1, plausible=SHARE,
        details="at most 1/(scenarios + 1): the worst alone"),
))

#: The ``[adjustment]`` keys: what the builder sets after the build (:mod:`cadcam.verify.builds`).
ADJUSTMENT_KEYS = KeyTable("[adjustment]", "A designed-in adjustment the builder sets after the build, each with "
                           "its range as a limit: each simulated build is set back as the adjustment table "
                           "(`adjustment.csv`) tells, and the P50 and P95 after adjusting are reported beside "
                           "those before.", (
    Key("preload_travel", "m", "± how far each spring's tensioning screw shifts its pre-extension (its extension "
        "at the reference angle, that is, the cable's length)", low=0, default=0.0, plausible=PART_SIZE,
        details="0: no screw"),
    Key("slot", "", "the placed parameter of the mechanisms that a slot lets the spring end move along", "string",
        default="", default_text="none",
        details="a parameter a mechanism places (anchored_pulley: `chi0`, an arc around the joint through the "
                "spring end; `ell`, a radial slot); every mechanism that has it gets its own slot"),
    Key("slot_travel", "m", "± how far the spring end moves along its slot (along the arc, for an angle)", low=0,
        default=0.0, plausible=PART_SIZE, details="0: no slot"),
))


#: A joint's ``band_weight``: the weight of its tolerance band in the NLP's objective
#: (:func:`cadcam.solve.objective._band_rows`); 0, the default, leaves the band out.
BAND_WEIGHT = Key(
    "band_weight", "N·m",
    "the weight of the joint's tolerance band in the objective", low=0, default=0.0,
    details="band_weight × ∫w dθ, w the band's first-order half-width under [tolerances] (beside tracking_weight "
    "× ∫(τ − τ_d)²; 0 leaves it out). Every part of w (rate, preload, spring ends' and idlers' placement, profile "
    "offset) on a joint whose springs act on it alone, but a differential pulley's profile offset; its springs' parts "
    "(rate, preload, spring-end placement) on a joint that a spring joins to another")

#: Largest span of a joint's angle range [deg]: cables may wrap helical grooves, but not without end.
MAX_JOINT_SPAN_DEG = 3600.0

#: A ``[[joints]]`` table's keys.
JOINT_KEYS = KeyTable("[[joints]]", "A joint: the range to balance, its torque target and the weights of its "
                      "objective terms.", (
    Key("theta_range_deg", "deg", "[min, max] joint angles from the reference pose", "numbers", length=2,
        low=-MAX_JOINT_SPAN_DEG, high=MAX_JOINT_SPAN_DEG, details=f"a non-empty range at most {MAX_JOINT_SPAN_DEG:g}° "
        f"wide (ten turns of a helical groove), within ±{MAX_JOINT_SPAN_DEG:g}°",
        check=lambda v: 0 < v[1] - v[0] <= MAX_JOINT_SPAN_DEG, words=f"0 < max − min ≤ {MAX_JOINT_SPAN_DEG:g}"),
    Key("sensitivity_weights", "", "one weight per spring of ∫|∂τ/∂k_j| in the objective (Johnston2023 Eq. 47)",
        "numbers", low=0, default=None, default_text="0 for every spring"),
    Key("name", "", "the joint's name", "string", default=None, default_text="'joint N'"),
    Key("tracking_weight", "", "the weight w₁ of ∫(τ − τ_d)² in the objective (Johnston2023 Eq. 46)", low=0,
        default=1.0),
    Key("acceptance", "", "limits on the joint's metrics of the fine re-check (see [joints.acceptance])", "table",
        default={}, check=bool, words="not empty"),
    BAND_WEIGHT,
    Key("target", "", "the torque the springs must give at the joint [N·m] (see Target kinds)", "table"),
))



@dataclass(frozen=True)
class Joint:
    """A joint angle with its range, its target and the weights of its objective terms.

    ``theta_range`` [rad] is the range to balance; ``tracking_weight`` is w₁ and
    ``sensitivity_weights`` the w of ∫|∂τ/∂k_j| for each spring j (Johnston2023 Eq. 46, 47).
    The torque on a joint is the sum over the mechanisms on it. ``acceptance``: pairs (a key
    of :data:`ACCEPTANCE`, limit) the spec gives; :attr:`limits` adds the defaults.
    ``band_weight`` [N·m]: :data:`BAND_WEIGHT`.
    """

    name: str
    theta_range: tuple[float, float]
    target: Target
    tracking_weight: float
    sensitivity_weights: tuple[float, ...]
    acceptance: tuple = ()
    band_weight: float = 0.0

    @property
    def limits(self) -> dict[str, float]:
        """The acceptance limits the fine re-check must meet: the spec's, then the defaults of
        :data:`ACCEPTANCE` for the keys it leaves out (none for a joint with no torque goal)."""
        if self.target.kind == "none":
            return {}
        given = {**{key: a.default for key, a in ACCEPTANCE.items()}, **dict(self.acceptance)}
        return {key: float(limit) for key, limit in given.items() if limit is not None}

    def grid(self, n: int) -> np.ndarray:
        """Uniform grid of ``n`` joint angles [rad] over ``theta_range``."""
        return np.linspace(*self.theta_range, n)


@dataclass(frozen=True)
class Problem:
    """A design problem: joints, mechanisms on them, springs joining their ports, the torque
    model (``energy`` by default; see :func:`cadcam.mechanisms.base.torque_models`), options
    and the sizes of the workshop files.

    Raises ValueError if a mechanism cannot compute ``torque_model``.
    """

    name: str
    source: str
    joints: tuple[Joint, ...]
    mechanisms: tuple[Mechanism, ...]
    springs: tuple[Spring, ...]
    torque_model: str = ENERGY
    options: Options = field(default_factory=Options)
    notes: str = ""
    workshop: Workshop = field(default_factory=Workshop)
    #: The spec's ``[tolerances]`` (pairs key, value); :attr:`tolerance` adds the defaults.
    tolerances: tuple = ()
    #: One line per value the spec gives that is plausible only in another unit or lies outside
    #: every catalogue (:meth:`cadcam.keys.Key.implausible`), as its reader found them: told,
    #: not refused (a spec written from this problem is read to the same lines).
    warnings: tuple[str, ...] = field(default=(), compare=False)
    #: The spec's ``[cable]``: the cable the profiles wrap, whose bend and tension are limits of
    #: the design (:meth:`curvature_limit`, :meth:`extension_limit`); None: a diameter alone
    #: (``workshop.cable_diameter``), neither checked.
    cable: Cable | None = None
    #: The spec's ``[friction]``: where the cables slide and the joints' bearings, which split each
    #: joint's torque into a band (:mod:`cadcam.verify.friction`); None: frictionless.
    friction: Friction | None = None
    #: The spec's ``[builds]`` and ``[adjustment]`` (pairs key, value); :attr:`build_options`
    #: and :attr:`adjustment` add the defaults.
    builds: tuple = ()
    adjustments: tuple = ()

    def __post_init__(self):
        for mech in self.mechanisms:
            mech.check_torque_model(self.torque_model)

    @property
    def tolerance(self) -> dict[str, float]:
        """Every :data:`TOLERANCES` key's value: the spec's, else its default."""
        return {**{key: t.default for key, t in TOLERANCES.items()}, **dict(self.tolerances)}

    @property
    def build_options(self) -> dict[str, Any]:
        """Every :data:`BUILD_KEYS` key's value: the spec's, else its default."""
        return {**{k.name: k.default for k in BUILD_KEYS.keys}, **dict(self.builds)}

    @property
    def adjustment(self) -> dict[str, Any]:
        """Every :data:`ADJUSTMENT_KEYS` key's value: the spec's, else its default."""
        return {**{k.name: k.default for k in ADJUSTMENT_KEYS.keys}, **dict(self.adjustments)}

    # -- structure -----------------------------------------------------------------------------
    @property
    def profiles(self) -> tuple[Profile, ...]:
        """Every mechanism's profiles, in mechanism order (the design's ``cams``)."""
        return tuple(p for m in self.mechanisms for p in m.profiles)

    def profile_slices(self) -> list[slice]:
        """For each mechanism, the slice of :attr:`profiles` it owns."""
        out, k = [], 0
        for m in self.mechanisms:
            out.append(slice(k, k + len(m.profiles)))
            k += len(m.profiles)
        return out

    def profile_joint(self, k: int) -> int:
        """The joint profile ``k`` turns with."""
        return next(m.joint for m, s in zip(self.mechanisms, self.profile_slices())
                    if s.start <= k < s.stop)

    @property
    def ports(self) -> list[tuple[int, str]]:
        """(mechanism, port name) of every port, in global port order."""
        return [(u, name) for u, m in enumerate(self.mechanisms) for name in m.ports]

    def network(self) -> Network:
        """The spring network over the global ports."""
        ports = self.ports
        return Network(list(self.springs), [self.mechanisms[u].joint for u, _ in ports],
                       {p: g for g, p in enumerate(ports)}, len(self.joints), self.arm_scales())

    def arm_scales(self) -> dict:
        """The weights of the cable paths' arms in every torque: the friction band's centre's
        where the spec tracks it (:meth:`cadcam.physics.friction.Friction.arm_scales`), else none."""
        return {} if self.friction is None else self.friction.arm_scales()

    def spring_parameters(self) -> SpringParameters:
        """The springs' rates k [N/m], preloads F0 [N] and travels [m], each a vector in spring
        order: what every torque model, the NLP and the exports read."""
        return SpringParameters(*(np.array([getattr(s, name) for s in self.springs], dtype=float)
                                  for name in ("rate", "preload", "travel")))

    def placed(self, placements: list[dict]) -> "Problem":
        """This problem with each mechanism's placed parameters set (``placements``: per
        mechanism, name → value [SI], as :attr:`cadcam.solve.ipopt.Solve.placements`): the
        problem a design with a placed mount is re-checked, drawn and written for."""
        if not any(placements):
            return self
        return replace(self, mechanisms=tuple(m.placed(v) if v else m for m, v in zip(self.mechanisms, placements)))

    def mounted_springs(self) -> list[tuple[int, int, str, int]]:
        """(spring j, mechanism u, port name, joint) of every spring with a free length that
        hangs from the mount of its one port (:attr:`cadcam.mechanisms.base.Mechanism.mounted_ports`):
        the springs the room along their cable bounds, and whose cable has a length to cut."""
        out = []
        for j, spring in enumerate(self.springs):
            if spring.free_length is None or len(spring.ports) != 1:
                continue
            (port,) = spring.ports
            mech = self.mechanisms[port.mechanism]
            if port.name in mech.mounted_ports:
                out.append((j, port.mechanism, port.name, mech.joint))
        return out

    # -- limits of the parts -------------------------------------------------------------------------
    def curvature_limit(self, k: int) -> float:
        """The least radius of curvature [m] of profile ``k`` over its wrapped range: the larger
        of its own ``min_curvature_radius`` and its cable's least profile radius
        (:attr:`cadcam.physics.cables.Cable.least_profile_radius`)."""
        own = self.profiles[k].min_curvature_radius
        return own if self.cable is None else max(own, self.cable.least_profile_radius)

    def extension_limit(self, j: int) -> float:
        """The largest extension [m] spring ``j`` may reach: its travel, or less where the force
        F0 + k·x it puts on its cable would pass the cable's working load
        (:meth:`cadcam.physics.cables.Cable.extension_limit`)."""
        s = self.springs[j]
        return s.travel if self.cable is None else min(s.travel, self.cable.extension_limit(s.rate, s.preload))

    # -- acceptance ------------------------------------------------------------------------------
    def spring_energy(self, i: int) -> float:
        """The energy [J] the springs acting on joint ``i`` store within their largest
        extension t_j (:meth:`extension_limit`: their travel, or their cable's limit),
        Σ_j (½k_j t_j² + F0_j t_j): the most their energy can change along its range."""
        network = self.network()
        return float(sum(s.energy(max(self.extension_limit(j), 0.0)) for j, s in enumerate(self.springs)
                         if i in network.joints_of(j)))

    def spring_torque_scale(self, i: int) -> float:
        """Joint ``i``'s springs' torque scale [N·m]: :meth:`spring_energy` over its range's
        span [rad], the torque those springs could hold along the whole range."""
        low, high = self.joints[i].theta_range
        return self.spring_energy(i) / (high - low)

    def torque_floor(self, i: int) -> float:
        """The least torque [N·m] joint ``i``'s ``relative_rmse`` is a share of:
        :data:`TORQUE_FLOOR` × :meth:`spring_torque_scale`."""
        return TORQUE_FLOOR * self.spring_torque_scale(i)

    def floor_acceptance(self, i: int, limit: float, rmse: float, share: float | None) -> tuple[float, str] | None:
        """Where joint ``i``'s ``relative_rmse`` = ``limit`` is a share of its torque floor
        (:meth:`torque_floor`) — its target's RMS, ``rmse`` / ``share``, being below it, or zero
        everywhere (``share`` None) — the largest RMSE [N·m] it accepts, ``limit`` × the floor,
        and that limit in words; None where the target's RMS is the larger (``share`` alone is
        judged) or ``share`` meets ``limit`` anyway."""
        if share is not None and share <= limit:
            return None
        floor, target_rms = self.torque_floor(i), 0.0 if share is None else rmse / share
        if target_rms >= floor:
            return None
        return limit * floor, (f"{100 * limit:.3g} % of the torque floor {1e3 * floor:.4g} N·mm, "
                               f"{100 * TORQUE_FLOOR:.3g} % of its springs' torque scale, the target's RMS "
                               f"({1e3 * target_rms:.3g} N·mm) being below it")

    # -- copies ----------------------------------------------------------------------------------
    def with_options(self, **kw) -> "Problem":
        """Copy with some :class:`Options` fields changed."""
        return replace(self, options=replace(self.options, **kw))

    def with_torque_model(self, name: str) -> "Problem":
        """Copy solved or evaluated under another torque model."""
        return replace(self, torque_model=name)

    def with_spring_rates(self, factor: float, springs=None) -> "Problem":
        """Copy with the rates of ``springs`` (indices; default every spring, as Johnston2023's
        Table 5 study does) multiplied by ``factor``."""
        return replace(self, springs=tuple(
            replace(s, rate=s.rate * factor) if springs is None or j in springs else s
            for j, s in enumerate(self.springs)))

    def with_weights(self, tracking: float | None = None, sensitivity=None, band: float | None = None) -> "Problem":
        """Copy with every joint's tracking weight, sensitivity weights and/or band weight
        replaced."""
        joints = tuple(replace(c, tracking_weight=c.tracking_weight if tracking is None else tracking,
                               sensitivity_weights=c.sensitivity_weights if sensitivity is None
                               else tuple(sensitivity),
                               band_weight=c.band_weight if band is None else band) for c in self.joints)
        return replace(self, joints=joints)

    def to_dict(self) -> dict:
        """The fully resolved problem in the spec format (SI units; tables inlined)."""
        mechanisms = []
        for m in self.mechanisms:
            prof = m.profiles[0]  # the spec form gives one basis and one set of limits for all
            mechanisms.append({
                "kind": m.kind, "name": m.name, "joint": m.joint + 1,
                "basis": prof.basis.name, "order": prof.basis.order,
                "rho_min": prof.rho_min, "rho_max": prof.rho_max,
                **({"min_curvature_radius": prof.min_curvature_radius}
                   if prof.min_curvature_radius > 0 else {}),
                **({"link_angle": m.link_angle} if m.link_angle is not None else {}),
                **m.spec_fields()})
        return {
            "name": self.name, "source": self.source, "notes": self.notes,
            "torque_model": self.torque_model,
            "solver": {**vars(self.options), "ipopt": dict(self.options.ipopt)},
            "joints": [{
                "name": c.name,
                "theta_range_deg": [float(np.degrees(t)) for t in c.theta_range],
                "tracking_weight": c.tracking_weight,
                "sensitivity_weights": list(c.sensitivity_weights),
                "band_weight": c.band_weight,
                "target": c.target.to_dict(),
                **({"acceptance": dict(c.acceptance)} if c.acceptance else {}),
            } for c in self.joints],
            "mechanisms": mechanisms,
            "springs": [s.to_dict() for s in self.springs],
            "workshop": self.workshop.to_dict(),
            **({"tolerances": dict(self.tolerances)} if self.tolerances else {}),
            **({"builds": dict(self.builds)} if self.builds else {}),
            **({"adjustment": dict(self.adjustments)} if self.adjustments else {}),
            **({"cable": self.cable.to_dict()} if self.cable is not None else {}),
            **({"friction": self.friction.to_dict()} if self.friction is not None else {}),
        }
