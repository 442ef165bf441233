"""Quadrature rules: Gauss–Legendre on [0, 1] and the trapezoidal rule on given nodes."""
from __future__ import annotations

from functools import lru_cache

import casadi as ca
import numpy as np


@lru_cache(maxsize=None)
def gauss_legendre(order: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of the ``order``-point Gauss–Legendre rule on [0, 1]."""
    x, w = np.polynomial.legendre.leggauss(order)
    return (x + 1) / 2, w / 2


def trapezoid_weights(x: np.ndarray) -> np.ndarray:
    """Weights of the trapezoidal rule on the nodes ``x``."""
    w = np.zeros_like(x)
    h = np.diff(x)
    w[:-1] += h / 2
    w[1:] += h / 2
    return w


def trapezoid_weights_sx(x):
    """Trapezoidal weights (row vector) on symbolic nodes ``x`` (a column)."""
    n = x.shape[0]
    h = x[1:] - x[:-1]
    w = ca.vertcat(h[0] / 2, (h[:-1] + h[1:]) / 2, h[n - 2] / 2) if n > 2 else ca.vertcat(h / 2, h / 2)
    return w.T
