"""The exact conversions between profile bases are made once per profile
(:func:`cadcam.physics.profile._exactly_converted`) and handed out as copies."""
import numpy as np
from numpy.polynomial import Chebyshev, Polynomial

from cadcam.physics.profile import Basis


def test_a_kept_conversion_is_numpys_and_is_not_changed_by_its_caller():
    basis = Basis("chebyshev", 5, (0.0, 4.0))
    m = np.array([0.04, 0.01, -0.002, 3e-4, 0.0, 1e-5])
    expected = Polynomial(m).convert(kind=Chebyshev, domain=[0.0, 4.0]).coef
    first = basis.from_monomial(m)
    np.testing.assert_array_equal(first, expected)
    first[:] = 0.0  # a caller's change of its copy
    np.testing.assert_array_equal(basis.from_monomial(m), expected)
