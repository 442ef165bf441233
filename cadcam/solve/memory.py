"""The memory an NLP will need, estimated from its size before IPOPT's functions are built, and
the budget it must fit: a problem inside every cap (the RR arm at grid 2000) can still need more
memory than the machine has, and CasADi then ends the run with ``std::bad_alloc`` minutes into
the build.

The estimate reads the NLP's symbolic graph (:meth:`Transcription._build_graph`: per-angle
functions mapped over the grid, built in a fraction of a second to a few seconds) before
CasADi expands and differentiates it, which is where the memory goes. :func:`operations`
counts the scalar operations of the NLP once expanded — each call of a per-angle function by
its instructions, a map of n calls n times, a dense product of an n × n matrix by its n²
products — and, for functions kept ``mapped``, each distinct function's instructions once and
the scalar operations of the graph's own nodes:

    peak [MB] ≈ :data:`BASE_MB` + (:data:`OPERATION_KB` × expanded operations
                                   + :data:`UNIT_KB` × (variables + rows)) / 1024

for functions expanded (``auto``, ``expanded``, and ``compiled``, which expands them first),
and for ``mapped`` ones with :data:`SHARED_KB` × the distinct functions' instructions +
:data:`GRAPH_KB` × the graph's operations in place of the expanded ones. Calibrated on the
peak resident memory of building the NLP in a fresh process (``getrusage``; a build's peak held
through the solve, but in the last row, whose two IPOPT iterations took it from 3.8 to
5.2 GB), each coefficient above the largest ratio it was fitted to (``×10``: ten turns at the
caps, grid 2000, quadrature order 16 and 5000 check points):

==========================  =====  ========  ============  ==========  =========  ========
spec                         grid  function  operations    variables   peak [MB]  estimate
                                             (graph's)     and rows               [MB]
==========================  =====  ========  ============  ==========  =========  ========
johnston2023_1dof              46  expanded        30 365         894        120       267
johnston2023_1dof             800  expanded       400 579      11 450        942     1 687
roller_follower_pendulum      200  expanded       173 246       2 252        434       775
endo2010_ordinary             200  expanded       199 113       2 609        475       869
endo2010_five_bar              46  expanded        98 812       1 382        265       508
ludovico2021_pendulum         200  expanded       340 347       3 939        786     1 371
johnston2023_three_cam_arm     16  expanded        49 824       1 741        132       346
johnston2023_rr_arm            46  expanded        69 877       2 085        176       419
johnston2023_rr_arm           400  expanded     1 053 997      14 121      1 209     3 959
fedorov2018_cable_robot        31  expanded     1 090 401       5 254      3 323     3 954
fedorov2018_cable_robot        31  mapped          54 726       5 254        871     1 331
                                                  (72 513)
fedorov2018_cable_robot       120  mapped          54 726       9 526        891     1 427
                                                 (141 221)
johnston2023_rr_arm           200  mapped             591       7 321         89       369
                                                 (206 005)
fedorov2018_cable_robot ×10  2000  mapped         182 353     276 166      5 215     9 693
                                               (3 964 181)
==========================  =====  ========  ============  ==========  =========  ========

Expanded, an operation took 1.1 to 3.1 KB; mapped, a distinct function's instruction about
15 KB besides the rest. So estimated, the RR arm at grid 2000, 18 million operations expanded
(its two dense 2000 × 2000 products among them), needs 61 GB: under a 4 GB limit its build ran
out of memory in the gradient, as the issue saw it do with ``std::bad_alloc``. Ten turns of
the cable robot at the caps fit in 9.5 GB with its mapped functions, and need 257 GB expanded.
"""
from __future__ import annotations

import os

import casadi as ca

from ..errors import SpecError
from ..files import env_cap

#: The interpreter with CasADi, NumPy and cadcam loaded [MB] (62 measured), with room.
BASE_MB = 150.0
#: Memory per scalar operation of the NLP expanded [KB] (the calibration's largest was 3.06).
OPERATION_KB = 3.5
#: Memory per instruction of a distinct function of a ``mapped`` NLP [KB]: CasADi builds
#: each one's derivatives symbolically once (the calibration's largest, less the share of its
#: graph and its variables and rows, was 15).
SHARED_KB = 20.0
#: Memory per scalar operation of a ``mapped`` NLP's graph's own nodes [KB]: vector nodes,
#: a few words per element (the calibration's largest, less the rest's share, was 0.3).
GRAPH_KB = 0.5
#: Memory per variable and per row of the NLP [KB]: IPOPT's iterates, Jacobian and KKT
#: factors (ten turns of the cable robot's 276 166 took 1.4 GB in two iterations, 5 KB each).
UNIT_KB = 15.0
#: The share of the machine's memory (its RAM, or its control group's limit where lower) one
#: NLP may be estimated to need [ratio]: the rest is the system's and other programs'.
MEMORY_SHARE = 0.8
#: Where a control group (v2, then v1) states a memory limit for this process [bytes].
CGROUP_LIMITS = ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes")
#: The MX operations that compute nothing of their own.
_PLACES = (ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_PARAMETER, ca.OP_CONST)


