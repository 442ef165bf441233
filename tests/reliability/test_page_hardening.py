"""Rule 6 of issue 48, the design page: a request for a name other than the address served is
refused; every callback's failure is one line on the page, never a server traceback; uploads
live in a folder removed when the file is replaced and when the session ends.

Inputs are generated (hypothesis, derandomized, no example database): ``Host`` values, upload
names and contents, field texts, and the message of an error injected into every callback. The
page is driven in-process (its widgets set as the browser sets them, the callbacks run to their
end); one server on a free loopback port answers the ``Host`` requests. No test here solves:
what they type is refused before the solver, or the design is stubbed.
"""
from __future__ import annotations

import asyncio
import errno
import html
import http.client
import json
import os
import re
import socket
import tempfile
import threading
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cadcam import examples, load_problem

ROOT = Path(__file__).resolve().parents[2]
SPEC_1DOF = ROOT / "models" / "johnston2023_1dof.toml"
#: Names the issue lists and their kin: each must open as any other name does.
HOSTILE_NAMES = ["..", ".", "/", "a/../../b.toml", "../../etc/passwd", "x\x00.toml", "\x1b[2J\x1b[31mred.toml",
                 "line\nbreak.toml", "<img src=x onerror=alert(1)>.toml", "C:\\Users\\x\\spec.toml", "é" * 300,
                 "a" * 5000 + ".toml", "\u202egnp.toml", "\ud800.toml", ""]
#: The names the issue lists, and a slash, a NUL and a long one: a spec under each opens.
ISSUE_NAMES = ["..", ".", "a/../../b.toml", "x\x00.toml", "é" * 300]
#: Field texts the issue lists and their kin: none is a value any field takes.
HOSTILE_TEXTS = ["9" * 5000, "-" + "9" * 5000, "1" + "0" * 400, "nan", "inf", "-inf", "1e999", "[nan, 1]",
                 "[1e400, 2]", "\x00", "\x1b[2J", "a\nb", "\ud800", "é", "<b>bold</b>", "{x = 1}"]
#: How long a request waits for the server's reply before it fails [s] (a refusal takes
#: milliseconds; the page itself is built in seconds).
REPLY_WAIT_S = 60.0


def _settings(n: int):
    return settings(max_examples=n, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))


@pytest.fixture(scope="module")
def app():
    """The page's module (Panel is the app extra's; looked for here, not while collecting)."""
    pytest.importorskip("panel", reason="Panel is the app extra's (make test installs it)")
    from cadcam.app import page
    return page


@pytest.fixture(scope="module")
def temp_root(tmp_path_factory):
    """The system's temporary folder, for this module a folder of its own: the upload folders
    left there are this module's."""
    root = tmp_path_factory.mktemp("page_temp")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(tempfile, "tempdir", str(root))
        yield root


@pytest.fixture(scope="module")
def view(app, temp_root):
    """A page on the 1-DOF wire cam, never designed (its designs are stubbed where a test
    needs one)."""
    return app.DesignPage(app.DesignState.template("johnston2023_1dof"))


@pytest.fixture(scope="module")
def form(app, temp_root):
    """Another page on the 1-DOF wire cam, for the edits of its fields alone."""
    return app.DesignPage(app.DesignState.template("johnston2023_1dof"))


def shown(pane) -> str:
    """What the browser shows of an HTML pane: its text, tags and entities resolved."""
    return html.unescape(re.sub(r"<[^>]+>", "", pane.object or ""))


def check_line(text: str, app, *internal: Path) -> None:
    """``text`` is a non-empty line a person reads: printable, not longer than the page's
    limit, naming no upload folder and no folder of ``internal``."""
    assert text and text.isprintable() and len(text) <= app.MESSAGE_CHARS, text
    assert app.UPLOAD_PREFIX not in text, text
    for folder in internal:
        assert str(folder) not in text, text


def leftovers(app, root: Path) -> list[Path]:
    """Upload folders under ``root`` once the worker has done what was queued (removals wait
    for the designs queued before them)."""
    app.WORKER.submit(lambda: None).result()
    return sorted(root.glob(f"{app.UPLOAD_PREFIX}*"))


async def _no_design(*args, **kwargs):
    """A design that is not made (the tests here are about what comes before the solver)."""


# -- Host ---------------------------------------------------------------------------------------
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def served(app):
    """The page's server (:func:`cadcam.app.page.app_server`) on a free port of 127.0.0.1, in a
    thread of this process: its port."""
    port, ready, box = _free_port(), threading.Event(), {}

    def run():
        asyncio.set_event_loop(asyncio.new_event_loop())
        box["server"] = server = app.app_server(None, port=port, address="127.0.0.1", show=False)
        server.start()
        ready.set()
        server.io_loop.start()
        server.stop()

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    assert ready.wait(120), "the page's server did not start"
    yield port
    server = box["server"]
    server.io_loop.add_callback(server.io_loop.stop)
    thread.join(30)


