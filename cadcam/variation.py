"""How a build varies from its design, declared once for the re-check's band and builds
(:mod:`cadcam.verify.tolerance`, :mod:`cadcam.verify.builds`) and the NLP's robust objective
(:mod:`cadcam.solve.robust`): where each parameter sits in p = [c; k; x₀; F0; q]
(:class:`Layout`), the step of p each tolerance allows (:func:`directions`), the draws of
builds within them (:func:`draws`) and the settings of the adjustment the builder makes after
the build (:func:`settings`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .problem import TOLERANCES, Problem


class Layout:
    """Where c, k, x₀, F0 and q sit in the parameter vector P of
    :func:`cadcam.verify.model.parameter_model`, and the design's values P₀."""

    def __init__(self, problem: Problem, design):
        S = len(problem.springs)
        sizes = [sum(b.size for b in design.bases), S, S, S,
                 sum(len(mech.parameters) for mech in problem.mechanisms)]
        self.start = dict(zip(("c", "k", "x0", "F0", "q"), np.cumsum([0, *sizes[:-1]])))
        self.size = int(sum(sizes))
        springs = problem.spring_parameters()
        self.nominal = np.concatenate([np.concatenate(design.coefficients), springs.rate, design.preextension,
                                       springs.preload,
                                       [v for mech in problem.mechanisms for v in mech.parameter_values()]])

    def split(self, values: np.ndarray) -> list[np.ndarray]:
        """``values`` (P) cut into the model's inputs c, k, x₀, F0, q."""
        return np.split(values, list(self.start.values())[1:])

    def step(self, index: int, value: float) -> np.ndarray:
        """A step of ``value`` in parameter ``index`` alone."""
        out = np.zeros(self.size)
        out[index] = value
        return out


def joint_scale(problem: Problem, i: int, tau_d: np.ndarray) -> float:
    """Joint ``i``'s scale [N·m], of which a build's torque error is a share: its target's peak
    |τ_d| over the samples ``tau_d``, or its torque floor where that is larger (a vanishing
    target); NaN for a joint without a torque goal."""
    if problem.joints[i].target.kind == "none":
        return np.nan
    return max(float(np.abs(tau_d).max()), problem.torque_floor(i))


#: The tolerances whose parts step p; the friction coefficient's moves no parameter of p but the
#: friction band's centre (:func:`friction_parts`).
STEPPED = tuple(key for key in TOLERANCES if key != "friction")


def directions(problem: Problem, bases, layout: Layout) -> tuple[dict, dict]:
    """For each tolerance of :data:`STEPPED`, the parameter steps it allows (P × steps): one
    column per spring, placed parameter or profile (``bases``: the design's), each its Δp; and
    each column's part in words."""
    tol = problem.tolerance
    cols: dict[str, list] = {key: [] for key in STEPPED}
    labels: dict[str, list] = {key: [] for key in STEPPED}

    def add(key: str, label: str, column: np.ndarray) -> None:
        cols[key].append(column)
        labels[key].append(label)
    for j, spring in enumerate(problem.springs):
        add("rate", f"{spring.name}'s rate", layout.step(layout.start["k"] + j, tol["rate"] * spring.rate))
        add("preload", f"{spring.name}'s preload", layout.step(layout.start["F0"] + j, tol["preload"] * spring.preload))
        add("placement", f"{spring.name}'s pre-extension", layout.step(layout.start["x0"] + j, tol["placement"]))
    first = layout.start["q"]
    for mech in problem.mechanisms:
        steps = mech.placement_steps(tol["placement"])
        for index, (quantity, step) in enumerate(zip(mech.parameters, steps)):
            if quantity.placed:
                add("placement", f"{mech.name}'s {quantity.name}", layout.step(first + index, step))
        first += len(mech.parameters)
    start = layout.start["c"]
    for k, basis in enumerate(bases):  # a uniform offset of ρ, in the profile's basis
        offset = np.zeros(layout.size)
        offset[start:start + basis.size] = basis.offset(tol["profile"])
        add("profile", f"cam {k + 1}'s offset", offset)
        start += basis.size
    return ({key: np.stack(c, axis=1) if c else np.zeros((layout.size, 0)) for key, c in cols.items()}, labels)


def friction_parts(problem: Problem) -> list:
    """The parts the ``friction`` tolerance draws, each its own: the guides and the idlers of
    ``[friction]``, whose coefficients move the friction band's centre (a joint bearing's
    friction widens the band about it and moves no torque)."""
    friction = problem.friction
    return [] if friction is None else [*friction.guides, *friction.idlers]


def draws(seed, count: int, columns: int, distribution: str) -> np.ndarray:
    """``count`` builds' draws (columns × count), each in [−1, 1], a share of its step:
    :data:`cadcam.problem.DISTRIBUTIONS`'s ``uniform``, or ``normal`` with σ = 1/3 cut at ±1
    (drawn by the inverse of its distribution function over the kept share). ``seed``: an
    integer, or a tuple of them (a stream of its own, as the robust objective's scenarios)."""
    rng = np.random.default_rng(seed)
    if distribution == "uniform":
        return rng.uniform(-1.0, 1.0, (columns, count))
    from scipy.special import ndtr, ndtri

    cut = ndtr(-3.0)
    return ndtri(rng.uniform(cut, 1.0 - cut, (columns, count))) / 3.0


@dataclass(frozen=True)
class Setting:
    """One thing the builder sets: a parameter of p (:func:`cadcam.verify.model.parameter_model`)
    and its range.

    Attributes
    ----------
    kind : str
        ``screw`` (a spring's tensioning screw) or ``slot`` (a mechanism's).
    number : int
        Its spring's or mechanism's number (1-based).
    index : int
        Its parameter's index in p.
    per_metre : float
        The parameter's change per metre of the setting's travel [SI/m]: 1 for a length, 1/arm
        for an angle.
    travel : float
        ± its range [m].
    what : str
        What it moves, and which way is +.
    parameter : str
        A slot's parameter, by its mechanism's name for it (empty for a screw).
    """

    kind: str
    number: int
    index: int
    per_metre: float
    travel: float
    what: str
    parameter: str = ""

    @property
    def name(self) -> str:
        """``screw 1``, ``slot 2``."""
        return f"{self.kind} {self.number}"

    @property
    def screw(self) -> bool:
        """Whether it is a tensioning screw (else a slot)."""
        return self.kind == "screw"

    @property
    def bound(self) -> float:
        """± its range in its parameter's units."""
        return self.travel * self.per_metre


def settings(problem: Problem, layout: Layout) -> list[Setting]:
    """The ``[adjustment]`` of ``problem`` as settings: a screw per spring, a slot per mechanism
    that places the ``slot`` parameter; none where their travel is 0."""
    adjust, out = problem.adjustment, []
    if adjust["preload_travel"] > 0:
        out += [Setting("screw", j + 1, int(layout.start["x0"]) + j, 1.0, adjust["preload_travel"],
                        f"{spring.name}'s pre-extension, its extension at the reference angle (+: longer)")
                for j, spring in enumerate(problem.springs)]
    first = int(layout.start["q"])
    for u, mech in enumerate(problem.mechanisms):
        names = list(mech.parameter_names)
        if adjust["slot"] in names and adjust["slot_travel"] > 0:
            at = names.index(adjust["slot"])
            quantity = mech.parameters[at]
            out.append(Setting("slot", u + 1, first + at, float(mech.placement_steps(1.0)[at]),
                               adjust["slot_travel"], f"{mech.name}'s {quantity.name}, {quantity.description} "
                               f"(+: larger)", quantity.name))
        first += len(names)
    return out
