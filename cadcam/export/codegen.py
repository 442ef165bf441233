"""Export a design's model, or a problem's NLP, as code: C (CasADi code generation), a shared
library built from it, and serialized CasADi Functions, with a JSON manifest.

What can be exported:

``model``
    ``cadcam_torque(theta, c, k, x0, F0) -> (tau, x, z)`` (z: every mechanism's departure
    unknowns, listed in the manifest's ``z_layout``) and ``cadcam_torque_jacobian`` (∂τ and ∂x
    with respect to the angles, the design coefficients, the spring rates, the pre-extensions
    and the preloads; ∂z with respect to the angles and the coefficients) of
    :func:`cadcam.verify.model.torque_function` with the tangency by unrolled Newton steps (no
    callback), and ``cadcam_design.h`` holding the design's numbers.
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
import subprocess
import tempfile
from pathlib import Path

import casadi as ca
import numpy as np

from ..version import __version__
from ..designs import Design
from ..files import atomic_path, staged_folder, write_json, write_text
from ..verify.evaluate import start_samples
from ..verify.model import NEWTON_STEPS, torque_function, torque_jacobian_function
from ..solve.compiled import CompileError, compiler, oracle_functions
from ..problem import Problem

WHATS = ("model", "problem")
FORMATS = ("c", "shared", "casadi")
#: The C standard of the generated code.
STANDARD = "-std=c99"
#: Flags the generated C is tested to compile with warning-free, at -O1 and -O2 (tests/export/test_export.py).
WARNINGS = [STANDARD, "-Wall", "-Wextra", "-Werror"]
#: The flags of ``--format shared`` (with ``-fPIC -shared``): the standard without the
#: warnings, which the tests check and which made Sec. 10.4's exported problem compile in 22.8 s
#: instead of 18.8 s (medians of 3, by hand, 2026-11-23); -O1: it compiled in 60–80 % of the time
#: -O2 took, into a constraint Jacobian and a Lagrangian Hessian that evaluate about as fast
#: (``make bench`` runs of 2026-11-23; see CHANGELOG).
CFLAGS = [STANDARD, "-O1"]
#: Gauss–Legendre points of the exported wrapped length (and as-printed friction) over the
#: whole wrap: tests check the exported torque against the 48-point evaluator to 1e-12.
EXPORT_QUADRATURE_ORDER = 24
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
    """The torque model of ``design`` and its Jacobians, code-generable (SX, no callbacks)."""
    kw = dict(order=EXPORT_QUADRATURE_ORDER, integrals="closed-form")
    f = torque_function(problem, design.bases, tangency="newton", **kw)
    jac = torque_jacobian_function(problem, design.bases, **kw)
    return [_renamed(f, "cadcam_torque"), _renamed(jac, "cadcam_torque_jacobian")]


def _renamed(f: ca.Function, name: str) -> ca.Function:
    args = f.sx_in() if f.is_a("SXFunction") else f.mx_in()
    return ca.Function(name, args, f.call(args), f.name_in(), f.name_out())


def problem_functions(problem: Problem):
    """The NLP functions of ``problem`` and the Transcription that built them: the functions
    that ``solver.functions = "compiled"`` compiles (:func:`cadcam.solve.compiled.oracle_functions`),
    from the graph of mapped per-angle functions, whose C holds each per-angle function once
    inside loops over the grid."""
    from ..solve.transcription import Transcription

    tr = Transcription(problem.with_options(functions="mapped"))
    generated = oracle_functions(tr.nlp)
    fns = [_renamed(generated[name], f"cadcam_{name}")
           for name in ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l")]
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


def _length_unit(scale: float) -> str:
    return "mm" if scale == 1e-3 else f"{scale:g} m"


def _rad(power: int) -> str:
    """rad, rad², rad³, … (the trapezoidal weights of ``power`` joints' angles)."""
    return "rad" + ("" if power == 1 else "⁰¹²³⁴⁵⁶⁷⁸⁹"[power] if power < 10 else f"^{power}")


def _x_labels(problem: Problem) -> list[tuple[str, str, str, str]]:
    """(name pattern, unit, description, role) of the transcription's variable blocks; the
    pattern's groups are 0-based indices, shown 1-based as ``{1}``, ``{2}``, … and a
    mechanism's unknown as ``{name}``."""
    from ..solve.transcription import FORCE_SCALE, LENGTH_SCALE, SENSITIVITY_SCALE, TORQUE_SCALE

    mm, rad_m = _length_unit(LENGTH_SCALE), _rad(len(problem.joints))
    force = "N" if FORCE_SCALE == 1 else f"{FORCE_SCALE:g} N"
    torque = "N·m" if TORQUE_SCALE == 1 else f"{TORQUE_SCALE:g} N·m"
    return [
        (r"c(\d+)", mm, "ρ coefficients of profile {1} in its basis", "design"),
        (r"x0", mm, "spring pre-extensions at the reference pose, one per spring", "design"),
        (r"z(\d+)_(\w+)", "", "departure unknown {name} of mechanism {1} at each grid angle of its joint",
         "departure"),
        (r"ref(\d+)", "", "departure unknowns of mechanism {1} at its reference angle", "departure"),
        (r"len(\d+)", mm, "wrapped length of profile {1} at each grid angle (Johnston2023 Eq. 10)",
         "auxiliary"),
        (r"wound(\d+)", mm, "length wound from each anchor of mechanism {1} at its reference pose",
         "auxiliary"),
        (r"e(\d+)_(\d+)", mm, "share of spring {1}'s extension from joint {2}'s angle, at each of its "
         "grid angles", "auxiliary"),
        (r"hi(\d+)", mm, "largest share of spring {1}'s extension from each of its joints", "auxiliary"),
        (r"lo(\d+)", mm, "smallest share of spring {1}'s extension from each of its joints", "auxiliary"),
        (r"U(\d+)", torque, "joint {1}'s torque terms that depend on its own angle only, at each grid "
         "angle", "auxiliary"),
        (r"V(\d+)_(\d+)_(\d+)", force, "joint {1}'s torque per unit of spring {2}'s extension share "
         "from joint {3} (k·a, the coupling term), at each grid angle", "auxiliary"),
        (r"t(\d+)", torque, "bound on joint {1}'s largest |τ − τ_d| (minimax epigraph)", "auxiliary"),
        (r"sp(\d+)_(\d+)", f"{SENSITIVITY_SCALE:g} m²", "positive part of joint {1}'s torque per unit "
         "of spring {2}'s rate (∂τ/∂k = x·a, x averaged over the other joints' angles), at each grid "
         "angle", "auxiliary"),
        (r"sn(\d+)_(\d+)", f"{SENSITIVITY_SCALE:g} m²", "negative part of joint {1}'s torque per unit "
         "of spring {2}'s rate, at each grid angle", "auxiliary"),
        (r"to(\d+)", mm, "bound on mechanism {1}'s largest |x − x_d| (minimax epigraph)", "auxiliary"),
        (r"mom(\d+)_(\d+)_(\d+)", f"{mm}·rad", "∫ of spring {2}'s share from joint {3} over that "
         "joint's angle (in joint {1}'s squared error)", "auxiliary"),
        (r"Me(\d+)_(\d+)_(\d+)", f"N·m·{mm}·{rad_m}", "target marginal of joint {1} times spring "
         "{2}'s share from joint {3} (in joint {1}'s squared error)", "auxiliary"),
        (r"UV(\d+)_(\d+)_(\d+)", "N²·m·rad", "∫ U·V of joint {1} for spring {2}'s share from joint "
         "{3} (in its squared error)", "auxiliary"),
        (r"VV(\d+)_(\d+)_(\d+)_(\d+)_(\d+)", f"({force})²·rad", "∫ V·V of joint {1} for the shares "
         "({2}, {3}) and ({4}, {5}) (spring, joint) (in its squared error)", "auxiliary"),
        (r"ee(\d+)_(\d+)_(\d+)_(\d+)_(\d+)", f"{mm}²·rad", "∫ of the product of the shares ({2}, "
         "{3}) and ({4}, {5}) (spring, joint) (in joint {1}'s squared error)", "auxiliary"),
    ]


def _p_labels(problem: Problem) -> list[tuple[str, str, str, str]]:
    """(name pattern, unit, description, role) of the transcription's parameter blocks."""
    rad_m = _rad(len(problem.joints))
    minimax = problem.options.objective == "minimax"
    return [
        (r"theta(\d+)", "rad", "grid angles of joint {1}", "grid"),
        (r"weights(\d+)", "1", "tracking weight of joint {1}", "weights"),
        (r"wsens(\d+)", "1", "sensitivity weights of joint {1}, one per spring", "weights"),
        (r"rt(\d+)", f"N·m·{rad_m}", "joint {1}'s target summed over the other joints' angles "
         "with the quadrature weights, at each of its grid angles", "target"),
        (r"td2(\d+)", f"N²·m²·{rad_m}", "∫τ_d² of joint {1} over the grid", "target"),
        (r"td(\d+)", "N·m", "joint {1}'s target at each of its grid angles (minimax)", "target"),
        (r"Mt(\d+)_(\d+)", f"N·m·{rad_m}", "joint {1}'s target summed over all but joints {1} and "
         "{2}, with the quadrature weights (rows joint {1}'s angles, column-major)", "target"),
        (r"q(\d+)", "SI", "mechanism {1}'s parameters", "mechanism"),
        (r"xd(\d+)", "m", "mechanism {1}'s output law x_d at each grid angle", "target"),
        (r"xs(\d+)", "1/mm" if minimax else "1/(mm²·rad)",
         "scale of mechanism {1}'s output error in the objective", "weights"),
        (r"rc(\d+)", "m", "smallest radius of curvature of profile {1}, with the limit margin",
         "limits"),
        (r"k", "N/m", "spring rates", "springs"),
        (r"F0", "N", "spring preloads", "springs"),
        (r"obj_scale", "1/(N·m)" if minimax else f"1/(N²·m²·{rad_m})", "scale of the torque "
         "objective (OBJECTIVE_SCALE over its value at zero torque)", "weights"),
    ]


def _layout(blocks: dict[str, tuple[int, int]], labels, problem: Problem) -> list[dict]:
    """The blocks of a transcription vector in order, each with offset, size, unit, description
    and role (``"unlabelled"`` for a block this module does not know yet)."""
    out = []
    for name, (offset, size) in sorted(blocks.items(), key=lambda item: item[1][0]):
        entry = {"name": name, "offset": offset, "size": size, "unit": "unknown",
                 "description": "a block cadcam.export.codegen does not describe", "role": "unlabelled"}
        for pattern, unit, text, role in labels:
            if not (m := re.fullmatch(pattern, name)):
                continue
            numbers = [int(g) for g in m.groups() if g.isdigit()]
            unknown = ""
            if pattern in (r"z(\d+)_(\w+)", r"ref(\d+)"):  # a mechanism's unknowns: their units
                mech = problem.mechanisms[numbers[0]]
                units = dict(zip(mech.unknowns, mech.unknown_units))
                if m.lastindex == 2:
                    unknown = m[2]
                    unit = units[unknown]
                else:
                    unit = (next(iter(units.values())) if len(set(units.values())) == 1
                            else "; ".join(f"{k} {u}" for k, u in units.items()))
            elif pattern == r"q(\d+)":
                names = problem.mechanisms[numbers[0]].parameter_names
                text = f"{text} ({', '.join(names)})"
            entry.update(unit=unit, role=role,
                         description=text.format(None, *(n + 1 for n in numbers), name=unknown))
            break
        out.append(entry)
    return out


def shared_library_command(source, library) -> list[str]:
    """The command that ``--format shared`` compiles C ``source`` into ``library`` with
    (:data:`CFLAGS`); CompileError if there is no C compiler."""
    return [compiler(), *CFLAGS, "-fPIC", "-shared", str(source), "-o", str(library), "-lm"]


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
        layouts = {"tangency": {"method": "unrolled Newton from each mechanism's closed-form guess",
                                "steps": NEWTON_STEPS, "accuracy_rad": 1e-12},
                   "z_layout": [{"mechanism": mech.name, "unknown": name, "unit": unit}
                                for mech in problem.mechanisms
                                for name, unit in zip(mech.unknowns, mech.unknown_units)]}
    else:
        functions, tr = problem_functions(problem)
        extra = {"problem_data.json": _problem_data(problem, design, tr)}
        layouts = {"x_layout": _layout(tr.v.blocks, _x_labels(problem), problem),
                   "p_layout": _layout(tr.p.blocks, _p_labels(problem), problem)}
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
    lbg, ubg = tr.bounds(problem)
    lbx, ubx = tr.variable_bounds(problem)
    return {
        "variables": {k: {"offset": a, "size": n} for k, (a, n) in tr.v.blocks.items()},
        "parameters_layout": {k: {"offset": a, "size": n} for k, (a, n) in tr.p.blocks.items()},
        "p": tr.parameters(problem).tolist(), "x0": tr.initial_guess(problem, design, start_samples(problem, design, tr.n, tr.start_order())).tolist(),
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
        run = subprocess.run(command, capture_output=True, text=True)
        if run.returncode != 0:
            raise ExportError(f"compiling {stem}.c failed: {run.stderr.strip()[:500]}")
    return lib.name
