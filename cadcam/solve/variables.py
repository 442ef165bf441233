"""The NLP's containers: named blocks of symbols for its variables and its parameters
(:class:`_Vars`), its constraint rows with their bounds and the definitions of its lifted
variables (:class:`_Rows`, with the bounds of equality and margin rows), and the layout of its
parameters (:func:`_parameter_blocks`)."""
from __future__ import annotations

import casadi as ca
import numpy as np

from .blocks import block_name
from ..problem import Problem


class _Vars:
    """Named blocks of symbols, stacked into one vector in the order they were added; each
    block is a family of :mod:`cadcam.solve.blocks` and an index (``families``)."""

    def __init__(self, kind: str):
        self.kind, self.blocks, self.families, self.syms, self.size = kind, {}, {}, {}, 0

    def add(self, family: str, n: int, *index):
        """A block of ``n`` symbols of ``family`` at ``index`` (named by :func:`block_name`)."""
        name = block_name(family, index)
        self.families[name] = (family, index)
        self.blocks[name] = (self.size, n)
        self.syms[name] = ca.MX.sym(f"{self.kind}_{name}", n)
        self.size += n
        return self.syms[name]

    def __getitem__(self, name):
        return self.syms[name]

    def vector(self):
        return ca.vertcat(*self.syms.values())

    def part(self, vec, name):
        a, n = self.blocks[name]
        return np.asarray(vec).ravel()[a:a + n]

    def put(self, vec, name, value):
        a, n = self.blocks[name]
        vec[a:a + n] = value


def _equal(problem: Problem) -> tuple[float, float]:
    """Bounds of equality rows."""
    return 0.0, 0.0


def _nonnegative(problem: Problem) -> tuple[float, float]:
    """Bounds of rows that are margins, met when ≥ 0."""
    return 0.0, np.inf


class _Rows:
    """The NLP's constraint rows in the order they were added, with their bounds, and the
    definitions of the lifted variables (in the order they were lifted).

    Parameters
    ----------
    v : _Vars
        The decision variables, to which :meth:`lift` adds.
    """

    def __init__(self, v: _Vars):
        self.v, self.g, self.bounds, self.lifted = v, [], [], []
        self.deferred_g, self.deferred_bounds = [], []
        self.epigraphs = []  # (block name, its rows' largest |error|) of each epigraph variable

    def constrain(self, expr, bounds, deferred: bool = False):
        """Add constraint rows; ``bounds(problem) -> (lo, hi)`` gives their numbers at
        solve time, so limits change between cases without a rebuild. ``deferred`` rows are
        imposed only where the optimum without them breaks them
        (:meth:`cadcam.solve.transcription.Transcription.solve`)."""
        (self.deferred_g if deferred else self.g).append(expr)
        (self.deferred_bounds if deferred else self.bounds).append((expr.shape[0], bounds))

    def epigraph(self, family: str, err, *index):
        """A new variable of ``family`` at ``index`` bounding the column ``err`` from above in
        absolute value (a minimax objective's epigraph: t − err ≥ 0 and t + err ≥ 0), kept in
        :attr:`epigraphs` with the largest |err|, where a start may meet its rows
        (:meth:`cadcam.solve.transcription.Transcription.epigraphs_met`). Returns it."""
        t = self.v.add(family, 1, *index)
        self.constrain(ca.vertcat(t - err, t + err), _nonnegative)
        self.epigraphs.append((block_name(family, index), ca.mmax(ca.fabs(err))))
        return t

    def tie(self, family: str, row_of, start, scale, *index):
        """A new variable of ``family`` at ``index`` defined implicitly, by the rows
        ``row_of(value) = 0`` (``value``: the variable in its units), where solving for it
        outright would put a dense expression in the NLP; ``start`` is its value at the start
        (the solution of the rows, or near it). Returns it in its units, ``scale`` (a number
        or a column) times the variable."""
        var = self.v.add(family, start.shape[0], *index)
        self.constrain(row_of(scale * var), _equal)
        self.lifted.append((block_name(family, index), start / scale))
        return scale * var

    def lift(self, family: str, expr, scale: float, *index):
        """A new variable of ``family`` at ``index`` tied to ``expr`` by an equality: keeps the
        Hessian sparse where ``expr`` would couple many variables through a large graph.
        Returns it in ``expr``'s units (the variable is ``expr / scale``)."""
        var = self.v.add(family, expr.shape[0], *index)
        name = block_name(family, index)
        self.constrain(var - expr / scale, _equal)
        self.lifted.append((name, expr / scale))
        return scale * var


def _parameter_blocks(problem: Problem) -> _Vars:
    """The NLP's parameters, in the order :meth:`cadcam.solve.transcription.Transcription.parameters`
    fills them: per joint its grid, weights and target marginals, per mechanism its numbers q
    and output law, the springs' rates and preloads and the objective's scale, and where a joint
    weighs its tolerance band, the band's weights and steps (the curvature limits ``rc``
    follow, added by :func:`cadcam.solve.rows._profile_rows`)."""
    opt, m, S = problem.options, len(problem.joints), len(problem.springs)
    n = opt.grid
    p = _Vars("p")
    for i in range(m):
        for name, size in (("theta", n), ("weights", 1), ("wsens", S), ("rt", n), ("td2", 1)):
            p.add(name, size, i)
        if opt.objective in ("minimax", "robust"):
            p.add("td", n, i)
        for c in range(m):
            if c != i:
                p.add("Mt", n * n, i, c)
    for u, mech in enumerate(problem.mechanisms):
        p.add("q", len(mech.parameter_names), u)
        if mech.output_target is not None:  # the output law's samples and scale
            p.add("xd", n, u)
            p.add("xs", 1, u)
    p.add("k", S)
    p.add("F0", S)
    p.add("obj_scale", 1)
    if any(c.band_weight > 0 for c in problem.joints):  # the band's weights and steps
        for i, c in enumerate(problem.joints):
            if c.band_weight > 0:
                p.add("wband", 1, i)
        p.add("dk", S)
        p.add("dF", S)
        for u, mech in enumerate(problem.mechanisms):
            p.add("dq", len(mech.parameter_names), u)
        p.add("tol", 2)
    return p
