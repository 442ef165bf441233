"""The design page: a Panel page on the Bokeh server (:func:`serve`), one per browser tab.

On the left the template or file opened and the form generated from the spec's declarations
(:mod:`cadcam.app.form`); an edited field is applied when it is left or Enter is pressed, and the
spec is designed again at once, in a worker thread, through the tab's :class:`cadcam.Session`
(the NLP built once per structure, warm from the last answer and its multipliers; its functions
as the spec says, by default expanded for a structure's first design while they compile in the
background, then compiled: :meth:`cadcam.solve.transcription.Transcription.adopt_compiled`).
The quantities a designer turns have a slider beside their field (:func:`cadcam.app.form.slider_of`):
while one moves, each step is designed warm from the last answer and drawn as it comes, the
steps passed while a design ran dropped (:class:`cadcam.app.latest.Latest`: only the newest is
designed); when it is let go, the design is made as after a typed edit, with the tolerance and
friction bands, the summary, the catalogue's lights and the springs' figure. Undo and redo step
through the designs the tab made from the file open (:mod:`cadcam.app.history`).

On the right, in a panel that stays in view while the form scrolls: the verdict line, what binds
and what the spec's values warn of, above the live view (:mod:`cadcam.app.live`): each mechanism
at the joint angle of the player below it, the spring end a mechanism places drawn as a handle
to drag, and the torque against its target with the error, the tolerance band and the friction
band, all drawn in the browser by Bokeh from data a design replaces in place. Under it the
summary, the springs' extensions against their travel, the spring catalogue with a feasibility
light per spring, and the files to download, each named after the file open
(:func:`cadcam.app.state.download_stem`). An input error is the command line's one
line, shown under the field it names. A joint's tabulated target has an editor of its own
(:mod:`cadcam.app.tables`): its angles' unit, its rows edited in place or pasted from a
spreadsheet, each change designed at once. A field that is another's quantity (Fedorov2018's
output law repeats its pendulum and springs) follows that other, and says so.

The catalogue table (:mod:`cadcam.app.parts`) lights each spring of one spring's catalogue for the
spec as edited now: by the catalogue's screen, before each design (milliseconds), and by the
verdict of each design the tab has made with a part under the same edits. Clicking a row makes
that spring the part and designs with it.

Every callback of the page (an edit, a slider, a handle, a catalogue pick or row, a template, an
upload, the player, undo, a download, the first design) runs through one guard
(:meth:`DesignPage.guarded`): what it raises
is shown as one line on the page (:func:`one_line`: control characters escaped, no folder
named) and logged as one line, never left to the server as a traceback; what the page shows
names no folder of the server, and an uploaded file by the browser's name for it
(:func:`scrubbed`). An upload, a spec with the CSV files it names (:mod:`cadcam.app.uploads`), is
written under names of the page's own to a folder of its own, removed once another file or a
template replaces it and when the tab's session ends or the server stops; the names the spec
gives are looked up among the files uploaded with it, never on the server's disk. The server
answers only to the address it serves on (:mod:`cadcam.app.hosts`).

Everything the page loads comes from this server: Bokeh's and Panel's scripts are served from it
(``resources="server"``), the plots' data and the springs' figure (a PNG image) come over its
socket.
"""
from __future__ import annotations

import asyncio
import contextlib
import functools
import inspect
import io
import logging
import re
import shutil
import signal
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
import panel as pn
from bokeh.models import PrintfTickFormatter
from matplotlib.figure import Figure
from panel.io.document import unlocked
from panel.io.state import set_curdoc

from .. import examples
from ..library_files import matplotlib_defaults
from ..make.step import available as step_available
from ..outputs.plots import springs_figure
from ..physics.catalogue import Need
from ..spec import SpecError
from ..targets import ANGLE_UNITS
from .state import (INPUT_ERRORS, TEMPLATES, DesignState, Outcome, Request, catalogue, download_stem, part_name,
                    result_json, zipped)
from .form import Field, Slider, slider_of, table_title, value_text
from .history import Edits
from .latest import Latest
from .live import LiveView
from .tables import TORQUE_UNIT
from .uploads import save as save_upload, shown as shown_name
from .parts import LIGHTS, NUMBERS, columns, count_line, part_lines, titles
from .views import dragged_end
from .hosts import refuse_other_hosts, served_hosts

log = logging.getLogger(__name__)

#: One worker: designs run one after another, whichever tab asked (the builds are shared).
WORKER = ThreadPoolExecutor(max_workers=1, thread_name_prefix="cadcam-design")

#: Resolution of the figures on the page [dots per inch].
PAGE_DPI = 100
#: Longest message the page shows for a failure [characters]: an error quoting a 5,000-digit
#: field stays a line a person reads.
MESSAGE_CHARS = 300
#: Start of the name of each uploaded file's folder, in the system's temporary folder.
UPLOAD_PREFIX = "cadcam-app-open-"
#: The verdict line while a design runs.
DESIGNING = "<span class='solving'>designing…</span>"
#: The verdict line of a design made while a slider moves (provisional: not re-checked on the fine grid).
MOVING = ("<small>(moving: the fine re-check, the bands, the summary and the lights follow when it is let go "
          "or rests)</small>")
#: How long a slider held still rests before its design is made in full, re-checked [s].
RESTING_S = 2.0
#: Width of the form's column [px].
FORM_WIDTH = 430
#: Units a slider shows no word for (a share, a number without a unit).
UNITLESS = ("", "-", "ratio")
#: The player's step through the joint angles [ms].
PLAYER_INTERVAL = 120
#: Rows of the catalogue table on one page: the table sends the browser that page alone.
CATALOGUE_ROWS = 15
#: The spring choice of the form for the spec's own spring.
OWN_SPRING = "the spec's spring"
#: Height of a table target's rows in its editor [px]: about eight rows, the others scrolled to.
TABLE_HEIGHT = 250
#: What the box a table is pasted into says while empty.
PASTE_HINT = ("paste two columns from a spreadsheet: angle, torque [N·m]; a header naming deg or rad sets the "
              "angles' unit")

#: Upload folders not yet removed (by any tab): the server removes those left when it stops.
_UPLOADS: set[Path] = set()
#: The folders of an absolute path in a message (POSIX, or a Windows drive's), not preceded by
#: a word: the page names a file by its name alone.
_FOLDERS = re.compile(r"(?<![\w.~-])(?:[A-Za-z]:)?[\\/](?:[^\\/\s'\"]+[\\/])+")

CSS = """
.field-error { color: #b00020; font-size: 12px; margin: -4px 10px 6px 10px; }
.verdict-success { color: #1b5e20; font-weight: bold; }
.verdict-failure { color: #b00020; font-weight: bold; }
.verdict-provisional { color: #8a6100; font-weight: bold; }
.page-error { color: #b00020; }
.catalogue-line { font-size: 13px; }
.verdict-lines { font-size: 12px; line-height: 1.3; }
.verdict-lines ul { margin: 0; padding-left: 18px; }
"""
#: The page's two columns, each its own scroll: the form, and the live view with what is under it,
#: the live view staying at the top of its column while what is under it scrolls.
COLUMN_STYLE = {"height": "100vh", "overflow-y": "auto"}
LIVE_STYLE = {"position": "sticky", "top": "0", "z-index": "10", "background": "white",
              "border-bottom": "1px solid #ddd"}