def request(port: int, host: bytes | None, path: str = "/", upgrade: bool = False) -> tuple[int, bytes]:
    """The status and body of a GET of ``path`` with ``Host: host`` as raw bytes (None: no
    header); ``upgrade`` asks for a websocket, as Bokeh's page does."""
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=REPLY_WAIT_S)
    try:
        connection.putrequest("GET", path, skip_host=True, skip_accept_encoding=True)
        if host is not None:
            connection.putheader("Host", host)
        if upgrade:
            for name, value in (("Upgrade", "websocket"), ("Connection", "Upgrade"), ("Sec-WebSocket-Version", "13"),
                                ("Sec-WebSocket-Key", "dGhlIHNhbXBsZSBub25jZQ=="), ("Origin", "http://127.0.0.1")):
                connection.putheader(name, value)
        connection.endheaders()
        reply = connection.getresponse()
        return reply.status, reply.read()
    finally:
        connection.close()


_LABEL = st.from_regex(r"[a-z0-9]([a-z0-9-]{0,20}[a-z0-9])?", fullmatch=True)
_NAMES = st.one_of(st.lists(_LABEL, min_size=1, max_size=4).map(".".join), st.ip_addresses().map(str),
                   st.ip_addresses(v=6).map(lambda a: f"[{a}]"),
                   st.sampled_from(["localhost", "127.0.0.1", "127.0.0.2", "0.0.0.0", "LOCALHOST", "localhost.",
                                    "127.0.0.1.nip.io", "localtest.me", ""]),
                   st.text(st.characters(blacklist_characters="\r\n"), max_size=40))
_PORTS = st.one_of(st.none(), st.integers(0, 70000).map(str), st.sampled_from(["", "*", "5006x", "-1"]))


@st.composite
def foreign_hosts(draw, port: int) -> bytes:
    """A ``Host`` value that is not the served address: a name or address, an optional port
    (the served one among others), as raw bytes (UTF-8 for the unicode among them)."""
    name, p = draw(_NAMES), draw(st.one_of(_PORTS, st.just(str(port))))
    value = name if p is None else f"{name}:{p}"
    return value.encode("utf-8", "surrogatepass")


@pytest.mark.slow  # the page served and its first design: make test-slow
def test_requests_for_other_hosts_are_refused_and_the_served_address_answers(app, served):
    from cadcam.app.hosts import served_hosts

    port = served
    allowed = served_hosts("127.0.0.1", port)
    assert allowed == {f"localhost:{port}", f"127.0.0.1:{port}"}

    @_settings(60)
    @given(host=foreign_hosts(port), path=st.sampled_from(["/", "/ws", "/favicon.ico", "/static/js/bokeh.min.js"]),
           upgrade=st.booleans())
    def refused(host, path, upgrade):
        if host.decode("latin-1").strip().lower() in allowed:
            return  # the served address, written by the strategy too
        status, body = request(port, host, path, upgrade)
        assert status in (400, 403), (host, path, status)
        assert b"bokeh" not in body.lower() and b"token" not in body.lower()

    refused()
    assert request(port, None)[0] in (400, 403)  # HTTP/1.1 needs a Host
    for host in sorted(allowed):
        assert request(port, host.encode(), "/favicon.ico")[0] == 200
        assert request(port, host.upper().encode(), "/favicon.ico")[0] == 200  # names are case-free
    status, body = request(port, f"127.0.0.1:{port}".encode())
    assert status == 200 and b"cadcam design page" in body


def test_served_hosts_are_the_address_and_the_loopback_names():
    from cadcam.app.hosts import served_hosts

    assert served_hosts("::1", 8000) == {"localhost:8000", "127.0.0.1:8000", "[::1]:8000"}
    assert served_hosts("127.0.0.1", 80) == {"localhost:80", "127.0.0.1:80", "localhost", "127.0.0.1"}
    everywhere = served_hosts("0.0.0.0", 5006)  # on every interface: this machine's own names too
    assert {f"{socket.gethostname().lower()}:5006", "0.0.0.0:5006"} <= everywhere  # (the browser opened sends the latter)
    assert served_hosts("", 5006) >= {f"{socket.gethostname().lower()}:5006"} and ":5006" not in served_hosts("", 5006)


# -- one line -----------------------------------------------------------------------------------
_SEGMENTS = st.lists(st.from_regex(r"[A-Za-z0-9_.~-]{1,12}", fullmatch=True).filter(lambda s: s not in (".", "..")),
                     min_size=1, max_size=6)


