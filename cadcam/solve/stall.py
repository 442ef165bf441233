"""A stall rule for IPOPT runs (:class:`StallRule`): a run still far from feasible after a
number of iterations is stopped there, where it would otherwise spend the rest of its iteration
limit. The rule in force (:data:`STALL_RULE`) is fixed into a build when it is made
(:class:`cadcam.solve.transcription.Transcription`); each of that build's IPOPT solvers then
carries CasADi's iteration callback (:func:`stall_watch`), which reads IPOPT's own iterates
(``inf_pr``, as :func:`cadcam.solve.ipopt.iteration_history` keeps them) and stops the run
where the rule says (IPOPT's ``User_Requested_Stop``, status :data:`STALL_STATUS`)."""
from __future__ import annotations

import contextlib
from contextvars import ContextVar
from dataclasses import dataclass

import casadi as ca

#: The status of a run the stall rule stopped (:data:`cadcam.solve.ipopt.IPOPT_STATUS`'s word
#: for IPOPT's ``User_Requested_Stop``, which only this rule's callback asks for).
STALL_STATUS = "stall_rule"


@dataclass(frozen=True)
class StallRule:
    """Stop an IPOPT run at iteration ``iteration`` (0: its start) where its primal
    infeasibility (IPOPT's inf_pr, in the NLP's scaled units: mm, mm²) has been at least
    ``inf_pr`` at each of its last ``window`` + 1 iterates, up to that one: a run that has not
    come near feasible and is not getting there. Each run of a solve (the first, the one
    imposing the deferred rows) is judged on its own iterations."""

    iteration: int
    window: int
    inf_pr: float

    def stops(self, inf_pr) -> bool:
        """Whether a run whose iterates so far had the primal infeasibilities ``inf_pr``
        (iteration 0 first) is stopped at its last."""
        return len(inf_pr) - 1 == self.iteration and min(inf_pr[self.iteration - self.window:]) >= self.inf_pr

    def words(self) -> str:
        """The rule in words."""
        return (f"primal infeasibility ≥ {self.inf_pr:g} at each of iterations {self.iteration - self.window} to "
                f"{self.iteration} of a run")


#: The stall rule that builds made now fix into their solvers (None: no rule); see
#: :func:`stall_rule`.
STALL_RULE: ContextVar[StallRule | None] = ContextVar("stall_rule", default=None)


@contextlib.contextmanager
def stall_rule(rule: StallRule | None):
    """Make ``rule`` the stall rule in force (:data:`STALL_RULE`) within the block: the builds
    made (or, by :func:`cadcam.solve.builds.built_for`, reused) there keep it."""
    token = STALL_RULE.set(rule)
    try:
        yield
    finally:
        STALL_RULE.reset(token)


class _Watch(ca.Callback):
    """CasADi's ``iteration_callback`` of one IPOPT solver (:attr:`solver`, set once built)
    that stops its run where ``rule`` says, reading the run's iterates from the solver."""

    def __init__(self, rule: StallRule, nlp: dict):
        ca.Callback.__init__(self)
        self.rule, self.solver = rule, None
        self.calls = 0  # of the run under way (:func:`run_starts`)
        nx, ng, n_p = (nlp[k].numel() for k in ("x", "g", "p"))
        self._sizes = {"x": nx, "f": 1, "g": ng, "lam_x": nx, "lam_g": ng, "lam_p": n_p}
        self.construct("stall_watch", {})

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "stop"

    def get_sparsity_in(self, i):
        return ca.Sparsity.dense(self._sizes[ca.nlpsol_out(i)], 1)

    def eval(self, arg):
        # read from the rule's iteration on: the solver's stats hold its whole history and cost
        # more to read than an iteration of a small NLP takes to evaluate; a run called back
        # fewer times than that has not reached the rule's iteration (CasADi records each
        # iterate before it calls back: the run's own, this one last)
        self.calls += 1
        if self.calls <= self.rule.iteration:
            return [0.0]
        return [float(self.rule.stops(self.solver.stats()["iterations"]["inf_pr"]))]


def stall_watch(rule: StallRule | None, nlp: dict) -> tuple[dict, object]:
    """The ``nlpsol`` options that make an IPOPT solver of ``nlp`` keep ``rule`` (none without
    a rule), and the watch to give the solver once built (:func:`watched`)."""
    if rule is None:
        return {}, None
    watch = _Watch(rule, nlp)
    return {"iteration_callback": watch}, watch


def run_starts(solver: ca.Function) -> None:
    """Tell the watch of ``solver`` (:func:`watched`; none: nothing) that a run starts: it counts
    a run's iterations from here. Without it a watch reads the solver's iterates at every
    iteration after its first run's rule iteration, to the same effect, more slowly."""
    watch = getattr(solver, "stall_watch", None)
    if watch is not None:
        watch.calls = 0


def watched(solver: ca.Function, watch) -> ca.Function:
    """``solver``, built with :func:`stall_watch`'s options, given its ``watch``: the watch
    reads the solver's iterates, and the solver keeps the watch alive (CasADi does not)."""
    if watch is not None:
        watch.solver = solver
        solver.stall_watch = watch
    return solver
