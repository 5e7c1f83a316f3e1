"""The dashboard's view of replicated studies in headless Chromium: error bars (standard errors),
statistically tied trials, the confirmation, the calibration and paged trial tables.

The same server and browser fixtures as tests/test_web_dashboard.py. The replicated studies are
stored with known samples, so every mean, standard error and tie is known exactly:

    rake  0: Ft 20, 22, 24 -> mean 22 +- 1.155
    rake 10: Ft 10, 11, 12 -> mean 11 +- 0.577  (the best)
    rake 20: Ft 11, 12, 13 -> mean 12 +- 0.577  (tied: |12 - 11| = 1 <= 2 sqrt(1/3 + 1/3) = 1.63)
    rake 30: Ft 14, 15, 16 -> mean 15 +- 0.577  (not tied: 4 > 1.63)
"""

from __future__ import annotations

import re
import time
import uuid
from pathlib import Path

import httpx
import pytest

from harness import sweep_doc
from test_web_dashboard import DESKTOP, Page, _api_study, _wait_study_done, browser, desktop, server  # noqa: F401 - fixtures

pytestmark = pytest.mark.browser

SAMPLES = {0: [20.0, 22.0, 24.0], 10: [10.0, 11.0, 12.0], 20: [11.0, 12.0, 13.0], 30: [14.0, 15.0, 16.0]}


def _store_replicated_sweep(server, samples: dict, name: str, confirm: dict | None = None) -> int:
    """A finished sweep with replicas (thrust minimised) whose runs carry the given samples."""
    from store import get_database
    from store.models import Job, Run, Study
    from solver.result import SOLVER_VERSION

    db = get_database(f"sqlite:///{Path(server['data']) / 'fibrecut.db'}")
    n_rep = len(next(iter(samples.values())))
    doc = {"name": name, "kind": "sweep", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
           "parameters": {"tool.rake_angle_deg": {"values": list(samples)}}, "replicas": n_rep,
           "objectives": [{"metric": "thrust_force_N_per_mm", "direction": "minimize"}]}
    t0 = time.time()
    with db.write() as s:
        st = Study(name=name, kind="sweep", status="done", document=doc, planned_jobs=n_rep * len(samples),
                   created_at=t0, updated_at=t0, finished_at=t0)
        s.add(st)
        s.flush()
        i = 0
        for rake, fts in samples.items():
            for k, ft in enumerate(fts):
                run_id = uuid.uuid4().hex
                summary = {"thrust_force_N_per_mm": ft, "cutting_force_N_per_mm": 2 * ft, "status": "ok", "wall_time_s": 0.001}
                s.add(Run(id=run_id, job_id=None, scene_hash=f"w-{run_id}", solver_version=SOLVER_VERSION, status="ok", summary=summary,
                          diagnosis=None, wall_time_s=0.001, has_file=False, created_at=t0))
                s.flush()
                s.add(Job(study_id=st.id, index=i, params={"tool.rake_angle_deg": rake, "replica": k},
                          scene={"tool": {"rake_angle_deg": rake}}, scene_hash=f"w-{run_id}", status="done", attempts=1,
                          progress=1.0, run_id=run_id, created_at=t0, finished_at=t0))
                i += 1
        return st.id