@_settings(100)
@given(folders=_SEGMENTS, name=st.from_regex(r"[a-z0-9_]{1,20}\.toml", fullmatch=True),
       text=st.text(st.characters(blacklist_characters="/\\"), max_size=400))
def test_a_message_is_one_printable_line_naming_files_by_their_names(app, folders, name, text):
    folder = "/" + "/".join(folders)
    line = app.one_line(f"{folder}/{name}: {text}")
    assert line.isprintable() and len(line) <= app.MESSAGE_CHARS and folder not in line
    assert line.startswith(f"{name}: ")
    if len(line) < app.MESSAGE_CHARS:  # not cut: each character of the text there, Python's escape of the others
        assert line == f"{name}: " + "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
    else:
        assert line.endswith("…")


# -- uploads ------------------------------------------------------------------------------------
def upload(widget, data: bytes, name: str) -> None:
    """Upload ``data`` named ``name`` with the upload ``widget`` as the browser does (both at
    once)."""
    widget.param.update(value=data, filename=name)


_CONTENTS = st.one_of(st.sampled_from([b"", b"name = 'x'\n", b"{", b"{\"problem\": 1}", b"[[joints]]\n", b"\xff\xfe\x00",
                                       b"rate = " + b"9" * 5000 + b"\n", b"x = 1" * 10000]),
                      st.binary(max_size=200))


@_settings(40)
@given(name=st.one_of(st.sampled_from(HOSTILE_NAMES), st.text()), data=_CONTENTS)
def test_an_upload_that_is_no_spec_says_so_in_one_line_and_leaves_no_folder(app, view, temp_root, name, data):
    opened = view.opened.object
    upload(view.upload, data, name)
    check_line(shown(view.open_error), app, temp_root, ROOT)
    assert not view.failure.visible  # an input error, under the upload: not a failure of the page
    assert view.opened.object == opened and view.folder is None  # the template stays open
    assert leftovers(app, temp_root) == []


@pytest.mark.parametrize("name", ISSUE_NAMES, ids=lambda n: repr(n[:12]))
def test_a_spec_under_any_name_opens_shown_by_that_name(app, view, temp_root, name, monkeypatch):
    monkeypatch.setattr(app.DesignPage, "design", _no_design)
    upload(view.upload, SPEC_1DOF.read_bytes(), name)
    assert view.open_error.object == "" and shown(view.opened).startswith("open ")
    check_line(shown(view.opened).removeprefix("open "), app, temp_root)
    assert view.state.path.parent == view.folder and view.folder.parent == temp_root  # nowhere the name says
    assert leftovers(app, temp_root) == [view.folder]
    view.close()
    assert leftovers(app, temp_root) == []


def test_an_uploads_folder_goes_when_another_file_or_a_template_replaces_it(app, view, temp_root, monkeypatch):
    monkeypatch.setattr(app.DesignPage, "design", _no_design)
    upload(view.upload, SPEC_1DOF.read_bytes(), "..")
    first = view.folder
    upload(view.upload, SPEC_1DOF.read_bytes().replace(b"rate = 1100", b"rate = -1"), ".")  # refused: the file stays
    assert view.folder == first and leftovers(app, temp_root) == [first]
    upload(view.upload, SPEC_1DOF.read_bytes(), "again.toml")  # another file replaces it: its folder goes
    assert view.folder != first and leftovers(app, temp_root) == [view.folder]
    view.template.value = app.TEMPLATES[1].title  # a template replaces it: its folder goes
    assert view.folder is None and leftovers(app, temp_root) == []


def test_an_upload_on_a_full_disk_fails_in_one_line_and_leaves_no_folder(app, view, temp_root, monkeypatch):
    def full(self, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self))

    monkeypatch.setattr(Path, "write_bytes", full)
    opened, view.failure.visible = view.opened.object, False
    upload(view.upload, SPEC_1DOF.read_bytes(), "full.toml")
    assert shown(view.failure).startswith("opening the file failed: OSError: [Errno 28] No space left on device")
    check_line(shown(view.failure), app, temp_root)
    assert view.opened.object == opened and leftovers(app, temp_root) == []


def test_a_result_json_is_judged_by_its_content_whatever_its_name(app, temp_root, monkeypatch):
    monkeypatch.setattr(app.DesignPage, "design", _no_design)
    view = app.DesignPage(app.DesignState.template("johnston2023_1dof"))
    problem = load_problem(SPEC_1DOF)
    upload(view.upload, json.dumps({"problem": problem.to_dict()}).encode(), "design.toml")
    assert view.open_error.object == "" and view.state.path.suffix == ".json"
    assert view.state.field("springs.1.rate").value == problem.springs[0].rate
    view.close()
    assert leftovers(app, temp_root) == []


