"""cadcam — design wire-wrapped cams and noncircular pulleys with CasADi and IPOPT.

Quick start::

    from cadcam import load_spec, optimize
    result = optimize(load_spec("models/johnston2023_1dof.toml"))
    result.status, result.evaluation.metrics["rmse"]
"""

from .designs import Design, DesignError  # noqa: E402
from .check.evaluate import evaluate  # noqa: E402
from .optimize import optimize  # noqa: E402
from .problem import Joint, Options, Problem  # noqa: E402
from .spec import SpecError, load_spec, parse_spec  # noqa: E402
from .version import __version__  # noqa: E402

__all__ = ["Joint", "Design", "DesignError", "Options", "Problem", "SpecError", "evaluate",
           "load_spec", "optimize", "parse_spec", "__version__"]
