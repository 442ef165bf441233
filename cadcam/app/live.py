"""The design page's live view: Bokeh plots drawn in the browser, whose data each new design
replaces in place (no figure drawn on the server, no image sent).

Beside each other: each mechanism at the joint angle chosen (its outline, the cable, the springs
at their length, the idlers, the link and its mass; a spring end the spec places is drawn as a
handle to drag, :func:`cadcam.app.views.spring_ends`), and the torque against its target over
the range, its tolerance band and friction band, with the error under it and the error its
acceptance allows. What is drawn is made in two steps: :meth:`LiveView.frame` makes the numbers
(in the page's worker: it evaluates the design's profiles), :meth:`LiveView.draw` puts them in
the plots' sources (in the page's loop). The plots are made again only when a design of another
shape comes (another number of joints or mechanisms, a spring end or none).
"""
from __future__ import annotations

import html
from typing import Callable, NamedTuple

import numpy as np
import panel as pn
from bokeh.events import PanEnd
from bokeh.layouts import column
from bokeh.models import (BasicTickFormatter, BoxAnnotation, ColumnDataSource, Legend, LegendItem, PointDrawTool,
                          Range1d, Span)
from bokeh.plotting import figure

from ..result import Result
from .views import (COLOURS, POSE_COLUMNS, TORQUE_COLUMNS, Box, SpringEnd, accepted_error, legend, limit_circles,
                    pose_columns, spring_ends, torque_columns, torque_title, view_box)

#: Least width of the torque plot (it fills the width left) and the heights of the torque plot and
#: of the error plot under it [px].
TORQUE_WIDTH, TORQUE_HEIGHT, ERROR_HEIGHT = 380, 330, 210
#: Side of a mechanism's square view [px], one mechanism; several share this height.
MECHANISM_SIDE = 440
#: Colours of the plots (those of the figures, :mod:`cadcam.outputs.plots`).
TORQUE_COLOUR, TARGET_COLOUR, ERROR_COLOUR, FRICTION_COLOUR = "#1f77b4", "black", "#d62728", "#ff7f0e"
CABLE_COLOUR, SPRING_COLOUR, ACCEPTED_COLOUR = "#ff7f0e", "#9467bd", "#2ca02c"
#: Largest array [values] the browser is sent in a message's text (:func:`sent`): Bokeh sends
#: each array as a binary buffer of its own, two websocket messages each (its header, its bytes),
#: and the browser handles each message as a task of its own; a curve of a few hundred points is
#: cheaper as one buffer than as text.
INLINE_VALUES = 128
#: The tools of every plot (a mechanism's view adds the handle of its spring ends).
TOOLS = "pan,wheel_zoom,box_zoom,reset,save"
#: How the key under the mechanisms' views marks each thing drawn (:func:`cadcam.app.views.legend`).
MARKS = {"outline": f"<b style='color:{COLOURS[0]}'>━</b>", "cable": f"<b style='color:{CABLE_COLOUR}'>━</b>",
         "spring": f"<b style='color:{SPRING_COLOUR}'>⩘</b>", "idler": "<span style='color:#404040'>◌</span>",
         "anchor": "■", "contact": f"<span style='color:{ERROR_COLOUR}'>●</span>",
         "binding": "<b style='color:crimson'>✕</b>", "handle": f"<span style='color:{SPRING_COLOUR}'>◉</span>"}


class Poses(NamedTuple):
    """What the live view shows of each mechanism at one joint angle (:meth:`LiveView.poses`)."""

    #: The columns of each mechanism's sources (:func:`cadcam.app.views.pose_columns`)
    columns: list[dict]
    #: Each mechanism's title at the angle shown
    headings: list[str]
    #: Each mechanism's spring ends to drag
    ends: list[list[SpringEnd]]