class PageError(Exception):
    """A request the page cannot do, said in one line (a download before any design)."""


def one_line(text: str, limit: int = MESSAGE_CHARS) -> str:
    """``text`` as one line the page shows: the folders of absolute paths left out, control and
    other unprintable characters escaped (a newline as ``\\n``), cut to ``limit`` characters."""
    text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in _FOLDERS.sub("", text))
    return text if len(text) <= limit else text[:limit - 1] + "…"


def public(message: str, names: dict[str, str], folders=()) -> str:
    """``message`` as one line (:func:`one_line`) naming no folder of the server
    (:func:`scrubbed`)."""
    return one_line(scrubbed(message, names, folders))


def scrubbed(text: str, names: dict[str, str], folders=()) -> str:
    """``text`` with each file of ``names`` (path → name) named by its name (what the page
    shows for it: an upload by the browser's name for it), and the server's folders and those of
    ``folders`` left out (each with the folders under it: a folder's name may hold blanks, which
    :func:`one_line` stops at), its lines kept."""
    for path in sorted(names, key=len, reverse=True):
        text = text.replace(path, names[path])
    for folder in sorted({str(f) for f in (*server_folders(), *folders)}, key=len, reverse=True):
        text = re.sub(re.escape(folder) + r"[\\/](?:[^\\/'\"\n:]*[\\/])*", "", text)
    return text


def server_folders() -> list[Path]:
    """The folders of the server a message may name: where cadcam is, where it runs, the
    user's home and the temporary folder (as given and resolved)."""
    folders = [resolved(Path(__file__)).parents[2], Path.cwd(), Path.home(), Path(tempfile.gettempdir())]
    return [f for folder in folders for f in (folder, resolved(folder)) if len(f.parts) > 1]


@functools.lru_cache(maxsize=64)
def resolved(path: Path) -> Path:
    """``path`` resolved (:meth:`pathlib.Path.resolve`), once per path: a resolution reads
    each folder of the path from the file system, and the page scrubs each line it shows
    (the verdict and what binds, at every slider step) of the same few folders."""
    return path.resolve()


def failure_line(action: str, exc: BaseException, line=one_line) -> str:
    """The one line saying that ``action`` failed with ``exc``: an input error's own words (they
    name what is wrong), else the action and the kind of error; made a line by ``line``."""
    if isinstance(exc, (*INPUT_ERRORS, PageError)):
        return line(str(exc))
    return line(f"{action} failed: {type(exc).__name__}: {exc}")


def slug(key: str) -> str:
    """A CSS class name for a dotted key (``springs.1.rate`` → ``springs-1-rate``)."""
    return re.sub(r"[^a-z0-9]+", "-", key.lower()).strip("-")


@matplotlib_defaults()
def png(fig: Figure, dpi: int = PAGE_DPI) -> bytes:
    """``fig`` as PNG bytes."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    return buffer.getvalue()


class Download(pn.widgets.FileDownload):
    """A download whose callback gives None when it failed (:meth:`DesignPage.guarded` has said
    why): nothing is sent, where Panel would raise."""

    def _sync_data(self, fileobj):
        if fileobj is not None:
            super()._sync_data(fileobj)


class _AtOnce:
    """A slider whose moves reach the page as they come: Panel gathers a widget's changes for 50 ms
    before it hands them on (``Syncable._debounce``), half a slider step's goal; the page drops
    the steps it has no time for itself (:class:`cadcam.app.latest.Latest`)."""

    _priority_changes = ["value", "value_throttled"]


class FloatSlider(_AtOnce, pn.widgets.FloatSlider):
    """Panel's FloatSlider, its moves handed on at once (:class:`_AtOnce`)."""


class IntSlider(_AtOnce, pn.widgets.IntSlider):
    """Panel's IntSlider, its moves handed on at once (:class:`_AtOnce`)."""


class RangeSlider(_AtOnce, pn.widgets.RangeSlider):
    """Panel's RangeSlider, its moves handed on at once (:class:`_AtOnce`)."""


