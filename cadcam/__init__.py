"""cadcam — design wire-wrapped cams and noncircular pulleys with CasADi and IPOPT.

Quick start::

    import cadcam
    result = cadcam.design("models/johnston2023_1dof.toml")
    result                    # a short summary: status, RMSE per joint, binding constraints
    result.success, result.nit, result.fun, result.x
    figures = result.plot()   # matplotlib Figures: profile, torque, springs, convergence
    result.save("out/demo")   # what `cadcam design -o out/demo` writes
    print(cadcam.check_derivatives("models/johnston2023_1dof.toml"))

See :mod:`cadcam.api`.
"""

from .api import (DerivativeCheck, check_derivatives, design, evaluate, load_design,  # noqa: E402
                  load_problem, read_study)
from .designs import Design, DesignError  # noqa: E402
from .optimize import optimize  # noqa: E402
from .problem import Joint, Options, Problem  # noqa: E402
from .result import Result  # noqa: E402
from .spec import SpecError, load_spec, parse_spec  # noqa: E402
from .sweep.study import StudyError  # noqa: E402
from .version import __version__  # noqa: E402

__all__ = ["DerivativeCheck", "Design", "DesignError", "Joint", "Options", "Problem", "Result", "SpecError",
           "StudyError",
           "check_derivatives", "design", "evaluate", "load_design", "load_problem", "load_spec", "optimize",
           "parse_spec", "read_study", "__version__"]
