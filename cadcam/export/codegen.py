"""Export a design's model, or a problem's NLP, as code: C (CasADi code generation), a shared
library built from it, and serialized CasADi Functions, with a JSON manifest.

What can be exported:

``model``
    ``cadcam_torque(theta, c, k, x0, F0) -> (tau, x, z)`` (z: every mechanism's departure
    unknowns, listed in the manifest's ``z_layout``) and ``cadcam_torque_jacobian`` (∂τ and ∂x
    with respect to the angles, the design coefficients, the spring rates, the pre-extensions
    and the preloads; ∂z with respect to the angles and the coefficients) of
    :func:`cadcam.verify.model.torque_function` with the tangency by unrolled Newton steps (no
    callback) from the design's solved poses interpolated in θ, and ``cadcam_design.h``
    holding the design's numbers.
``problem``
    The design NLP of :class:`cadcam.solve.transcription.Transcription`: objective, constraints,
    objective gradient, constraint Jacobian and Lagrangian Hessian, with the problem's
    parameter vector, bounds and a starting point in ``problem_data.json``. The manifest's
    ``x_layout`` and ``p_layout`` describe the decision and parameter vectors block by block
    (name, offset, size, unit, description, role) in the transcription's order.

CasADi's generated C leaves some function parameters unused (casadi issues #1875, #2014),
which ``-Wextra -Werror`` rejects; :func:`_mark_unused` adds ``(void)`` for every parameter of
each generated function so the code compiles warning-free with
``gcc -std=c99 -Wall -Wextra -Werror`` at -O1 and -O2, and nothing else.
"""
from __future__ import annotations

import re
import tempfile
from pathlib import Path

import casadi as ca
import numpy as np

from ..version import __version__
from ..designs import Design
from ..files import atomic_path, staged_folder, write_json, write_text
from ..physics.wrap import EXPORT_ORDER, whole_wrap_order
from ..verify.evaluate import start_samples
from ..verify.model import NEWTON_STEPS, solved_poses, torque_function, torque_jacobian_function
from ..solve.blocks import P_BLOCKS, X_BLOCKS, describe
from ..solve.compiled import CompileError, compiler, compiler_failure, oracle_functions, run_compiler
from ..problem import Problem

WHATS = ("model", "problem")
FORMATS = ("c", "shared", "casadi")
#: The NLP functions ``--what problem`` exports (each as ``cadcam_<name>``).
NLP_EXPORTED = ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l")
#: The functions of each export by ``what``: their C symbols and ``.casadi`` file names.
FUNCTIONS = {"model": ("cadcam_torque", "cadcam_torque_jacobian"),
             "problem": tuple(f"cadcam_{name}" for name in NLP_EXPORTED)}
#: The C standard of the generated code.
STANDARD = "-std=c99"
#: Flags the generated C is tested to compile with warning-free, at -O1 and -O2 (tests/export/test_export.py).
WARNINGS = [STANDARD, "-Wall", "-Wextra", "-Werror"]
#: The flags of ``--format shared`` (with ``-fPIC -shared``): the standard without the
#: warnings, which the tests check and which lengthen the compile; -O1, because -O2 compiles
#: markedly slower into functions that evaluate about as fast (``make bench`` times the
#: export's compile, benchmarks/results.md).
CFLAGS = [STANDARD, "-O1"]