def test_replicated_means_are_drawn_with_error_bars_and_tied_trials_marked(desktop, server):
    sid = _store_replicated_sweep(server, SAMPLES, "e2e-ties")
    page = desktop.page
    desktop.goto(f"#/studies/{sid}")
    chart = page.locator(".chart-card", has=page.locator("h2", has_text="Ft N/mm against rake_angle_deg"))
    chart.locator("circle.point").first.wait_for()
    # one point per rake angle (means), each with an error bar of one standard error
    assert chart.locator("circle.point").count() == 4
    bars = chart.locator("g.errbar")
    assert bars.count() == 4
    lengths = bars.evaluate_all("gs => gs.map(g => { const l = g.querySelector('line'); return Math.abs(l.y2.baseVal.value - l.y1.baseVal.value); })")
    titles = chart.locator("circle.point title").all_text_contents()
    by_rake = {float(t.split("rake_angle_deg = ")[1].split(",")[0]): t for t in titles}
    assert "22 ± 1.2" in by_rake[0] and "11 ± 0.58" in by_rake[10] and "12 ± 0.58" in by_rake[20], titles
    # the bars' lengths (2 sem, in pixels) are in the ratio of the standard errors: rake 0's is twice the others'
    order = chart.locator("circle.point").evaluate_all("cs => cs.map(c => c.querySelector('title').textContent)")
    l0 = lengths[[i for i, t in enumerate(order) if "rake_angle_deg = 0," in t][0]]
    l10 = lengths[[i for i, t in enumerate(order) if "rake_angle_deg = 10," in t][0]]
    assert l0 == pytest.approx(2 * l10, rel=0.05), lengths
    # exactly one trial is statistically tied with the best (20 deg), and it is marked
    assert chart.locator("circle.tie").count() == 1
    tie_xy = chart.locator("circle.tie").evaluate("c => [c.cx.baseVal.value, c.cy.baseVal.value]")
    pts = chart.locator("circle.point").evaluate_all("cs => cs.map(c => [c.cx.baseVal.value, c.cy.baseVal.value, c.querySelector('title').textContent])")
    tied_title = next(t for x, y, t in pts if abs(x - tie_xy[0]) < 0.5 and abs(y - tie_xy[1]) < 0.5)
    assert "rake_angle_deg = 20," in tied_title
    # the table: one row per trial with mean ± standard error, best and tied badges
    rows = page.locator("table.trials tbody tr")
    assert rows.count() == 4
    best = page.locator("table.trials tbody tr[data-best]")
    tied = page.locator("table.trials tbody tr[data-tied]")
    assert best.count() == 1 and tied.count() == 1
    assert "11 ± 0.58" in best.inner_text() and "3 / 3" in best.inner_text()
    assert "12 ± 0.58" in tied.inner_text() and "tied" in tied.inner_text()
    assert "1 trial statistically tied" in page.locator("dl.facts").inner_text()
    # the service says the same
    body = httpx.get(f"{server['url']}/api/studies/{sid}", timeout=10).json()
    assert body["best"][0]["params"]["tool.rake_angle_deg"] == 10
    assert [t["params"]["tool.rake_angle_deg"] for t in body["best"][0]["tied"]] == [20]
    desktop.shot("study-replicated-ties-1280")


def test_long_trial_tables_are_paged(desktop, server):
    sid = _api_study(server, sweep_doc(120, name="e2e-paging"))
    page = desktop.page
    desktop.goto(f"#/studies/{sid}")
    _wait_study_done(page)
    rows = page.locator("table.trials tbody tr")
    page.locator(".pager .page-of", has_text="of 120").wait_for()
    assert rows.count() == 50
    assert page.locator(".pager .page-of").inner_text() == "Page 1 of 3 · rows 1–50 of 120"
    assert page.locator(".pager button.prev").is_disabled()
    first_page = rows.first.locator("td").first.inner_text()
    page.locator(".pager button.next").click()
    assert page.locator(".pager .page-of").inner_text() == "Page 2 of 3 · rows 51–100 of 120"
    assert rows.count() == 50 and rows.first.locator("td").first.inner_text() != first_page
    page.locator(".pager button.last").click()
    assert page.locator(".pager .page-of").inner_text() == "Page 3 of 3 · rows 101–120 of 120"
    assert rows.count() == 20 and page.locator(".pager button.next").is_disabled()
    # a filter goes back to the first page of what it matches
    page.fill("#trial-filter", "failed")
    assert rows.count() == 0 and page.locator(".pager button").count() == 0
    page.fill("#trial-filter", "")
    assert rows.count() == 50 and page.locator(".pager .page-of").inner_text().startswith("Page 1 of 3")
    # the page is no longer thousands of pixels high
    assert page.evaluate("document.documentElement.scrollHeight") < 8000
    desktop.shot("study-paged-1280")


def test_replicated_trial_tables_page_by_trial(desktop, server):
    samples = {r: [10.0 + r, 11.0 + r] for r in range(60)}
    sid = _store_replicated_sweep(server, samples, "e2e-paging-replicas")
    page = desktop.page
    desktop.goto(f"#/studies/{sid}")
    page.locator(".pager .page-of").wait_for()
    assert page.locator(".pager .page-of").inner_text() == "Page 1 of 2 · rows 1–50 of 60"
    assert "60 of 60 trials (120 runs in all)" in page.locator(".filters").inner_text()
    page.locator(".pager button.next").click()
    assert page.locator("table.trials tbody tr").count() == 10


