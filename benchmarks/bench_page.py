"""The design page's speed: each template designed as the page designs it, then designed again
after a small edit, against the same edit solved from the default start (the objective a warm
design must not lose) and warm without the last answer's multipliers; then, in the browser, a
slider dragged step by step until each step's new curves arrive.

``make bench`` (``python benchmarks/bench_page.py``; ``--browser [TEMPLATE ...]`` times only the
browser's slider steps, of the templates named). The page's path is
:class:`cadcam.app.state.DesignState` over a :class:`cadcam.Session`, functions as the spec says
(by default ``auto``), timed as they run once a template's libraries are in the cache, where
the background compile of the page's first design of that template leaves them: a template's
libraries (its NLP's and its NLP's with the outline rows) not yet there are compiled first,
untimed, and the table says how many. The edit is spring 1's rate
× :data:`EDIT`; the warm design starts from the last answer and its IPOPT multipliers
(:data:`cadcam.solve.ipopt.WARM_IPOPT`). For comparison, through the same kept NLP and
after the page's design: the last design without its multipliers, under the spec's own IPOPT
options (how a Session started before it kept them), and the default start. In-process, a
slider's step is what the page does while a slider moves, after that warm design: a further
step of the edit designed provisionally (no fine re-check, :meth:`cadcam.Session.design` with
``recheck=False``) and the numbers the live view draws of it (:meth:`cadcam.app.live.LiveView.frame`,
without the bands), in wall and CPU time (the CPU time is what another load on a shared machine
stretches less).

In the browser (:func:`browser_steps`): ``cadcam app`` served on localhost with the same cache,
Debian's Chromium driven by Playwright opens each of :data:`LIVE_TEMPLATES`, presses spring 1's
rate slider and moves it :data:`STEPS` times by a few pixels, each step once the last step's
curves arrived; a step's time runs from the browser's pointer event to the torque plot's data
replaced in the browser (and to the next frame painted after it). Goals (issues 30, 32 and 53):
a 1-DOF design back within 2 s, a warm re-solve after a small edit within 0.3 s, a slider step's
new curves within 0.1 s for the wire cam, the anchored pulleys and the roller follower (a goal
row each).
"""
from __future__ import annotations

import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

from cadcam.api import load_problem
from cadcam.app.live import LiveView
from cadcam.app.state import TEMPLATES, DesignState
from cadcam.optimize import optimize, start_design, warm_optimize
from cadcam.solve import compiled
from cadcam.solve.builds import built_for
from cadcam.solve.transcription import Transcription

sys.path.insert(0, str(Path(__file__).resolve().parent))
from goals import print_goals, spec_label  # noqa: E402

#: The edit: spring 1's rate times this.
EDIT = 1.02
#: The key edited.
KEY = "springs.1.rate"
#: Goals [s]: the first design of a template, a warm re-design after the edit, a slider step's
#: new curves in the browser.
FIRST_S, WARM_S, STEP_S = 2.0, 0.3, 0.1
#: The templates whose slider steps are timed in the browser: the wire cam, the anchored pulleys
#: and the roller follower (the 1-DOF templates of issue 53's goal).
LIVE_TEMPLATES = ("johnston2023_1dof", "ludovico2021_pendulum", "roller_follower_pendulum")
#: The slider moved, the steps timed and those before them not timed (the first designs of a
#: structure while it moves), and each step [px] (about 1 % of the rate).
SLIDER, STEPS, WARM_UP, STEP_PX = "springs-1-rate", 12, 2, 3
#: How long the browser waits for a page, a design or a step's curves before it gives up [s].
PAGE_WAIT_S = 180.0
ROOT = Path(__file__).resolve().parent.parent
CHROMIUM = Path("/usr/bin/chromium")
#: Chromium's flags on a closed network (those of tests/app/test_page_browser.py).
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def _timed(fn, *args):
    t0 = time.perf_counter()
    result = fn(*args)
    return result, time.perf_counter() - t0


def _cell(result, seconds: float) -> str:
    return f"{seconds:.2f} | {result.nit} | {result.fun:.6g} ({result.status})"


def _compile(state: DesignState) -> int:
    """Compile into the cache, as the page's background compiles do, the libraries of
    ``state``'s NLP and of its NLP with the outline rows (the second solve's) that are not
    there yet, where its functions are ``auto`` and there is a compiler; return how many (the
    NLP built here is not kept: the page's first design builds its own)."""
    problem = load_problem(state.path, variant=state.variant)
    if problem.options.method != "nlp" or problem.options.functions != "auto" or not compiled.available():
        return 0
    tr = Transcription(start_design(problem)[0].with_options(functions="compiled"))
    return tr.compiled_now + compiled.library(tr.whole_nlp)[1]


