"""A design: the coefficients of every profile and one pre-extension per spring (Johnston2023,
Eq. 46–47). In JSON the profiles are ``cams`` (the name cadcam has always used), in the order of
the problem's mechanisms."""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field

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
    poses : list of (ndarray, ndarray), optional
        Per mechanism, the departure unknowns the design was checked at: the angles θ [rad]
        (increasing: its joint's design grid and its reference angle) and z (unknowns × angles,
        SI). A design run keeps them, so that re-evaluating the design starts its rootfinder
        where the run's converged (:func:`cadcam.verify.evaluate.evaluate`) and finds the same
        roots: from the closed-form guess alone it can land on another branch (Endo2010's
        five-bar arm's second pulley). None: not known.
    """

    bases: list[Basis]
    coefficients: list[np.ndarray]
    preextension: np.ndarray
    poses: list | None = field(default=None, repr=False)

    def monomial(self, i: int) -> np.ndarray:
        """Cam ``i``'s ρ coefficients in increasing powers of φ [m·rad⁻ᵏ]."""
        return self.bases[i].to_monomial(self.coefficients[i])

    def in_bases(self, bases) -> "Design":
        """This design with each profile's coefficients in ``bases`` (:meth:`Basis.converted`:
        exact where a basis's degree is at least the profile's, else a least-squares fit), as
        a start for a problem whose profiles have those bases."""
        bases = list(bases)
        if bases == self.bases:
            return self
        return Design(bases, [b.converted(c, s) for b, c, s in zip(bases, self.coefficients, self.bases)],
                      self.preextension, self.poses)

    def to_dict(self) -> dict:
        """The ``design`` member of a result JSON."""
        cams = []
        for i, b in enumerate(self.bases):
            m = self.monomial(i)
            cams.append({"basis": b.name, "order": b.order, "domain": list(b.domain),
                         "coefficients": [float(v) for v in self.coefficients[i]],
                         "monomial_coefficients": [float(v) for v in m],
                         "monomial_coefficients_highest_first": [float(v) for v in m[::-1]]})
        out = {"cams": cams, "preextension": [float(v) for v in self.preextension]}
        if self.poses is not None:
            out["poses"] = [{"theta": [float(v) for v in theta], "z": np.asarray(z, dtype=float).tolist()}
                            for theta, z in self.poses]
        return out

    @classmethod
    def from_dict(cls, data: dict, problem: Problem, origin: str = "<design>") -> "Design":
        """Read a design for ``problem``.

        Each cam gives ``basis`` + ``coefficients`` (+ ``domain`` for Chebyshev), or only
        ``monomial_coefficients`` (increasing powers) or ``monomial_coefficients_highest_first``
        (the papers' order); any polynomial degree is accepted. ``preextension`` lists one
        value per spring [m]; ``poses`` (optional, as a design run writes them) per mechanism
        ``theta`` [rad] (increasing) and ``z`` (one row per unknown).
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
        poses = None if data.get("poses") is None else _poses(data["poses"], problem, origin)
        return cls(bases, coefs, np.asarray(x0, dtype=float), poses)


def _poses(data, problem: Problem, origin: str) -> list:
    """``design.poses`` read for ``problem``'s mechanisms; DesignError (one line) if malformed."""
    form = ("one entry per mechanism, each {theta: [increasing angles, rad], z: [one list per "
            "unknown, as long as theta]}")
    if not (isinstance(data, list) and len(data) == len(problem.mechanisms)):
        raise DesignError(f"{origin}: design.poses must hold {form}; got {short_repr(data)}")
    out = []
    for u, (entry, mech) in enumerate(zip(data, problem.mechanisms)):
        where = f"{origin}: design.poses[{u + 1}]"
        if not (isinstance(entry, dict) and isinstance(entry.get("z"), list)
                and len(entry["z"]) == len(mech.unknowns)):
            raise DesignError(f"{where} must be {{theta, z}} with {len(mech.unknowns)} rows of z "
                              f"({', '.join(mech.unknowns)}); got {short_repr(entry)}")
        theta = _numbers(entry.get("theta"), f"{where}.theta", "[rad]")
        if not np.all(np.diff(theta) > 0):
            raise DesignError(f"{where}.theta must increase; got {short_repr(entry['theta'])}")
        if not all(isinstance(row, list) and len(row) == theta.size for row in entry["z"]):
            raise DesignError(f"{where}.z must hold rows of {theta.size} numbers, as many as theta; "
                              f"got {short_repr(entry['z'])}")
        z = np.vstack([_numbers(row, f"{where}.z", "(SI)") for row in entry["z"]])
        out.append((theta, z))
    return out


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