class Frame(NamedTuple):
    """What the live view shows of one design (:meth:`LiveView.frame`)."""

    #: What the plots are made for: the joints' and mechanisms' names, the spring ends' keys
    shape: tuple
    torque: list[dict]
    titles: list[str]
    accepted: list[float | None]
    poses: Poses
    #: Each mechanism's view and circles (None: keep those shown, a design while a slider moves)
    boxes: list[Box] | None
    limits: list[dict] | None
    #: The key under the mechanisms' views (:func:`cadcam.app.views.legend`)
    key: list[tuple[str, str]]
    #: Whether the spec has friction, so a friction band (None: keep what is shown, a design
    #: while a slider moves)
    friction: bool | None = None


class LiveView:
    """The live view's plots, in two Panel panes: :attr:`mechanisms` and :attr:`torque`.

    Parameters
    ----------
    on_end_moved : callable
        ``on_end_moved(key, x, y, final)``: a spring end's handle moved to (x, y) [mm] in the
        view of the joint angle shown, ``final`` once the drag ends.
    """

    def __init__(self, on_end_moved: Callable[[str, float, float, bool], None]):
        self.on_end_moved = on_end_moved
        self.mechanisms = pn.pane.Bokeh(None, css_classes=["mechanism-view"])
        self.key = pn.pane.HTML("", css_classes=["mechanism-key"], width=MECHANISM_SIDE, margin=(0, 10),
                                styles={"font-size": "11px", "line-height": "1.4"})
        self.torque = pn.pane.Bokeh(None, css_classes=["torque-view"], sizing_mode="stretch_width")
        self.shape: tuple | None = None
        self.torque_sources: list[ColumnDataSource] = []
        self.pose_sources: list[dict[str, ColumnDataSource]] = []
        self.end_sources: list[ColumnDataSource] = []
        self.accepted: BoxAnnotation | None = None
        self.band_renderers: list = []
        self.friction_renderers: list = []
        self.friction_items: list[LegendItem] = []
        self.torque_figure = None
        self.mechanism_figures: list = []
        #: How many times the plots' data were replaced (a test's and the benchmark's sign)
        self.draws = 0

    # -------------------------------------------------------------------------------- numbers
    @staticmethod
    def poses(result: Result, k: int, keys) -> Poses:
        """Each mechanism of ``result`` at index ``k`` of its joint grid, with a handle for each
        spring end whose field is among ``keys``."""
        problem, ev = result.problem, result.evaluation
        mechanisms = range(len(problem.mechanisms))
        thetas = [float(ev.units[u].theta[int(np.clip(k, 0, ev.units[u].theta.size - 1))]) for u in mechanisms]
        angle = "θ" if len(problem.joints) == 1 else "θ{}"
        return Poses([pose_columns(ev, u, k) for u in mechanisms],
                     [f"{m.name}: {angle.format(m.joint + 1)} = {np.degrees(t):.0f}°"
                      for m, t in zip(problem.mechanisms, thetas)],
                     [spring_ends(problem, u, thetas[u], keys) for u in mechanisms])

    @classmethod
    def frame(cls, result: Result, k: int, keys, bands: bool = True, views: bool = True) -> Frame:
        """The numbers of ``result`` the live view shows, its mechanisms at index ``k`` of the
        joint grid (:meth:`poses`): with ``bands`` the tolerance and friction bands, with
        ``views`` each mechanism's view box (both left out while a slider moves)."""
        problem, ev = result.problem, result.evaluation
        mechanisms = range(len(problem.mechanisms))
        poses = cls.poses(result, k, keys)
        torque = torque_columns(result, bands)
        shape = (tuple(j.name for j in problem.joints) if torque else (),
                 tuple(m.name for m in problem.mechanisms), tuple(e.key for row in poses.ends for e in row))
        return Frame(shape=shape, torque=torque, titles=[torque_title(result, i) for i in range(len(torque))],
                     accepted=[accepted_error(problem, i) for i in range(len(torque))], poses=poses,
                     boxes=[view_box(ev, u) for u in mechanisms] if views else None,
                     limits=[limit_circles(problem, u) for u in mechanisms] if views else None,
                     key=legend(problem, bool(shape[2])), friction=bool(problem.friction) if bands else None)

    # ---------------------------------------------------------------------------------- plots
    def draw(self, frame: Frame) -> None:
        """Show ``frame``: its numbers put in the plots' sources, the plots made again first
        where ``frame`` is of another shape (unless it keeps no view box: a design while a
        slider moves, whose final design then makes them)."""
        layouts = None
        if frame.shape != self.shape:
            if frame.boxes is None:
                return
            layouts = self._build(frame)
        for source, data in zip(self.torque_sources, frame.torque):
            put(source, data)
        if frame.friction is not None:  # no friction band, nor its words in the legend, without friction
            for renderer, item in zip(self.friction_renderers, self.friction_items):
                renderer.visible = item.visible = frame.friction
        if self.torque_figure is not None and frame.titles:
            self.torque_figure.title.text = frame.titles[0] if len(frame.titles) == 1 else "torque per joint"
            accepted = frame.accepted[0] if len(frame.accepted) == 1 else None
            self.accepted.visible = accepted is not None
            if accepted is not None:
                self.accepted.bottom, self.accepted.top = -accepted, accepted
        if frame.boxes is not None:
            for sources, fig, box, limits in zip(self.pose_sources, self.mechanism_figures, frame.boxes, frame.limits):
                fig.x_range.start, fig.x_range.end = box.lo[0], box.hi[0]
                fig.y_range.start, fig.y_range.end = box.lo[1], box.hi[1]
                put(sources["limits"], limits)
        self.show_poses(frame.poses)
        if layouts is not None:  # the plots made with their data: the browser sets no range on empty ones
            self.torque.object, self.mechanisms.object = layouts
            self.key.object = " &nbsp; ".join(f"{MARKS[mark]}&nbsp;{html.escape(words)}" for mark, words in frame.key)
        self.draws += 1

    def show_poses(self, poses: Poses) -> None:
        """Show the mechanisms at the angle of ``poses`` (of a design of the shape shown)."""
        if len(poses.columns) != len(self.pose_sources):
            return
        for sources, columns, fig, heading in zip(self.pose_sources, poses.columns, self.mechanism_figures,
                                                  poses.headings):
            for name in POSE_COLUMNS:
                put(sources[name], columns[name])
            fig.title.text = heading
        for source, ends in zip(self.end_sources, poses.ends):
            source.data = {"x": [e.x for e in ends], "y": [e.y for e in ends], "key": [e.key for e in ends]}

    def clear(self) -> None:
        """No plots (a spec with no design yet, or none that can be drawn)."""
        self.shape = None
        self.mechanisms.object = self.torque.object = None

    def _build(self, frame: Frame) -> tuple:
        """Make the plots for designs of ``frame``'s shape; returns their layouts (torque,
        mechanisms), to show once they have their data."""
        self.shape = frame.shape
        # the browser keeps the models replaced for a while: the names find the plots shown alone
        for model in [*self.torque_sources, *self.end_sources, *self.mechanism_figures,
                      *([self.torque_figure] if self.torque_figure is not None else []),
                      *(source for sources in self.pose_sources for source in sources.values())]:
            model.name = None
        return self._build_torque(frame), self._build_mechanisms(frame)

    def _build_torque(self, frame: Frame):
        self.torque_sources = [ColumnDataSource({c: [] for c in TORQUE_COLUMNS}, name=f"torque-{i + 1}")
                               for i in range(len(frame.torque))]
        if not self.torque_sources:
            self.torque_figure = None
            return None
        top = figure(min_width=TORQUE_WIDTH, height=TORQUE_HEIGHT, tools=TOOLS, y_axis_label="torque [N·mm]",
                     toolbar_location="above", sizing_mode="stretch_width", name="torque-plot")
        bottom = figure(min_width=TORQUE_WIDTH, height=ERROR_HEIGHT, tools=TOOLS, x_range=top.x_range,
                        x_axis_label="θ [deg]", y_axis_label="τ − τ_d [N·mm]", toolbar_location=None,
                        sizing_mode="stretch_width")
        items, self.band_renderers, self.friction_renderers, self.friction_items = [], [], [], []
        several = len(self.torque_sources) > 1
        for i, (source, name) in enumerate(zip(self.torque_sources, frame.shape[0])):
            colour = COLOURS[i % len(COLOURS)] if several else TORQUE_COLOUR
            band = top.varea(x="theta", y1="band_lo", y2="band_hi", source=source, fill_color=colour, fill_alpha=0.18)
            friction = top.varea(x="theta", y1="friction_lo", y2="friction_hi", source=source, fill_alpha=0.0,
                                 hatch_pattern="/", hatch_color=FRICTION_COLOUR, hatch_alpha=0.7)
            target = top.line("theta", "tau_d", source=source, color=TARGET_COLOUR, line_dash="dashed", line_width=1.5)
            tau = top.line("theta", "tau", source=source, color=colour, line_width=2)
            bottom.line("theta", "error", source=source, color=ERROR_COLOUR if not several else colour, line_width=1.5)
            self.band_renderers.append(band)
            self.friction_renderers.append(friction)
            named = f" ({name})" if several else ""
            self.friction_items.append(LegendItem(label="friction band [τ⁻, τ⁺]" if not several else
                                                  f"friction band{named}", renderers=[friction]))
            items += [LegendItem(label=f"target τ_d{named}", renderers=[target]),
                      LegendItem(label=f"τ{named}", renderers=[tau]),
                      LegendItem(label="tolerance band (built part, first order)" if not several else
                                 f"tolerance band{named}", renderers=[band]), self.friction_items[-1]]
        top.add_layout(Legend(items=items, location="top_left", label_text_font_size="8pt", click_policy="hide",
                              background_fill_alpha=0.7))
        self.accepted = BoxAnnotation(fill_color=ACCEPTED_COLOUR, fill_alpha=0.15, visible=False)
        bottom.add_layout(self.accepted)
        bottom.add_layout(Span(location=0, dimension="width", line_color="grey", line_width=1))
        top.title.text_font_size = "10pt"
        for fig in (top, bottom):  # torques of a pendulum reach 1e5 N·mm: written out, not as powers of ten
            fig.yaxis.formatter = BasicTickFormatter(power_limit_high=7, power_limit_low=-4)
        # the ranges fit in the browser to each new curve: were they sent back, each slider step
        # would bring the server two messages to read before the next step's
        for axis_range in (top.x_range, top.y_range, bottom.y_range):
            axis_range.syncable = False
        self.torque_figure = top
        return column(top, bottom, sizing_mode="stretch_width")

    def _build_mechanisms(self, frame: Frame):
        count = len(frame.poses.columns)
        side = MECHANISM_SIDE if count == 1 else int((TORQUE_HEIGHT + ERROR_HEIGHT + 40) / count)
        self.pose_sources, self.end_sources, self.mechanism_figures = [], [], []
        for u in range(count):
            fig = figure(width=side, height=side, tools=TOOLS, match_aspect=True, x_range=Range1d(-1, 1), name=f"mechanism-{u + 1}",
                         y_range=Range1d(-1, 1), x_axis_label="x [mm]", y_axis_label="y [mm]",
                         toolbar_location="above")
            fig.title.text_font_size = "10pt"
            sources = {name: ColumnDataSource({c: [] for c in columns}, name=f"mechanism-{u + 1}-{name}")
                       for name, columns in POSE_COLUMNS.items()}
            sources["limits"] = ColumnDataSource({"x": [], "y": [], "r": []})
            fig.circle("x", "y", radius="r", source=sources["limits"], fill_alpha=0, line_color="grey",
                       line_dash="dotted")
            fig.multi_line("xs", "ys", source=sources["arm"], line_color="grey", line_width=6, line_alpha=0.45)
            fig.scatter("x", "y", source=sources["mass"], size=14, color="#4d4d4d")
            fig.text("x", "y", text="words", source=sources["mass"], text_font_size="8pt", x_offset=6, y_offset=-4)
            fig.multi_line("xs", "ys", source=sources["outline"], line_color="colour", line_alpha=0.55)
            fig.multi_line("xs", "ys", source=sources["wound"], line_color="colour", line_width=3.5)
            fig.multi_line("xs", "ys", source=sources["springs"], line_color=SPRING_COLOUR, line_width=1.5)
            fig.multi_line("xs", "ys", source=sources["cable"], line_color=CABLE_COLOUR, line_width=1.8)
            fig.circle("x", "y", radius="r", source=sources["idlers"], fill_alpha=0, line_color="#404040",
                               line_dash="dashed")
            fig.scatter("x", "y", source=sources["points"], size=9, fill_color="white", line_color=SPRING_COLOUR,
                        line_width=1.5)
            fig.scatter("x", "y", source=sources["anchors"], marker="square", size=7, color="black")
            fig.scatter("x", "y", source=sources["contacts"], size=8, color="#d62728")
            fig.scatter("x", "y", source=sources["binding"], marker="x", size=13, line_width=2.5,
                                color="crimson")
            fig.scatter([0], [0], marker="cross", size=12, color="black")
            ends = ColumnDataSource({"x": [], "y": [], "key": []}, name=f"mechanism-{u + 1}-ends")
            if frame.poses.ends[u]:
                handle = fig.scatter("x", "y", source=ends, size=16, fill_color=SPRING_COLOUR, fill_alpha=0.35,
                                     line_color=SPRING_COLOUR, line_width=2)
                tool = PointDrawTool(renderers=[handle], add=False, drag=True, description="drag the spring end")
                fig.add_tools(tool)
                fig.toolbar.active_drag = tool
                ends.on_change("data", self._ends_changed)
                fig.on_event(PanEnd, lambda event, source=ends: self._ends_released(source))
            self.pose_sources.append(sources)
            self.end_sources.append(ends)
            self.mechanism_figures.append(fig)
        return column(*self.mechanism_figures) if count > 1 else self.mechanism_figures[0]

    # ----------------------------------------------------------------------------- handles
    def _ends_changed(self, attr, old, new) -> None:
        """A handle moved in the browser (or the page drew the ends again: then no end moved)."""
        self._moved(new, old, final=False)

    def _ends_released(self, source: ColumnDataSource) -> None:
        self._moved(source.data, None, final=True)

    def _moved(self, new: dict, old: dict | None, final: bool) -> None:
        for i, key in enumerate(new.get("key", [])):
            x, y = float(new["x"][i]), float(new["y"][i])
            if old is not None and i < len(old.get("x", [])) and (float(old["x"][i]), float(old["y"][i])) == (x, y):
                continue
            self.on_end_moved(key, x, y, final)


