"""The design page's live view without a browser: the numbers it draws of a design (the torque
and its bands, a mechanism at one angle, the spring end's handle), its Bokeh sources replaced in
place, and the page designing as a slider moves, when it is let go, and stepping back."""
import asyncio

import numpy as np
import pytest

from cadcam.app.state import DesignState
from cadcam.units import MM
from cadcam.app.views import (dragged_end, joint_line, pose_columns, spring_ends, torque_columns, view_box)

pytest.importorskip("panel", reason="Panel is the app extra's (make test installs it)")

#: A small NLP of each template's structure: a coarse grid, few check points, expanded functions.
SMALL = (("solver.grid", "12"), ("solver.convexity_points", "24"), ("solver.functions", "expanded"))


def _small(name: str) -> DesignState:
    state = DesignState.template(name)
    for key, value in SMALL:
        assert state.edit(key, value) is None
    return state


@pytest.fixture(scope="module")
def pendulum():
    """Ludovico2021's anchored pulleys (their spring ends turn with the joint), designed small."""
    state = _small("ludovico2021_pendulum")
    result = state.design().result
    assert result.success
    return result


@pytest.fixture(scope="module")
def wire_cam():
    """The 1-DOF wire cam's page, designed small once."""
    from cadcam.app.page import DesignPage

    view = DesignPage(_small("johnston2023_1dof"))
    asyncio.run(view.design())
    assert view.state.result.success
    return view


def test_the_torque_drawn_is_the_designs_with_its_tolerance_band(wire_cam):
    result = wire_cam.state.result
    (columns,) = torque_columns(result)
    ev, band = result.evaluation, result.band
    np.testing.assert_array_equal(columns["theta"], np.degrees(ev.theta[0]))
    assert columns["theta"][[0, -1]] == pytest.approx([0.0, 90.0])
    np.testing.assert_allclose(columns["tau"], MM * ev.tau[0])
    np.testing.assert_allclose(columns["error"], MM * (ev.tau[0] - ev.tau_d[0]))
    np.testing.assert_allclose(columns["band_hi"] - columns["tau"], MM * band.half_width[0])
    np.testing.assert_allclose(columns["tau"] - columns["band_lo"], MM * band.half_width[0])
    assert band.half_width[0].max() > 0 and result.friction is None
    np.testing.assert_array_equal(columns["friction_lo"], columns["tau"])  # no friction: no band
    (moving,) = torque_columns(result, bands=False)  # while a slider moves: no band yet
    np.testing.assert_array_equal(moving["band_lo"], moving["band_hi"])


def test_a_joints_line_holds_the_other_joints_at_their_first_angle():
    ev = type("Ev", (), {"problem": type("P", (), {"joints": [0, 1, 2]})(), "grid": 4})()
    line = joint_line(ev, 1)
    assert list(np.array(np.unravel_index(line, (4, 4, 4))).T[:, 1]) == [0, 1, 2, 3]
    assert set(np.array(np.unravel_index(line, (4, 4, 4)))[[0, 2]].ravel()) == {0}


def test_the_spring_is_drawn_at_its_length_at_each_angle(pendulum):
    """Between the first and last angle a spring's zigzag grows by the spring's extension there."""
    ev = pendulum.evaluation
    x = ev.tensor.extension(0, ev.tensor.line([0], 0)).ravel()
    first, last = (pose_columns(ev, 0, k)["springs"] for k in (0, ev.grid - 1))

    def length(springs):
        xs, ys = springs["xs"][0], springs["ys"][0]
        return float(np.hypot(xs[-1] - xs[0], ys[-1] - ys[0]))

    assert length(last) - length(first) == pytest.approx(MM * (x[-1] - x[0]), rel=1e-6)
    assert abs(x[-1] - x[0]) > 1e-3


def test_the_view_box_holds_the_mechanism_at_every_angle(pendulum):
    ev = pendulum.evaluation
    box = view_box(ev, 1)
    for k in range(ev.grid):
        drawn = pose_columns(ev, 1, k)
        points = np.concatenate([np.column_stack((x, y)) for name in ("outline", "springs", "cable")
                                 for x, y in zip(drawn[name]["xs"], drawn[name]["ys"])])
        assert np.all(points >= np.array(box.lo)) and np.all(points <= np.array(box.hi))
    assert box.hi[0] - box.lo[0] == pytest.approx(box.hi[1] - box.lo[1])  # square: the view keeps its aspect