def template_rows(template) -> tuple[float, float, tuple[float, float], list[str]]:
    """The first design and the warm re-design of ``template`` (:data:`TEMPLATES`) on the
    page's path, with the two comparisons (none for a spec designed by a method of its own: it
    has no NLP); returns the first design's and the warm re-design's wall times [s], the wall
    and CPU times of a slider's step in-process [s] (:func:`_step_s`) and the table's cells."""
    state = DesignState.template(template.spec, variant=template.variant)
    name = spec_label(template.spec, template.variant)
    compiled_now = _compile(state)
    first = state.design()
    if first.result is None:
        raise RuntimeError(f"{name}: {first.error}")
    last = first.result
    error = state.edit(KEY, repr(EDIT * state.field(KEY).value))
    if error is not None:
        raise RuntimeError(f"{name}: {error}")
    warm = state.design(KEY)
    if warm.result is None:
        raise RuntimeError(f"{name}: {warm.error}")
    step_s = _step_s(state)
    first_cell = (f"{first.seconds:.2f} ({last.build_time_s:.2f} + {last.solve.solve_time_s:.2f} + "
                  f"{last.recheck_time_s:.2f})")
    problem = load_problem(state.path, variant=state.variant, overrides=state.override_pairs())
    if problem.options.method != "nlp":
        cells = [name, warm.result.functions, first_cell,
                 f"{_cell(warm.result, warm.seconds)}, by its method ({problem.options.method})",
                 _step_cell(step_s), "no NLP | | ", "no NLP | | ", "–"]
        return first.seconds, warm.seconds, step_s, cells
    completed, start = default = start_design(problem)
    transcription, _ = built_for(completed)
    plain, plain_s = _timed(warm_optimize, problem, transcription, last.design, last.evaluation.metrics.objective,
                            "the last design", None, default)
    cold, cold_s = _timed(optimize, completed, transcription, start)
    functions = warm.result.functions
    built = f"{functions}{f' ({compiled_now} compiled first)' if compiled_now else ''}"
    how = "warm" if "(warm start" in warm.result.message else "from the default start"
    equal = warm.result.fun <= cold.fun * (1 + 1e-6) or not cold.success
    cells = [name, built, first_cell, f"{_cell(warm.result, warm.seconds)}, {how}", _step_cell(step_s),
             _cell(plain, plain_s), _cell(cold, cold_s), "yes" if equal else "**no**"]
    return first.seconds, warm.seconds, step_s, cells


def _step_s(state: DesignState) -> tuple[float, float]:
    """What the page's worker does for a slider's step before the new curves are sent, after
    the last design: spring 1's rate × :data:`EDIT` once more, designed provisionally (no fine
    re-check, as while a slider moves) and the live view's numbers without the bands
    (:meth:`cadcam.app.live.LiveView.frame`); its wall and CPU times [s]."""
    error = state.edit(KEY, repr(EDIT * state.value(KEY)))
    if error is not None:
        raise RuntimeError(error)
    wall, cpu = time.perf_counter(), time.process_time()
    outcome = state.run(state.ask(KEY), KEY, recheck=False)
    if outcome.result is None:
        raise RuntimeError(outcome.error)
    LiveView.frame(outcome.result, 0, {f.key for f in state.fields}, bands=False, views=False)
    return time.perf_counter() - wall, time.process_time() - cpu


def _step_cell(step_s: tuple[float, float]) -> str:
    return f"{1e3 * step_s[0]:.0f} ({1e3 * step_s[1]:.0f} CPU)"


# ------------------------------------------------------------------------------------ browser
#: In the browser: the time of each pointer event; and of each replacement of the torque plot's
#: data, of the frame painted after it, and the curve; ``window.__next`` settles at the next
#: (:data:`NEXT`: the step's wait is no polling, which would take the machine's time from the page).
WATCH = """() => {
  window.__moves = []; window.__changes = [];
  if (!window.__watching) {
    window.addEventListener('pointermove', () => window.__moves.push(performance.now()), true);
    window.__watching = true;
  }
  const src = Bokeh.documents[0].get_model_by_name('torque-1');
  src.properties.data.change.connect(() => {
    const came = performance.now(), tau = Array.from(src.data.tau);
    requestAnimationFrame(() => {
      window.__changes.push([came, performance.now(), tau]);
      if (window.__settle) window.__settle();
    });
  });
}"""
#: In the browser: a promise settled by the next replacement of the torque plot's data (:data:`WATCH`).
NEXT = "() => { window.__next = new Promise(settle => { window.__settle = settle; }); }"
#: In the browser: wait for that promise, or fail after the seconds given.
AWAIT = """(seconds) => Promise.race([window.__next,
    new Promise((_, fail) => setTimeout(() => fail(new Error('no new curve')), 1000 * seconds))])"""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _serve(port: int) -> subprocess.Popen:
    """``cadcam app`` on ``port`` of 127.0.0.1 (this process's cache of compiled libraries),
    once it answers."""
    proc = subprocess.Popen([sys.executable, "-m", "cadcam", "app", "--example", LIVE_TEMPLATES[0], "--port",
                             str(port), "--no-browser"], cwd=ROOT, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env=os.environ.copy())
    deadline = time.monotonic() + PAGE_WAIT_S
    while True:
        try:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=PAGE_WAIT_S).read()
            return proc
        except OSError:
            if proc.poll() is not None or time.monotonic() > deadline:
                proc.kill()
                raise RuntimeError(f"cadcam app did not serve on port {port}") from None
            time.sleep(0.2)