class DesignPage:
    """One tab's page over one :class:`DesignState`."""

    def __init__(self, state: DesignState):
        self.state = state
        self.name = state.path.name  # what the page calls the file open: an upload by the browser's name
        self.folder: Path | None = None  # the upload folder of the file open, if uploaded
        self.given_tables: tuple[str, ...] = ()  # the names of the CSV files uploaded with it
        self.inputs: dict[str, pn.widgets.TextInput] = {}
        self.errors: dict[str, pn.pane.HTML] = {}
        self.headings: dict[int, pn.pane.HTML] = {}  # each spring's, by its number
        self.spring_picks: dict[int, pn.widgets.Select] = {}  # each spring's choice, by its number
        self.table_widgets: dict[str, tuple] = {}  # each table target's unit and rows, by its key
        self.sliders: dict[str, list] = {}  # each turned field's slider (a point's one per coordinate), by its key
        self.slider_kinds: dict[str, Slider] = {}  # what each slider spans now
        self._shown = 0  # designs asked for: only the last one's figures are shown
        self._asked: Edits | None = None  # the edits of the last design asked for as made (not while moving)
        self._error_key: str | None = None  # the field whose error is shown
        self._moving: str | None = None  # the field a slider or handle moves now (what its design names)
        self._resting: asyncio.Task | None = None  # the full design of a slider held still, once it rests
        self.template = pn.widgets.Select(name="Template", options=self._template_options(),
                                          value=self._template_option(), css_classes=["template"],
                                          sizing_mode="stretch_width")
        self.template.param.watch(self.guarded("opening the template", self._on_template), "value")
        self.upload = pn.widgets.FileInput(accept=".toml,.json,.csv", multiple=True, css_classes=["open-file"],
                                           sizing_mode="stretch_width")
        self.upload.param.watch(self.guarded("opening the file", self._on_upload), ["value", "filename"])
        self.open_error = pn.pane.HTML("", css_classes=["field-error", "open-error"])
        self.opened = pn.pane.HTML("", css_classes=["opened"])
        self.failure = pn.pane.HTML("", css_classes=["page-error"], visible=False, sizing_mode="stretch_width")
        self.form = pn.Column(sizing_mode="stretch_width")
        self.verdict = pn.pane.HTML("", css_classes=["verdict"], sizing_mode="stretch_width")
        self.lines = pn.pane.HTML("", css_classes=["verdict-lines"], sizing_mode="stretch_width", margin=(0, 10))
        self.details = pn.pane.HTML("", css_classes=["details"], sizing_mode="stretch_width")
        self.springs = pn.pane.PNG(None, css_classes=["springs-figure"], width=740)
        self.live = LiveView(self._on_end_moved)
        self.player = pn.widgets.Player(name="joint angle", start=0, end=1, value=0, interval=PLAYER_INTERVAL,
                                        loop_policy="loop", show_loop_controls=False, css_classes=["pose-player"],
                                        width=420)
        self.player.param.watch(self.guarded("drawing the mechanism", self._on_pose), "value")
        self._moves = Latest(self.guarded("designing as the slider moves", self._design_moving))
        self._poses = Latest(self.guarded("drawing the mechanism", self._draw_pose))
        self.undo = pn.widgets.Button(label="↶ undo", css_classes=["undo"], disabled=True, width=80)
        self.redo = pn.widgets.Button(label="↷ redo", css_classes=["redo"], disabled=True, width=80)
        self.undo.on_click(self.guarded("stepping back", self._on_undo))
        self.redo.on_click(self.guarded("stepping forth", self._on_redo))
        self.history_line = pn.pane.HTML("", css_classes=["history-line"], margin=(12, 6))
        self.doc = None  # the tab's Bokeh document, whose plots' data the page replaces (:meth:`drawing`)
        self._named: list[tuple[Download, str]] = []  # each download button and the end of its file's name
        self.downloads = pn.Row(*self._download_buttons(), css_classes=["downloads"])
        self.spring_slot = pn.widgets.Select(name="the catalogue of", css_classes=["catalogue-slot"], width=400)
        self.catalogue_line = pn.pane.HTML("", css_classes=["catalogue-line"], sizing_mode="stretch_width")
        self.catalogue_table = self._catalogue_table()
        self._build_form()
        self._show_opened()
        self.spring_slot.param.watch(self.guarded("showing the catalogue", self._on_slot), "value")

    # ----------------------------------------------------------------------------- layout
    def view(self) -> pn.Row:
        """The page: the form's column, and the live view's, each its own scroll."""
        left = pn.Column(pn.pane.HTML("<h2>cadcam design page</h2>"), self.template,
                         pn.pane.HTML("<small>or open a spec (TOML) or a result.json, with the CSV files it names "
                                      "(choose them together):</small>"), self.upload,
                         self.open_error, self.opened, self.form, width=FORM_WIDTH, styles=COLUMN_STYLE,
                         css_classes=["form-column"])
        live = pn.Column(self.failure, self.verdict, self.lines,
                         pn.Row(self.undo, self.redo, self.history_line, self.downloads),
                         pn.Row(pn.Column(self.live.mechanisms, self.live.key, self.player), self.live.torque,
                                sizing_mode="stretch_width"),
                         styles=LIVE_STYLE, css_classes=["live-panel"], sizing_mode="stretch_width")
        under = pn.Tabs(("Summary", self.details), ("Springs", self.springs),
                        ("Spring catalogue", pn.Column(self.spring_slot, self.catalogue_line, self.catalogue_table,
                                                       sizing_mode="stretch_width")),
                        dynamic=False, sizing_mode="stretch_width")
        right = pn.Column(live, under, styles=COLUMN_STYLE, sizing_mode="stretch_width", css_classes=["live-column"])
        return pn.Row(left, right, sizing_mode="stretch_width")

    def _template_title(self) -> str | None:
        here = (self.state.path.stem, self.state.variant)
        return next((t.title for t in TEMPLATES if (t.spec, t.variant) == here and self.folder is None), None)

    def _template_options(self) -> list[str]:
        """The templates, after the file open where it is none of them."""
        titles = [t.title for t in TEMPLATES]
        return titles if self._template_title() else [self._template_option(), *titles]

    def _template_option(self) -> str:
        """The choice of template naming what is open: its title, else the file's name."""
        return self._template_title() or f"{one_line(self.name)} (the file open)"

    def _build_form(self) -> None:
        """One card per group of fields, the fields of each numbered table under its name."""
        self.inputs.clear()
        self.errors.clear()
        self.headings.clear()
        self.spring_picks.clear()
        self.table_widgets.clear()
        self.sliders.clear()
        self.slider_kinds.clear()
        cards: dict[str, list] = {}
        heading = None
        for f in self.state.fields:
            items = cards.setdefault(f.group, [])
            title = table_title(f.key, self.state.table_names())
            if title and title != heading and f.group in ("Springs", "Geometry", "Target and range"):
                table = ".".join(f.key.split(".")[:2])
                head = pn.pane.HTML(_heading(title), margin=(8, 10, 0, 10), css_classes=[f"heading-{slug(table)}"])
                items.append(head)
                if f.group == "Springs":
                    number = int(f.key.split(".")[1])
                    self.headings[number] = head
                    items.append(self._catalogue_pick(number))
                if f.group == "Target and range" and f"{table}.target" in self.state.tables:
                    items.append(self._table_editor(f"{table}.target"))
            heading = title
            box = pn.widgets.TextInput(name=f.label, value=f.text, description=f.help,
                                       placeholder="default", css_classes=["field", f"field-{slug(f.key)}"],
                                       sizing_mode="stretch_width")

            async def edited(event, key=f.key):  # a coroutine function, which param awaits
                await self._on_edit(key, event.new)

            box.param.watch(self.guarded(f"applying {f.key}", edited), "value")
            error = pn.pane.HTML("", css_classes=["field-error", f"error-{slug(f.key)}"], visible=False,
                                 sizing_mode="stretch_width")
            self.inputs[f.key], self.errors[f.key] = box, error
            slider = self._slider(f)
            items += [box if slider is None else pn.Row(box, slider, sizing_mode="stretch_width"), error]
        self.form.objects = [pn.Card(*items, title=group, collapsed=group in ("Solver", "Workshop files"),
                                     sizing_mode="stretch_width") for group, items in cards.items()]
        self._show_set_keys()
        self._show_slots()
        self.spring_slot.visible = len(self.state.springs) > 1

    def _show_slots(self) -> None:
        """The springs the catalogue table may be of, each named as the form names it."""
        numbers = sorted(self.state.springs)
        self.spring_slot.param.update(  # both at once, the choice kept where it still is one
            options={_numbered(n, self.state.table_names()[f"springs.{n}"]): n for n in numbers},
            value=self.spring_slot.value if self.spring_slot.value in numbers else next(iter(numbers), None))

    def _show_set_keys(self) -> None:
        """Disable the fields that the design method now chosen, or a spring's catalogue part,
        sets itself, and those in step with another field, saying so in their labels
        (:meth:`DesignState.set_by_method`, :meth:`DesignState.set_by_part`,
        :attr:`DesignState.links`)."""
        for f in self.state.fields:
            method, part = self.state.set_by_method(f.key), self.state.set_by_part(f.key)
            leader = self.state.links.get(f.key)
            box = self.inputs[f.key]
            box.disabled = method is not None or part is not None or leader is not None
            for slider in self.sliders.get(f.key, []):
                slider.disabled = box.disabled
            box.name = (f"{f.label}: set by method {method}" if method is not None
                        else f"{f.label}: set by part {part}" if part is not None
                        else f"{f.label}: kept equal to {self._named_field(leader)}" if leader is not None
                        else f.label)

    def _named_field(self, key: str) -> str:
        """Field ``key`` as another field's label names it: its key within its table (no unit)
        and the table, a joint by its name, a spring by its number (its name may be long):
        ``target.mass of pendulum``, ``rate of spring 1``."""
        label = self.state.field(key).label.split(" [")[0]
        table, number = key.split(".")[:2]
        return f"{label} of {f'spring {number}' if table == 'springs' else table_title(key, self.state.table_names())}"

    def _show_values(self, keys=None) -> None:
        """Fields ``keys`` (default: all) show their values now (a spring chosen, a field in step
        with one edited)."""
        for key in self.inputs if keys is None else keys:
            self.inputs[key].value = value_text(self.state.value(key))
        self._show_sliders(keys)

    # ----------------------------------------------------------------------------- sliders
    def _slider(self, f: Field) -> pn.Column | None:
        """The slider of field ``f`` (:func:`cadcam.app.form.slider_of`) about its value now,
        showing its value and unit; None for a field a designer does not turn. Moved, each
        step is designed as it comes; let go, the design is made in full."""
        value = self.state.value(f.key)
        kind = slider_of(f, value)
        if kind is None:
            return None
        unit = "" if kind.unit in UNITLESS else f" {kind.unit}"
        common = dict(step=kind.step, format=PrintfTickFormatter(format=f"%.4g{unit}"), sizing_mode="stretch_width",
                      margin=(4, 10, 0, 10))
        if kind.kind == "range":
            widgets = [RangeSlider(label="", start=kind.start, end=kind.end, value=tuple(value), **common)]
        elif kind.kind == "point":
            widgets = [FloatSlider(label=axis, start=lo, end=hi, value=v, **common)
                       for axis, (lo, hi), v in zip("xy", kind.spans, value)]
        elif kind.kind == "integer":
            widgets = [IntSlider(label="", start=int(kind.start), end=int(kind.end), value=int(value), **common)]
        else:
            widgets = [FloatSlider(label="", start=kind.start, end=kind.end, value=float(value), **common)]

        async def moved(event, key=f.key):
            if not self._shows_its_field(key):  # else the page showing the field's value, no move
                await self._turn(key, self._slider_value(key), final=False)

        async def released(event, key=f.key):
            await self._turn(key, self._slider_value(key), final=True)

        for w in widgets:
            w.param.watch(self.guarded(f"moving {f.key}", moved), "value")
            w.param.watch(self.guarded(f"setting {f.key}", released), "value_throttled")
        self.sliders[f.key], self.slider_kinds[f.key] = widgets, kind
        return pn.Column(*widgets, css_classes=["slider", f"slider-{slug(f.key)}"], sizing_mode="stretch_width")

    def _slider_value(self, key: str):
        """The value field ``key``'s slider shows, as the field takes it (a step's binary noise
        rounded off)."""
        kind, widgets = self.slider_kinds[key], self.sliders[key]
        if kind.kind == "range":
            return [kind.snapped(v) for v in widgets[0].value]
        if kind.kind == "point":
            return [kind.snapped(w.value) for w in widgets]
        return int(widgets[0].value) if kind.kind == "integer" else kind.snapped(widgets[0].value)

    def _shows_its_field(self, key: str) -> bool:
        """Whether field ``key``'s slider shows the field's value as it is (not rounded to its
        step): the page set it so."""
        kind, widgets, value = self.slider_kinds[key], self.sliders[key], self.state.value(key)
        shown = list(widgets[0].value) if kind.kind == "range" else [w.value for w in widgets]
        return shown == (list(value) if isinstance(value, list) else [value])

    def _show_sliders(self, keys=None) -> None:
        """Sliders of fields ``keys`` (default: all) show their fields' values now, each spanning
        them anew where a value lies beyond its span (typed, or a spring picked); not a value its
        key refuses."""
        for key in self.sliders if keys is None else [k for k in keys if k in self.sliders]:
            value, kind, widgets = self.state.value(key), self.slider_kinds[key], self.sliders[key]
            if not self.state.field(key).declaration.ok(value):
                continue  # a value the key refuses (its error is under the field): the slider stays
            shown = value if isinstance(value, list) else [value]
            spans = kind.spans if kind.kind == "point" else [(kind.start, kind.end)] * len(shown)
            if not all(isinstance(v, (int, float)) and lo <= v <= hi for v, (lo, hi) in zip(shown, spans)):
                anew = slider_of(self.state.field(key), value)
                if anew is None:
                    continue  # a value no slider shows (an expression): the field says it
                self.slider_kinds[key] = kind = anew
                for w, (lo, hi) in zip(widgets, kind.spans if kind.kind == "point" else [(kind.start, kind.end)]):
                    w.param.update(start=lo, end=hi, step=kind.step)
            if kind.kind == "range":
                widgets[0].value = tuple(value)
            else:
                for w, v in zip(widgets, shown):
                    w.value = v

    async def _turn(self, key: str, value, final: bool) -> None:
        """Field ``key`` turned to ``value`` by its slider or handle: the field follows; while it
        moves the newest step is designed as it comes, and when it is let go the design is
        made in full (none where the edits are those of the design shown)."""
        text = value_text(value)
        turned = text != value_text(self.state.value(key))
        if turned:
            error = self.state.edit(key, text)
            if error:
                self._show_error(key, error)
                return
        elif not final:
            return  # the page showing a value (a typed edit, a step back): no move
        moving = not final and self.state.edits() != self._asked
        if moving:
            self._moving = key
            self._rest(None)
            self._moves.ask()
        if turned and moving:  # shown once the step's design has gone to the worker, while it designs
            asyncio.get_running_loop().call_soon(self.guarded(f"moving {key}", self._show_turned), key)
        elif turned:
            self._show_turned(key)
        if final:
            self._moves.drop()
            if self.state.edits() != self._asked:
                await self.design(edited=key)

    def _show_turned(self, key: str) -> None:
        """Field ``key`` turned: it, its slider and those in step with it show their values, in
        one message (else a message each, whose making would hold a slider's step back)."""
        with self.drawing():
            self._show_error(None, None)
            self._show_values([key, *(k for k, leader in self.state.links.items() if leader == key)])

    def _rest(self, key: str | None) -> None:
        """Forget the full design of a slider at rest asked for, if any; with ``key``, ask it
        anew: in :data:`RESTING_S`, field ``key`` designed in full unless it moves again
        first (the provisional design shown re-checked while the slider is held still)."""
        if self._resting is not None:
            self._resting.cancel()
        self._resting = None if key is None else asyncio.ensure_future(self._at_rest(key))

    async def _at_rest(self, key: str) -> None:
        await asyncio.sleep(RESTING_S)
        self._resting = None
        if self.state.edits() != self._asked:
            await self.guarded(f"setting {key}", self.design)(edited=key)

    async def _design_moving(self) -> None:
        """Design the edits now, while a slider moves (:class:`cadcam.app.latest.Latest`: the
        steps passed meanwhile were dropped), and draw it unless a full design was asked for
        since; its bands, summary and lights come with the design made when it is let go."""
        if self.state.edits() == self._asked:
            return  # asked for in full meanwhile
        shown, key = self._shown, self._moving
        request = self.state.ask(key)
        outcome, frame = await self._in_worker(self._moving_design, request, key, self.player.value, set(self.inputs))
        if shown != self._shown:
            return
        self._rest(key)
        if outcome.error is not None:
            self._show_error(outcome.field, outcome.error)
            self.verdict.object = self._verdict(outcome)
            return
        self._show_error(None, None)
        with self.drawing():  # the curves first, the lines above them in the same message
            self.live.draw(frame)
            self.verdict.object = self._verdict(outcome) + " " + MOVING
            self.lines.object = self._lines(outcome.result)

    def _moving_design(self, request: Request, key: str | None, pose: int, keys: set[str]):
        """(In the worker.) The provisional design of ``request`` (no fine re-check,
        :meth:`cadcam.app.state.DesignState.run`) and what the live view draws of it at ``pose``
        (with the handles of the fields ``keys``), without the bands and view boxes."""
        outcome = self.state.run(request, key, recheck=False)
        frame = None if outcome.result is None else LiveView.frame(outcome.result, pose, keys, bands=False,
                                                                    views=False)
        return outcome, frame

    def _on_end_moved(self, key: str, x: float, y: float, final: bool) -> None:
        """A spring end's handle dragged to (x, y) [mm] in the view: its field turned
        (:func:`cadcam.app.views.dragged_end`: at the angle shown)."""
        result = self.state.result
        if result is None:
            return
        u = int(key.split(".")[1]) - 1
        unit = result.evaluation.units[u]
        theta = float(unit.theta[int(np.clip(self.player.value, 0, unit.theta.size - 1))])
        value = dragged_end(result.problem, u, theta, x, y)
        turn = self.guarded(f"moving {key}", self._turn)
        asyncio.ensure_future(turn(key, value, final))

    # ----------------------------------------------------------------------- table targets
    def _table_editor(self, key: str) -> pn.Column:
        """The editor of table target ``key`` (``joints.1.target``): the unit of its angles, its
        rows (a cell edited in place) and a box to paste rows into from a spreadsheet; each
        change is designed at once. Its error shows under it."""
        name = slug(key)
        unit = pn.widgets.RadioButtonGroup(options=list(ANGLE_UNITS), css_classes=[f"table-unit-{name}"],
                                           margin=(4, 10))
        rows = pn.widgets.Tabulator(pd.DataFrame(columns=["angle", "torque"]), show_index=False,
                                    layout="fit_columns", height=TABLE_HEIGHT, sizing_mode="stretch_width",
                                    css_classes=["target-table", f"table-{name}"])
        paste = pn.widgets.TextAreaInput(placeholder=PASTE_HINT, height=70, sizing_mode="stretch_width",
                                         css_classes=[f"table-paste-{name}"])
        use = pn.widgets.Button(label="use the rows pasted", css_classes=[f"table-use-{name}"], margin=(4, 10))
        self.table_widgets[key] = (unit, rows)
        self._show_table(key)

        async def unit_chosen(event):
            if event.new != self.state.table(key).unit:  # not the page showing a table's own unit
                await self._table_changed(key, self.state.edit_table(key, unit=event.new))

        async def cell_edited(event):
            now = rows.value
            await self._table_changed(key, self.state.edit_table(key, rows=list(zip(now["angle"], now["torque"]))))

        async def pasted(event):
            error = self.state.paste_table(key, paste.value_input or paste.value or "", unit.value)
            if error is None:
                paste.param.update(value="", value_input="")
            await self._table_changed(key, error)

        unit.param.watch(self.guarded(f"setting the unit of {key}", unit_chosen), "value")
        rows.on_edit(self.guarded(f"editing {key}", cell_edited))
        use.on_click(self.guarded(f"pasting {key}", pasted))
        self.errors[key] = pn.pane.HTML("", css_classes=["field-error", f"error-{name}"], visible=False,
                                        sizing_mode="stretch_width")
        return pn.Column(pn.pane.HTML("<small>target table: the angles in</small>", margin=(6, 10, 0, 10)), unit,
                         rows, paste, use, self.errors[key], sizing_mode="stretch_width",
                         css_classes=[f"table-editor-{name}"])

    def _show_table(self, key: str) -> None:
        """Table target ``key``'s editor shows its rows and unit now."""
        unit, rows = self.table_widgets[key]
        table = self.state.table(key)
        unit.value = table.unit
        rows.param.update(value=pd.DataFrame(list(table.rows), columns=["angle", "torque"]),
                          titles={"angle": f"angle [{table.unit}]", "torque": f"torque [{TORQUE_UNIT}]"})

    async def _table_changed(self, key: str, error: str | None) -> None:
        """Show table target ``key`` as edited and design; or show ``error``, the edit's."""
        if error is not None:
            self._show_error(key, error)
            return
        self._show_error(None, None)
        self._show_table(key)
        await self.design(edited=key)

    def _catalogue_pick(self, number: int) -> pn.widgets.Select:
        """A choice of spring ``number``: the spec's, one of the papers' catalogue, or the part
        picked in the catalogue table (chosen there)."""
        pick = pn.widgets.Select(name="from the catalogue", options=self._spring_options(number),
                                 value=self._spring_option(number), css_classes=[f"catalogue-springs-{number}"],
                                 sizing_mode="stretch_width")

        async def picked(event):
            if event.new == self._spring_option(number):
                return  # what the spring is already (the page showing a part picked in the table)
            self.state.pick_spring(number, None if event.new == OWN_SPRING else event.new)
            await self._spring_changed(number)

        pick.param.watch(self.guarded(f"picking spring {number}", picked), "value")
        self.spring_picks[number] = pick
        return pick

    def _spring_options(self, number: int) -> list[str]:
        part = self.state.parts.get(number)
        return [OWN_SPRING, *(s["name"] for s in catalogue()), *([_part_option(part)] if part else [])]

    def _spring_option(self, number: int) -> str:
        """What spring ``number`` is now, as its choice names it."""
        if number in self.state.parts:
            return _part_option(self.state.parts[number])
        return self.state.picks.get(number, {}).get("name", OWN_SPRING)

    async def _spring_changed(self, number: int) -> None:
        """Show spring ``number`` as now chosen (its heading, choice and fields, the catalogue
        table's name for it) and design."""
        self._show_form()
        await self.design()

    def _catalogue_table(self) -> pn.widgets.Tabulator:
        """The catalogue table: one page of rows in the browser, sorted and filtered by the
        server; the best light first; a click on a row designs with its spring."""
        lights = {"type": "traffic", "min": 0, "max": len(LIGHTS) - 1, "color": [v.colour for v in LIGHTS.values()]}
        filters = {"part": {"type": "input", "func": "like", "placeholder": "part"},
                   "verdict": {"type": "list", "values": list(LIGHTS), "func": "=", "clearable": True},
                   "reason": {"type": "input", "func": "like", "placeholder": "words"},
                   **{c.name: {"type": "number", "func": c.test, "placeholder": "≥" if c.test == ">=" else "≤"}
                      for c in NUMBERS}}
        # the columns fit the page, the reason in the width left (all of it on hovering), titles wrapped
        widths = {"light": 34, "part": 90, "verdict": 84, **{c.name: 76 for c in NUMBERS}}
        table = pn.widgets.Tabulator(
            pd.DataFrame(columns=columns()), pagination="remote", page_size=CATALOGUE_ROWS, selectable=1,
            show_index=False, disabled=True, titles=titles(), formatters={"light": lights}, header_filters=filters,
            sorters=[{"field": "light", "dir": "asc"}], layout="fit_columns", widths=widths,
            configuration={"columnDefaults": {"headerWordWrap": True, "tooltip": True}},
            css_classes=["catalogue-table"], sizing_mode="stretch_width")
        table.on_click(self.guarded("designing with a catalogue spring", self._on_row))
        return table

    # ----------------------------------------------------------------------------- guard
    def guarded(self, action: str, callback):
        """``callback`` (a coroutine function or a plain one), its failure shown on the page as
        one line (:meth:`fail`) instead of raised into the server; a plain callback then gives
        None. Every callback of the page is one of these; ``action`` says what it does
        (``opening the file``)."""
        if inspect.iscoroutinefunction(callback):
            @functools.wraps(callback)
            async def run(*args, **kwargs):
                try:
                    return await callback(*args, **kwargs)
                except Exception as exc:
                    self.fail(action, exc)
        else:
            @functools.wraps(callback)
            def run(*args, **kwargs):
                try:
                    return callback(*args, **kwargs)
                except Exception as exc:
                    self.fail(action, exc)
        run.guarded = action
        return run

    def fail(self, action: str, exc: Exception) -> None:
        """Show and log the one line of ``action``'s failure ``exc`` (:func:`failure_line`); a
        design it stopped is no longer said to be under way. The traceback of an error that is
        not the input's goes to the log's debug level, for a report."""
        line = failure_line(action, exc, self._public)
        self.failure.object, self.failure.visible = _escape(line), True
        if self.verdict.object == DESIGNING:
            self.verdict.object = "<span class='verdict-failure'>not designed: the error is above</span>"
        expected = isinstance(exc, (*INPUT_ERRORS, PageError))
        log.log(logging.INFO if expected else logging.WARNING, "design page: %s", line)
        if not expected:
            log.debug("design page: %s", action, exc_info=exc)

    # ---------------------------------------------------------------------------- actions
    async def _on_edit(self, key: str, text: str) -> None:
        if text.strip() == value_text(self.state.value(key)) and key != self._error_key:
            return  # what the field shows already (a field set by the page, Enter on an unchanged value)
        self._show_error(None, None)
        error = self.state.edit(key, text)
        if error:
            self._show_error(key, error)
            return
        if key == "solver.method":
            self._show_set_keys()
        self._show_values([key, *(k for k, leader in self.state.links.items() if leader == key)])
        await self.design(edited=key)

    async def design(self, edited: str | None = None) -> None:
        """Design the edits now in the worker and show what it gave: the verdict and what binds,
        the live view with its bands, the summary, the catalogue table with the verdict of a
        part designed with, and the springs' figure (drawn in the worker too); the design is
        recorded in the tab's history. The table's screen comes before the design, from the
        parse the design then uses."""
        self._shown += 1
        shown = self._shown
        self._moves.drop()
        self._rest(None)
        self.failure.visible = False
        self.verdict.object = DESIGNING
        request = self.state.ask(edited)
        self._asked = request.edits
        await self._show_catalogue()
        outcome, frame, details = await self._in_worker(self._full_design, request, edited, self.player.value,
                                                        set(self.inputs))
        if shown != self._shown:  # a later edit is being designed: show that one
            return
        self.state.keep(request, outcome)
        await self._show_design(outcome, frame, details, shown)

    def _full_design(self, request: Request, edited: str | None, pose: int, keys: set[str]):
        """(In the worker.) The design of ``request``, what the live view draws of it and its
        summary's lines (:meth:`_drawn`)."""
        outcome = self.state.run(request, edited)
        return (outcome, *self._drawn(outcome, pose, keys))

    @staticmethod
    def _drawn(outcome: Outcome, pose: int, keys: set[str]) -> tuple:
        """(In the worker.) What the live view draws of ``outcome`` at ``pose`` (with the
        handles of the fields ``keys``) and its summary's lines; None, None for an error."""
        result = outcome.result
        if result is None:
            return None, None
        lines = [f"  {line}" for line in part_lines(result.problem)] + result.summary().splitlines()[1:]
        return LiveView.frame(result, pose, keys), "\n".join(lines)

    async def _show_design(self, outcome: Outcome, frame, details: str | None, shown: int) -> None:
        """Show ``outcome``, the design asked for ``shown``-th, with its live view ``frame`` and
        summary ``details``: then the catalogue table and the springs' figure, unless a later
        design was asked for meanwhile. The plots first: the verdict says they are drawn."""
        if frame is not None:
            with self.drawing():
                self.live.draw(frame)
            self.player.end = max(outcome.result.evaluation.units[0].theta.size - 1, 1)
        self._show(outcome, details)
        self._show_history()
        await self._show_catalogue()
        result = outcome.result
        if result is not None and shown == self._shown:
            image = await self._in_worker(lambda: png(springs_figure(result.evaluation)) if result.problem.springs
                                          else None)
            if shown == self._shown:
                self.springs.object = image

    @contextlib.contextmanager
    def drawing(self):
        """Where the live view's plots are changed: the tab's document unlocked, its changes sent
        to the browser as one message when the block ends (a callback of the page's loop, or of
        a handle in the plots, holds no lock on it)."""
        with set_curdoc(self.doc) if self.doc is not None else contextlib.nullcontext(), unlocked():
            yield

    # ----------------------------------------------------------------------------- history
    def _show_history(self) -> None:
        history = self.state.history
        self.undo.disabled, self.redo.disabled = not history.can_undo, not history.can_redo
        self.history_line.object = f"<small>{history.words()}</small>"

    async def _on_undo(self, event) -> None:
        await self._step(self.state.history.undo())

    async def _on_redo(self, event) -> None:
        await self._step(self.state.history.redo())

    async def _step(self, entry) -> None:
        """Show the design of history ``entry`` (its edits and what they gave) as it was made:
        the form, the sliders, the spring choices and the tables follow."""
        if entry is None:
            return
        self._shown += 1
        shown = self._shown
        self._moves.drop()
        self._rest(None)
        edits, outcome = entry
        self.state.restore(edits, outcome)
        self._asked = edits
        self._show_form()
        frame, details = await self._in_worker(self._drawn, outcome, self.player.value, set(self.inputs))
        if shown == self._shown:
            await self._show_design(outcome, frame, details, shown)

    def _show_form(self) -> None:
        """Every field, slider, spring choice and table of the form shows the edits now."""
        for number in self.headings:
            self.headings[number].object = _heading(self.state.table_names()[f"springs.{number}"])
            # both at once: a choice left out of the new options would otherwise be replaced by the first
            self.spring_picks[number].param.update(options=self._spring_options(number),
                                                   value=self._spring_option(number))
        for key in self.table_widgets:
            self._show_table(key)
        self._show_values()
        self._show_set_keys()
        self._show_slots()

    async def _show_catalogue(self) -> None:
        """The catalogue table of the spring chosen above it, for the spec as edited now (the
        rows made in the worker); the spring's part selected."""
        number = self.spring_slot.value
        if number is None:
            self.catalogue_line.object = "<span class='catalogue-count'>This spec has no springs.</span>"
            return
        view = await self._in_worker(self.state.catalogue_view, number, self._public)
        if view is None or number != self.spring_slot.value:
            return  # a spec that cannot be read (its design says why), or another spring chosen meanwhile
        rows = view.rows
        part = self.state.part(number)
        if not _same_rows(self.catalogue_table.value, rows):  # most edits change no light: nothing is sent
            self.catalogue_table.value = rows
        self.catalogue_table.selection = [int(i) for i in np.flatnonzero(rows["part"] == part)]
        now = f"part {part}" if part else "the spec's own spring"
        untested = (" (the screen tests a spring alone on its joint: this one shares the work with another)"
                    if view.need == Need() else "")
        line = (f"{self._public(view.origin)} for spring {number}: {count_line(rows)}"
                f"{untested}. Spring {number} is {now}; click a row to design with that spring instead.")
        self.catalogue_line.object = f"<span class='catalogue-count'>{_escape(line)}</span>"

    def _public(self, message: str) -> str:
        """``message`` as the page shows it: one line naming no folder of the server (:func:`public`)."""
        return one_line(self._scrubbed(message))

    def _scrubbed(self, text: str) -> str:
        """``text`` naming the file open and the files uploaded with it by the names the user
        knows them by, and no folder of the server (:func:`scrubbed`)."""
        path = self.state.path
        names = {**self.state.aliases, str(path): self.name, str(resolved(path)): self.name}
        return scrubbed(text, names, [resolved(path.parent)])

    async def _on_slot(self, event) -> None:
        await self._show_catalogue()

    async def _on_row(self, event) -> None:
        """Design with the spring of the row clicked as the part of the spring chosen above the table."""
        number = self.spring_slot.value
        self.state.pick_part(number, str(self.catalogue_table.value["part"].iloc[event.row]))
        await self._spring_changed(number)

    async def _in_worker(self, fn, *args):
        """``fn(*args)`` in the worker, whose thread designs and draws one thing at a time."""
        return await asyncio.get_running_loop().run_in_executor(WORKER, fn, *args)

    async def _on_template(self, event) -> None:
        chosen = next((t for t in TEMPLATES if t.title == event.new), None)
        if chosen is not None and event.new != self._template_title():
            await self._open(examples.path(chosen.spec), variant=chosen.variant)

    async def _on_upload(self, *events) -> None:
        """Open the spec uploaded with the CSV files it names (:func:`cadcam.app.uploads.save`),
        written under names of the page's own: the browser's names are only shown."""
        data, names = self.upload.value, self.upload.filename
        if data is None or names is None:
            return  # the upload widget cleared, or half set
        data, names = (data, names) if isinstance(data, list) else ([data], [names])
        if not isinstance(names, list) or len(names) != len(data) or not data:
            return  # half set: the names follow
        folder = Path(tempfile.mkdtemp(prefix=UPLOAD_PREFIX))
        _UPLOADS.add(folder)
        await self._open(folder=folder, files=list(zip(names, data)))

    async def _open(self, path: Path | None = None, variant: str | None = None, folder: Path | None = None,
                    files: list[tuple[str, bytes]] | None = None) -> None:
        """Open spec ``path`` (its ``variant``), or the upload ``files`` ((name, content) pairs)
        written to their folder ``folder``, and design it; the folder of the file it replaces is
        removed. A file that cannot be opened leaves no folder and the file open as it was; a
        spec error is shown under the upload."""
        names: dict[str, str] = {} if path is None else {str(path): path.name}
        try:
            if files is not None:
                uploaded = save_upload(files, folder)
                names = uploaded.aliases
                path, name, given = uploaded.path, uploaded.name, uploaded.tables
                state = DesignState(path, original=uploaded.original, aliases=uploaded.aliases)
            else:
                name, given = path.name, ()
                state = DesignState(path, variant=variant)
        except Exception as exc:
            _discard(folder)
            if not isinstance(exc, SpecError):
                raise
            self.open_error.object = _escape(public(str(exc), names))
            return
        self.open_error.object = ""
        state.session = self.state.session  # the builds and last answers stay with the tab
        self.state, self.name, self.given_tables = state, name, given
        _discard(self.folder)
        self.folder = folder
        if files is None:  # the browser's file box names the file open, or none
            self.upload.clear()
        self._show_opened()
        self._build_form()
        self._show_history()  # the file's own: none yet
        self.player.value = 0  # a file opened is shown at its range's first angle
        await self.design()

    def close(self) -> None:
        """Remove the upload folder of the file open (the tab's session has ended)."""
        _discard(self.folder)
        self.folder = None

    async def _on_pose(self, event) -> None:
        self._poses.ask()

    async def _draw_pose(self) -> None:
        """Draw the mechanisms at the player's angle now (:class:`cadcam.app.latest.Latest`: the
        player steps faster than a design is drawn on a busy worker, and the angles it passed
        meanwhile would otherwise hold the next design back)."""
        result, pose = self.state.result, self.player.value
        if result is not None:
            poses = await self._in_worker(LiveView.poses, result, pose, set(self.inputs))
            with self.drawing():
                self.live.show_poses(poses)

    # ------------------------------------------------------------------------------- views
    def _opened(self) -> str:
        """The line naming the file open (and its variant, or the CSV files uploaded with it)."""
        variant = f" (variant {self.state.variant})" if self.state.variant else ""
        tables = f" with {', '.join(shown_name(n) for n in self.given_tables)}" if self.given_tables else ""
        return f"<small>open {_escape(one_line(self.name + variant + tables))}</small>"

    def _show_opened(self) -> None:
        """Name the file open: in the line above the form, in the choice of template and in the
        names of the files to download."""
        self.opened.object = self._opened()
        # both at once: the choice kept in the options (the file's, then a template's)
        self.template.param.update(options=self._template_options(), value=self._template_option())
        stem = download_stem(self.name, self.state.variant)
        for button, end in self._named:
            button.filename = stem + end

    def _show_error(self, key: str | None, message: str | None) -> None:
        """Show ``message`` under field ``key`` (None: under no field). Only the field showing an
        error and field ``key`` are set: setting every field's (tens of them) took a slider's step
        milliseconds of the page's loop, for nothing to show."""
        for k in dict.fromkeys((self._error_key, key)):
            pane = self.errors.get(k)
            if pane is not None:
                shown = k == key
                pane.object, pane.visible = _escape(self._public(message)) if shown else "", shown
        self._error_key = key

    def _verdict(self, outcome: Outcome) -> str:
        """The verdict line of ``outcome``: its status and message, or the error it ended in."""
        if outcome.error is not None:
            return f"<span class='verdict-failure'>not designed: {_escape(self._public(outcome.error))}</span>"
        result = outcome.result
        style = "verdict-provisional" if result.provisional else "verdict-success" if result.success else "verdict-failure"
        status = f"{result.status} (provisional)" if result.provisional else result.status
        return (f"<span class='{style}'>{_escape(status)}: {_escape(self._scrubbed(result.message))}</span>"
                f" <small>(designed in {outcome.seconds:.2f} s, functions {result.functions})</small>")

    def _lines(self, result) -> str:
        """What binds and what the spec's values warn of, one line each, above the plots."""
        items = [f"<li>binding: {_escape(self._scrubbed(b))}</li>" for b in result.binding]
        items += [f"<li class='spec-warning'>warning: {_escape(self._scrubbed(w))}</li>" for w in result.spec_warnings]
        return f"<ul>{''.join(items)}</ul>" if items else ""

    def _show(self, outcome: Outcome, details: str | None) -> None:
        """The verdict, the lines above the plots and the summary of ``outcome`` (``details``:
        its summary's lines, made in the worker)."""
        self.verdict.object = self._verdict(outcome)
        if outcome.error is not None:
            self._show_error(outcome.field, outcome.error)
            if self.state.result is not None:
                self.details.object = ("<small>The plots, result.json and workshop files are those of the "
                                       "last design made; the spec (TOML) has the edits as they are.</small>")
            return
        self._show_error(None, None)
        self.lines.object = self._lines(outcome.result)
        self.details.object = ("<pre style='white-space: pre-wrap; font-size: 12px'>"
                               + _escape(self._scrubbed(details or "")) + "</pre>")
        if not outcome.result.problem.springs:
            self.springs.object = None

    # --------------------------------------------------------------------------- downloads
    def _download_buttons(self) -> list:
        def spec():
            return io.BytesIO(self.state.spec_toml().encode("utf-8"))

        def result():
            return io.BytesIO(self.state.own_names(result_json(self._result())).encode("utf-8"))

        def dxf():
            files = self._result_files(False)
            return io.BytesIO(zipped({n: d for n, d in files.items() if n.endswith(".dxf")}))

        def solids():
            files = self._result_files(False, solids=True)
            return io.BytesIO(zipped({n: d for n, d in files.items() if n.endswith(".step")}))

        def everything():  # with the page's verdict lines, as summary.txt
            files = self._result_files(True, solids=True)
            return io.BytesIO(zipped({**files, "summary.txt": (self._result().summary() + "\n").encode("utf-8")}))

        def button(make, end: str, label: str, kind: str, what: str | None = None) -> Download:
            """A download of the file ``make`` gives, named after the design and ending in ``end``;
            ``what`` it holds said on hovering."""
            made = Download(callback=self.guarded(f"downloading {label}", make), label=label,
                            filename=download_stem(self.name, self.state.variant) + end,
                            css_classes=[f"download-{kind}"], button_type="primary", description=what)
            self._named.append((made, end))
            return made

        return [button(spec, ".toml", "spec (TOML)", "spec"),
                button(result, "_result.json", "result.json", "result"),
                button(dxf, "_dxf.zip", "DXF (zip)", "dxf"),
                *([button(solids, "_step.zip", "STEP (zip)", "step")] if step_available() else []),
                button(everything, "_outputs.zip", "every file (zip)", "all",
                       "every file cadcam design writes: SVG, solids, sheets, figures, and the summary")]

    def _result(self):
        result = self.state.result
        if result is None:
            raise PageError("nothing to download yet: no design has been made from this file (the line below says why)")
        return result

    def _result_files(self, figures: bool, solids: bool = False) -> dict[str, bytes]:
        return self.state.result_files(self._result(), figures=figures, solids=solids)