def test_a_spring_end_dragged_at_an_angle_sets_the_field_that_puts_it_there(pendulum, wire_cam):
    problem = pendulum.problem
    mech = problem.mechanisms[0]
    assert mech.turning == "spring_end"  # the end turns with the joint: drawn elsewhere than its field
    theta = np.radians(60.0)
    (end,) = spring_ends(problem, 0, theta, {"mechanisms.1.spring_end"})
    np.testing.assert_allclose([end.x, end.y], MM * mech.spring_end(theta))
    value = dragged_end(problem, 0, theta, end.x + 20.0, end.y - 10.0)
    moved = type(mech)(**{**mech.__dict__, "spring_end_x": value[0], "spring_end_y": value[1]})
    np.testing.assert_allclose(MM * moved.spring_end(theta), [end.x + 20.0, end.y - 10.0], atol=0.1)
    assert spring_ends(problem, 0, theta, set()) == []  # no field for it: no handle
    assert spring_ends(wire_cam.state.result.problem, 0, theta, set(wire_cam.inputs)) == []  # a wire cam has none


def test_a_new_design_replaces_the_plots_data_in_place(pendulum, wire_cam):
    from cadcam.app.live import LiveView

    live = LiveView(lambda *args: None)
    live.draw(LiveView.frame(pendulum, 3, {"mechanisms.1.spring_end", "mechanisms.2.spring_end"}))
    torque, sources, figures = live.torque_figure, live.torque_sources, live.mechanism_figures
    assert len(figures) == 2 and len(live.end_sources[0].data["x"]) == 1
    ends = live.end_sources[0].data
    np.testing.assert_allclose([ends["x"][0], ends["y"][0]],
                               MM * pendulum.problem.mechanisms[0].spring_end(pendulum.evaluation.units[0].theta[3]))
    tau = np.array(sources[0].data["tau"])
    live.draw(LiveView.frame(pendulum, 5, {"mechanisms.1.spring_end"}, bands=False, views=False))  # another shape
    assert live.torque_figure is torque and live.draws == 1  # drawn when let go, as made then
    live.draw(LiveView.frame(pendulum, 5, {"mechanisms.1.spring_end", "mechanisms.2.spring_end"}, bands=False,
                             views=False))
    assert (live.torque_figure, live.torque_sources, live.mechanism_figures) == (torque, sources, figures)
    angle = np.degrees(pendulum.evaluation.units[0].theta[5])
    assert live.draws == 2 and figures[0].title.text == f"pulley 1: θ = {angle:.0f}°" and 80 < angle < 90
    np.testing.assert_array_equal(sources[0].data["tau"], tau)
    np.testing.assert_array_equal(sources[0].data["band_lo"], sources[0].data["band_hi"])
    live.draw(LiveView.frame(wire_cam.state.result, 0, set(wire_cam.inputs)))  # another template
    assert live.torque_figure is not torque and len(live.mechanism_figures) == 1


def test_a_slider_moved_designs_each_step_and_let_go_makes_the_design_undo_steps_back(wire_cam):
    from cadcam.app.page import MOVING

    view = wire_cam
    live, history = view.live, view.state.history
    first = np.array(live.torque_sources[0].data["tau"])

    async def slide():
        draws = live.draws
        await view._turn("springs.1.rate", 1180.0, final=False)
        await view._moves.idle()
        assert live.draws == draws + 1 and MOVING in view.verdict.object
        assert "verdict-provisional" in view.verdict.object and "success (provisional)" in view.verdict.object
        moving = np.array(live.torque_sources[0].data["tau"])
        await view._turn("springs.1.rate", 1180.0, final=True)
        return moving

    moving = asyncio.run(slide())
    assert not np.allclose(moving, first)
    assert view.inputs["springs.1.rate"].value == "1180.0" and view.sliders["springs.1.rate"][0].value == 1180.0
    assert history.words() == "design 2 of 2" and MOVING not in view.verdict.object
    assert "verdict-success" in view.verdict.object and not view.state.result.provisional
    assert view.state.result.problem.springs[0].rate == 1180.0
    np.testing.assert_allclose(live.torque_sources[0].data["tau"], moving, rtol=1e-6)
    assert view.undo.disabled is False and view.redo.disabled is True

    asyncio.run(view._on_undo(None))
    assert view.inputs["springs.1.rate"].value == "1100.0" and view.sliders["springs.1.rate"][0].value == 1100.0
    np.testing.assert_array_equal(live.torque_sources[0].data["tau"], first)
    assert (history.words(), view.undo.disabled, view.redo.disabled) == ("design 1 of 2", True, False)
    asyncio.run(view._on_redo(None))
    assert view.inputs["springs.1.rate"].value == "1180.0" and view.state.overrides["springs.1.rate"] == 1180.0
    np.testing.assert_allclose(live.torque_sources[0].data["tau"], moving, rtol=1e-6)


