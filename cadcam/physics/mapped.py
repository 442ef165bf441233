"""CasADi functions mapped over many points, each map built once; SX functions replayed on
numpy arrays (:func:`replayed`), all points at once; and functions called on numpy arrays
through CasADi's buffers (:func:`direct`)."""
from __future__ import annotations

import threading
from functools import lru_cache

import casadi as ca
import numpy as np

#: How many maps are kept (a function and a count of points each): the re-check's and a design
#: page's, whose designs evaluate the same functions on the same grids edit after edit.
KEPT_MAPS = 512


@lru_cache(maxsize=KEPT_MAPS)
def mapped(f: ca.Function, n: int) -> ca.Function:
    """``f.map(n)``, built once per function and count (a function is its own key: the cached
    functions of a structure, :func:`cadcam.mechanisms.base.pose_function` and the like). A map
    takes about half a millisecond to build, as long as evaluating a small one: a warm design of
    the 1-DOF spec built fourteen, 7 ms of its 70."""
    return f.map(n)


#: numpy's operation for each CasADi SX operation a replay (:func:`replayed`,
#: :class:`cadcam.verify.evaluate.TensorFunction`) performs on arrays: of one operand, of two,
#: and those linear in their operands (which a tensor replay keeps as sums of products).
UNARY_OPS = {ca.OP_ASSIGN: lambda a: a, ca.OP_SQ: np.square, ca.OP_INV: np.reciprocal,
             ca.OP_SQRT: np.sqrt, ca.OP_EXP: np.exp, ca.OP_LOG: np.log, ca.OP_SIN: np.sin,
             ca.OP_COS: np.cos, ca.OP_TAN: np.tan, ca.OP_ASIN: np.arcsin, ca.OP_ACOS: np.arccos,
             ca.OP_ATAN: np.arctan, ca.OP_SINH: np.sinh, ca.OP_COSH: np.cosh,
             ca.OP_TANH: np.tanh, ca.OP_ASINH: np.arcsinh, ca.OP_ACOSH: np.arccosh,
             ca.OP_ATANH: np.arctanh, ca.OP_FABS: np.abs, ca.OP_SIGN: np.sign,
             ca.OP_FLOOR: np.floor, ca.OP_CEIL: np.ceil}
BINARY_OPS = {ca.OP_DIV: np.divide, ca.OP_POW: np.power, ca.OP_CONSTPOW: np.power,
              ca.OP_ATAN2: np.arctan2, ca.OP_FMIN: np.fmin, ca.OP_FMAX: np.fmax,
              ca.OP_FMOD: np.fmod, ca.OP_COPYSIGN: np.copysign, ca.OP_HYPOT: np.hypot}
LINEAR_OPS = {ca.OP_ADD: lambda a, b: a + b, ca.OP_SUB: lambda a, b: a - b,
              ca.OP_MUL: lambda a, b: a * b, ca.OP_NEG: lambda a: -a,
              ca.OP_TWICE: lambda a: a * 2.0}
#: The operations IEEE 754 rounds exactly (arithmetic, the square root, the least and greatest
#: of two, the absolute value): a replay made of these alone (and inputs, outputs and constants)
#: gives CasADi's values to the bit, the same operations in the same order.
ARITHMETIC_OPS = frozenset((ca.OP_ADD, ca.OP_SUB, ca.OP_MUL, ca.OP_NEG, ca.OP_TWICE, ca.OP_SQ, ca.OP_DIV,
                            ca.OP_INV, ca.OP_ASSIGN, ca.OP_SQRT, ca.OP_FMIN, ca.OP_FMAX, ca.OP_FABS))
_IO = (ca.OP_CONST, ca.OP_INPUT, ca.OP_OUTPUT)
_OPS = {**UNARY_OPS, **BINARY_OPS, **LINEAR_OPS}
_TWO_OPERANDS = frozenset((*BINARY_OPS, ca.OP_ADD, ca.OP_SUB, ca.OP_MUL))
#: From this many points on a replay (:func:`replayed`) of a function of a few thousand
#: instructions (the re-check's pose of a mechanism) takes less time than its map: a replay
#: costs a numpy call per instruction, a map a call of the function per point.
REPLAY_POINTS = 200