def browser_steps(templates=LIVE_TEMPLATES) -> dict[str, list[tuple[float, float]]] | str:
    """Per template of ``templates`` (of :data:`LIVE_TEMPLATES`), each timed slider step's (new
    curves, painted) [s] in the browser; or why it was not measured."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        return "Playwright is not installed (the dev extra's)"
    if not CHROMIUM.exists():
        return f"{CHROMIUM} is missing (make test installs Debian's chromium)"
    for name in templates:  # their libraries in the cache, as after a user's first designs
        _compile(DesignState.template(name))
    port = _free_port()
    server = _serve(port)
    try:
        with sync_playwright() as p:
            context = p.chromium.launch_persistent_context(
                tempfile.mkdtemp(prefix="cadcam-bench-chromium-"), executable_path=str(CHROMIUM),
                args=CHROMIUM_ARGS, headless=True, viewport={"width": 1400, "height": 1000})
            page = context.new_page()
            page.goto(f"http://127.0.0.1:{port}/")
            page.wait_for_selector(".verdict-success", timeout=PAGE_WAIT_S * 1e3)
            out = {}
            for name in templates:
                out[name] = _steps(page, name)
            context.close()
            return out
    finally:
        server.terminate()
        server.wait(timeout=30)


def _open(page, name: str) -> None:
    """Open template ``name`` and wait for its design's torque curve."""
    template = next(t for t in TEMPLATES if t.spec == name)
    if page.locator(".template select").input_value() != template.title:
        page.locator(".template select").select_option(label=template.title)
        page.get_by_text(f"open {name}.toml").wait_for(timeout=PAGE_WAIT_S * 1e3)
        # a template opened starts a history of its own: its first design shown, not the last one's
        # (whose history may say "design 1 of 1" too, and whose form stays until the new design
        # is shown: its summary names the spec)
        page.locator(".history-line").get_by_text("design 1 of 1").wait_for(timeout=PAGE_WAIT_S * 1e3)
        page.locator(".details").get_by_text(f"{name}:").wait_for(timeout=PAGE_WAIT_S * 1e3)
    deadline = time.monotonic() + PAGE_WAIT_S
    while (page.locator(f".slider-{SLIDER} .noUi-handle").count() == 0 or page.locator("span.solving").count()
           or not page.locator("span.verdict-success").count()
           or not page.evaluate("() => Bokeh.documents[0].get_model_by_name('torque-1') !== null")):
        if time.monotonic() > deadline:
            raise RuntimeError(f"{name}: no design in {PAGE_WAIT_S:g} s")
        page.wait_for_timeout(100)


def _steps(page, name: str) -> list[tuple[float, float]]:
    """Drag the rate slider of template ``name`` :data:`WARM_UP` + :data:`STEPS` steps, each once
    the last step's curves came; the timed steps' (new curves, painted) [s]."""
    _open(page, name)
    page.evaluate(WATCH)
    handle = page.locator(f".slider-{SLIDER} .noUi-handle").first
    handle.scroll_into_view_if_needed()
    box = handle.bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    times = []
    for i in range(1, WARM_UP + STEPS + 1):
        moves = page.evaluate("window.__moves.length")
        page.evaluate(NEXT)
        page.mouse.move(x + STEP_PX * i, y)
        page.evaluate(AWAIT, PAGE_WAIT_S)
        moved, (came, painted, tau), before = page.evaluate(
            "[window.__moves[window.__moves.length - 1], window.__changes[window.__changes.length - 1], "
            "window.__changes.length > 1 ? window.__changes[window.__changes.length - 2][2] : null]")
        if page.evaluate("window.__moves.length") <= moves:
            raise RuntimeError(f"{name}: the browser saw no pointer move")
        if before is not None and tau == before:
            raise RuntimeError(f"{name}: step {i} drew the same curve")
        if i > WARM_UP:
            times.append(((came - moved) / 1e3, (painted - moved) / 1e3))
    page.mouse.up()
    page.wait_for_timeout(500)
    return times