def test_a_value_typed_beyond_its_slider_spans_the_slider_anew_and_stays_as_typed(wire_cam):
    """The slider shows the value typed, finer than its step; that is no move of the slider,
    which would round the field to its step. A value the key refuses leaves the slider."""
    view = wire_cam
    slider = view.sliders["springs.2.travel"][0]
    assert slider.end < 0.2 and slider.step == 1e-4
    view.state.edit("springs.2.travel", "0.2345678")
    view._show_values(["springs.2.travel"])
    assert slider.start <= 0.2345678 <= slider.end and slider.value == 0.2345678
    assert view.inputs["springs.2.travel"].value == "0.2345678"
    assert view.state.overrides["springs.2.travel"] == 0.2345678
    view.state.edit("springs.2.travel", "-1")  # refused by its key: the field says so, the slider stays
    view._show_values(["springs.2.travel"])
    assert slider.value == 0.2345678 and view.inputs["springs.2.travel"].value == "-1"


def test_the_friction_band_is_drawn_and_named_only_where_the_spec_has_friction(wire_cam):
    from cadcam.app.live import LiveView

    live = LiveView(lambda *args: None)
    frame = LiveView.frame(wire_cam.state.result, 0, set())
    assert wire_cam.state.result.problem.friction is None and frame.friction is False
    live.draw(frame)
    (item,), (renderer,) = live.friction_items, live.friction_renderers
    assert item.label.value.startswith("friction band") and not item.visible and not renderer.visible
    live.draw(frame._replace(friction=True))
    assert item.visible and renderer.visible
    live.draw(LiveView.frame(wire_cam.state.result, 0, set(), bands=False, views=False))  # moving: kept
    assert item.visible and renderer.visible


def test_a_plots_source_is_sent_only_the_columns_that_changed():
    from bokeh.document import Document
    from bokeh.models import ColumnDataSource

    from cadcam.app.live import put

    def data(n, y):
        return {"x": np.arange(float(n)), "y": np.full(n, y), "xs": [np.arange(2.0)] * n, "w": ["a"] * n}

    source = ColumnDataSource(data(3, 0.0))
    doc = Document()
    doc.add_root(source)
    sent = []  # the columns of each change the browser is sent (None: the whole data)
    doc.on_change(lambda event: sent.append(getattr(event, "cols", None)))
    put(source, data(3, 1.0))
    assert sent == [["y"]]
    np.testing.assert_array_equal(source.data["y"], np.ones(3))
    put(source, data(3, 1.0))
    assert sent == [["y"]]  # nothing changed: nothing sent
    put(source, data(4, 1.0))
    assert len(source.data["x"]) == 4 and sent == [["y"], None]  # another length: the whole data replaced


def test_a_slider_held_still_is_designed_in_full_once_it_rests(wire_cam, monkeypatch):
    from cadcam.app import page

    monkeypatch.setattr(page, "RESTING_S", 0.01)
    view, history = wire_cam, wire_cam.state.history
    assert view.state.edit("springs.2.travel", "") is None  # the spec's travel again (a test above refused one)

    async def hold():
        await view._turn("springs.1.rate", 1150.0, final=False)
        await view._moves.idle()
        assert "verdict-provisional" in view.verdict.object and view._resting is not None
        await view._resting

    made = len(history.entries)
    asyncio.run(hold())
    assert len(history.entries) == made + 1 and page.MOVING not in view.verdict.object
    assert "verdict-success" in view.verdict.object and "fine re-check grid" in view.verdict.object
    assert view.state.result.problem.springs[0].rate == 1150.0 and not view.state.result.provisional


