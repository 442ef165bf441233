"""Automatic derivatives against finite differences, as a table (the habit of OpenMDAO's
``check_partials``): for a CasADi Function, every (output, input) block of its Jacobian by
CasADi's automatic differentiation against central differences of the function itself."""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

#: Relative step of the central differences: h_j = STEP·max(|x_j|, scale of the input).
STEP = 1e-6
#: Most columns of one block differenced (a seeded sample of the columns beyond it).
MAX_COLUMNS = 400


@dataclass
class Partial:
    """One Jacobian block ∂output/∂input at one point.

    Attributes
    ----------
    of, wrt : str
        Names of the function, output and input (``"torque model: tau"``, ``"theta"``).
    shape : tuple of int
        (rows, columns checked of the input's columns).
    abs_error : float
        Frobenius norm of (automatic − finite difference) over the checked columns, in the
        output's units per input unit.
    rel_error : float
        ``abs_error`` divided by the norm of the finite-difference block (by the automatic
        block's if that is zero; 0 if both are zero).
    norm : float
        Frobenius norm of the automatic block.
    """

    of: str
    wrt: str
    shape: tuple[int, int]
    abs_error: float
    rel_error: float
    norm: float

    def passed(self, tol: float) -> bool:
        """The block agrees within ``tol`` relative error (an absolute error below
        ``tol``·1e-3 also passes: a block that is zero up to rounding)."""
        return self.rel_error <= tol or self.abs_error <= 1e-3 * tol


def compare(value, x: np.ndarray, ad: np.ndarray, of: str, wrt: str, scale: float = 1.0,
            rng: np.random.Generator | None = None) -> Partial:
    """One Jacobian block by automatic differentiation against central differences.

    Parameters
    ----------
    value : callable
        x ↦ the output as a flat array (the function whose derivative ``ad`` claims to be).
    x : ndarray
        The point, a flat array of the input.
    ad : ndarray
        The automatic Jacobian d value / d x, shape (outputs, x.size).
    of, wrt : str
        Names of the output and the input, for the table.
    scale : float
        Typical size of the input's entries: the step is :data:`STEP`·max(|x_j|, scale).
    rng : numpy.random.Generator, optional
        Picks the columns when x has more than :data:`MAX_COLUMNS` entries (default seed 0).
    """
    x = np.asarray(x, dtype=float).ravel()
    cols = np.arange(x.size)
    if x.size > MAX_COLUMNS:
        cols = np.sort((rng or np.random.default_rng(0)).choice(x.size, MAX_COLUMNS, replace=False))
    ad = np.asarray(ad, dtype=float).reshape(-1, x.size)[:, cols]
    fd = np.zeros_like(ad)
    for k, col in enumerate(cols):
        h = STEP * max(abs(x[col]), scale)
        plus, minus = x.copy(), x.copy()
        plus[col] += h
        minus[col] -= h
        fd[:, k] = (np.ravel(value(plus)) - np.ravel(value(minus))) / (2 * h)
    err = float(np.linalg.norm(ad - fd))
    ref = float(np.linalg.norm(fd)) or float(np.linalg.norm(ad))
    return Partial(of, wrt, (ad.shape[0], cols.size), err, err / ref if ref > 0 else 0.0,
                   float(np.linalg.norm(ad)))


def function_partials(f: ca.Function, point: dict, outputs: list[str], inputs: list[str],
                      scale: dict | None = None, label: str | None = None) -> list[Partial]:
    """Every block ∂output/∂input of the CasADi Function ``f`` at ``point`` (a value per input
    name) by CasADi's automatic differentiation against central differences of ``f``;
    ``scale`` gives each input's typical size (default 1), ``label`` prefixes the output
    names (default the function's name)."""
    jac = f.factory(f"{f.name()}_jac", f.name_in(), [f"jac:{o}:{i}" for o in outputs for i in inputs])
    args = {name: np.asarray(point[name], dtype=float).ravel() for name in f.name_in()}
    blocks = jac(**args)
    rows = []
    for i in inputs:
        for o in outputs:
            def value(xi, o=o, i=i):
                return np.asarray(f(**{**args, i: xi})[o]).ravel(order="F")
            rows.append(compare(value, args[i], np.asarray(ca.densify(blocks[f"jac_{o}_{i}"])),
                                f"{label or f.name()}: {o}", i, (scale or {}).get(i, 1.0)))
    return rows


def worst(rows: list[Partial]) -> list[Partial]:
    """Per (of, wrt), the row with the largest relative error (over several points), in first
    appearance order."""
    out: dict[tuple[str, str], Partial] = {}
    for r in rows:
        key = (r.of, r.wrt)
        if key not in out or r.rel_error > out[key].rel_error:
            out[key] = r
    return list(out.values())


def table(rows: list[Partial], tol: float) -> str:
    """The blocks as a fixed-width text table, worst relative error per block, with a verdict
    column against ``tol``."""
    head = f"{'of':<34} {'wrt':<8} {'shape':>10} {'|AD|':>10} {'abs error':>10} {'rel error':>10}  check"
    lines = [head, "-" * len(head)]
    for r in rows:
        shape = f"{r.shape[0]}x{r.shape[1]}"
        lines.append(f"{r.of:<34} {r.wrt:<8} {shape:>10} {r.norm:>10.3e} {r.abs_error:>10.3e} "
                     f"{r.rel_error:>10.3e}  {'ok' if r.passed(tol) else 'FAIL'}")
    return "\n".join(lines)