def _browser_table(browser: dict[str, list[tuple[float, float]]]) -> None:
    print("| template | steps | new curves: median | max | painted: median | max |")
    print("|---|---|---|---|---|---|")
    for name, times in browser.items():
        came, painted = ([1e3 * t[i] for t in times] for i in (0, 1))
        print(f"| {name} | {len(times)} | {statistics.median(came):.0f} | {max(came):.0f} | "
              f"{statistics.median(painted):.0f} | {max(painted):.0f} |", flush=True)


def browser_only(templates: list[str]) -> int:
    """``--browser [TEMPLATE ...]``: only the browser's slider steps, of ``templates`` (default:
    :data:`LIVE_TEMPLATES`), as :func:`main` prints them."""
    unknown = [t for t in templates if t not in LIVE_TEMPLATES]
    if unknown:
        print(f"bench_page.py: {', '.join(unknown)} is not one of {', '.join(LIVE_TEMPLATES)}", file=sys.stderr)
        return 2
    browser = browser_steps(tuple(templates) or LIVE_TEMPLATES)
    if isinstance(browser, str):
        print(f"Not measured: {browser}.")
        return 1
    _browser_table(browser)
    return 0


def main() -> int:
    print(f"\nThe design page's path for each template (`DesignState`: a `cadcam.Session`, functions as the page "
          f"runs them once the template's libraries are in the cache): the first design (build + solve + fine re-check), then {KEY} × {EDIT} designed warm "
          "from the last answer and its multipliers; beside it the same edit warm from the last design without its "
          "multipliers and from the default start, through the same kept NLP; time [s] | iterations | objective. "
          f"A slider's step in-process: {KEY} × {EDIT} once more designed provisionally (no fine re-check, as while a "
          "slider moves) and the live view's numbers, wall (CPU). One run each, wall time.\n")
    print("| template | functions | first design [s] (build + solve + re-check) | page, warm: time | iterations | "
          "objective | slider step in-process [ms] | last design without multipliers: time | iterations | objective | "
          "default start: time | iterations | objective | warm no worse than the default start |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    firsts, warms, steps = {}, {}, {}
    for template in TEMPLATES:
        first_s, warm_s, step_s, cells = template_rows(template)
        name = cells[0]
        firsts[name], warms[name], steps[name] = first_s, warm_s, step_s
        print("| " + " | ".join(cells) + " |", flush=True)
    browser = browser_steps()
    print(f"\nIn the browser (Debian's Chromium, Playwright): spring 1's rate slider moved {STEPS} steps of {STEP_PX} px "
          f"after {WARM_UP} untimed, each once the last step's curves came; from the pointer event to the torque "
          "plot's data replaced, and to the frame painted after it [ms].\n")
    if isinstance(browser, str):
        print(f"Not measured: {browser}.")
    else:
        _browser_table(browser)
    listed = "; ".join
    rows: list[tuple[str, str, bool]] = [
        (f"a 1-DOF design back within {FIRST_S:g} s (the page's first design of each template, libraries from the "
         "cache)", listed(f"{n} {s:.2f} s" for n, s in firsts.items()), max(firsts.values()) <= FIRST_S),
        (f"warm re-solve after a small edit ≤ {WARM_S:g} s (the page's re-design of each template, {KEY} × {EDIT})",
         listed(f"{n} {s:.2f} s" for n, s in warms.items()), max(warms.values()) <= WARM_S),
    ]
    for name in LIVE_TEMPLATES:  # a row each: the browser's median, or the in-process step where it was not measured
        wall, cpu = steps[name]
        inside = f"in-process {1e3 * wall:.0f} ms wall, {1e3 * cpu:.0f} ms CPU"
        goal = f"{name}: a slider step's new curves ≤ {1e3 * STEP_S:g} ms"
        if isinstance(browser, str):
            rows.append((f"{goal} (in-process: the browser not measured)", inside, wall <= STEP_S))
        else:
            median = statistics.median(t[0] for t in browser[name])
            rows.append((f"{goal} in the browser (median of {STEPS} steps)", f"{1e3 * median:.0f} ms ({inside})",
                         median <= STEP_S))
    print_goals(rows, "issues 30, 32 and 53")
    return 0


if __name__ == "__main__":
    sys.exit(browser_only(sys.argv[2:]) if sys.argv[1:2] == ["--browser"] else main())
