"""The design page's worker without a browser: what the player asks of it while a pose is slow."""
import asyncio
import threading
import time

import pytest

from cadcam.app.state import DesignState


def test_the_player_passing_angles_faster_than_they_draw_draws_the_angle_it_stops_on(monkeypatch):
    """A pose drawn on a busy worker is slower than the player's step; the angles the player
    passed while it was drawn are not drawn after it (they would hold the worker, and the
    design queued behind them, for as many draws)."""
    pytest.importorskip("panel", reason="Panel is the app extra's (make test installs it)")
    from cadcam.app import page

    drawn, first_started = [], threading.Event()

    def slow_poses(result, k, keys):
        first_started.set()
        time.sleep(0.2)
        drawn.append(k)
        return f"poses at {k}"

    shown = []
    monkeypatch.setattr(page.LiveView, "poses", staticmethod(slow_poses))
    view = page.DesignPage(DesignState.template("johnston2023_1dof"))
    monkeypatch.setattr(view.live, "show_poses", shown.append)
    view.state.result = "a design"
    view.player.end = 20

    async def play(poses):
        for p in poses:
            view.player.value = p
            await view._on_pose(None)
            if p == poses[0]:
                await asyncio.get_running_loop().run_in_executor(None, first_started.wait)
        await view._poses.idle()

    asyncio.run(play(list(range(1, 11))))
    assert drawn == [1, 10] and shown == ["poses at 1", "poses at 10"]
