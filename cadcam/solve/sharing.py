"""An IPOPT solver that shares the derivatives a built solver generated.

Generating an NLP's constraint Jacobian and Lagrangian Hessian is most of its build (on
Fedorov2018's balancer, seconds). A transcription solves its NLP again warm from an answer and
its multipliers, under other IPOPT options: that solver calls the first one's derivatives, the
very functions, so its iterates are those a solver built anew would take.
"""
from __future__ import annotations

import casadi as ca

from ..library_files import ipopt_options

#: The functions IPOPT calls that CasADi generates by derivation, by the ``nlpsol`` option that
#: supplies each one: CasADi's name of the function.
DERIVATIVES = {"grad_f": "nlp_grad_f", "jac_g": "nlp_jac_g", "hess_lag": "nlp_hess_l"}


def sharing_solver(solver: ca.Function, nlp: dict, options: dict, expand: bool = True) -> ca.Function:
    """IPOPT with ``options`` on ``nlp``, the NLP ``solver`` solves, evaluating ``solver``'s
    derivatives.

    Parameters
    ----------
    solver : casadi.Function
        A built IPOPT ``nlpsol`` of ``nlp``.
    nlp : dict
        Its NLP as MX (``x``, ``p``, ``f``, ``g``): the new solver evaluates ``f`` and ``g``
        from it, and derives from it the gradient CasADi's IPOPT interface builds for itself
        (``nlp_grad``).
    options : dict
        The new solver's ``nlpsol`` options (IPOPT's under ``ipopt.``).
    expand : bool
        Evaluate ``f`` and ``g`` as SX (else as their MX graphs).
    """
    derivatives = {option: solver.get_function(name) for option, name in DERIVATIVES.items()}
    return ca.nlpsol(solver.name(), "ipopt", nlp, ipopt_options({**options, **derivatives, "expand": expand}))
