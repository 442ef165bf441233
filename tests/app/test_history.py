"""The designs a page's tab made, stepped back and forth through (undo, redo), and requests
served newest first while a slider moves, without a browser."""
import asyncio
from types import SimpleNamespace

import pytest

from cadcam.app.history import Edits, History
from cadcam.app.latest import Latest
from cadcam.app.state import DesignState


def _edits(rate: float) -> Edits:
    return Edits.of({"springs.1.rate": rate}, {}, {}, {})


def test_undo_steps_back_redo_forth_and_a_new_design_drops_those_stepped_back_over():
    history = History()
    assert (history.undo(), history.redo(), history.words()) == (None, None, "no design yet")
    for rate in (1000.0, 1100.0, 1200.0):
        history.record(_edits(rate), f"design at {rate:g}")
    assert history.undo() == (_edits(1100.0), "design at 1100")
    assert history.undo() == (_edits(1000.0), "design at 1000")
    assert (history.undo(), history.can_undo, history.words()) == (None, False, "design 1 of 3")
    assert history.redo() == (_edits(1100.0), "design at 1100")
    history.record(_edits(1300.0), "design at 1300")
    assert [o for _, o in history.entries] == ["design at 1000", "design at 1100", "design at 1300"]
    assert (history.redo(), history.words()) == (None, "design 3 of 3")


def test_the_same_edits_designed_again_replace_their_entry_and_the_oldest_go_first():
    history = History(size=3)
    history.record(_edits(1000.0), "first")
    history.record(_edits(1000.0), "again")
    assert history.entries == [(_edits(1000.0), "again")]
    for rate in (1.0, 2.0, 3.0):
        history.record(_edits(rate), rate)
    assert [o for _, o in history.entries] == [1.0, 2.0, 3.0] and history.at == 2


def test_edits_are_copies():
    overrides = {"springs.1.rate": 1000.0, "cams.1.theta_range_deg": [0.0, 90.0]}
    edits = Edits.of(overrides, {}, {}, {})
    overrides["cams.1.theta_range_deg"][1] = 80.0
    assert edits.overrides["cams.1.theta_range_deg"] == [0.0, 90.0]


def test_a_step_back_shows_the_edits_and_design_made_not_a_new_one(monkeypatch):
    state = DesignState.template("johnston2023_1dof")
    designed = []

    def design(problem, recheck=True):  # the session's design, recorded: a step back designs nothing
        designed.append(problem.springs[0].rate)
        return SimpleNamespace(problem=problem, name=f"design at {problem.springs[0].rate:g}")

    monkeypatch.setattr(state.session, "design", design)
    first = state.design()
    state.edit("springs.1.rate", "1200")
    state.edit("cams.1.theta_range_deg", "[0.0, 80.0]")
    second = state.design("springs.1.rate")
    assert (first.result.name, second.result.name, designed) == ("design at 1100", "design at 1200", [1100.0, 1200.0])
    edits, outcome = state.history.undo()
    state.restore(edits, outcome)
    assert (state.overrides, state.last, state.result, designed) == ({}, first, first.result, [1100.0, 1200.0])
    state.restore(*state.history.redo())
    assert state.overrides == {"springs.1.rate": 1200.0, "cams.1.theta_range_deg": [0.0, 80.0]}
    assert state.result is second.result and state.value("springs.1.rate") == 1200.0


def test_a_design_asked_is_of_the_edits_when_asked():
    """The page asks on its loop and designs in its worker: an edit made meanwhile is not in it."""
    state = DesignState.template("johnston2023_1dof")
    state.edit("springs.1.rate", "1200")
    request = state.ask("springs.1.rate")
    state.edit("springs.1.rate", "1300")
    assert request.problem.springs[0].rate == 1200.0 and request.edits.overrides == {"springs.1.rate": 1200.0}
    state.edit("springs.1.travel", "-1")  # the spec as edited cannot be read: the request carries its error
    refused = state.ask("springs.1.travel")
    assert refused.problem is None and refused.error.field == "springs.1.travel"
    assert state.run(refused) is refused.error


def test_requests_made_while_one_is_served_are_served_once_the_newest():
    asked, served = [], []

    async def serve():
        served.append(asked[-1])
        await asyncio.sleep(0.05)

    async def slide():
        latest = Latest(serve)
        for step in range(10):  # a slider's steps, faster than they are served
            asked.append(step)
            latest.ask()
            await asyncio.sleep(0.005)
        await latest.idle()
        return latest

    latest = asyncio.run(slide())
    assert served[0] == 0 and served[-1] == 9 and len(served) < 10
    assert latest.served == len(served) and latest.served + latest.dropped == 10


def test_a_request_dropped_is_not_served():
    served = []

    async def serve():
        served.append(len(served))
        await asyncio.sleep(0.02)

    async def run():
        latest = Latest(serve)
        latest.ask()
        await asyncio.sleep(0)
        latest.ask()  # waits for the first
        latest.drop()  # and is asked otherwise
        await latest.idle()
        return latest

    latest = asyncio.run(run())
    assert served == [0] and (latest.served, latest.dropped) == (1, 1)


@pytest.mark.parametrize("steps", [1, 3])
def test_each_request_after_the_last_served_is_served(steps):
    served = []

    async def serve():
        served.append(1)

    async def run():
        latest = Latest(serve)
        for _ in range(steps):
            latest.ask()
            await latest.idle()

    asyncio.run(run())
    assert len(served) == steps
