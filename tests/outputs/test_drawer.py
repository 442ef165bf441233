"""Drawings drawn while this process works on (``cadcam design`` forks its drawing processes
before the design and draws the figures while it makes the workshop files): the processes draw
while the block runs, batches sent later are drawn after the earlier ones, an error of the
block ends the processes before it comes out, and where nothing may be forked the drawings are
drawn as they are sent."""
import os
import threading

from cadcam.outputs.forked import Drawer

from ..conftest import SPEC_1DOF
from .test_forked import _gone, _run, _workers

#: Script lines: drawings that each wait for the file ``go`` the block writes (drawn before the
#: block, they would wait in vain), and a block that waits for them to start.
MEANWHILE = """
def waiting(name):
    (out / f"{name}.pid").write_text(str(os.getpid()))
    deadline = time.monotonic() + 60
    while not (out / "go").exists():
        assert time.monotonic() < deadline, "the block did not run while the drawing waited"
        time.sleep(0.02)
    (out / name).write_text(str(os.getpid()))
import __main__
__main__.waiting, __main__.mark = waiting, mark
from cadcam.outputs.forked import Call, Drawer
"""


def test_the_processes_draw_while_the_block_runs_and_later_batches_after(tmp_path):
    code = MEANWHILE + """
with Drawer(2) as drawer:
    drawer.send([Call('__main__', 'waiting', ('d0',)), Call('__main__', 'waiting', ('d1',))])
    while not all((out / f'd{i}.pid').exists() for i in range(2)):
        time.sleep(0.02)
    drawer.send([Call('__main__', 'mark', ('d2',))])
    (out / 'go').write_text('')
    drawer.wait()
print('after', flush=True)
"""
    code_, stdout, stderr = _run(code, tmp_path)
    assert code_ == 0, stderr
    parent, after = stdout.split()
    assert after == "after"
    drawers = {(tmp_path / f"d{i}").read_text() for i in range(3)}
    assert parent not in drawers and len(drawers) == 2  # drawn by two processes of their own
    assert (tmp_path / "d2").stat().st_mtime >= (tmp_path / "go").stat().st_mtime


def test_an_error_of_the_block_ends_the_processes_before_it_comes_out(tmp_path):
    code = MEANWHILE + """
try:
    with Drawer(2) as drawer:
        drawer.send([Call('__main__', 'mark', ('d0', 60)), Call('__main__', 'mark', ('d1', 60))])
        while not all((out / f'd{i}.pid').exists() for i in range(2)):
            time.sleep(0.02)
        raise ValueError('the block failed')
except ValueError as exc:
    print(exc, flush=True)
"""
    code_, stdout, stderr = _run(code, tmp_path)
    assert code_ == 0, stderr
    assert stdout.splitlines()[-1] == "the block failed"
    workers = _workers(tmp_path, ["d0", "d1"])
    assert _gone(workers, 1.0)  # ended before the error came out, not left drawing
    assert not any((tmp_path / f"d{i}").exists() for i in range(2))


def test_where_nothing_may_be_forked_the_drawings_are_drawn_as_they_are_sent():
    order, stop = [], threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        with Drawer(2) as drawer:
            order.append(("block", os.getpid()))
            drawer.send([lambda: order.append(("drawn", os.getpid()))] * 2)
            order.append(("sent", os.getpid()))
            drawer.wait()
    finally:
        stop.set()
        other.join()
    assert order == [("block", os.getpid())] + [("drawn", os.getpid())] * 2 + [("sent", os.getpid())]


# The tests below run in a new process, as ``cadcam design`` does: a test worker may run other
# Python threads (a design page's worker, left by another test), and then nothing is forked.
IMPORTS = """
sys.modules.pop("tabnanny", None)
def record_import():
    (out / "seen").write_text(str("tabnanny" in sys.modules))
import __main__
__main__.record_import = record_import
from cadcam.outputs.forked import Call, Drawer
with Drawer(2, ("cadcam_no_such_module", "tabnanny")) as drawer:
    drawer.send([Call("__main__", "record_import")])
    drawer.wait()
print("tabnanny" in sys.modules, flush=True)
"""


def test_the_drawing_processes_import_the_writers_first_and_leave_a_failed_import_to_the_writer(tmp_path):
    """``cadcam design``'s drawing processes import the figures' libraries while the design is
    made (:class:`cadcam.outputs.forked.Drawer`); one that fails is left to the drawing."""
    code, stdout, stderr = _run(IMPORTS, tmp_path)
    assert code == 0, stderr
    assert (tmp_path / "seen").read_text() == "True"  # imported before the drawing, past the failure
    assert stdout.split()[-1] == "False"  # by the drawing process, not here


INTERRUPTED_DESIGN = """
import importlib
module = importlib.import_module("cadcam.optimize")
importlib.import_module("cadcam.api")  # first: its own name for optimize stays the real function
import multiprocessing
def interrupted(problem):
    first, = multiprocessing.active_children()
    children = Path(f"/proc/{first.pid}/task/{first.pid}/children")
    deadline = time.monotonic() + 60
    while not children.read_text().split():
        assert time.monotonic() < deadline, "the first drawing process forked no other"
        time.sleep(0.02)
    (out / "drawers").write_text(" ".join(map(str, [first.pid, *map(int, children.read_text().split())])))
    raise KeyboardInterrupt
module.optimize = interrupted
os.cpu_count = lambda: 2
from cadcam.cli import main
from cadcam.files import process_alive
code = main(["design", SPEC, "-o", str(out / "o")])
drawers = [int(pid) for pid in (out / "drawers").read_text().split()]
print(len(drawers), sum(process_alive(pid) for pid in drawers), code, flush=True)  # alive as it returns
"""


def test_an_interrupt_during_the_design_ends_the_drawing_processes_forked_before_it(tmp_path):
    """``cadcam design`` forks its drawing processes before the design, so that they import
    matplotlib meanwhile (the first forks the others once it has); a Ctrl-C during the design
    ends every one of them before the run exits 130, and nothing is written."""
    code, stdout, stderr = _run(f"SPEC = {str(SPEC_1DOF)!r}\n" + INTERRUPTED_DESIGN, tmp_path)
    assert code == 0, stderr
    assert stdout.split()[-3:] == ["2", "0", "130"] and "interrupted" in stderr  # two, none left
    assert not (tmp_path / "o").exists()