def test_the_session_ending_removes_its_upload_folder(app, temp_root, monkeypatch):
    import panel as pn
    from bokeh.document import Document
    from panel.io.state import set_curdoc

    monkeypatch.setattr(app.DesignPage, "design", _no_design)
    doc = Document()
    with set_curdoc(doc):
        row = app.page(str(SPEC_1DOF))
    (ended,) = doc.session_destroyed_callbacks
    upload(row.select(pn.widgets.FileInput)[0], SPEC_1DOF.read_bytes(), "mine.toml")
    assert len(leftovers(app, temp_root)) == 1
    ended(None)
    assert leftovers(app, temp_root) == []


# -- fields -------------------------------------------------------------------------------------
_HUGE = st.integers(min_value=2 ** 1024, max_value=10 ** 4200).map(str)
_TEXTS = st.one_of(st.sampled_from(HOSTILE_TEXTS), _HUGE, _HUGE.map(lambda s: "-" + s),
                   st.sampled_from(["+inf", "+nan", "-nan", "NaN", "1e309", "-1e309", "0x" + "f" * 300,
                                    "0o" + "7" * 400, "0b1" + "0" * 1100, "[0x" + "f" * 300 + ", 1]"]),
                   st.text(st.characters(categories=("Cc", "Cf", "Zl", "Zp", "So", "Lo")), min_size=1, max_size=30))


def edit_refused(app, view, key: str, text: str) -> None:
    """Type ``text`` into field ``key`` of ``view`` and check that it is refused before any
    solve, in one line under a field (and in the verdict if the design refused it), with
    nothing failing; then put the spec's value back without a design."""
    import param

    box = view.inputs[key]
    view.verdict.object = ""
    box.value = text
    assert not view.failure.visible, shown(view.failure)  # an input error: nothing failed
    assert view.state.result is None  # refused before any solve
    (under,) = [k for k, pane in view.errors.items() if pane.visible]
    assert under in (key, view.state.last.field)
    check_line(shown(view.errors[under]), app, ROOT, examples.path("johnston2023_1dof").parent)
    if view.verdict.object:  # the design's error, the parse error shows under the field alone
        check_line(shown(view.verdict).removeprefix("not designed: "), app, ROOT)
    view.state.overrides.clear()
    with param.parameterized.discard_events(box):
        box.value = view.state.field(key).text


@pytest.mark.parametrize("text", HOSTILE_TEXTS, ids=lambda t: repr(t[:12]))
def test_each_text_the_issue_names_in_a_number_field_is_one_line_under_it(app, form, text):
    edit_refused(app, form, "springs.1.rate", text)


@_settings(60)
@given(data=st.data(), text=_TEXTS)
def test_no_text_in_any_field_is_a_traceback_each_is_one_line_under_a_field(app, form, data, text):
    key = data.draw(st.sampled_from(sorted(form.inputs)), label="field")
    box = form.inputs[key]
    if box.disabled or text.strip() == box.value.strip():
        return  # a field the page does not let one edit, or what it shows already
    edit_refused(app, form, key, text)


def test_a_download_with_no_design_says_so_and_sends_nothing_but_the_spec(app, form):
    form.state.overrides.clear()
    form.inputs["springs.1.rate"].value = "9" * 5000  # refused by the design: nothing designed yet
    assert form.state.result is None
    for button in form.view().select(app.Download):
        form.failure.visible = False
        button._clicks += 1
        if "download-spec" in button.css_classes:  # the spec with the edits as they are
            assert not form.failure.visible and button.data.startswith("data:")
        else:
            assert button.data is None and form.failure.visible
            assert shown(form.failure).startswith("nothing to download yet: no design has been made")
    form.state.overrides.clear()


# -- numbers no float holds, in a spec file or an override ----------------------------------------
@pytest.mark.parametrize("digits", [400, 4300, 5000])
def test_a_spec_number_too_long_for_a_float_or_an_int_is_a_spec_error_naming_it(tmp_path, digits):
    from cadcam.spec import SpecError

    spec = tmp_path / "long.toml"
    spec.write_text(SPEC_1DOF.read_text().replace("rate = 1100.0", f"rate = {'9' * digits}", 1))
    with pytest.raises(SpecError, match=r"springs\[1\]\.rate|not valid TOML \(an integer of more than"):
        load_problem(spec)


def test_every_field_refuses_an_int_no_float_holds_as_one_spec_error(app, form):
    from cadcam.spec import SpecError
    from cadcam.targets import ExpressionError

    state = app.DesignState.template("johnston2023_1dof")
    for key in form.inputs:
        state.overrides = {key: 10 ** 400}  # as the field sets it (a table the spec leaves out too)
        with pytest.raises((SpecError, ExpressionError), match=re.escape(key.split(".")[-1])):
            load_problem(state.path, overrides=state.override_pairs())
