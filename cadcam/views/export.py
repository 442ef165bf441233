"""Export a design's model, or a problem's NLP, as code: C (CasADi code generation), a shared
library built from it, and serialized CasADi Functions, with a JSON manifest.

What can be exported:

``model``
    ``cadcam_torque(theta, c, k, x0) -> (tau, x, alpha, gamma)`` and
    ``cadcam_torque_jacobian`` (∂τ, ∂x, ∂α, ∂γ with respect to the angles, the design
    coefficients, the spring rates and the pre-extensions) of :func:`cadcam.check.model.torque_function`
    with the tangency by unrolled Newton steps (no callback), and ``cadcam_design.h`` holding
    the design's numbers.
``problem``
    The design NLP of :class:`cadcam.nlp.transcription.Transcription`: objective, constraints,
    objective gradient, constraint Jacobian and Lagrangian Hessian, with the problem's
    parameter vector, bounds and a starting point in ``problem_data.json``.

CasADi's generated C leaves some function parameters unused (casadi issues #1875, #2014),
which ``-Wextra -Werror`` rejects; :func:`_mark_unused` adds ``(void)`` for every parameter of
each generated function so the code compiles warning-free with
``gcc -std=c99 -Wall -Wextra -Werror -O2`` and nothing else.
"""
from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import casadi as ca
import numpy as np

from ..version import __version__
from ..designs import Design
from ..files import atomic_path, staged_folder, write_json, write_text
from ..check.evaluate import start_samples
from ..check.model import NEWTON_STEPS, torque_function, torque_jacobian_function
from ..problem import Problem

WHATS = ("model", "problem")
FORMATS = ("c", "shared", "casadi")
CFLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-O2"]
#: Gauss–Legendre points of the exported wrapped length (and as-printed friction) over the
#: whole wrap: tests check the exported torque against the 48-point evaluator to 1e-12.
EXPORT_QUADRATURE_ORDER = 24
_UNITS = {"theta": "rad", "c": "m", "k": "N/m", "x0": "m", "F0": "N", "tau": "N·m", "x": "m",
          "z": "SI (see z_layout)"}
_DESCRIPTIONS = {
    "theta": "joint angles, one per joint",
    "c": "ρ coefficients of every profile, stacked in profile order",
    "k": "spring rates, one per spring", "x0": "spring pre-extensions at the reference pose",
    "F0": "spring preloads (initial tension), one per spring",
    "tau": "joint torques under the torque model named in the manifest",
    "x": "spring extensions (Johnston2023 Eq. 14, 16, 17)",
    "z": "every mechanism's departure unknowns at θ, stacked (see z_layout)",
}


class ExportError(ValueError):
    """An export that cannot be made (bad choice of what or format, compiler failure)."""


def model_functions(problem: Problem, design: Design) -> list[ca.Function]:
    """The torque model of ``design`` and its Jacobians, code-generable (SX, no callbacks)."""
    kw = dict(order=EXPORT_QUADRATURE_ORDER, wire_arm="closed-form")
    f = torque_function(problem, design.bases, tangency="newton", **kw)
    jac = torque_jacobian_function(problem, design.bases, **kw)
    return [_renamed(f, "cadcam_torque"), _renamed(jac, "cadcam_torque_jacobian")]


def _renamed(f: ca.Function, name: str) -> ca.Function:
    args = [f.sx_in(i) for i in range(f.n_in())]
    return ca.Function(name, args, f.call(args), f.name_in(), f.name_out())


def problem_functions(problem: Problem):
    """The NLP functions of ``problem`` and the Transcription that built them."""
    from ..nlp.transcription import Transcription

    tr = Transcription(problem)
    fns = []
    for name in ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l"):
        fns.append(_renamed(tr.solver.get_function(name), f"cadcam_{name}"))
    return fns, tr


def _io(f: ca.Function, side: str) -> list[dict]:
    n = f.n_in() if side == "in" else f.n_out()
    out = []
    for i in range(n):
        name = f.name_in(i) if side == "in" else f.name_out(i)
        shape = list(f.size_in(i) if side == "in" else f.size_out(i))
        entry = {"name": name, "shape": shape}
        if name in _UNITS:
            entry.update(unit=_UNITS[name], description=_DESCRIPTIONS[name])
        elif m := re.fullmatch(r"d(\w+)_d(\w+)", name):
            den = _UNITS[m[2]]
            entry.update(unit=f"{_UNITS[m[1]]}/{f'({den})' if '/' in den else den}",
                         description=f"∂{m[1]}/∂{m[2]}, rows {m[1]}, columns {m[2]}")
        out.append(entry)
    return out


def _mark_unused(source: str) -> str:
    """Add ``(void)name;`` for each parameter at the top of every function definition."""
    pattern = re.compile(r"^(?P<head>[^\n;#=]*?\b\w+\((?P<params>[^()]*)\)\s*\{)$", re.M)

    def add(m):
        names = [re.findall(r"(\w+)\s*$", p.strip())[0] for p in m["params"].split(",")
                 if p.strip() and p.strip() != "void"]
        return m["head"] + "".join(f"\n  (void){n};" for n in names)

    return pattern.sub(add, source)


