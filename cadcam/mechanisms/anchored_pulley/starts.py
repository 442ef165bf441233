"""Starts of the anchored-spring pulley for the design NLP: Kim & Deshpande's closed form
(Ludovico2021 Sec. II) fitted in the profile's basis."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...physics.profile import fit_profile
from .kim_deshpande import closed_form
from .model import AnchoredPulley


def closed_form_start(problem, start, shares=None, samples: int = 400):
    """A start from Kim & Deshpande's closed form (Ludovico2021 Sec. II): each anchored-spring
    pulley shaped for its share of its joint's torque, fitted in its basis; other profiles
    keep their shape in ``start``.

    Parameters
    ----------
    problem : cadcam.problem.Problem
        Every anchored pulley needs a spring of its own on its ``cable`` port; its fixed
        pre-extension (else 10 % of travel) is the extension u₀ at its reference angle.
    start : cadcam.designs.Design
        The start the other profiles and the pre-extensions are taken from
        (:func:`cadcam.designs.default_start`).
    shares : dict, optional
        Mechanism index → callable θ [rad] → that pulley's torque ∂V_u/∂θ [N·m] (cadcam's
        sign); by default a pulley alone on its joint takes the joint's whole target (a target
        of that joint's angle only).
    samples : int
        Joint angles at which the closed form is evaluated and fitted.

    Returns
    -------
    cadcam.designs.Design
        The fitted profiles; where the closed form is infeasible (a cusp, a non-regular point)
        the fit is only a start, which the NLP then corrects.
    """
    coefs = list(start.coefficients)
    slices = problem.profile_slices()
    for u, mech in enumerate(problem.mechanisms):
        if not isinstance(mech, AnchoredPulley):
            continue
        joint = problem.joints[mech.joint]
        share = (shares or {}).get(u)
        if share is None:
            if sum(m.joint == mech.joint for m in problem.mechanisms) > 1:
                raise ValueError(f"mechanism {mech.name!r} shares its joint: give its torque share")
            share = own_target(problem, mech.joint)
        spring, u0 = own_spring(problem, u)
        ell, chi0, sigma = mech.parameter_values()[:3]
        theta = np.linspace(*joint.theta_range, samples)
        form = closed_form(lambda th, f=share: sigma * f(th), theta, mech.reference_angle,
                           spring.rate, u0, ell, spring.preload, chi0)
        k = slices[u].start
        coefs[k] = fit_profile(problem.profiles[k].basis, *uniform_polar(form.envelope, samples))
    return replace(start, coefficients=coefs, poses=None)  # new profiles: their poses are not known


def own_spring(problem, u: int):
    """(spring, u₀) of anchored pulley ``u``: the one spring on its ``cable`` port alone, and
    its fixed pre-extension (else 10 % of travel) [m], the extension at the pulley's reference
    angle; ValueError if it has none of its own."""
    own = [s for s in problem.springs if [(p.mechanism, p.name) for p in s.ports] == [(u, "cable")]]
    if len(own) != 1:
        raise ValueError(f"mechanism {problem.mechanisms[u].name!r} needs one spring of its own on its cable port")
    spring = own[0]
    return spring, spring.preextension if spring.preextension is not None else 0.1 * spring.travel


def own_target(problem, i: int):
    """Joint ``i``'s target as a vectorised callable of its own angle [rad] (the others at 0:
    for targets that depend on their own joint's angle only)."""
    f = problem.joints[i].target.function(len(problem.joints), i)

    def target(theta):
        theta = np.asarray(theta, dtype=float)
        angles = np.zeros((len(problem.joints), theta.size))
        angles[i] = theta.ravel()
        return np.asarray(f.map(theta.size)(angles)).reshape(theta.shape)
    return target


def uniform_polar(env, samples: int):
    """The envelope's polar samples (φ, ρ) resampled uniformly in φ (the departure point can
    sweep fast where the moment arm changes fast), continued linearly down to the anchor
    φ = 0 (a convex continuation: ρ″ = 0)."""
    order = np.argsort(env.phi_polar)
    phi, rho = env.phi_polar[order], env.rho[order]
    lo = max(phi[0], 0.0)
    grid = np.linspace(lo, phi[-1], samples)
    values = np.interp(grid, phi, rho)
    slope = (values[1] - values[0]) / (grid[1] - grid[0])
    head = np.linspace(0.0, lo, max(int(samples * lo / (phi[-1] - lo + 1e-12)), 2), endpoint=False)
    return np.concatenate([head, grid]), np.concatenate([values[0] + slope * (head - lo), values])