#: (unit, description) of the inputs and outputs of the exported model
_MODEL_LABELS = {
    "theta": ("rad", "joint angles, one per joint"),
    "c": ("m", "ρ coefficients of every profile, each in its basis (design.bases), stacked in "
               "profile order"),
    "k": ("N/m", "spring rates, one per spring"),
    "x0": ("m", "spring pre-extensions at the reference pose"),
    "F0": ("N", "spring preloads (initial tension), one per spring"),
    "tau": ("N·m", "joint torques under the torque model named in the manifest"),
    "x": ("m", "spring extensions at θ, one per spring (Johnston2023 Eq. 14, 16, 17)"),
    "z": ("SI (see z_layout)", "every mechanism's departure unknowns at θ, stacked (see z_layout)"),
}
#: (unit, description) of the inputs and outputs of the exported NLP functions (CasADi's names)
_PROBLEM_LABELS = {
    "x": ("per block (see x_layout)",
          "the decision vector: profile coefficients, departure unknowns, pre-extensions and "
          "auxiliary variables, in blocks in the transcription's order (see x_layout for each "
          "block's offset, size and unit: coefficients and lengths in mm, departure unknowns in "
          "SI)"),
    "p": ("per block (see p_layout)", "the parameter vector: the problem's numbers (grid angles, "
          "target integrals, weights, rates, mechanism parameters), see p_layout and "
          "problem_data.json's p"),
    "f": ("1", "the scaled objective IPOPT minimises: Johnston2023 Eq. 46/47 (or the minimax "
               "error) times p's obj_scale, plus each output law's error times its xs"),
    "g": ("scaled (lengths in mm)", "constraint rows, in the transcription's order; their bounds are "
          "problem_data.json's lbg and ubg"),
    "lam_f": ("1", "multiplier of the objective in the Lagrangian"),
    "lam_g": ("1/(unit of the row)", "constraint multipliers, one per row of g"),
    "grad_f_x": ("1/(unit of x)", "∂f/∂x, one entry per entry of x"),
    "jac_g_x": ("(unit of g)/(unit of x)", "∂g/∂x, rows g, columns x"),
    "triu_hess_gamma_x_x": ("1/(unit of x)²", "upper triangle of ∇²ₓ(lam_f·f + lam_gᵀg), the "
                            "lower triangle zero"),
}


class ExportError(ValueError):
    """An export that cannot be made (bad choice of what or format, compiler failure)."""


def model_functions(problem: Problem, design: Design) -> list[ca.Function]:
    """The torque model of ``design`` and its Jacobians, code-generable (SX, no callbacks), their
    Newton started from the design's poses solved on the design grid
    (:func:`cadcam.verify.model.solved_poses`)."""
    kw = dict(order=whole_wrap_order(design.bases, EXPORT_ORDER), integrals="closed-form",
              poses=solved_poses(problem, design))
    f = torque_function(problem, design.bases, tangency="newton", **kw)
    jac = torque_jacobian_function(problem, design.bases, **kw)
    return [_renamed(g, name) for g, name in zip((f, jac), FUNCTIONS["model"])]


def _renamed(f: ca.Function, name: str) -> ca.Function:
    args = f.sx_in() if f.is_a("SXFunction") else f.mx_in()
    return ca.Function(name, args, f.call(args), f.name_in(), f.name_out())


def problem_functions(problem: Problem):
    """The NLP functions of ``problem`` and the Transcription that built them: the functions
    of its whole NLP, deferred outline rows included, that ``solver.functions = "compiled"``
    compiles (:func:`cadcam.solve.compiled.oracle_functions`), from the graph of mapped
    per-angle functions, whose C holds each per-angle function once inside loops over the grid."""
    from ..solve.transcription import Transcription

    tr = Transcription(problem.with_options(functions="mapped"))
    generated = oracle_functions(tr.whole_nlp)
    fns = [_renamed(generated[name], f"cadcam_{name}") for name in NLP_EXPORTED]
    return fns, tr


