"""IPOPT solvers that share the derivatives a built solver generated.

Generating an NLP's constraint Jacobian and Lagrangian Hessian is most of its build (on
Fedorov2018's balancer, seconds per solver). A transcription solves its NLP again warm from an
answer and its multipliers, and solves it with its deferred rows appended: those solvers call
the first solver's functions and generate derivatives of the appended rows only.
"""
from __future__ import annotations

import casadi as ca

#: The functions IPOPT calls that CasADi generates by derivation, by the ``nlpsol`` option that
#: supplies each one: CasADi's name of the function.
DERIVATIVES = {"grad_f": "nlp_grad_f", "jac_g": "nlp_jac_g", "hess_lag": "nlp_hess_l"}


def sharing_solver(solver: ca.Function, nlp: dict, options: dict, rows: ca.Function | None = None,
                   expand: bool = True) -> ca.Function:
    """IPOPT with ``options`` on ``nlp``, the NLP ``solver`` solves, with the rows
    ``rows(x, p)`` appended to its constraints if given, evaluating ``solver``'s derivatives.

    Parameters
    ----------
    solver : casadi.Function
        A built IPOPT ``nlpsol`` of ``nlp`` (expanded, mapped or from a compiled library).
    nlp : dict
        Its NLP as MX (``x``, ``p``, ``f``, ``g``): the new solver evaluates ``f`` and ``g``
        from it, and derives from it the gradient CasADi's IPOPT interface builds for itself
        (``nlp_grad``), which a compiled library's functions cannot be derived for.
    options : dict
        The new solver's ``nlpsol`` options (IPOPT's under ``ipopt.``).
    rows : casadi.Function, optional
        Rows ``(x, p) → g_d`` to append: the new solver's constraints are ``[g; g_d]``, its
        Jacobian ``solver``'s stacked on theirs, its Lagrangian Hessian ``solver``'s at the
        multipliers of ``g`` plus theirs at those of ``g_d``.
    expand : bool
        Evaluate ``nlp``'s ``f`` and ``g`` and the rows' derivatives as SX (else as their MX
        graphs).
    """
    derivatives = {option: solver.get_function(name) for option, name in DERIVATIVES.items()}
    if rows is not None:
        rows = rows.expand() if expand else rows
        nlp = {**nlp, "g": ca.vertcat(nlp["g"], rows(nlp["x"], nlp["p"]))}
        derivatives["jac_g"] = _stacked_jacobian(derivatives["jac_g"], rows, expand)
        derivatives["hess_lag"] = _summed_hessian(derivatives["hess_lag"], rows, expand)
    return ca.nlpsol(solver.name(), "ipopt", nlp, {**options, **derivatives, "expand": expand})


def _symbols(rows: ca.Function, expand: bool):
    """Symbols of ``rows``' inputs ``x``, ``p`` and of one multiplier per row (SX if ``expand``)."""
    kind = ca.SX if expand else ca.MX
    return (kind.sym("x", rows.sparsity_in(0)), kind.sym("p", rows.sparsity_in(1)),
            kind.sym("lam", rows.size1_out(0)))


def _stacked_jacobian(jac_g: ca.Function, rows: ca.Function, expand: bool) -> ca.Function:
    """``(x, p) → ([g; g_d], [∂g/∂x; ∂g_d/∂x])`` from ``jac_g`` (``(x, p) → (g, ∂g/∂x)``) and
    the rows ``g_d = rows(x, p)``."""
    xs, ps, _ = _symbols(rows, expand)
    gd = rows(xs, ps)
    own = ca.Function("jac_rows", [xs, ps], [gd, ca.jacobian(gd, xs)])
    x, p = ca.MX.sym("x", jac_g.sparsity_in(0)), ca.MX.sym("p", jac_g.sparsity_in(1))
    (g, J), (g_d, J_d) = jac_g(x, p), own(x, p)
    return ca.Function("nlp_jac_g", [x, p], [ca.vertcat(g, g_d), ca.vertcat(J, J_d)],
                       ["x", "p"], jac_g.name_out())


def _summed_hessian(hess_lag: ca.Function, rows: ca.Function, expand: bool) -> ca.Function:
    """The upper triangle of ∇²ₓ(λ_f f + λᵀg + λ_dᵀg_d) from ``hess_lag`` (that of
    ∇²ₓ(λ_f f + λᵀg)) and the rows ``g_d = rows(x, p)``, the multipliers ``[λ; λ_d]`` one input."""
    xs, ps, lam_d = _symbols(rows, expand)
    own = ca.Function("hess_rows", [xs, ps, lam_d], [ca.triu(ca.hessian(ca.dot(lam_d, rows(xs, ps)), xs)[0])])
    x, p = ca.MX.sym("x", hess_lag.sparsity_in(0)), ca.MX.sym("p", hess_lag.sparsity_in(1))
    lam_f, m = ca.MX.sym("lam_f"), hess_lag.size1_in(3)
    lam_g = ca.MX.sym("lam_g", m + rows.size1_out(0))
    H = hess_lag(x, p, lam_f, lam_g[:m]) + own(x, p, lam_g[m:])
    return ca.Function("nlp_hess_l", [x, p, lam_f, lam_g], [H], hess_lag.name_in(), hess_lag.name_out())