def _same_rows(shown: pd.DataFrame | None, rows: pd.DataFrame) -> bool:
    """Whether the catalogue table ``shown`` has ``rows`` already (the same parts, lights and
    reasons: the other columns are the catalogue's)."""
    return shown is not None and shown.shape == rows.shape and all(
        shown[c].equals(rows[c]) for c in ("part", "verdict", "reason"))


def _numbered(number: int, name: str) -> str:
    """Spring ``number`` named ``name``, as the catalogue table's choice of spring shows it."""
    return name if name == f"spring {number}" else f"spring {number}: {name}"


def _part_option(part: str) -> str:
    """The choice of a spring naming the part picked in the catalogue table."""
    return f"{part_name(part)} (picked in the catalogue table)"


def _heading(title: str) -> str:
    """A numbered table's heading in the form."""
    return f"<b>{_escape(title)}</b>"


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def _discard(folder: Path | None) -> None:
    """Remove upload folder ``folder`` once the worker has done what was queued before it (a
    design of the file in it may be under way)."""
    if folder is None:
        return
    try:
        WORKER.submit(_remove, folder)
    except RuntimeError:  # the worker has stopped (the server too): nothing reads the folder now
        _remove(folder)


def _remove(folder: Path) -> None:
    shutil.rmtree(folder, ignore_errors=True)
    _UPLOADS.discard(folder)