def _io(f: ca.Function, side: str, labels: dict[str, tuple[str, str]]) -> list[dict]:
    """Name, shape, unit and description of each input (``side`` "in") or output of ``f``;
    ``d<out>_d<in>`` names are Jacobian blocks of the model."""
    n = f.n_in() if side == "in" else f.n_out()
    out = []
    for i in range(n):
        name = f.name_in(i) if side == "in" else f.name_out(i)
        shape = list(f.size_in(i) if side == "in" else f.size_out(i))
        entry = {"name": name, "shape": shape}
        if name in labels:
            entry.update(unit=labels[name][0], description=labels[name][1])
        elif (m := re.fullmatch(r"d(\w+)_d(\w+)", name)) and m[1] in labels and m[2] in labels:
            num, den = labels[m[1]][0], labels[m[2]][0]
            entry.update(unit=f"{num}/{f'({den})' if '/' in den else den}",
                         description=f"∂{m[1]}/∂{m[2]}, rows {m[1]}, columns {m[2]}")
        out.append(entry)
    return out


def _layout(v, families, problem: Problem) -> list[dict]:
    """The blocks of a transcription vector ``v`` in order, each with offset, size, and the
    unit, description and role its family declares (:mod:`cadcam.solve.blocks`)."""
    out = []
    for name, (offset, size) in sorted(v.blocks.items(), key=lambda item: item[1][0]):
        unit, text, role = describe(families, *v.families[name], problem)
        out.append({"name": name, "offset": offset, "size": size, "unit": unit, "description": text,
                    "role": role})
    return out


def shared_library_command(source, library) -> list[str]:
    """The command that ``--format shared`` compiles C ``source`` into ``library`` with
    (:data:`CFLAGS`), their paths absolute (the compiler runs elsewhere:
    :func:`cadcam.solve.compiled.run_compiler`); CompileError if there is no C compiler."""
    return [compiler(), *CFLAGS, "-fPIC", "-shared", str(Path(source).absolute()), "-o",
            str(Path(library).absolute()), "-lm"]


def _mark_unused(source: str) -> str:
    """Add ``(void)name;`` for each parameter at the top of every function definition."""
    pattern = re.compile(r"^(?P<head>[^\n;#=]*?\b\w+\((?P<params>[^()]*)\)\s*\{)$", re.M)

    def add(m):
        names = [re.findall(r"(\w+)\s*$", p.strip())[0] for p in m["params"].split(",")
                 if p.strip() and p.strip() != "void"]
        return m["head"] + "".join(f"\n  (void){n};" for n in names)

    return pattern.sub(add, source)


def _design_header(problem: Problem, design: Design) -> str:
    springs = problem.spring_parameters()

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
             arr("cadcam_design_k", springs.rate, "spring rates [N/m]"),
             arr("cadcam_design_x0", design.preextension, "pre-extensions [m]"),
             arr("cadcam_design_F0", springs.preload, "preloads [N]"),
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
    # the manifest last: the set is complete
    with staged_folder(out, "manifest.json", export_file_names(what, formats)) as stage:
        return _write(problem, design, what, formats, stage)


def export_file_names(what: str, formats: list[str]) -> list[str]:
    """The names of the files :func:`export` writes for ``what`` in ``formats``, known before
    any work (a folder holding a file cadcam may not replace is refused before it)."""
    stem = f"cadcam_{what}"
    c = "c" in formats or "shared" in formats
    return (["manifest.json", *(["problem_data.json"] if what == "problem" else [])]
            + ([f"{stem}.c", f"{stem}.h", *(["cadcam_design.h"] if what == "model" else [])] if c else [])
            + ([f"lib{stem}.so"] if "shared" in formats else [])
            + ([f"{name}.casadi" for name in FUNCTIONS[what]] if "casadi" in formats else []))


