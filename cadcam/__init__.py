"""cadcam — design wire-wrapped cams and noncircular pulleys with CasADi and IPOPT.

Quick start::

    import cadcam
    result = cadcam.design("models/johnston2023_1dof.toml")
    result                    # a short summary: status, RMSE per joint, binding constraints
    result.success, result.nit, result.fun, result.x
    figures = result.plot()   # matplotlib Figures: profile, torque, springs, convergence
    result.save("out/demo")   # what `cadcam design -o out/demo` writes
    print(cadcam.check_derivatives("models/johnston2023_1dof.toml"))

See :mod:`cadcam.api`. The names below are imported on first use, so that ``import cadcam``
is quick and the command line handles a signal from its first moment (:mod:`cadcam.interrupts`).
"""
from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING

#: The public names, by the module that defines them.
_PUBLIC = {
    "api": ("DerivativeCheck", "Session", "check_derivatives", "compile_ahead", "design", "evaluate",
            "load_design", "load_problem", "read_study"),
    "designs": ("Design", "DesignError"),
    "optimize": ("optimize",),
    "problem": ("Joint", "Options", "Problem"),
    "result": ("Result",),
    "spec": ("SpecError", "load_spec", "parse_spec"),
    "sweep.study": ("StudyError",),
    "version": ("__version__",),
}
_MODULE_OF = {name: module for module, names in _PUBLIC.items() for name in names}

__all__ = sorted(_MODULE_OF)  # noqa: PLE0605 (built from _PUBLIC, where the names are declared)

if TYPE_CHECKING:  # the names as type checkers see them (``X as X``: re-exported)
    from .api import DerivativeCheck as DerivativeCheck, Session as Session
    from .api import check_derivatives as check_derivatives, compile_ahead as compile_ahead
    from .api import design as design, evaluate as evaluate, load_design as load_design
    from .api import load_problem as load_problem, read_study as read_study
    from .designs import Design as Design, DesignError as DesignError
    from .optimize import optimize as optimize
    from .problem import Joint as Joint, Options as Options, Problem as Problem
    from .result import Result as Result
    from .spec import SpecError as SpecError, load_spec as load_spec, parse_spec as parse_spec
    from .sweep.study import StudyError as StudyError
    from .version import __version__ as __version__


class _Package(types.ModuleType):
    """The package's module type: a submodule named like a public name (``cadcam.optimize``,
    the module of the function ``optimize``) does not replace that name when it is imported."""

    def __setattr__(self, name: str, value) -> None:
        if not (name in _MODULE_OF and isinstance(value, types.ModuleType)):
            super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package


def __getattr__(name: str):
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module 'cadcam' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