def _design_header(problem: Problem, design: Design) -> str:
    def arr(name, values, unit):
        vals = ", ".join(repr(float(v)) for v in values)
        return f"/* {unit} */\nstatic const casadi_real {name}[{len(values)}] = {{{vals}}};\n"

    lines = ["/* cadcam design numbers for cadcam_torque (generated; SI units) */",
             "#ifndef CADCAM_DESIGN_H", "#define CADCAM_DESIGN_H", '#include "cadcam_model.h"',
             f"#define CADCAM_N_JOINTS {len(problem.joints)}",
             f"#define CADCAM_N_PROFILES {len(problem.profiles)}",
             f"#define CADCAM_N_SPRINGS {len(problem.springs)}",
             arr("cadcam_design_c", np.concatenate(design.coefficients),
                 "rho coefficients of every profile, stacked, in each profile's basis [m]"),
             arr("cadcam_design_k", [s.rate for s in problem.springs], "spring rates [N/m]"),
             arr("cadcam_design_x0", design.preextension, "pre-extensions [m]"),
             arr("cadcam_design_F0", [s.preload for s in problem.springs], "preloads [N]"),
             "#endif"]
    return "\n".join(lines) + "\n"


def export(problem: Problem, design: Design, what: str, formats, out) -> dict:
    """Write the chosen functions in the chosen formats to folder ``out``; return the manifest.

    Parameters
    ----------
    what : {"model", "problem"}
    formats : iterable of {"c", "shared", "casadi"}
        ``shared`` builds ``libcadcam_<what>.so`` from the C source with the system compiler.
    """
    if what not in WHATS:
        raise ExportError(f"--what {what!r}: expected one of {WHATS}")
    formats = list(dict.fromkeys(formats))
    bad = [f for f in formats if f not in FORMATS]
    if bad or not formats:
        raise ExportError(f"--format {','.join(bad) or '(none)'}: expected some of {FORMATS}")
    with staged_folder(out, last=("manifest.json",)) as stage:  # the manifest last: the set is complete
        return _write(problem, design, what, formats, stage)


def _write(problem: Problem, design: Design, what: str, formats: list[str], out: Path) -> dict:
    """The files of :func:`export` written into ``out`` (a staging folder); the manifest."""
    if what == "model":
        functions, extra = model_functions(problem, design), {}
    else:
        functions, tr = problem_functions(problem)
        lbg, ubg = tr.bounds(problem)
        lbx, ubx = tr.variable_bounds(problem)
        extra = {"problem_data.json": {
            "variables": {k: {"offset": a, "size": n} for k, (a, n) in tr.v.blocks.items()},
            "parameters_layout": {k: {"offset": a, "size": n} for k, (a, n) in tr.p.blocks.items()},
            "p": tr.parameters(problem).tolist(), "x0": tr.initial_guess(problem, design, start_samples(problem, design, tr.n, tr.start_order())).tolist(),
            "lbx": lbx.tolist(), "ubx": ubx.tolist(), "lbg": lbg.tolist(), "ubg": ubg.tolist(),
            "note": "lengths in the NLP vector are in mm (see cadcam.nlp.transcription); "
                    "infinite bounds are written as ±Infinity"}}
    stem = f"cadcam_{what}"
    manifest = {"cadcam_version": __version__, "casadi_version": ca.__version__, "what": what,
                "torque_model": problem.torque_model, "problem": problem.name,
                "storage": "dense inputs and outputs, column-major (CasADi order)",
                "design": design.to_dict(), "files": [], "functions": []}
    if what == "model":
        manifest["tangency"] = {"method": "unrolled Newton from each mechanism's closed-form guess",
                                "steps": NEWTON_STEPS, "accuracy_rad": 1e-12}
        manifest["z_layout"] = [{"mechanism": mech.name, "unknown": name, "unit": unit}
                                for mech in problem.mechanisms
                                for name, unit in zip(mech.unknowns, mech.unknown_units)]
    for f in functions:
        manifest["functions"].append({"name": f.name(), "inputs": _io(f, "in"),
                                      "outputs": _io(f, "out")})
    if "c" in formats or "shared" in formats:
        with tempfile.TemporaryDirectory(dir=out) as tmp:
            cg = ca.CodeGenerator(f"{stem}.c", {"with_header": True})
            for f in functions:
                cg.add(f)
            cg.generate(tmp + "/")
            source = _mark_unused((Path(tmp) / f"{stem}.c").read_text())
            header = (Path(tmp) / f"{stem}.h").read_text()
        write_text(out / f"{stem}.c", source)
        write_text(out / f"{stem}.h", header)
        manifest["files"] += [f"{stem}.c", f"{stem}.h"]
        if what == "model":
            write_text(out / "cadcam_design.h", _design_header(problem, design))
            manifest["files"].append("cadcam_design.h")
    if "shared" in formats:
        lib = out / f"lib{stem}.so"
        compiler = shutil.which("cc") or shutil.which("gcc")
        if compiler is None:
            raise ExportError("--format shared needs a C compiler (cc or gcc) on PATH")
        with atomic_path(lib) as tmp:
            run = subprocess.run([compiler, *CFLAGS, "-fPIC", "-shared", str(out / f"{stem}.c"),
                                  "-o", str(tmp), "-lm"], capture_output=True, text=True)
            if run.returncode != 0:
                raise ExportError(f"compiling {stem}.c failed: {run.stderr.strip()[:500]}")
        manifest["files"].append(lib.name)
    if "casadi" in formats:
        for f in functions:
            with atomic_path(out / f"{f.name()}.casadi") as tmp:
                f.save(str(tmp))
            manifest["files"].append(f"{f.name()}.casadi")
    for name, data in extra.items():
        write_json(out / name, data)
        manifest["files"].append(name)
    write_json(out / "manifest.json", manifest)
    return manifest