def test_an_error_is_shown_under_its_field_alone_and_cleared_where_it_was(wire_cam):
    """Only the field showing an error and the field named are set (a slider's step clears the
    error without setting every field's); the error moves from field to field and goes."""
    view = wire_cam
    assert view._error_key is None
    view._show_error("springs.1.rate", "rate: bad")
    shown = [k for k, pane in view.errors.items() if pane.visible]
    assert shown == ["springs.1.rate"] and view.errors["springs.1.rate"].object == "rate: bad"
    view._show_error("springs.2.travel", "travel: bad")
    shown = [k for k, pane in view.errors.items() if pane.visible]
    assert shown == ["springs.2.travel"] and view.errors["springs.1.rate"].object == ""
    set_panes = []  # each field whose error pane is set, whether or not its value changes
    for key, pane in view.errors.items():
        pane.param.watch(lambda event, key=key: set_panes.append(key), ["object", "visible"], onlychanged=False)
    view._show_error(None, None)
    assert not any(pane.visible or pane.object for pane in view.errors.values()) and view._error_key is None
    assert set(set_panes) == {"springs.2.travel"} and len(view.errors) > 10
    view._show_error(None, None)  # nothing shown: nothing set
    assert set(set_panes) == {"springs.2.travel"} and not any(pane.visible for pane in view.errors.values())


def test_small_columns_are_sent_in_the_messages_text_and_large_ones_as_binary_buffers():
    """Each binary buffer is two websocket messages the browser handles one by one: a design
    while a slider moves sends its torque (a few tens of angles) and its short curves as text."""
    from bokeh.document import Document
    from bokeh.models import ColumnDataSource
    from bokeh.protocol import Protocol

    from cadcam.app.live import INLINE_VALUES, put

    source = ColumnDataSource({"tau": np.zeros(46), "xs": [np.zeros(401), np.zeros(2)]})
    doc = Document()
    doc.add_root(source)
    events = []
    doc.on_change(events.append)
    long, short = np.linspace(0.0, 1.0, INLINE_VALUES + 1), np.array([1.0, 2.0])
    put(source, {"tau": np.arange(46.0), "xs": [long, short]})
    message = Protocol().create("PATCH-DOC", events)
    assert [b.to_bytes() for b in message.buffers] == [long.tobytes()]  # the long curve alone
    assert source.data["tau"] == list(range(46)) and source.data["xs"][1] == [1.0, 2.0]
    np.testing.assert_array_equal(source.data["xs"][0], long)


def test_the_torque_plots_ranges_stay_in_the_browser(wire_cam):
    """The browser fits the torque and error plots' ranges to each new curve; sent back, they
    would be two messages for the server to read before each next slider step."""
    live = wire_cam.live
    bottom = live.torque.object.children[1]
    ranges = [live.torque_figure.x_range, live.torque_figure.y_range, bottom.y_range]
    assert bottom.x_range is ranges[0] and not any(r.syncable for r in ranges)
    assert all(fig.x_range.syncable and fig.y_range.syncable for fig in live.mechanism_figures)  # the server sets these


def test_a_slider_step_goes_to_the_worker_before_its_field_shows_the_value(wire_cam, monkeypatch):
    """The field follows a slider's step while the worker designs it: its message is made once
    the step's design has gone to the worker, not before it."""
    view = wire_cam
    asked, in_worker = [], view._in_worker

    async def watched(fn, *args):
        asked.append((fn.__name__, view.inputs["springs.1.rate"].value))
        return await in_worker(fn, *args)

    monkeypatch.setattr(view, "_in_worker", watched)
    before = view.inputs["springs.1.rate"].value

    async def step():
        await view._turn("springs.1.rate", 1170.0, final=False)
        await view._moves.idle()

    asyncio.run(step())
    assert before != "1170.0" and asked == [("_moving_design", before)]
    assert view.inputs["springs.1.rate"].value == "1170.0" and view.sliders["springs.1.rate"][0].value == 1170.0
    assert "verdict-provisional" in view.verdict.object
