"""The re-check's minima refined in step (:func:`cadcam.verify.evaluate._refine_mins`): each
level's angles of several minima in one call of the profile, the same minima as refined one at a
time (:func:`_refine_min`, each its own calls), a quantity that is not finite left NaN."""
import numpy as np

from cadcam.physics.mapped import mapped
from cadcam.physics.profile import Basis, profile_function
from cadcam.verify.evaluate import REFINE_LEVELS, _profile_extremes, _refine_min, _refine_mins


class Calls:
    """The profile function mapped over as many angles as it is given, its calls counted."""

    def __init__(self, prof):
        self.prof, self.calls = prof, 0

    def __call__(self, p, c):
        self.calls += 1
        return mapped(self.prof, p.size)(p, c)


def test_minima_refined_in_step_are_those_refined_one_at_a_time():
    basis = Basis("chebyshev", 5, (0.0, 6.0))
    prof = profile_function(basis)
    rng = np.random.default_rng(7)
    for _ in range(5):
        c = np.r_[0.03, rng.normal(0.0, 0.004, 5)]
        phi = np.linspace(0.0, rng.uniform(1.0, 6.0), 500)
        rho, _, _, conv = (np.asarray(v).ravel() for v in mapped(prof, phi.size)(phi, c))
        wanted = [(conv, 3, 1.0), (rho, 0, 1.0), (-rho, 0, -1.0)]
        apart, together = Calls(prof), Calls(prof)
        one_by_one = [_refine_min(apart, c, phi, *w) for w in wanted]
        assert _refine_mins(together, c, phi, wanted) == one_by_one
        assert (apart.calls, together.calls) == (3 * REFINE_LEVELS, REFINE_LEVELS)
        # and the re-check's own scan gives them
        scan = _profile_extremes(basis, c, float(phi[-1]), phi.size)
        assert [scan[3], scan[4], -scan[5]] == one_by_one


def test_a_quantity_not_finite_is_nan_and_the_others_are_refined_as_alone():
    phi = np.linspace(0.0, 1.0, 11)
    local = lambda p, c: [np.abs(p - 0.123456789), (p - 0.7) ** 2]  # noqa: E731 — two outputs, mapped
    bad = np.where(phi > 0.5, np.nan, phi)
    out = _refine_mins(local, None, phi, [(np.abs(phi - 0.123456789), 0, 1.0), (bad, 1, 1.0), ((phi - 0.7) ** 2, 1, 1.0)])
    assert np.isnan(out[1])
    assert out[0] == _refine_min(local, None, phi, np.abs(phi - 0.123456789), 0)
    assert out[2] == _refine_min(local, None, phi, (phi - 0.7) ** 2, 1)
    assert 0.0 <= out[0] < 1e-11 and 0.0 <= out[2] < 1e-11