def test_optimisation_with_confirmation_shows_the_reranking(desktop, server):
    sid = _api_study(server, {
        "name": "e2e-confirm", "kind": "optimize", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
        "parameters": {"tool.rake_angle_deg": {"values": [0, 10, 20, 30]}}, "n_trials": 6, "parallelism": 3, "seed": 4,
        "replicas": 2, "objectives": [{"metric": "thrust_force_N_per_mm", "direction": "minimize"}],
        "confirm": {"top_k": 2, "replicas": 2, "fidelity": "analytic", "fixed": {"tool.edge_radius_um": 5}}})
    page = desktop.page
    desktop.goto(f"#/studies/{sid}")
    _wait_study_done(page)
    card = page.locator(".chart-card", has=page.locator("h2", has_text="Confirmation"))
    card.locator("table.confirmation tbody tr").first.wait_for()
    body = httpx.get(f"{server['url']}/api/studies/{sid}", timeout=10).json()
    conf = body["confirmation"]
    assert conf["status"] == "done" and len(conf["trials"]) == 2
    rows = card.locator("table.confirmation tbody tr")
    assert rows.count() == 2
    assert "best" in rows.first.inner_text() and "2 / 2" in rows.first.inner_text()
    assert body["best"][0]["confirmed"] is True
    assert "this ranking is the study's answer" in card.inner_text()
    # the stage selector shows the confirmation's own trials
    page.select_option("#trial-stage", "confirm")
    assert page.locator("table.trials tbody tr").count() == 2


def test_calibration_page_shows_fitted_values_residuals_and_the_preset(desktop, server):
    from test_service_calibration import calibrate_doc

    doc = calibrate_doc(n_trials=20, parallelism=4)
    sid = _api_study(server, doc)
    page = desktop.page
    desktop.goto(f"#/studies/{sid}")
    _wait_study_done(page, timeout_s=120)
    card = page.locator(".chart-card", has=page.locator("h2", has_text="Calibration"))
    card.locator("table.residuals tbody tr").first.wait_for()
    assert card.locator("table.calibration tbody tr").count() == 2
    assert card.locator("table.residuals tbody tr").count() == 16
    link = card.get_by_role("link", name="Download the calibrated scene (YAML)")
    r = httpx.get(server["url"] + link.get_attribute("href"), timeout=10)
    assert r.status_code == 200 and "base: seed-0deg-fem-quick" in r.text
    assert "misfit" in page.locator("dl.facts").inner_text()


def test_calibration_from_the_form_with_a_csv_file_names_bad_rows_and_columns(browser, server, tmp_path):
    from test_service_calibration import _csv, measurements

    desktop = Page(browser, server["url"], DESKTOP, allowed=("status of 422",))  # the bad file's answer, shown in the form
    try:
        _calibration_form(desktop, server, tmp_path, _csv, measurements)
    finally:
        desktop.close()


def _calibration_form(desktop, server, tmp_path, _csv, measurements):
    page = desktop.page
    desktop.goto("#/new")
    page.get_by_label("Calibrate").check()
    page.fill("input[type=text] >> nth=0", "e2e-calibrate-form")
    bad = tmp_path / "bad.csv"
    bad.write_text("tool.rake_angle_deg,cut.depth_um,cutting_force_N_per_mm,sd_N_per_mm\n10,50,20.1,1.0\n20,fifty,19.0,1.0\n")
    page.set_input_files("input[type=file]", str(bad))
    err = page.locator(".field.invalid .field-error")
    err.first.wait_for()
    assert "not a number" in err.first.inner_text()
    summary = page.locator(".error-summary").inner_text()
    assert "measurements_csv.row 3.cut.depth_um" in summary, summary
    good = tmp_path / "good.csv"
    good.write_text(_csv(measurements()))
    page.set_input_files("input[type=file]", str(good))
    page.locator("p[role=status]", has_text="8 measured points").wait_for()
    # the fitted field and its bounds, then submit
    row = page.locator(".param-row").first
    row.locator("input[type=text]").first.fill("materials.interface.shear_strength_MPa")
    row.locator("select").first.select_option("range")
    row.get_by_label("Low").fill("10")
    row.get_by_label("High").fill("100")
    page.get_by_label("Fidelity", exact=True).select_option("analytic")
    page.get_by_label("Trials", exact=True).fill("12")
    page.get_by_role("button", name="Create study").click()
    page.wait_for_url(re.compile(r".*#/studies/\d+$"))
    _wait_study_done(page, timeout_s=120)
    page.locator(".chart-card h2", has_text="Calibration").wait_for()
    sid = int(page.url.rsplit("/", 1)[1])
    doc = httpx.get(f"{server['url']}/api/studies/{sid}", timeout=10).json()["document"]
    assert doc["kind"] == "calibrate" and len(doc["measurements"]) == 8
    desktop.shot("study-calibration-1280")