class Replay:
    """An SX function evaluated at many points at once by performing its instructions, in its
    order, on numpy arrays that hold every point, without a call of the function per point,
    which costs more than a few instructions (the re-check's dense scan of a profile, some
    ten times faster). A function of the operations IEEE 754 rounds exactly
    (:data:`ARITHMETIC_OPS`) gives the values of :func:`mapped` to the bit (:attr:`exact`);
    with ``rounding``, one with other functions (sin, cos, atan2, …) is replayed too, its
    values then those of numpy's functions, equal to the C library's that CasADi calls to
    their rounding (on this project's machines, to the bit). Any other function, and any
    where ``rounding`` is not given, is evaluated by :func:`mapped`.

    Called as the map is (each input a column: one value, the same at every point, or its
    entries × points, a row of points for a scalar input); returns what the map returns, as
    arrays (``numpy.asarray`` of its result: rows × columns · points): a function of one output
    that output, else the list of them.
    """

    def __init__(self, f: ca.Function, rounding: bool = False):
        self.f = f
        ops = [f.instruction_id(k) for k in range(f.n_instructions())] if f.is_a("SXFunction") else None
        columns = all(f.sparsity_in(i).is_dense() and f.size2_in(i) == 1 for i in range(f.n_in()))
        known = ops is not None and columns and all(op in _OPS or op in _IO for op in ops)
        #: Whether the replay gives the map's values to the bit (else, where it replays, to rounding).
        self.exact = known and all(op in ARITHMETIC_OPS or op in _IO for op in ops)
        #: Whether the function is replayed (else mapped).
        self.replays = self.exact or (known and rounding)
        self._run = _replay_code(f, ops) if self.replays else None

    def __call__(self, *args):
        outs = self._outputs(args)
        return outs[0] if len(outs) == 1 else outs

    def _outputs(self, args) -> list[np.ndarray]:
        """Every output at the points of ``args`` (:meth:`__call__`'s)."""
        f = self.f
        n = max(np.size(a) // max(f.numel_in(i), 1) for i, a in enumerate(args))  # the points
        if not self.replays:
            return [np.asarray(v) for v in mapped(f, n).call([ca.DM(a) for a in args])]
        values = [np.asarray(a, dtype=float).reshape(f.nnz_in(i), -1) if f.nnz_in(i) else None
                  for i, a in enumerate(args)]  # an empty input has no entry to read
        out = [np.zeros((f.nnz_out(i), n)) for i in range(f.n_out())]
        with np.errstate(all="ignore"):  # a NaN or infinity where CasADi's gives one, without a warning
            self._run(values, out)
        return [self._laid_out(i, v) for i, v in enumerate(out)]

    def _laid_out(self, i: int, nonzeros: np.ndarray) -> np.ndarray:
        """Output ``i``'s ``nonzeros`` × points laid out as the map's result: the points' values
        side by side, each rows × columns (zeros where the output is structurally zero)."""
        rows, cols = self.f.size_out(i)
        n = nonzeros.shape[1]
        dense = np.zeros((rows * cols, n))
        dense[self.f.sparsity_out(i).find()] = nonzeros  # column-major entries
        return dense.reshape(cols, rows, n).transpose(1, 2, 0).reshape(rows, n * cols)


#: The operations a replay's code writes as Python's own arithmetic on arrays (the same
#: numpy operations :data:`LINEAR_OPS` and OP_ASSIGN call), by their form in the code.
_INLINE = {ca.OP_ADD: "{0} + {1}", ca.OP_SUB: "{0} - {1}", ca.OP_MUL: "{0} * {1}", ca.OP_NEG: "-{0}",
           ca.OP_TWICE: "{0} * 2.0", ca.OP_ASSIGN: "{0}"}


def _replay_code(f: ca.Function, ops: list[int]):
    """The instructions ``ops`` of the SX function ``f`` as one Python function
    ``run(values, out)``: each instruction a line, in CasADi's order, its work vector's entries
    local variables (an input's row of ``values``, an output's row of ``out`` written, a
    constant, or an operation of :data:`_OPS` on arrays), the same operations on the same
    values as performing them one by one, without reading each instruction again at every
    call (which cost more than the numpy operations of a profile's scan)."""
    lines, constants = ["def run(values, out):"], []
    for k, op in enumerate(ops):
        ins, outs = f.instruction_input(k), f.instruction_output(k)
        if op == ca.OP_INPUT:
            lines.append(f"    w{outs[0]} = values[{ins[0]}][{ins[1]}]")
        elif op == ca.OP_OUTPUT:
            lines.append(f"    out[{outs[0]}][{outs[1]}] = w{ins[0]}")
        elif op == ca.OP_CONST:
            constants.append(f.instruction_constant(k))
            lines.append(f"    w{outs[0]} = constants[{len(constants) - 1}]")
        else:
            operands = [f"w{i}" for i in ins[:2 if op in _TWO_OPERANDS else 1]]
            form = _INLINE.get(op, f"op{op}({', '.join('{%d}' % i for i in range(len(operands)))})")
            lines.append(f"    w{outs[0]} = " + form.format(*operands))
    lines.append("    return None")
    scope = {"constants": constants, **{f"op{op}": fn for op, fn in _OPS.items()}}
    exec(compile("\n".join(lines), f"<replay of {f.name()}>", "exec"), scope)  # noqa: S102 -- code made here
    return scope["run"]


@lru_cache(maxsize=KEPT_MAPS)
def replayed(f: ca.Function, rounding: bool = False) -> Replay:
    """:class:`Replay` of ``f`` (with ``rounding``), made once per function (as
    :func:`mapped`'s maps are)."""
    return Replay(f, rounding)


class Direct:
    """``f`` called on numpy arrays through CasADi's function buffers (``Function.buffer``):
    the same evaluation of the same function as calling it, without converting each argument
    to a CasADi matrix and each result back, which costs some tens of microseconds an argument,
    more than evaluating a small function (a mechanism's drawing calls them pose by pose).

    Called as ``f`` is, with numbers, sequences or arrays (an argument of an input's entries, or
    for a map of ``f``, of one point's entries: the same at every point); returns each output
    as an array of its rows × columns (``numpy.asarray`` of the call's result): a function of
    one output that output, else the list of them. Any other argument, and an evaluation that
    fails, goes through the call itself (its error is the call's). Each thread has its buffers.
    """

    def __init__(self, f: ca.Function):
        self.f = f
        self._dense = all(f.sparsity_in(i).is_dense() for i in range(f.n_in()))
        # read once: each of CasADi's answers costs microseconds, as much as a small evaluation
        self._shapes_in = [f.size_in(i) for i in range(f.n_in())]
        self._outs = [(f.nnz_out(i), f.size_out(i), None if f.sparsity_out(i).is_dense() else f.sparsity_out(i).find())
                      for i in range(f.n_out())]
        self._threads = threading.local()

    def __call__(self, *args):
        outs = self._outputs(args)
        return outs[0] if len(outs) == 1 else outs

    def _outputs(self, args) -> list[np.ndarray]:
        columns = [self._column(i, a) for i, a in enumerate(args)] if self._dense and len(args) == len(
            self._shapes_in) else None
        if columns is None or any(c is None for c in columns):
            return self._called(args)
        buffer, evaluate = self._buffer()
        results = [np.empty(nnz) for nnz, _, _ in self._outs]
        for i, column in enumerate(columns):
            buffer.set_arg(i, memoryview(column))
        for i, result in enumerate(results):
            buffer.set_res(i, memoryview(result))
        evaluate()
        if buffer.ret() != 0:  # failed: the call says how
            return self._called(args)
        return [self._laid_out(i, v) for i, v in enumerate(results)]

    def _called(self, args) -> list[np.ndarray]:
        out = self.f(*args)
        return [np.asarray(v) for v in (out if isinstance(out, (list, tuple)) else [out])]

    def _buffer(self):
        kept = getattr(self._threads, "buffer", None)
        if kept is None:
            kept = self._threads.buffer = self.f.buffer()
        return kept

    def _column(self, i: int, arg) -> np.ndarray | None:
        """Input ``i``'s entries (column-major) from ``arg``, as the call takes it: a matrix of
        the input's shape, a vector of its length either way round, or one of the input's
        rows × some columns repeated across it (a map's point); None for any other (an
        empty input has one entry of room: a buffer is never empty)."""
        rows, cols = self._shapes_in[i]
        try:
            values = np.asarray(arg, dtype=float)
        except (TypeError, ValueError):
            return None
        if values.ndim > 2:
            return None
        shape = values.shape if values.ndim == 2 else (values.size, 1)
        flat = values.ravel(order="F")
        if rows * cols == 0:
            return np.zeros(1) if flat.size == 0 else None
        if shape == (rows, cols) or (1 in shape and 1 in (rows, cols) and flat.size == rows * cols):
            return np.ascontiguousarray(flat)
        if shape[0] == rows and shape[1] and cols % shape[1] == 0:
            return np.tile(flat, cols // shape[1])
        return None

    def _laid_out(self, i: int, nonzeros: np.ndarray) -> np.ndarray:
        _, (rows, cols), entries = self._outs[i]
        if entries is None:
            return nonzeros.reshape((rows, cols), order="F")
        dense = np.zeros(rows * cols)
        dense[entries] = nonzeros
        return dense.reshape((rows, cols), order="F")


@lru_cache(maxsize=KEPT_MAPS)
def direct(f: ca.Function) -> Direct:
    """:class:`Direct` of ``f``, made once per function (as :func:`mapped`'s maps are)."""
    return Direct(f)


def on_points(f: ca.Function, n: int):
    """``f`` evaluated at ``n`` points as fast as it is to the map's rounding: replayed
    (:func:`replayed` with ``rounding``) from :data:`REPLAY_POINTS` on, else its map called
    through its buffers (:func:`direct`); either is called as the map is, and returns arrays."""
    return replayed(f, rounding=True) if n >= REPLAY_POINTS else direct(mapped(f, n))
