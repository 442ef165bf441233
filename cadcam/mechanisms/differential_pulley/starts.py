"""The start of a differential pair for the design NLP: Fedorov's envelope pulleys
(Fedorov2018 Sec. 2.2), which also fix the pair's cable length."""
from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np

from ...errors import SpecError
from .fedorov_envelope import cable_lengths, differential_envelopes, fit_pulley


def envelope_start(kind, problem, design, samples: int = 2001):
    """Fedorov's envelope pulleys (Fedorov2018 Sec. 2.2) as the start of every differential pair
    (a mechanism of ``kind``) without a ``cable_length``: shaped for its output law (or, without one, circles at its
    start distance), transferring cable at its rolling radius
    (:meth:`~cadcam.mechanisms.differential_pulley.model.DifferentialPulley.start_radius`).

    Returns the problem with those pairs' anchor angles and cable lengths set from the start
    (the NLP then keeps the cable length) and ``design`` with their profiles replaced.
    """
    mechanisms, coefs = list(problem.mechanisms), list(design.coefficients)
    for u, (mech, sl) in enumerate(zip(problem.mechanisms, problem.profile_slices())):
        if not isinstance(mech, kind) or mech.cable_length > 0:
            continue
        theta = np.linspace(*problem.joints[mech.joint].theta_range, samples)
        x, dx = _law(mech, theta)
        _check_law_in_slider_range(mech, x)
        try:
            mech, envs = differential_envelopes(mech, theta, x, dx, mech.start_radius(mech.profiles[0]))
            fitted = [fit_pulley(p.basis, env) for p, env in zip(mech.profiles, envs)]
            length = _reference_length(mech, fitted, theta, x, envs)
        except (ValueError, RuntimeError) as exc:  # RuntimeError: no pose where the cable touches both
            reason = str(exc).splitlines()[0] if isinstance(exc, ValueError) else "no cable touches the fitted pulleys"
            raise SpecError(f"mechanism {mech.name!r}: Fedorov's envelope method finds no start for its "
                            f"output law ({reason}); change the output law, the rolling radius or the "
                            "idler's slider range") from None
        mechanisms[u] = replace(mech, cable_length=length)
        coefs[sl] = fitted
    return (replace(problem, mechanisms=tuple(mechanisms)),
            replace(design, coefficients=coefs, poses=None))  # new profiles: their poses are not known


def _reference_length(mech, fitted, theta: np.ndarray, x: np.ndarray, envs) -> float:
    """The cable length [m] of the fitted pulleys ``fitted`` at the pose nearest the pair's
    reference angle where Newton, started from the envelopes' departure angles, reaches both
    tangencies (:func:`.fedorov_envelope.cable_lengths`): a fitted pulley is a little off its
    envelope, which can leave Newton no root near its start at one pose and not at the next.
    RuntimeError where it reaches them at no pose."""
    alpha0 = np.vstack([env.phi_polar for env in envs])
    k = int(np.argmin(np.abs(theta - mech.reference_angle)))
    at_reference = cable_lengths(mech, fitted, theta[k], x[k], alpha0[:, k])[0]
    if np.isfinite(at_reference):  # the usual case, one Newton solve
        return float(at_reference)
    lengths = cable_lengths(mech, fitted, theta, x, alpha0)
    found = np.flatnonzero(np.isfinite(lengths))
    if not found.size:
        raise RuntimeError("no pose where the cable touches both fitted pulleys")
    return float(lengths[found[np.argmin(np.abs(theta[found] - mech.reference_angle))]])


def _check_law_in_slider_range(mech, x: np.ndarray) -> None:
    """SpecError, before any work, when the output law ``x`` [m] leaves the idler's slider."""
    lo, hi = mech.slider_range
    if x.min() < lo or x.max() > hi:
        raise SpecError(f"mechanism {mech.name!r}: its output law moves the idler over "
                        f"{1e3 * x.min():.4g} … {1e3 * x.max():.4g} mm, outside its slider_range "
                        f"[{1e3 * lo:.4g}, {1e3 * hi:.4g}] mm; change the law (its mass, springs or "
                        "slider_zero) or widen the slider range")


def _law(mech, theta: np.ndarray):
    """x(θ) [m] and dx/dθ [m/rad] of a pair's output law (constant without one)."""
    if mech.output_target is None:
        return np.full_like(theta, mech.slider_start()), np.zeros_like(theta)
    t = ca.SX.sym("theta")
    x = mech.output_target.expression([t], 0)
    f = ca.Function("law", [t], [x, ca.jacobian(x, t)]).map(theta.size)
    return tuple(np.asarray(v).ravel() for v in f(theta))
