"""A design: the coefficients of every profile and one pre-extension per spring (Johnston2023,
Eq. 46–47). In JSON the profiles are ``cams`` (the name cadcam has always used), in the order of
the problem's mechanisms."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .problem import Problem
from .physics.profile import Basis, monomial_from_highest_first


#: Most coefficients a design's profile may have (Chebyshev degree 40; the spec's cap).
MAX_COEFFICIENTS = 41


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
            try:
                if "coefficients" in cam and cam.get("basis") in ("monomial", "chebyshev"):
                    c = np.asarray(cam["coefficients"], dtype=float)
                    dom = tuple(cam.get("domain", profiles[i].basis.domain))
                    if len(dom) != 2 or not float(dom[1]) > float(dom[0]):
                        raise DesignError(f"{where}: domain must be [lo, hi] with hi > lo [rad]")
                    b = Basis(cam["basis"], c.size - 1, (float(dom[0]), float(dom[1])))
                elif "monomial_coefficients" in cam:
                    c = np.asarray(cam["monomial_coefficients"], dtype=float)
                    b = Basis("monomial", c.size - 1, profiles[i].basis.domain)
                elif "monomial_coefficients_highest_first" in cam:
                    c = monomial_from_highest_first(cam["monomial_coefficients_highest_first"])
                    b = Basis("monomial", c.size - 1, profiles[i].basis.domain)
                else:
                    raise DesignError(f"{where}: give basis + coefficients, "
                                      "monomial_coefficients or monomial_coefficients_highest_first")
            except (TypeError, ValueError) as exc:
                if isinstance(exc, DesignError):
                    raise
                raise DesignError(f"{where}: coefficients must be a list of numbers [m]") from None
            if c.ndim != 1 or c.size < 1 or not np.all(np.isfinite(c)):
                raise DesignError(f"{where}: coefficients must be a non-empty list of finite numbers [m]")
            if c.size > MAX_COEFFICIENTS:
                raise DesignError(f"{where}: {c.size} coefficients; the cap is {MAX_COEFFICIENTS} "
                                  "(degree 40, cadcam.design.MAX_COEFFICIENTS)")
            bases.append(b)
            coefs.append(c)
        try:
            x0 = np.asarray(data["preextension"], dtype=float)
        except (KeyError, TypeError, ValueError):
            raise DesignError(f"{origin}: design.preextension must be a list of numbers [m], "
                              "one per spring") from None
        if x0.shape != (len(problem.springs),) or not np.all(np.isfinite(x0)):
            raise DesignError(f"{origin}: design.preextension must hold {len(problem.springs)} "
                              "finite numbers [m], one per spring")
        return cls(bases, coefs, x0)
