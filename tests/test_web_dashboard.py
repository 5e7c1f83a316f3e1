"""End-to-end tests of the web dashboard in headless Chromium.

A real server (``fibrecut serve``: the FastAPI app and a pool of two worker processes, on
SQLite in a temporary data folder) runs on a free local port. Studies use the analytic
fidelity, so every run takes milliseconds. Playwright drives Debian's Chromium
(/usr/bin/chromium, installed by scripts/install-browser.sh); every page fails its test on any
browser console error or uncaught exception. Screenshots go to test-artifacts/.

The run page's histories and frames are checked on a run whose HDF5 file is written by the
solver's own writer (solver.result.Result.write_hdf5) from small hand-made arrays with known
shapes: this exercises the page's rendering, not the physics.

Where Chromium is missing the tests skip with that reason, except under CI (``CI`` set),
where they fail.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import signal
import socket
import subprocess
import sys
import time
import uuid
from pathlib import Path

import httpx
import numpy as np
import pytest

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[1]
ARTIFACTS = ROOT / "test-artifacts"
CHROMIUM = os.environ.get("FIBRECUT_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
DESKTOP = {"width": 1280, "height": 800}
PHONE = {"width": 390, "height": 844}


def _need_browser():
    problem = None
    if not Path(CHROMIUM).is_file():
        problem = f"Chromium not found at {CHROMIUM} (install it with scripts/install-browser.sh)"
    else:
        try:
            import playwright.sync_api  # noqa: F401
        except ImportError:
            problem = "the Python package playwright is not installed (pip install -e '.[test]')"
    if problem:
        if os.environ.get("CI"):
            pytest.fail(f"{problem}; CI is set, so the browser tests must run")
        pytest.skip(problem)


# ---------------------------------------------------------------------------- fixtures
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def _serve(data: Path, workers: int = 2, **env_extra):
    """`fibrecut serve` on a free local port; yields its base URL, stops it on exit."""
    port = _free_port()
    log = open(data / "serve.log", "w")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])),
               FIBRECUT_LOG="WARNING")
    env.pop("FIBRECUT_API_TOKEN", None)
    env.update(env_extra)
    proc = subprocess.Popen([sys.executable, "-m", "cli.main", "serve", "--host", "127.0.0.1", "--port", str(port),
                             "--data", str(data), "--workers", str(workers)], cwd=ROOT, env=env, stdout=log,
                            stderr=subprocess.STDOUT, start_new_session=True)
    base = f"http://127.0.0.1:{port}"
    try:
        deadline = time.time() + 60
        while True:
            try:
                if httpx.get(f"{base}/api/health", timeout=1).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            if proc.poll() is not None or time.time() > deadline:
                pytest.fail(f"the server did not start: {(data / 'serve.log').read_text()[-3000:]}")
            time.sleep(0.2)
        yield base
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(20)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
        log.close()


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """`fibrecut serve` with two workers on SQLite in a temporary data folder."""
    _need_browser()
    data = tmp_path_factory.mktemp("fibrecut-data")
    with _serve(data) as base:
        yield {"url": base, "data": data}


@pytest.fixture(scope="module")
def browser(server):
    from playwright.sync_api import sync_playwright

    ARTIFACTS.mkdir(exist_ok=True)
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        yield b
        b.close()


class Page:
    """A browser page that records console errors and uncaught exceptions."""

    def __init__(self, browser, base, viewport, allowed=()):
        self.ctx = browser.new_context(viewport=viewport, accept_downloads=True)
        self.page = self.ctx.new_page()
        self.page.set_default_timeout(20_000)
        self.base = base
        self.errors: list[str] = []
        self.allowed = allowed
        self.page.on("console", self._console)
        self.page.on("pageerror", lambda exc: self.errors.append(f"uncaught: {exc}"))

    def _console(self, msg):
        if msg.type == "error" and not any(a in msg.text for a in self.allowed):
            self.errors.append(f"console: {msg.text}")

    def goto(self, hash_="#/"):
        self.page.goto(f"{self.base}/{hash_}")

    def shot(self, name):
        self.page.evaluate("window.scrollTo(0, 0)")
        self.page.screenshot(path=str(ARTIFACTS / f"{name}.png"), full_page=True)

    def close(self):
        self.ctx.close()
        assert not self.errors, "browser console errors:\n" + "\n".join(self.errors)


@pytest.fixture
def desktop(browser, server):
    p = Page(browser, server["url"], DESKTOP)
    yield p
    p.close()


def _svg_marks(locator) -> int:
    """Drawn marks (paths, circles, rects of bars) inside the SVGs of a locator."""
    return locator.evaluate_all(
        "els => els.reduce((n, e) => n + e.querySelectorAll('path.series, circle.point, rect.bar, .pc-lines path').length, 0)")


def _wait_study_done(page, timeout_s=60):
    page.locator("h1 .badge", has_text="done").wait_for(timeout=timeout_s * 1000)


def _api_study(server, doc) -> int:
    r = httpx.post(f"{server['url']}/api/studies", json=doc, timeout=10)
    assert r.status_code == 201, r.text
    return r.json()["id"]


# ---------------------------------------------------------------------------- the form, a sweep, a run
def test_sweep_created_through_the_form_completes_and_its_run_opens(desktop, server):
    page = desktop.page
    desktop.goto("#/new")
    page.get_by_label("Study name", exact=True).fill("e2e-rake-depth")
    page.get_by_label("Fidelity", exact=True).select_option("analytic")
    row = page.locator(".param-row").first
    row.get_by_label("Values (comma-separated)").fill("0, 15, 30")
    page.get_by_role("button", name="+ parameter").click()
    row2 = page.locator(".param-row").nth(1)
    row2.get_by_label("Field (dotted name)").fill("cut.depth_um")
    row2.get_by_label("Given as").select_option("range")
    row2.get_by_label("Low").fill("50")
    row2.get_by_label("High").fill("150")
    row2.get_by_label("Step").fill("50")
    assert page.locator("#study-size").inner_text() == "9 runs"  # 3 values x 3 levels
    desktop.shot("form-filled-1280")
    page.get_by_role("button", name="Create study").click()
    page.wait_for_url("**/#/studies/*")
    _wait_study_done(page)
    page.locator("table.trials tbody tr").first.wait_for()
    assert page.locator("table.trials tbody tr").count() == 9  # 3 rake angles x 3 depths
    assert page.locator(".progress-text").first.inner_text().startswith("9/9 done")
    # charts: parallel coordinates, importance, a response plot per metric and parameter
    titles = page.locator(".chart-card h2").all_inner_texts()
    assert "Parallel coordinates" in titles and "Parameter importance" in titles
    assert any(t.startswith("Ft N/mm against rake_angle_deg") for t in titles), titles
    for card in page.locator(".chart-card").all():
        assert _svg_marks(card.locator("svg")) > 0, card.locator("h2").inner_text()
    # sort the table by thrust force, descending, and filter it
    header = page.locator("th", has_text="Ft N/mm").locator("button")
    header.click()
    header.click()
    assert page.locator("th", has_text="Ft N/mm").get_attribute("aria-sort") == "descending"
    col = [c for c, t in enumerate(page.locator("table.trials thead th").all_text_contents()) if t.startswith("Ft N/mm")][0]
    values = [float(v) for v in page.locator(f"table.trials tbody tr td:nth-child({col + 1})").all_inner_texts()]
    assert values == sorted(values, reverse=True) and len(values) == 9
    page.get_by_label("Filter").fill("150")
    # the filter keeps the rows whose text holds "150": the three depth-150 rows, and any other row
    # in which some cell (a run time, a force) happens to contain those digits
    rows = page.locator("table.trials tbody tr").all_inner_texts()
    dcol = [c for c, t in enumerate(page.locator("table.trials thead th").all_text_contents()) if "depth" in t][0]
    depths = [float(v) for v in page.locator(f"table.trials tbody tr td:nth-child({dcol + 1})").all_inner_texts()]
    assert depths.count(150.0) == 3 and all("150" in r for r in rows) and len(rows) < 9
    page.get_by_label("Filter").fill("")
    # CSV export from the server
    with page.expect_download() as dl:
        page.get_by_role("link", name="Export CSV").click()
    csv_text = Path(dl.value.path()).read_text()
    assert csv_text.splitlines()[0].startswith("job_id,") and len(csv_text.splitlines()) == 10
    desktop.shot("study-sweep-1280")
    # open a run
    page.locator("table.trials tbody tr").first.get_by_role("link", name="Run of trial").click()
    page.wait_for_url("**/#/runs/*")
    page.locator("h1", has_text="Run").wait_for()
    assert page.locator(".metric").count() >= 4
    page.locator(".chart-card svg rect.bar").first.wait_for()
    assert _svg_marks(page.locator(".chart-card svg")) > 0  # the analytic model's force components
    scene = json.loads(page.locator(".scene-json pre").text_content())
    assert scene["fidelity"] == "analytic" and scene["cut"]["depth_um"] in (50, 100, 150)
    href = page.get_by_role("link", name="Download HDF5").get_attribute("href")
    r = httpx.get(server["url"] + href, timeout=10)
    assert r.status_code == 200 and r.content[:8] == b"\x89HDF\r\n\x1a\n"
    desktop.shot("run-analytic-1280")


def test_studies_list_updates_live(desktop, server):
    page = desktop.page
    desktop.goto("#/")
    page.locator("h1", has_text="Studies").wait_for()
    sid = _api_study(server, {"name": "e2e-live", "kind": "sweep", "scene": "seed-90deg-fem-quick", "fixed": {"fidelity": "analytic"},
                              "parameters": {"tool.edge_radius_um": {"values": [5, 10, 20, 40]}}})
    row = page.locator(f'tr[data-study-id="{sid}"]')
    row.wait_for(timeout=10_000)  # appears without a reload
    row.locator(".badge", has_text="done").wait_for(timeout=30_000)
    assert "4/4 done" in row.locator(".progress-text").inner_text()
    desktop.shot("studies-1280")


def test_cancel_a_running_study_from_its_page(desktop, server):
    sid = _api_study(server, {"name": "e2e-cancel", "kind": "sweep", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
                              "parameters": {"tool.rake_angle_deg": {"low": 0, "high": 40, "step": 0.05}}})  # 801 points
    page = desktop.page
    desktop.goto(f"#/studies/{sid}")
    page.get_by_role("button", name="Cancel study").click()
    page.locator("h1 .badge", has_text="cancelled").wait_for(timeout=30_000)
    assert page.get_by_role("button", name="Cancel study").is_hidden()
    study = httpx.get(f"{server['url']}/api/studies/{sid}", timeout=10).json()
    assert study["status"] == "cancelled" and study["counts"]["cancelled"] > 0
    assert "cancelled" in page.locator(".progress-text").inner_text()


def test_optimisation_with_two_objectives_shows_history_pareto_and_importance(browser, server):
    sid = _api_study(server, {
        "name": "e2e-pareto", "kind": "optimize", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
        "parameters": {"tool.rake_angle_deg": {"low": 0, "high": 40}, "cut.depth_um": {"low": 25, "high": 150}},
        "sampler": "nsga2", "n_trials": 16, "parallelism": 4, "seed": 3,
        "objectives": [{"metric": "thrust_force_N_per_mm", "direction": "minimize"},
                       {"metric": "material_removal_rate_mm2_s", "direction": "maximize"}]})
    for viewport, tag in ((DESKTOP, "1280"), (PHONE, "390")):
        p = Page(browser, server["url"], viewport)
        try:
            page = p.page
            p.goto(f"#/studies/{sid}")
            _wait_study_done(page)
            titles = page.locator(".chart-card h2").all_inner_texts()
            assert any(t.startswith("Pareto front") for t in titles), titles
            assert any(t.startswith("History") for t in titles), titles
            pareto = page.locator(".chart-card", has=page.locator("h2", has_text="Pareto front"))
            ringed = pareto.locator("circle.point[stroke='#111827']").count()
            assert ringed >= 1
            # the page's front agrees with the service's
            trials = httpx.get(f"{server['url']}/api/studies/{sid}/trials", timeout=10).json()
            assert ringed == sum(1 for t in trials if t.get("on_pareto_front"))
            for card in page.locator(".chart-card").all():
                assert _svg_marks(card.locator("svg")) > 0, card.locator("h2").inner_text()
            # nothing wider than the viewport (no horizontal page scroll) on either size
            assert page.evaluate("document.documentElement.scrollWidth") <= viewport["width"]
            p.shot(f"study-pareto-{tag}")
        finally:
            p.close()


# ---------------------------------------------------------------------------- keyboard only
def test_form_keyboard_only_shows_the_api_422_next_to_the_field(browser, server):
    # the 422 answer of the deliberate mistake is the one console message allowed here
    p = Page(browser, server["url"], DESKTOP, allowed=("status of 422",))
    try:
        page = p.page
        p.goto("#/new")
        page.locator("h1", has_text="New study").wait_for()
        # every control has a label
        unlabelled = page.evaluate("""() => [...document.querySelectorAll('form input, form select')]
            .filter(e => e.type !== 'radio' ? !(e.labels && e.labels.length) : !document.querySelector(`label[for="${e.id}"]`))
            .map(e => e.outerHTML)""")
        assert unlabelled == []
        assert page.evaluate("document.activeElement.name") == "name"  # focus starts on the name
        page.keyboard.press("Control+A")
        page.keyboard.type("kb-study")
        # Tab through the form: the fidelity (arrow keys choose analytic), then the parameter's
        # field name; the focus ring is visible on every stop
        seen = []
        for _ in range(14):
            page.keyboard.press("Tab")
            info = page.evaluate("""() => { const e = document.activeElement; const s = getComputedStyle(e);
                return {ph: e.getAttribute('placeholder'), name: e.getAttribute('name'), outline: s.outlineStyle, width: s.outlineWidth}; }""")
            seen.append(info)
            assert info["outline"] != "none" and info["width"] != "0px", info
            if info["name"] == "fidelity":
                page.keyboard.press("ArrowDown")
                assert page.evaluate("document.activeElement.value") == "analytic"
            if info["ph"] == "tool.rake_angle_deg":
                break
        else:
            pytest.fail(f"Tab never reached the parameter field: {seen}")
        assert [i["name"] for i in seen].index("fidelity") < len(seen) - 1
        page.keyboard.press("Control+A")
        page.keyboard.type("tool.rake_angl")  # a typo: the API rejects it
        page.keyboard.press("Enter")
        msg = page.locator(".param-row .row-msg")
        msg.wait_for()
        assert "unknown scene field" in msg.inner_text()
        assert page.locator(".error-summary").is_visible()
        # the focus went to the field named by the API, marked invalid and described by the message
        focused = page.evaluate("""() => ({ph: document.activeElement.getAttribute('placeholder'),
            invalid: document.activeElement.getAttribute('aria-invalid'),
            described: (document.activeElement.getAttribute('aria-describedby') || '').split(' ')
                .map(id => document.getElementById(id)?.textContent || '').join(' ')})""")
        assert focused["ph"] == "tool.rake_angle_deg" and focused["invalid"] == "true"
        assert "unknown scene field" in focused["described"]
        p.shot("form-422-1280")
        # fix it from the keyboard and submit with Enter
        page.keyboard.press("Control+A")
        page.keyboard.type("tool.rake_angle_deg")
        page.keyboard.press("Enter")
        page.wait_for_url("**/#/studies/*")
        page.locator("h1", has_text="kb-study").wait_for()
        assert "fidelity = analytic" in page.locator(".facts").inner_text()
        # the trials table sorts from the keyboard: Tab to a column header, Enter
        _wait_study_done(page)
        page.locator("table.trials tbody tr").first.wait_for()
        for _ in range(40):
            page.keyboard.press("Tab")
            if page.evaluate("document.activeElement.classList.contains('sort') && document.activeElement.textContent.startsWith('rake_angle_deg')"):
                break
        else:
            pytest.fail("Tab never reached the rake_angle_deg column header")
        page.keyboard.press("Enter")
        page.keyboard.press("Enter")
        assert page.locator("th[data-key='p:tool.rake_angle_deg']").get_attribute("aria-sort") == "descending"
        assert page.evaluate("document.activeElement.textContent").startswith("rake_angle_deg")  # the focus stays
    finally:
        p.close()


def test_form_reads_well_on_a_phone(browser, server):
    p = Page(browser, server["url"], PHONE)
    try:
        page = p.page
        p.goto("#/new")
        page.locator(".param-row").first.wait_for()
        assert page.evaluate("document.documentElement.scrollWidth") <= PHONE["width"]
        box = page.get_by_role("button", name="Create study").bounding_box()
        assert box["x"] >= 0 and box["x"] + box["width"] <= PHONE["width"]
        p.shot("form-390")
        p.goto("#/")
        page.locator("tr[data-study-id], .empty:not([hidden])").first.wait_for()
        assert page.evaluate("document.documentElement.scrollWidth") <= PHONE["width"]
        p.shot("studies-390")
    finally:
        p.close()


# ---------------------------------------------------------------------------- run page: histories, frames, diagnosis
def _rendering_run(server, status="unstable") -> str:
    """A run record and HDF5 file (written by solver.result) with small hand-made histories and frames."""
    from store import get_database
    from store.models import Run
    from solver.result import SOLVER_VERSION, Result
    from solver.scene import load_scene

    scene = load_scene("seed-0deg-fem-quick")
    nx, ny = 16, 6  # 16 x 6 quads of 5 um
    xs, ys = np.meshgrid(np.arange(nx + 1) * 5e-6, np.arange(ny + 1) * 5e-6)
    node = lambda i, j: j * (nx + 1) + i  # noqa: E731
    quads = np.array([[node(i, j), node(i + 1, j), node(i + 1, j + 1), node(i, j + 1)] for j in range(ny) for i in range(nx)])
    material = np.array([(j % 2) for j in range(ny) for i in range(nx)], np.int8)  # fibre and matrix strips
    frames, times = [], []
    for k in range(3):
        px = xs.ravel() + 0.0
        py = ys.ravel() + (ys.ravel() > 20e-6) * (xs.ravel() < 20e-6 * (k + 1)) * 2e-6 * (k + 1)  # a lifting chip
        state = np.zeros(len(quads), np.uint8)
        state[(ny - 1) * nx: (ny - 1) * nx + 3 * (k + 1)] = 1
        n_p = 4 * (k + 1)  # SPH particles under the edge, with the keys the hybrid coupler writes
        frames.append({"positions": np.stack([px, py], 1), "material": material, "state": state,
                       "damage": np.linspace(0, 1, len(quads)).astype(np.float32),
                       "stress": np.tile(np.array([1e6, -2e6, 5e5], np.float32), (len(quads), 1)),
                       "particles_x": np.linspace(60e-6, 75e-6, n_p), "particles_y": np.full(n_p, 28e-6),
                       "particles_material": np.ones(n_p, np.int32), "particles_damage": np.zeros(n_p)})
        times.append((k + 1) * 1e-6)
    t = np.linspace(0, 3e-6, 200)
    travel = np.linspace(0, 60, 200)
    res = Result(scene=scene, status=status, steps=12345, wall_time_s=1.5)
    res.series["forces"] = {"time": t, "Fc": 30 * (1 - np.exp(-travel / 8)), "Ft": 15 * (1 - np.exp(-travel / 8)), "travel_um": travel}
    res.series["energies"] = {"time": t, "external_work": 1e-3 * t / 3e-6, "internal": 0.6e-3 * t / 3e-6, "kinetic": 0.1e-3 * t / 3e-6}
    res.series["diagnostics"] = {"time": t, "dt": 5e-11 * (1 - 0.9 * (t > 2.5e-6))}
    # the tool (solver/tool.py layout): edge arc centre, velocity -20 m/s, r = 5 um, rake 10 deg, clearance 7 deg
    a, g = math.radians(10), math.radians(7)
    tool0 = np.array([100e-6, 10e-6, -20.0, 0.0, 5e-6, a, g, math.cos(a), math.sin(a), math.cos(g), math.sin(g), 1.0])
    res.series["mesh"] = {"x": xs.ravel(), "y": ys.ravel(), "quads": quads, "material": material, "tool0": tool0}
    res.frames, res.frame_times = frames, times
    res.metrics.update({f"{face}_{c}_force_N_per_mm": v for face, vc, vt in (("rake", 22.0, -3.0), ("edge", 7.0, 15.0),
                                                                       ("clearance", 0.5, 2.7))
                        for c, v in (("cutting", vc), ("thrust", vt))})  # the split by tool face, as solver.cutting
    res.metrics.update({"cutting_force_N_per_mm": 29.5, "thrust_force_N_per_mm": 14.7, "damage_depth_um": 12.0,
                        "bounce_back_um": 3.0, "energy_error": 0.02,
                        "steady_window": {"travel_from_um": 30.0, "travel_to_um": 60.0, "samples": 100, "rule": "last 50 % of the cut length"}})
    if status == "unstable":
        res.diagnosis = {"check": "time step collapse", "where": "element 85", "when": "t = 2.5 us",
                         "what": "dt fell by 10x in one chunk", "change": "refine the mesh or lower numerics.cfl"}
    run_id = uuid.uuid4().hex
    res.write_hdf5(Path(server["data"]) / "runs" / f"{run_id}.h5")
    db = get_database(f"sqlite:///{Path(server['data']) / 'fibrecut.db'}")
    summary = json.loads(json.dumps(res.summary(), default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)))
    with db.write() as s:
        s.add(Run(id=run_id, job_id=None, scene_hash="rendering-test-" + run_id[:8], solver_version=SOLVER_VERSION, status=status,
                  summary=summary, diagnosis=res.diagnosis, wall_time_s=1.5, has_file=True, worker_id=None, host="test",
                  created_at=time.time()))
    return run_id


def test_run_page_draws_histories_frames_and_the_diagnosis(browser, server):
    run_id = _rendering_run(server)
    for viewport, tag in ((DESKTOP, "1280"), (PHONE, "390")):
        p = Page(browser, server["url"], viewport)
        try:
            page = p.page
            p.goto(f"#/runs/{run_id}")
            page.locator("h1", has_text="Run").wait_for()
            assert page.locator(".diagnosis h2").inner_text() == "Stability diagnosis"
            assert "time step collapse" in page.locator(".diagnosis").inner_text()
            force = page.locator(".chart-card", has=page.locator("h2", has_text="Force history"))
            force.locator("path.series").first.wait_for()
            assert force.locator("path.series").count() == 4  # Fc, Ft and their steady means
            band = force.locator("rect.band")
            assert band.count() == 1 and float(band.get_attribute("width")) > 0
            assert "tool travel" in force.locator("svg").text_content()
            faces = page.locator(".chart-card", has=page.locator("h2", has_text="Forces by tool face"))
            faces.locator("rect.bar").first.wait_for()
            assert faces.locator("rect.bar").count() == 6  # Fc and Ft on the rake face, the edge and the clearance face
            assert "clearance Ft" in faces.text_content() and "rake Fc" in faces.text_content()
            for title in ("Energy balance", "Time-step history"):
                card = page.locator(".chart-card", has=page.locator("h2", has_text=title))
                assert card.locator("path.series").count() >= 1, title
            # frames: the canvas is painted, the slider moves, colouring by state shows failed elements
            canvas = page.locator("canvas.frame-canvas")
            page.wait_for_function("() => document.querySelector('.frame-label')?.textContent.startsWith('3 of 3')")
            painted = lambda: canvas.evaluate("""c => { const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
                let n = 0; for (let i = 0; i < d.length; i += 4) if (!(d[i] === 248 && d[i+1] === 250 && d[i+2] === 252)) n++; return n / (d.length / 4); }""")  # noqa: E731
            legend = page.locator(".chart-card", has=page.locator("h2", has_text="Chip frames")).locator(".legend")
            legend.locator(".legend-item").first.wait_for()
            assert painted() > 0.2
            assert "fibre" in legend.inner_text() and "matrix" in legend.inner_text() and "tool" in legend.inner_text()
            assert "SPH particles (12)" in legend.inner_text()  # the hybrid's particles of frame 3 are drawn
            slider = page.locator("#frame-slider")
            slider.focus()
            page.keyboard.press("Home")
            page.wait_for_function("() => document.querySelector('.frame-label').textContent.startsWith('1 of 3')")
            page.select_option("#frame-colour", "state")
            legend.locator(".legend-item", has_text="failed").wait_for()
            assert painted() > 0.2
            p.shot(f"run-histories-{tag}")
            assert page.evaluate("document.documentElement.scrollWidth") <= viewport["width"]
        finally:
            p.close()


# ---------------------------------------------------------------------------- accuracy against cost, analysis helpers
def test_convergence_study_shows_accuracy_against_cost(desktop, server):
    sid = _api_study(server, {"name": "e2e-h", "kind": "convergence", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
                              "parameters": {"numerics.element_size_um": {"values": [8, 4, 2]}}})
    page = desktop.page
    desktop.goto(f"#/studies/{sid}")
    _wait_study_done(page)
    card = page.locator(".chart-card", has=page.locator("h2", has_text="Accuracy against cost"))
    card.wait_for()
    # the analytic model does not depend on the element size: the page says so instead of plotting zeros
    assert "does not depend on element_size_um" in card.inner_text()


def _convergence_study(server) -> tuple[int, dict]:
    """A finished convergence study over the element size h (8, 4, 2, 1 um) stored in the
    service's database, whose runs follow Fc(h) = Fc* (1 + 0.01 h^2), Ft(h) = Ft* (1 + 0.03 h^2)
    at a wall time of 1/h^2 s: the relative error against the finest level (h = 1) is
    c (h^2 - 1) / (1 + c)."""
    from store import get_database
    from store.models import Job, Run, Study
    from solver.result import SOLVER_VERSION

    db = get_database(f"sqlite:///{Path(server['data']) / 'fibrecut.db'}")
    levels = [8.0, 4.0, 2.0, 1.0]
    doc = {"name": "e2e-h-fem", "kind": "convergence", "scene": "seed-0deg-fem-quick", "fixed": {}, "parameters": {"numerics.element_size_um": {"values": levels}}}
    t0 = time.time()
    expected = {}
    with db.write() as s:
        st = Study(name=doc["name"], kind="convergence", status="done", document=doc, planned_jobs=4, created_at=t0, updated_at=t0, finished_at=t0)
        s.add(st)
        s.flush()
        for i, h_um in enumerate(levels):
            run_id = uuid.uuid4().hex
            summary = {"cutting_force_N_per_mm": 30.0 * (1 + 0.01 * h_um**2), "thrust_force_N_per_mm": 15.0 * (1 + 0.03 * h_um**2),
                       "damage_depth_um": 10.0, "wall_time_s": 1.0 / h_um**2, "status": "ok", "steps": 100, "fidelity": "fem2d"}
            s.add(Run(id=run_id, job_id=None, scene_hash=f"conv-{run_id}", solver_version=SOLVER_VERSION, status="ok", summary=summary,
                      diagnosis=None, wall_time_s=1.0 / h_um**2, has_file=False, created_at=t0))
            s.flush()  # the job refers to the run
            s.add(Job(study_id=st.id, index=i, params={"numerics.element_size_um": h_um}, scene={"numerics": {"element_size_um": h_um}},
                      scene_hash=f"conv-{run_id}", status="done", attempts=1, progress=1.0, run_id=run_id, created_at=t0, finished_at=t0))
            if h_um != 1.0:
                expected[h_um] = sorted([0.01 * (h_um**2 - 1) / 1.01, 0.03 * (h_um**2 - 1) / 1.03])
        sid = st.id
    return sid, expected


def test_accuracy_against_cost_plots_each_level_error_over_wall_time(desktop, server):
    sid, expected = _convergence_study(server)
    page = desktop.page
    desktop.goto(f"#/studies/{sid}")
    card = page.locator(".chart-card", has=page.locator("h2", has_text="Accuracy against cost"))
    card.locator("circle.point").first.wait_for()
    assert "log" in card.locator(".hint").inner_text()
    titles = card.locator("circle.point title").all_text_contents()
    # one point per coarse level and metric (Fc, Ft; the damage depth does not change), with its error
    assert len(titles) == 2 * len(expected), titles
    for h_um, err in expected.items():
        hits = [t for t in titles if t.startswith(f"numerics.element_size_um = {h_um:g}:")]
        shown = sorted(float(t.split("error ")[1].split(" ")[0]) for t in hits)
        assert len(shown) == 2 and all(math.isclose(a, b, rel_tol=1e-3) for a, b in zip(shown, err)), (h_um, shown, err)
    desktop.shot("study-convergence-1280")
    # the run of the h = 4 um level carries its estimated discretisation error (service/discretisation.py)
    row = page.locator("table.trials tbody tr", has=page.locator("td", has_text=re.compile(r"^4$")))
    row.get_by_role("link", name="Run of trial").click()
    page.locator("#est-h").wait_for()
    notes = page.locator(".metric-note").all_inner_texts()
    assert f"± {100 * expected[4.0][0]:.3g} % (discretisation)" in notes, notes  # Fc: 0.01 (16 - 1) / 1.01
    desktop.shot("run-estimated-error-1280")


def test_convergence_with_replicas_created_through_the_form(desktop, server):
    """The form's convergence kind asks for replicas; 2 levels x 3 replicas is 6 runs, and the
    finished study lists its 2 levels, 3 of 3 replicas ok each (analytic fidelity: milliseconds)."""
    page = desktop.page
    desktop.goto("#/new")
    page.get_by_label("Study name", exact=True).fill("e2e-conv-replicas")
    page.get_by_label("Fidelity", exact=True).select_option("analytic")
    page.get_by_label("Convergence", exact=True).check()
    row = page.locator(".param-row").first
    row.get_by_label("Field (dotted name)").fill("numerics.element_size_um")
    row.get_by_label("Values (comma-separated)").fill("5, 2.5")
    page.get_by_label("Replicas per level").fill("3")
    page.wait_for_function("() => document.querySelector('#study-size').textContent === '6 runs'")
    page.get_by_role("button", name="Create study").click()
    page.wait_for_url("**/#/studies/*")
    _wait_study_done(page)
    levels = page.locator(".chart-card", has=page.locator("h2", has_text="Levels"))
    levels.locator("table.levels tbody tr").nth(1).wait_for()
    rows = levels.locator("table.levels tbody tr").all_inner_texts()
    assert len(rows) == 2 and all("3 / 3" in r for r in rows), rows
    assert page.locator("table.trials tbody tr").count() == 6


def test_convergence_with_replicas_shows_level_means_and_resolved_errors(desktop, server):
    """A stored convergence study of 2 levels x 3 replicas with known samples (Fc at h = 2 um: 12, 14,
    16; at the finest h = 1 um: 10, 11, 12; Ft 5 everywhere): the Levels card gives the means with
    their standard errors and the error of the coarse mean, 3/11 = 27.3 %, with its standard error
    sqrt(4/3 + 1/3) / 11 = 11.7 %; the accuracy chart draws one point per level, not per run."""
    from store import get_database
    from store.models import Job, Run, Study
    from solver.result import SOLVER_VERSION

    db = get_database(f"sqlite:///{Path(server['data']) / 'fibrecut.db'}")
    doc = {"name": "e2e-replicas", "kind": "convergence", "scene": "seed-0deg-fem-quick", "fixed": {},
           "parameters": {"numerics.element_size_um": {"values": [2.0, 1.0]}}, "replicas": 3}
    samples = {2.0: [12.0, 14.0, 16.0], 1.0: [10.0, 11.0, 12.0]}
    t0 = time.time()
    with db.write() as s:
        st = Study(name=doc["name"], kind="convergence", status="done", document=doc, planned_jobs=6, created_at=t0, updated_at=t0, finished_at=t0)
        s.add(st)
        s.flush()
        i = 0
        for h_um, fcs in samples.items():
            for k, fc in enumerate(fcs):
                run_id = uuid.uuid4().hex
                summary = {"cutting_force_N_per_mm": fc, "thrust_force_N_per_mm": 5.0, "wall_time_s": 4.0 / h_um**2, "status": "ok", "steps": 100}
                s.add(Run(id=run_id, job_id=None, scene_hash=f"rep-{run_id}", solver_version=SOLVER_VERSION, status="ok", summary=summary,
                          diagnosis=None, wall_time_s=4.0 / h_um**2, has_file=False, created_at=t0))
                s.flush()
                s.add(Job(study_id=st.id, index=i, params={"numerics.element_size_um": h_um, "replica": k},
                          scene={"numerics": {"element_size_um": h_um, "speed_scaling": 1000.0 * (1 + k * 1e-6)}},
                          scene_hash=f"rep-{run_id}", status="done", attempts=1, progress=1.0, run_id=run_id, created_at=t0, finished_at=t0))
                i += 1
        sid = st.id
    page = desktop.page
    desktop.goto(f"#/studies/{sid}")
    levels = page.locator(".chart-card", has=page.locator("h2", has_text="Levels"))
    levels.locator("table.levels tbody tr").first.wait_for()
    rows = levels.locator("table.levels tbody tr").all_inner_texts()
    assert len(rows) == 2, rows
    coarse = next(r for r in rows if "element_size_um = 2" in r)
    assert "3 / 3" in coarse and "14 ± 1.2" in coarse and "27.3 % ± 12 %" in coarse, coarse
    assert "(finest)" in next(r for r in rows if "element_size_um = 1" in r)
    card = page.locator(".chart-card", has=page.locator("h2", has_text="Accuracy against cost"))
    card.locator("circle.point").first.wait_for()
    titles = card.locator("circle.point title").all_text_contents()
    # Fc's coarse level only: Ft has zero error, the finest level is the reference
    assert len(titles) == 1 and titles[0].startswith("numerics.element_size_um = 2: error of the mean 0.2727 ± 0.12"), titles
    assert "over 3 replicas, 1.0 s per run" in titles[0], titles
    desktop.shot("study-convergence-replicas-1280")
    # the run of the coarse level's first replica carries the level mean's error and its standard error
    row = page.locator("table.trials tbody tr").first  # trial 0: h = 2 um, replica 0 (the unperturbed scene)
    assert row.locator("td").nth(2).inner_text() == "2" and row.locator("td").nth(3).inner_text() == "0", row.inner_text()
    row.get_by_role("link", name="Run of trial").click()
    page.locator("#est-h").wait_for()
    notes = page.locator(".metric-note").all_inner_texts()
    assert "± 27.3 % (discretisation; its standard error 12 %)" in notes, notes
    assert "over 3 replicas" in page.locator("section[aria-labelledby=est-h]").inner_text()


def test_analysis_helpers_against_python_references(desktop, server):
    """Spearman's rho, the Pareto front, best-so-far and the error against the finest level
    computed by web/static/analysis.js in the browser, against scipy and brute force."""
    from scipy.stats import spearmanr

    rng = np.random.default_rng(7)
    x = rng.normal(size=40).round(1)  # rounding makes ties
    y = (x ** 3 + rng.normal(scale=0.5, size=40)).round(1)
    pts = rng.uniform(size=(60, 2)).round(2)
    desktop.goto("#/")
    page = desktop.page
    page.locator("h1", has_text="Studies").wait_for()
    out = page.evaluate("""async ([x, y, pts]) => {
        const a = await import('/static/analysis.js');
        return {rho: a.spearman(x, y), front: a.paretoFront(pts, ['minimize', 'maximize']),
                best: a.bestSoFar([3, null, 5, 1, 2, 0.5], 'minimize'),
                err: a.errorAgainstFinest([{level: 8, wall: 1, value: 12}, {level: 4, wall: 4, value: 10.5}, {level: 2, wall: 16, value: 10}])};
    }""", [x.tolist(), y.tolist(), pts.tolist()])
    assert math.isclose(out["rho"], spearmanr(x, y).statistic, rel_tol=1e-12)
    brute = [i for i, p in enumerate(pts)
             if not any((q[0] <= p[0] and q[1] >= p[1]) and (q[0] < p[0] or q[1] > p[1]) for q in pts)]
    assert sorted(out["front"]) == brute
    assert out["best"] == [3, 3, 3, 1, 1, 0.5]
    assert [(r["level"], round(r["error"], 12)) for r in out["err"]["points"]] == [(8, 0.2), (4, 0.05)]


def test_form_asks_for_the_token_when_the_server_requires_one(browser, tmp_path):
    _need_browser()
    with _serve(tmp_path, workers=0, FIBRECUT_API_TOKEN="s3cret-token") as base:
        # the first, token-less POST answers 401: the one console message allowed here
        p = Page(browser, base, DESKTOP, allowed=("status of 401",))
        try:
            page = p.page
            p.goto("#/new")
            page.get_by_label("Study name", exact=True).fill("token-study")
            page.get_by_role("button", name="Create study").click()
            box = page.get_by_label("API token", exact=True)
            box.wait_for()
            assert page.evaluate("document.activeElement.type") == "password"
            box.fill("s3cret-token")
            box.press("Enter")
            page.wait_for_url("**/#/studies/*")
            page.locator("h1", has_text="token-study").wait_for()
            assert page.evaluate("localStorage.getItem('fibrecut.token')") == "s3cret-token"
        finally:
            p.close()
