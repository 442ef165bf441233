"""Drawings drawn while this process works on (``cadcam design`` forks its drawing processes
before the design and draws the figures while it makes the workshop files): the processes draw
while the block runs, batches sent later are drawn after the earlier ones, an error of the
block ends the processes before it comes out, and where nothing may be forked the drawings are
drawn as they are sent."""
import os
import threading

from cadcam.outputs.forked import Drawer

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