def page(path: str | None = None) -> pn.Row:
    """A new tab's page over ``path`` (default: the first template), designed once loaded; its
    upload folder removed when its session ends."""
    state = DesignState(Path(path)) if path else DesignState.template(TEMPLATES[0].spec)
    view = DesignPage(state)
    view.doc = pn.state.curdoc
    pn.state.onload(view.guarded("designing", view.design))
    pn.state.on_session_destroyed(lambda session_context: view.close())
    return view.view()


def app_server(path: str | None = None, port: int = 5006, address: str = "127.0.0.1", show: bool = True):
    """The page's Bokeh server on ``address``:``port``, listening but not started: every script
    from this server, no asset from the network, and no answer to a name other than the
    address it serves on (:func:`cadcam.app.hosts.served_hosts`), the websocket's ``Origin``
    held to the same names."""
    pn.extension(raw_css=[CSS], inline=True)
    hosts = served_hosts(address, port)
    origins = sorted(h for h in hosts if not h.startswith("["))  # Bokeh reads no IPv6 origin
    server = pn.serve({"/": lambda: page(path)}, port=port, address=address, show=show, websocket_origin=origins,
                      title="cadcam design page", resources="server", threaded=False, start=False, print_url=True)
    refuse_other_hosts(server._tornado, hosts)
    return server


def serve(path: str | None = None, port: int = 5006, address: str = "127.0.0.1", show: bool = True) -> None:
    """Serve the page on ``address``:``port`` (:func:`app_server`; one user on localhost by
    default) until interrupted, terminated or hung up; then remove the upload folders left."""
    server = app_server(path, port=port, address=address, show=show)

    def stop(*_) -> None:  # as Panel stops on SIGINT: the loop ends, then the cleanup below
        server.io_loop.asyncio_loop.call_soon_threadsafe(server.io_loop.stop)

    for name in ("SIGTERM", "SIGHUP"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), stop)
    try:
        server.start()
        server.io_loop.start()
    finally:  # a stopped server exits once the worker's task under way ends, not everything queued
        WORKER.shutdown(wait=False, cancel_futures=True)
        for folder in list(_UPLOADS):
            _remove(folder)


__all__ = ["DesignPage", "PageError", "app_server", "one_line", "page", "serve", "slug"]
