"""The design page's worker without a browser: what the player asks of it while a frame is slow."""
import asyncio
import threading
import time
from types import SimpleNamespace

import pytest

from cadcam.app.state import DesignState


class SlowFrames:
    """Frames drawn one at a time, each taking a while, with the poses drawn recorded."""

    def __init__(self):
        self.drawn: list[int] = []
        self.first_started = threading.Event()

    def png(self, i: int) -> bytes:
        self.first_started.set()
        time.sleep(0.2)
        self.drawn.append(i)
        return f"frame {i}".encode()


def test_the_player_passing_frames_faster_than_they_draw_draws_the_frame_it_stops_on():
    """A frame drawn for the first time is slower than the player's step; the poses the player
    passed while it was drawn are not drawn after it (they would hold the worker, and the
    design queued behind them, for as many draws)."""
    pytest.importorskip("panel", reason="Panel is the app extra's (make test installs it)")
    from cadcam.app.page import DesignPage
    view = DesignPage(DesignState.template("johnston2023_1dof"))
    view.frames = frames = SlowFrames()

    async def play(poses):
        first = asyncio.ensure_future(view._on_pose(SimpleNamespace(new=poses[0])))
        await asyncio.get_running_loop().run_in_executor(None, frames.first_started.wait)
        await asyncio.gather(first, *(view._on_pose(SimpleNamespace(new=p)) for p in poses[1:]))

    asyncio.run(play(list(range(1, 11))))
    assert frames.drawn == [1, 10]
    assert view.mechanism.object == b"frame 10"
