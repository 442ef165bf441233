"""The memory an NLP will need, estimated from its size before IPOPT's functions are built, and
the budget it must fit: a problem inside every cap (the RR arm at grid 2000, ten turns of a
helical drum at the quadrature and check-point caps) can still need more memory than the
machine has, and CasADi then ends the run with ``std::bad_alloc`` minutes into the build.

The estimate reads the NLP's symbolic graph (:meth:`Transcription._build_graph`, which maps
per-angle functions and takes a fraction of a second to seconds), before CasADi expands it into
scalar operations and differentiates them, which is where the memory goes:

    peak [MB] ≈ :data:`BASE_MB` + :data:`UNIT_KB` × (variables + rows) / 1024
                + :data:`DENSE_KB` × (dense coupled entries) / 1024

The dense entries are the n × n products of a least-squares joint's target marginals with the
shares of the springs that couple it to another joint (:func:`dense_entries`): their Jacobian
is dense. Calibrated on the peak resident memory of building the NLP, functions expanded
(which needs the most), in a fresh process (``getrusage``), on a 2-core machine; three IPOPT
iterations of the RR arm added nothing to its build's peak at grids 46 to 200. Each
coefficient is above the largest ratio measured:

==========================  =====  =========  ======  =========  =======
spec                         grid  variables   rows    peak [MB]  KB/unit
==========================  =====  =========  ======  =========  =======
johnston2023_1dof              46        330     564        120       66
johnston2023_1dof             800      5 608   5 842        942       79
roller_follower_pendulum      200        610   1 642        434      169
endo2010_ordinary             200        408   2 201        475      158
endo2010_five_bar              46        200   1 182        265      150
ludovico2021_pendulum         200        817   3 122        786      188
fedorov2018_cable_robot       120      3 504   6 022        891       83
johnston2023_three_cam_arm     16        433   1 308        132       41
johnston2023_rr_arm            46        671   1 414        176       56
johnston2023_rr_arm           200      2 827   4 494        570  (dense)
johnston2023_rr_arm           400      5 627   8 494      1 209  (dense)
==========================  =====  =========  ======  =========  =======

(KB per variable or row above the interpreter's 62 MB.) The RR arm's rows past grid 46 fix the
dense term: above its 56 KB a unit, its 2·n² dense entries took 1.4 KB each at grid 200 and
1.2 KB at 400. Its grid 2000 is estimated at 28.5 GB (under a 4 GB limit its build ran out of
memory in the gradient, with ``std::bad_alloc``).
"""
from __future__ import annotations

import os

from ..errors import SpecError
from ..files import env_cap

#: The interpreter with CasADi, NumPy and cadcam loaded, and a mapped NLP's fixed share [MB].
BASE_MB = 150.0
#: Memory per variable or row of the NLP [KB] (the calibration's largest was 188).
UNIT_KB = 200.0
#: Memory per entry of a dense n × n product of a coupled joint's target marginals [KB] (the
#: calibration's largest was 1.4).
DENSE_KB = 2.0
#: The share of the machine's memory (its RAM, or its control group's limit where lower) one
#: NLP may be estimated to need [ratio]: the rest is the system's and other programs'.
MEMORY_SHARE = 0.8
#: Where a control group (v2, then v1) states a memory limit for this process [bytes].
CGROUP_LIMITS = ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes")


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


def dense_entries(problem) -> int:
    """The entries of the dense n × n products in the NLP of ``problem``: one product per
    least-squares joint i with a torque goal and per spring on it that also acts on another
    joint c, for each such c (:func:`cadcam.solve.transcription._squared_error`'s ``Me``)."""
    if problem.options.objective != "least_squares":
        return 0
    net, n = problem.network(), problem.options.grid
    terms = sum(len(net.joints_of(j)) - 1 for i, joint in enumerate(problem.joints) if joint.tracking_weight > 0
                for j in range(net.S) if i in net.joints_of(j))
    return terms * n * n


def estimated_mb(variables: int, rows: int, dense: int) -> float:
    """The peak memory [MB] of building and solving an NLP of ``variables`` and ``rows`` with
    ``dense`` dense coupled entries (module docstring)."""
    return BASE_MB + (UNIT_KB * (variables + rows) + DENSE_KB * dense) / 1024


def check_memory(problem, variables: int, rows: int) -> None:
    """Raise :class:`MemoryBudgetError` where the NLP of ``problem``, of ``variables`` and
    ``rows``, is estimated to need more memory than the budget."""
    dense = dense_entries(problem)
    need, budget = estimated_mb(variables, rows, dense), memory_budget_mb()
    if need <= budget:
        return
    coupled = f" and {dense:,} dense coupled entries" if dense else ""
    raise MemoryBudgetError(
        f"the NLP of {variables:,} variables, {rows:,} rows{coupled} would need about {need / 1024:.3g} GB of "
        f"memory, beyond the budget of {budget / 1024:.3g} GB ({100 * MEMORY_SHARE:.0f} % of this machine's "
        f"{machine_memory_mb() / 1024:.3g} GB): lower solver.grid (or solver.quadrature_order, "
        "solver.convexity_points, the profiles' order), or raise the budget deliberately with "
        "CADCAM_CAP_MEMORY_MB")