def put(source: ColumnDataSource, data: dict) -> None:
    """Put ``data`` in ``source``, sending the browser only the columns that changed where the
    columns and their lengths stay (a design while a slider moves changes the torque, not the
    angles or the target), else the whole data; small arrays as lists (:func:`sent`)."""
    old = source.data
    if set(old) != set(data) or any(len(old[c]) != len(v) for c, v in data.items()):
        source.data = {c: sent(v) for c, v in data.items()}
        return
    changed = {c: sent(v) for c, v in data.items() if not _same(old[c], v)}
    if changed:
        source.data.update(changed)


def sent(column):
    """``column`` as the browser is sent it: a number array of at most :data:`INLINE_VALUES`
    values as a list (in the message's text), a larger one as it is (a binary buffer); a list
    of curves, each so."""
    if isinstance(column, np.ndarray):
        return column.tolist() if column.size <= INLINE_VALUES else column
    return [sent(v) if isinstance(v, np.ndarray) else v for v in column]


def _same(a, b) -> bool:
    """Whether two columns hold the same values: a number array, a list of words, or a list of
    arrays (a curve's coordinates)."""
    if isinstance(b, np.ndarray) or isinstance(a, np.ndarray):
        return np.array_equal(a, b)
    return len(a) == len(b) and all(np.array_equal(x, y) if isinstance(y, np.ndarray) else x == y
                                    for x, y in zip(a, b))


__all__ = ["Frame", "LiveView", "Poses", "put", "sent"]