class MemoryBudgetError(SpecError):
    """An NLP whose estimated memory is beyond the budget (:func:`memory_budget_mb`); one line."""


def machine_memory_mb() -> float:
    """This machine's memory [MB]: its RAM, or a lower limit of its control group."""
    total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    for path in CGROUP_LIMITS:
        try:
            with open(path) as f:
                text = f.read().strip()
        except OSError:
            continue
        if text.isdigit():
            total = min(total, int(text))
    return total / 2**20


def memory_budget_mb() -> int:
    """The memory [MB] an NLP may be estimated to need: :data:`MEMORY_SHARE` of
    :func:`machine_memory_mb`, or ``CADCAM_CAP_MEMORY_MB`` (a positive integer) where given."""
    return env_cap("memory_mb", int(MEMORY_SHARE * machine_memory_mb()))


def operations(f: ca.Function) -> tuple[int, int, int]:
    """(expanded, in functions, in the graph): the scalar operations of ``f`` with every call
    expanded; the instructions of each distinct SX function it calls, once; and the
    operations of its MX graph's own nodes, a dense product counted by its scalar products."""
    functions: dict[int, int] = {}

    def expanded(fn: ca.Function, own: list) -> int:
        kind = fn.class_name()
        if kind == "SXFunction":
            functions[hash(fn)] = fn.n_instructions()
            return fn.n_instructions()
        if kind == "Map":
            info = fn.info()
            return info["n"] * expanded(info["f"], [])
        if kind != "MXFunction":
            return sum(expanded(fn.get_function(name), []) for name in fn.get_function()) or fn.nnz_out()
        total = 0
        for k in range(fn.n_instructions()):
            op, node = fn.instruction_id(k), fn.instruction_MX(k)
            if op == ca.OP_CALL:
                total += expanded(node.which_function(), own)
            elif op not in _PLACES:
                count = node.dep(1).nnz() * node.dep(2).size2() if op == ca.OP_MTIMES else max(node.nnz(), 1)
                total += count
                own.append(count)
        return total

    graph: list[int] = []
    return expanded(f, graph), sum(functions.values()), sum(graph)


def estimated_mb(units: int, counts: tuple[int, int, int], mapped: bool) -> float:
    """The peak memory [MB] of building and solving an NLP of ``units`` variables and rows
    whose :func:`operations` are ``counts``, its functions ``mapped`` or expanded (module
    docstring)."""
    expanded, shared, graph = counts
    work = SHARED_KB * shared + GRAPH_KB * graph if mapped else OPERATION_KB * expanded
    return BASE_MB + (work + UNIT_KB * units) / 1024


def check_memory(options, nlp: dict) -> None:
    """Raise :class:`MemoryBudgetError` where the NLP ``nlp`` (CasADi ``x``, ``p``, ``f``,
    ``g``), built with the solver ``options``, is estimated to need more memory than the
    budget."""
    units = nlp["x"].numel() + nlp["g"].numel()
    counts = operations(ca.Function("nlp", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]]))
    need, budget = estimated_mb(units, counts, options.functions == "mapped"), memory_budget_mb()
    if need <= budget:
        return
    mapped = "" if options.functions == "mapped" else ', keep its functions mapped (solver.functions = "mapped")'
    raise MemoryBudgetError(
        f"the NLP of {nlp['x'].numel():,} variables and {nlp['g'].numel():,} rows, {counts[0]:,} scalar operations "
        f"expanded, would need about {need / 1024:.3g} GB of memory, beyond the budget of {budget / 1024:.3g} GB "
        f"({100 * MEMORY_SHARE:.0f} % of this machine's {machine_memory_mb() / 1024:.3g} GB): lower solver.grid "
        f"(or solver.quadrature_order, solver.convexity_points, the profiles' order){mapped}, or raise the budget "
        "deliberately with CADCAM_CAP_MEMORY_MB")