def _write(problem: Problem, design: Design, what: str, formats: list[str], out: Path) -> dict:
    """The files of :func:`export` written into ``out`` (a staging folder); the manifest."""
    if what == "model":
        functions, extra = model_functions(problem, design), {}
        layouts = {"tangency": {"method": "unrolled Newton from the design's poses, solved on the design "
                                          "grid and interpolated linearly in the joint angle",
                                "steps": NEWTON_STEPS, "pose_angles": problem.options.grid,
                                "accuracy_rad": 1e-12},
                   "z_layout": [{"mechanism": mech.name, "unknown": name, "unit": unit}
                                for mech in problem.mechanisms
                                for name, unit in zip(mech.unknowns, mech.unknown_units)]}
    else:
        functions, tr = problem_functions(problem)
        extra = {"problem_data.json": _problem_data(problem, design, tr)}
        layouts = {"x_layout": _layout(tr.v, X_BLOCKS, problem),
                   "p_layout": _layout(tr.p, P_BLOCKS, problem)}
    stem = f"cadcam_{what}"
    manifest = {"cadcam_version": __version__, "casadi_version": ca.__version__, "what": what,
                "torque_model": problem.torque_model, "problem": problem.name,
                "storage": "dense inputs and outputs, column-major (CasADi order)",
                "design": design.to_dict(), "files": [], "functions": [], **layouts}
    labels = _MODEL_LABELS if what == "model" else _PROBLEM_LABELS
    for f in functions:
        manifest["functions"].append({"name": f.name(), "inputs": _io(f, "in", labels),
                                      "outputs": _io(f, "out", labels)})
    if "c" in formats or "shared" in formats:
        manifest["files"] += _write_c(functions, stem, out)
        if what == "model":
            write_text(out / "cadcam_design.h", _design_header(problem, design))
            manifest["files"].append("cadcam_design.h")
    if "shared" in formats:
        manifest["files"].append(_write_shared_library(stem, out))
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


def _problem_data(problem: Problem, design: Design, tr) -> dict:
    """``problem_data.json``: the NLP's vector layouts, parameter vector, bounds and the
    starting point of ``design``, from its transcription ``tr``."""
    lbg, ubg = tr.whole_bounds(problem)
    lbx, ubx = tr.variable_bounds(problem)
    x0, pv = tr.start_point(problem, design, start_samples(problem, design, tr.n, tr.start_order()))
    return {
        "variables": {k: {"offset": a, "size": n} for k, (a, n) in tr.v.blocks.items()},
        "parameters_layout": {k: {"offset": a, "size": n} for k, (a, n) in tr.p.blocks.items()},
        "p": pv.tolist(), "x0": x0.tolist(),
        "lbx": lbx.tolist(), "ubx": ubx.tolist(), "lbg": lbg.tolist(), "ubg": ubg.tolist(),
        "note": "lengths in the NLP vector are in mm (manifest.json's x_layout gives each "
                "block's unit); infinite bounds are written as ±Infinity"}


def _write_c(functions: list[ca.Function], stem: str, out: Path) -> list[str]:
    """``functions`` as C source ``<stem>.c`` and header ``<stem>.h`` in ``out``, every
    parameter marked used (:func:`_mark_unused`); the names of the files."""
    with tempfile.TemporaryDirectory(dir=out) as tmp:
        # without CasADi's comment per operation, which doubled the problem's C
        cg = ca.CodeGenerator(f"{stem}.c", {"with_header": True, "verbose": False})
        for f in functions:
            cg.add(f)
        cg.generate(tmp + "/")
        source = _mark_unused((Path(tmp) / f"{stem}.c").read_text())
        header = (Path(tmp) / f"{stem}.h").read_text()
    write_text(out / f"{stem}.c", source)
    write_text(out / f"{stem}.h", header)
    return [f"{stem}.c", f"{stem}.h"]


def _write_shared_library(stem: str, out: Path) -> str:
    """``lib<stem>.so`` compiled in ``out`` from ``<stem>.c`` there; its name."""
    lib = out / f"lib{stem}.so"
    with atomic_path(lib) as tmp:
        try:
            command = shared_library_command(out / f"{stem}.c", tmp)
        except CompileError:
            raise ExportError("--format shared needs a C compiler (cc or gcc) on PATH") from None
        run = run_compiler(command)
        if run.returncode != 0:
            raise ExportError(f"compiling {stem}.c failed: {compiler_failure(run)}")
    return lib.name
