"""A design: the coefficients of every profile and one pre-extension per spring (Johnston2023,
Eq. 46–47). In JSON the profiles are ``cams`` (the name cadcam has always used), in the order of
the problem's mechanisms."""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass

import numpy as np

from .files import short_repr
from .problem import Problem
from .physics.profile import Basis, monomial_from_highest_first


#: Most coefficients a design's profile may have (Chebyshev degree 40; the spec's cap).
MAX_COEFFICIENTS = 41
#: Largest |end| of a profile's design interval [rad]: a spec's joint angles lie within ten turns
#: (:data:`cadcam.spec.MAX_JOINT_SPAN_DEG`) and a profile's interval reaches a quarter turn beyond.
MAX_DOMAIN = 20.5 * math.pi


class DesignError(ValueError):
    """A design that does not fit its problem; the message is one line."""


@dataclass
class Design:
    """Profiles and pre-extensions.

    Attributes
    ----------
    bases : list of Basis
    coefficients : list of ndarray
        ρ coefficients of each profile in its basis [m].
    preextension : ndarray
        x₀ of each spring at θ = 0 [m].
    """

    bases: list[Basis]
    coefficients: list[np.ndarray]
    preextension: np.ndarray

    def monomial(self, i: int) -> np.ndarray:
        """Cam ``i``'s ρ coefficients in increasing powers of φ [m·rad⁻ᵏ]."""
        return self.bases[i].to_monomial(self.coefficients[i])

    def to_dict(self) -> dict:
        """The ``design`` member of a result JSON."""
        cams = []
        for i, b in enumerate(self.bases):
            m = self.monomial(i)
            cams.append({"basis": b.name, "order": b.order, "domain": list(b.domain),
                         "coefficients": [float(v) for v in self.coefficients[i]],
                         "monomial_coefficients": [float(v) for v in m],
                         "monomial_coefficients_highest_first": [float(v) for v in m[::-1]]})
        return {"cams": cams, "preextension": [float(v) for v in self.preextension]}

    @classmethod
    def from_dict(cls, data: dict, problem: Problem, origin: str = "<design>") -> "Design":
        """Read a design for ``problem``.

        Each cam gives ``basis`` + ``coefficients`` (+ ``domain`` for Chebyshev), or only
        ``monomial_coefficients`` (increasing powers) or ``monomial_coefficients_highest_first``
        (the papers' order); any polynomial degree is accepted. ``preextension`` lists one
        value per spring [m].
        """
        if isinstance(data, dict) and "design" in data:
            data = data["design"]
        if not isinstance(data, dict) or not isinstance(data.get("cams"), list):
            raise DesignError(f"{origin}: expected a JSON object with design.cams (a list) and "
                              "design.preextension")
        profiles = problem.profiles
        if len(data["cams"]) != len(profiles):
            raise DesignError(f"{origin}: design.cams has {len(data['cams'])} entries; the "
                              f"problem has {len(profiles)} profiles")
        bases, coefs = [], []
        for i, cam in enumerate(data["cams"]):
            where = f"{origin}: design.cams[{i + 1}]"
            if not isinstance(cam, dict):
                raise DesignError(f"{where}: expected a JSON object with basis and coefficients")
            if "coefficients" in cam and cam.get("basis") in ("monomial", "chebyshev"):
                c = _numbers(cam["coefficients"], f"{where}: coefficients", "[m]")
                dom = cam.get("domain", list(profiles[i].basis.domain))
                if not (isinstance(dom, (list, tuple)) and len(dom) == 2 and all(map(_is_number, dom))
                        and -MAX_DOMAIN <= float(dom[0]) < float(dom[1]) <= MAX_DOMAIN):
                    raise DesignError(f"{where}: domain must be [lo, hi] with hi > lo [rad], both within "
                                      f"±{MAX_DOMAIN:.4g} rad (ten turns and a quarter); got {short_repr(dom)}")
                b = Basis(cam["basis"], c.size - 1, (float(dom[0]), float(dom[1])))
            elif "monomial_coefficients" in cam:
                c = _numbers(cam["monomial_coefficients"], f"{where}: monomial_coefficients", "[m·rad⁻ᵏ]")
                b = Basis("monomial", c.size - 1, profiles[i].basis.domain)
            elif "monomial_coefficients_highest_first" in cam:
                c = monomial_from_highest_first(_numbers(
                    cam["monomial_coefficients_highest_first"],
                    f"{where}: monomial_coefficients_highest_first", "[m·rad⁻ᵏ]"))
                b = Basis("monomial", c.size - 1, profiles[i].basis.domain)
            else:
                raise DesignError(f"{where}: give basis + coefficients, "
                                  "monomial_coefficients or monomial_coefficients_highest_first")
            if c.size > MAX_COEFFICIENTS:
                raise DesignError(f"{where}: {c.size} coefficients; the cap is {MAX_COEFFICIENTS} "
                                  "(degree 40, cadcam.designs.MAX_COEFFICIENTS)")
            bases.append(b)
            coefs.append(c)
        x0 = data.get("preextension")
        if not (isinstance(x0, list) and len(x0) == len(problem.springs) and all(map(_is_number, x0))):
            raise DesignError(f"{origin}: design.preextension must hold {len(problem.springs)} finite "
                              f"numbers [m], one per spring; got {short_repr(x0)}")
        return cls(bases, coefs, np.asarray(x0, dtype=float))


def _is_number(v) -> bool:
    """A finite JSON number that fits a float (not a boolean, not a string of digits)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool) and abs(v) <= sys.float_info.max


def _numbers(value, where: str, unit: str) -> np.ndarray:
    """``value`` as an array if it is a non-empty list of finite numbers; else one line."""
    if not (isinstance(value, list) and value and all(map(_is_number, value))):
        raise DesignError(f"{where} must be a non-empty list of finite numbers {unit}; got {short_repr(value)}")
    return np.asarray(value, dtype=float)


def default_start(problem: Problem) -> Design:
    """Circular profiles of each mechanism's start radius
    (:meth:`cadcam.mechanisms.base.Mechanism.start_radius`) and pre-extensions at 10 % of travel
    (or the spring's fixed pre-extension)."""
    bases, coefs = [], []
    for mech in problem.mechanisms:
        for prof in mech.profiles:
            m = np.zeros(prof.basis.size)
            m[0] = mech.start_radius(prof)
            bases.append(prof.basis)
            coefs.append(prof.basis.from_monomial(m))
    return Design(bases, coefs, preextensions(problem, lambda s: 0.1 * s.travel))


def preextensions(problem: Problem, free) -> np.ndarray:
    """Each spring's fixed pre-extension, or ``free(spring)`` where it is a design variable."""
    return np.array([free(s) if s.preextension is None else s.preextension for s in problem.springs])
