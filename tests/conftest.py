"""Shared fixtures: the 1-DOF model spec and the RR-arm problem with Johnston2023's Table 3 design."""
import contextlib
import json
import shutil
import signal
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import cadcam
from cadcam import Design, load_spec
from cadcam.solve import compiled

ROOT = Path(__file__).resolve().parents[1]
SPEC_1DOF = ROOT / "models" / "johnston2023_1dof.toml"

SPEC_RR = ROOT / "models" / "johnston2023_rr_arm.toml"
TABLE3 = ROOT / "models" / "johnston2023_table3_design.json"
TABLE4 = ROOT / "models" / "johnston2023_table4_design.json"
#: Ludovico2021's inverted pendulum balanced by an antagonistic pair of anchored pulleys.
SPEC_PENDULUM = ROOT / "models" / "ludovico2021_pendulum.toml"
#: A pendulum balanced by a radial cam on a translating roller follower.
SPEC_ROLLER = ROOT / "models" / "roller_follower_pendulum.toml"
#: A package outside cadcam that adds a mechanism through the entry-point group.
PLUGIN = ROOT / "tests" / "plugin"


def toy_pulley():
    """The plug-in's mechanism class, imported from its folder and registered, as its entry
    point registers it when the package is installed."""
    import importlib.util
    import sys

    from cadcam.mechanisms.base import register

    module = sys.modules.get("cadcam_toy_pulley")
    if module is None:
        spec = importlib.util.spec_from_file_location("cadcam_toy_pulley", PLUGIN / "cadcam_toy_pulley.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules["cadcam_toy_pulley"] = module
        spec.loader.exec_module(module)
    return register(module.ToyPulley)


@pytest.fixture(scope="session", autouse=True)
def interrupts_as_at_a_terminal():
    """Ctrl-C handled as a terminal's session has it. A shell without job control starts a
    background job (``make test &`` in a script) with SIGINT ignored, and an ignored signal
    stays ignored in every process started from it: the tests that interrupt a solve or the
    drawing processes would then see no KeyboardInterrupt at all. Python's own handler here is
    the default action again in the processes the tests start."""
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    yield


@pytest.fixture(scope="session", autouse=True)
def private_compile_cache(tmp_path_factory):
    """Every test in an empty cache of compiled libraries of its session, with no background
    compiles: ``functions = "auto"`` then expands every NLP, as on a machine without a
    compiler, whatever libraries this machine has cached (tests of compiled functions set a
    cache of their own)."""
    with pytest.MonkeyPatch.context() as env:
        env.setenv("CADCAM_CACHE_DIR", str(tmp_path_factory.mktemp("compiled")))
        env.setenv(compiled.BACKGROUND_ENV, "0")
        yield


@pytest.fixture(scope="session")
def planted(tmp_path_factory):
    """A shared library whose constructor writes the file ``loaded`` beside it: proof if it is
    ever loaded. Its soname is its own path (a library linked with it loads it from there), and
    it defines ``memset`` (a linker looking for that symbol takes it)."""
    if shutil.which("cc") is None:
        pytest.skip("no C compiler to build the library")
    folder = tmp_path_factory.mktemp("planted")
    source = folder / "planted.c"
    library = folder / "libplanted.so"
    source.write_text('#include <stdio.h>\n__attribute__((constructor)) static void planted(void) {\n'
                      f'  FILE *f = fopen("{folder / "loaded"}", "w"); if (f) fclose(f);\n}}\n'
                      "void *memset(void *s, int c, unsigned long n) {\n"
                      "  unsigned char *p = s; while (n--) *p++ = (unsigned char)c; return s;\n}\n")
    subprocess.run(["cc", "-shared", "-fPIC", str(source), "-o", str(library), f"-Wl,-soname,{library}"],
                   check=True)
    return library


@pytest.fixture(scope="session")
def design_1dof(tmp_path_factory):
    """The 1-DOF model designed on a grid of 12 (a quick design), in an empty working folder."""
    with contextlib.chdir(tmp_path_factory.mktemp("design_1dof")):
        return cadcam.design(SPEC_1DOF, grid=12)


@pytest.fixture(scope="session")
def problem_1dof():
    return load_spec(SPEC_1DOF)


@pytest.fixture(scope="session")
def result_1dof(problem_1dof):
    """The 1-DOF model optimized as its spec states it (no files written): solved once per test
    worker for every module that reads that optimum. Read it, never change it (a test that
    alters a result alters a copy)."""
    return cadcam.optimize(problem_1dof)


@pytest.fixture(scope="session")
def pendulum_result():
    """The Ludovico2021 pendulum designed as its spec states it (``cadcam.design``, no files
    written): solved once per test worker for every module that reads that optimum. Read it,
    never change it."""
    return cadcam.design(SPEC_PENDULUM)


@pytest.fixture(scope="session")
def roller_result():
    """The roller follower's pendulum balancer designed as its spec states it
    (``cadcam.design``, no files written), once per test worker. Read it, never change it."""
    return cadcam.design(SPEC_ROLLER)


@pytest.fixture(scope="session")
def rr_problem():
    return load_spec(SPEC_RR)


@pytest.fixture(scope="session")
def table3(rr_problem):
    return Design.from_dict(json.loads(TABLE3.read_text()), rr_problem)


#: Marks a test that compiles C (skipped where cadcam finds no C compiler).
needs_cc = pytest.mark.skipif(not compiled.available(), reason="no C compiler on this machine")

#: How long a background compile of a small NLP may take [s] (seconds at -O1 alone; a loaded CI
#: machine runs the test suite beside it).
COMPILE_WAIT_S = 180.0


def wait_for_library():
    """The compiled libraries in the cache once there is one (a background compile ended), or
    none after :data:`COMPILE_WAIT_S`."""
    deadline = time.monotonic() + COMPILE_WAIT_S
    while not compiled.cached_libraries() and time.monotonic() < deadline:
        time.sleep(0.2)
    return compiled.cached_libraries()


def at_once(task, count: int = 2) -> list[BaseException]:
    """Run ``task()`` on ``count`` threads released together (a barrier); the exceptions they
    raised."""
    start, errors = threading.Barrier(count), []

    def run():
        start.wait()
        try:
            task()
        except Exception as exc:  # noqa: BLE001 - returned to the test
            errors.append(exc)

    threads = [threading.Thread(target=run) for _ in range(count)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return errors


def circle_design(problem, radius, x0):
    """A circular cam of ``radius`` [m] in the problem's basis."""
    b = problem.profiles[0].basis
    m = np.zeros(b.size)
    m[0] = radius
    return Design([b], [b.from_monomial(m)], np.asarray(x0, dtype=float))


def check_output_file(path):
    """Check that an output file holds what its type promises, not just some bytes: a PNG
    image with a drawing on it, a one-page-or-more PDF, an SVG with a path, a DXF with
    entities, a CSV of finite numbers, a closed binary STL of positive volume. Returns the
    STL's volume [file units³] or ``None``."""
    import xml.etree.ElementTree as ET

    path = Path(path)
    data = path.read_bytes()
    kind = path.suffix
    if kind == ".png":
        import matplotlib.image
        img = matplotlib.image.imread(path)
        assert img.ndim == 3 and min(img.shape[:2]) >= 200, (path, img.shape)
        background = img[0, 0]
        drawn = np.any(np.abs(img - background) > 0.1, axis=2).mean()
        assert drawn > 0.002, f"{path}: an empty picture ({drawn:.2%} of pixels drawn)"
    elif kind == ".pdf":
        assert data.startswith(b"%PDF-") and b"/Type /Page" in data and data.rstrip().endswith(b"%%EOF"), path
    elif kind == ".svg":
        root = ET.fromstring(data)
        assert root.tag.endswith("svg") and any(e.tag.endswith(("path", "polyline", "polygon")) for e in root.iter())
    elif kind == ".dxf":
        import ezdxf
        assert len(ezdxf.readfile(path).modelspace()) > 0, path
    elif kind == ".csv":
        rows = data.decode().splitlines()
        assert len(rows) >= 3 and "," in rows[0]
        values = np.array([[float(v) for v in r.split(",")] for r in rows[1:]])
        assert values.shape[1] == rows[0].count(",") + 1 and np.isfinite(values).all(), path
    elif kind == ".stl":
        n = int(np.frombuffer(data[80:84], "<u4")[0])
        assert n > 0 and len(data) == 84 + 50 * n, path
        tri = np.frombuffer(data[84:], np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]))["v"]
        tri = tri.astype(float)
        edges = {}
        for t in np.round(tri, 6):  # closed: every edge is shared by exactly two triangles
            for a, b in ((0, 1), (1, 2), (2, 0)):
                key = tuple(sorted((tuple(t[a]), tuple(t[b]))))
                edges[key] = edges.get(key, 0) + 1
        assert set(edges.values()) == {2}, f"{path}: not a closed surface"
        volume = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6
        assert volume > 0, path
        return float(volume)
    else:
        raise AssertionError(f"no check for {path}")
    return None
