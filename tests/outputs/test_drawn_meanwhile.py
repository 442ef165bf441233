"""Drawings drawn while this process works on (``cadcam design`` draws its figures while it makes
the workshop files): the workers run during the block, an error of the block ends them before
it comes out, and where nothing may be forked the drawings are drawn before the block."""
import os
import threading

from cadcam.outputs.forked import drawn_meanwhile

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
from cadcam.outputs.forked import drawn_meanwhile
"""


def test_the_workers_draw_while_the_block_runs(tmp_path):
    code = MEANWHILE + """
with drawn_meanwhile([partial(waiting, 'd0'), partial(waiting, 'd1')], 2):
    while not all((out / f'd{i}.pid').exists() for i in range(2)):
        time.sleep(0.02)
    (out / 'go').write_text('')
print('after', flush=True)
"""
    code_, stdout, stderr = _run(code, tmp_path)
    assert code_ == 0, stderr
    parent, after = stdout.split()
    assert after == "after"
    drawers = {(tmp_path / f"d{i}").read_text() for i in range(2)}
    assert parent not in drawers and len(drawers) == 2  # each drawn by a worker of its own


def test_an_error_of_the_block_ends_the_workers_before_it_comes_out(tmp_path):
    code = MEANWHILE + """
try:
    with drawn_meanwhile([partial(mark, 'd0', 60), partial(mark, 'd1', 60)], 2):
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


def test_where_nothing_may_be_forked_the_drawings_are_drawn_before_the_block():
    order, stop = [], threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        with drawn_meanwhile([lambda: order.append(("drawn", os.getpid()))] * 2, 2):
            order.append(("block", os.getpid()))
    finally:
        stop.set()
        other.join()
    assert order == [("drawn", os.getpid())] * 2 + [("block", os.getpid())]
