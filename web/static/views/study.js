// Study page: progress, trials table (sortable, filterable, paged; rows link to their run),
// optimisation history, Pareto front, parallel coordinates, parameter importance, response
// plots for sweeps, accuracy against cost for resolution studies, CSV export. Studies with
// replicated trials show one row and one point per trial: the mean over its replicas with its
// standard error as an error bar, the best trial and the trials statistically tied with it;
// and their confirmation, screening and calibration cards.

import { ApiError, endpoints, setToken } from "../api.js";
import { bestSoFar, errorAgainstFinest, fmt, fmtDuration, isNum, paretoFront, spearman } from "../analysis.js";
import { barChart, parallelCoordinates, plot, PALETTE } from "../charts.js";
import { badge, errorBox, h, poller, tokenBox } from "../dom.js";
import { bestText, metricLabel, objectivesOf, progressBar, shortMetric } from "./studies.js";

export const RESOLUTION_FIELDS = ["numerics.element_size_um", "numerics.mass_scaling", "numerics.speed_scaling"];
const DEFAULT_METRICS = ["cutting_force_N_per_mm", "thrust_force_N_per_mm", "damage_depth_um"];
const TERMINAL = ["done", "failed", "cancelled"];
export const PAGE_SIZE = 50;

const metricOf = (t, m) => {
  const v = t.metrics ? t.metrics[m] : undefined;
  if (isNum(v)) return v;
  if (m === "wall_time_s" && isNum(t.wall_time_s)) return t.wall_time_s;
  return null;
};
const finished = (t) => t.status === "done" && t.metrics;
const shortParam = (p) => p.split(".").pop();

function trialLabel(t) {
  return t.trial_number ?? t.index ?? t.job_id;
}
const semOf = (t, m) => (isNum(t.sem?.[m]) ? t.sem[m] : null);
const pm = (a, b, digits = 2) => (isNum(a) ? `${fmt(a)}${isNum(b) ? ` ± ${fmt(b, digits)}` : ""}` : "–");
const STAGE_LABEL = { search: "trials", screen: "screening", check: "checks at the screening fidelity", confirm: "confirmation" };

/** A point of /points (one trial of one stage: means over its replicas) in the shape of a trial row. */
export function pointAsTrial(p, i) {
  return { ...p, job_id: p.job_ids[0], run_id: p.run_ids[0] || null, index: i, wall_time_s: p.wall_time_per_run_s, isPoint: true };
}

/** The metrics a study is about: its objectives, else the usual force and damage metrics. */
export function studyMetrics(study, trials) {
  if (study.kind === "calibrate") return [{ metric: "misfit_sd", direction: "minimize" }];
  const objs = objectivesOf(study);
  if (objs.length) return objs.map((o) => ({ metric: o.metric, direction: o.direction || "minimize" }));
  return DEFAULT_METRICS.filter((m) => trials.some((t) => isNum(metricOf(t, m)))).map((metric) => ({ metric, direction: "minimize" }));
}

export function paramNames(study, trials) {
  const names = Object.keys(study.document?.parameters || {});
  for (const t of trials) for (const k of Object.keys(t.params || {})) if (!names.includes(k)) names.push(k);
  return names;
}

export async function studyPage(main, id) {
  const head = h("div", { class: "page-head" });
  const overview = h("section", { class: "card", "aria-label": "Overview" });
  const charts = h("div", { class: "chart-grid" });
  const tableCard = h("section", { class: "card", "aria-labelledby": "trials-h" });
  const live = h("p", { class: "muted small", role: "status", "aria-live": "polite" });
  main.append(h("nav", { class: "crumbs", "aria-label": "Breadcrumb" }, h("a", { href: "#/" }, "Studies"), " / ", h("span", {}, `#${id}`)), head, overview, charts, tableCard, live);

  const state = { sortKey: "index", sortDir: 1, filter: "", status: "", study: null, trials: [], points: [], stage: "search", page: 0, chartsKey: "" };
  const usePoints = () => state.points.length > 0;
  const stageRows = (stage) => state.points.filter((p) => p.stage === stage).map(pointAsTrial);
  const tableRows = () => (usePoints() ? stageRows(state.stage) : state.trials);
  const filterInput = h("input", { type: "search", id: "trial-filter", placeholder: "e.g. 20 or failed", autocomplete: "off" });
  const statusSelect = h("select", { id: "trial-status" }, ["", "done", "running", "queued", "failed", "cancelled"].map((s) => h("option", { value: s }, s || "any status")));
  const table = h("table", { class: "data trials" });
  const count = h("span", { class: "muted small" });
  const stageSelect = h("select", { id: "trial-stage" });
  const stageField = h("div", { class: "field inline", hidden: true }, h("label", { for: "trial-stage" }, "Stage"), stageSelect);
  const pager = h("div", { class: "pager", role: "navigation", "aria-label": "Pages of trials" });
  filterInput.addEventListener("input", () => { state.filter = filterInput.value.trim().toLowerCase(); state.page = 0; renderTable(); });
  statusSelect.addEventListener("change", () => { state.status = statusSelect.value; state.page = 0; renderTable(); });
  stageSelect.addEventListener("change", () => { state.stage = stageSelect.value; state.page = 0; renderTable(); });
  const csvLink = h("a", { class: "button", href: endpoints.trialsCsvUrl(id), download: `study-${id}-trials.csv` }, "Export CSV");
  const pointsCsvLink = h("a", { class: "button", href: `/api/studies/${encodeURIComponent(id)}/points.csv`, download: `study-${id}-points.csv`, hidden: true,
    title: "one row per trial: mean, sd, standard error and n of every metric" }, "Export means (CSV)");
  tableCard.append(
    h("div", { class: "card-head" }, h("h2", { id: "trials-h" }, "Trials"), h("div", { class: "actions" }, pointsCsvLink, " ", csvLink)),
    h("div", { class: "filters" },
      h("div", { class: "field inline" }, h("label", { for: "trial-filter" }, "Filter"), filterInput),
      h("div", { class: "field inline" }, h("label", { for: "trial-status" }, "Status"), statusSelect), stageField, count),
    h("div", { class: "table-scroll" }, table), pager);

  function pointColumns() {
    const rows = tableRows();
    const params = paramNames(state.study, rows);
    const metrics = state.study.kind === "calibrate" ? ["misfit_sd"] : studyMetrics(state.study, rows).map((o) => o.metric);
    if (state.study.kind !== "calibrate") for (const m of ["cutting_force_N_per_mm", "thrust_force_N_per_mm"]) if (!metrics.includes(m)) metrics.push(m);
    const single = state.study.kind === "calibrate" || objectivesOf(state.study).length === 1;
    return [
      { key: "index", label: "#", get: (t) => trialLabel(t), num: true },
      { key: "status", label: "Status", get: (t) => [t.status, t.best ? "best" : "", t.tied ? "tied" : "", t.on_pareto_front && !single ? "front" : "", t.feasible === false && t.status === "done" ? "infeasible" : ""].filter(Boolean).join(" "),
        render: (t) => [badge(t.status),
          t.best ? h("span", { class: "badge good", title: "the best mean" }, "best") : null,
          t.tied ? h("span", { class: "badge tie", title: "statistically tied with the best: its mean is within two combined standard errors of the best's" }, "tied") : null,
          t.on_pareto_front && !single ? h("span", { class: "badge good", title: "on the Pareto front of the means" }, "front") : null,
          t.feasible === false && t.status === "done" ? h("span", { class: "badge warn", title: "its means break a constraint" }, "infeasible") : null] },
      ...params.map((p) => ({ key: `p:${p}`, label: shortParam(p), title: p, get: (t) => t.params?.[p], num: true })),
      ...metrics.map((m) => ({ key: `m:${m}`, label: m === "misfit_sd" ? "misfit (sd)" : shortMetric(m), title: `${m}: mean ± standard error over the replicas`, get: (t) => metricOf(t, m), num: true,
        render: (t) => h("span", { class: "pm", title: isNum(t.sd?.[m]) ? `sd ${fmt(t.sd[m])}, n = ${t.n?.[m]}` : `n = ${t.n?.[m] ?? 0}` }, pm(metricOf(t, m), semOf(t, m))) })),
      { key: "replicas", label: "Replicas ok", get: (t) => t.replicas_ok, num: true, render: (t) => `${t.replicas_ok} / ${t.replicas}` },
      { key: "run", label: "Run", get: (t) => t.run_id, render: (t) => (t.run_id ? h("a", { href: `#/runs/${t.run_id}?study=${id}`, "aria-label": `Run of trial ${trialLabel(t)}` }, "open") : t.errors?.length ? h("span", { class: "muted small", title: t.errors.join("; ") }, "error") : "–") },
    ];
  }

  function columns() {
    if (usePoints()) return pointColumns();
    const params = paramNames(state.study, state.trials);
    const metrics = studyMetrics(state.study, state.trials).map((o) => o.metric);
    for (const m of ["cutting_force_N_per_mm", "thrust_force_N_per_mm"]) if (!metrics.includes(m)) metrics.push(m);
    return [
      { key: "index", label: "#", get: (t) => trialLabel(t), num: true },
      { key: "status", label: "Status", get: (t) => [t.cached ? "cached" : t.status, t.run_status && t.run_status !== "ok" ? t.run_status : "",
        t.on_pareto_front ? "best front" : "", t.feasible === false ? "infeasible" : ""].filter(Boolean).join(" "), render: (t) => [badge(t.cached ? "cached" : t.status), t.run_status && t.run_status !== "ok" ? badge(t.run_status) : null,
        t.on_pareto_front ? h("span", { class: "badge good", title: studyMetrics(state.study, state.trials).length > 1 ? "on the Pareto front" : "the best feasible trial" }, studyMetrics(state.study, state.trials).length > 1 ? "front" : "best") : null,
        t.feasible === false && t.status === "done" ? h("span", { class: "badge warn", title: "breaks a constraint" }, "infeasible") : null,
        t.status === "running" ? h("span", { class: "muted small" }, ` ${Math.round(100 * (t.progress || 0))}%`) : null] },
      ...params.map((p) => ({ key: `p:${p}`, label: shortParam(p), title: p, get: (t) => t.params?.[p], num: true })),
      ...metrics.map((m) => ({ key: `m:${m}`, label: shortMetric(m), title: m, get: (t) => metricOf(t, m), num: true })),
      { key: "wall", label: "Wall time", get: (t) => t.wall_time_s ?? metricOf(t, "wall_time_s"), num: true, render: (t) => fmtDuration(t.wall_time_s ?? metricOf(t, "wall_time_s")) },
      { key: "run", label: "Run", get: (t) => t.run_id, render: (t) => (t.run_id ? h("a", { href: `#/runs/${t.run_id}?study=${id}`, "aria-label": `Run of trial ${trialLabel(t)}` }, "open") : t.error ? h("span", { class: "muted small", title: t.error }, "error") : "–") },
    ];
  }

  // what a cell shows (the filter matches what the user reads: a run id behind "open" or a wall
  // time of 150 ms shown as "0.15 s" must not match "150")
  function shownText(c, t) {
    if (c.render) return h("span", {}, c.render(t)).textContent;
    const v = c.get(t);
    return typeof v === "number" ? fmt(v) : String(v ?? "–");
  }

  function renderTable() {
    const cols = columns();
    const all = tableRows();
    const stages = [...new Set(state.points.map((p) => p.stage))];
    pointsCsvLink.hidden = !usePoints();
    stageField.hidden = stages.length < 2;
    if (stages.join() !== [...stageSelect.options].map((o) => o.value).join()) {
      stageSelect.replaceChildren(...stages.map((st) => h("option", { value: st, selected: st === state.stage }, STAGE_LABEL[st] || st)));
    }
    const rows = all.filter((t) => {
      if (state.status && t.status !== state.status) return false;
      if (!state.filter) return true;
      const text = cols.map((c) => shownText(c, t)).join(" ").toLowerCase();
      return state.filter.split(/\s+/).every((w) => text.includes(w));
    });
    const col = cols.find((c) => c.key === state.sortKey) || cols[0];
    rows.sort((a, b) => {
      const va = col.get(a), vb = col.get(b);
      if (va === null || va === undefined) return 1;
      if (vb === null || vb === undefined) return -1;
      return (typeof va === "number" && typeof vb === "number" ? va - vb : String(va).localeCompare(String(vb))) * state.sortDir;
    });
    const thead = h("thead", {}, h("tr", {}, cols.map((c) => {
      const active = c.key === col.key;
      const btn = h("button", { type: "button", class: "sort", title: c.title ? `Sort by ${c.title}` : `Sort by ${c.label}` }, c.label, h("span", { class: "arrow", "aria-hidden": "true" }, active ? (state.sortDir > 0 ? " ▲" : " ▼") : ""));
      btn.addEventListener("click", () => {
        if (state.sortKey === c.key) state.sortDir = -state.sortDir;
        else { state.sortKey = c.key; state.sortDir = 1; }
        renderTable();
        table.querySelector(`th[data-key="${CSS.escape(c.key)}"] button`)?.focus();
      });
      return h("th", { scope: "col", "data-key": c.key, "aria-sort": active ? (state.sortDir > 0 ? "ascending" : "descending") : null, class: c.num ? "num" : "" }, btn);
    })));
    const pages = Math.max(1, Math.ceil(rows.length / PAGE_SIZE));
    state.page = Math.min(state.page, pages - 1);
    const first = state.page * PAGE_SIZE;
    const shown = rows.slice(first, first + PAGE_SIZE);
    const tbody = h("tbody", {}, shown.map((t) => h("tr", { dataset: { status: t.status, ...(t.tied ? { tied: "" } : {}), ...(t.best ? { best: "" } : {}) } }, cols.map((c) => {
      const v = c.render ? c.render(t) : shownText(c, t);
      return h("td", { class: c.num ? "num" : "", "data-label": c.label }, v);
    }))));
    table.replaceChildren(h("caption", { class: "sr-only" }, "Trials of the study; column headers sort"), thead, tbody);
    const noun = usePoints() ? (state.stage === "search" ? "trials" : STAGE_LABEL[state.stage]) : "trials";
    count.textContent = `${rows.length} of ${all.length} ${noun}` + (usePoints() && state.trials.length > all.length ? ` (${state.trials.length} runs in all)` : "");
    renderPager(pages, first, shown.length, rows.length);
  }

  function renderPager(pages, first, n, total) {
    if (pages <= 1) { pager.replaceChildren(); return; }
    const go = (k) => { state.page = k; renderTable(); pager.querySelector(k > 0 ? "button.next" : "button.prev")?.focus(); };
    const btn = (label, cls, k, disabled) => h("button", { type: "button", class: `button ${cls}`, disabled, onclick: () => go(k) }, label);
    pager.replaceChildren(
      btn("« First", "first", 0, state.page === 0),
      btn("‹ Previous", "prev", state.page - 1, state.page === 0),
      h("span", { class: "muted small page-of", "aria-live": "polite" }, `Page ${state.page + 1} of ${pages} · rows ${first + 1}–${first + n} of ${total}`),
      btn("Next ›", "next", state.page + 1, state.page >= pages - 1),
      btn("Last »", "last", pages - 1, state.page >= pages - 1));
  }

  const titleBox = h("div");
  const cancelBtn = h("button", { type: "button", class: "button danger", onclick: async () => {
    cancelBtn.disabled = true;
    try {
      await endpoints.cancelStudy(id);
    } catch (err) {
      if (err instanceof ApiError && err.status === 401) {
        const box = tokenBox((t) => { setToken(t); box.remove(); cancelBtn.click(); });
        head.after(box);
        box.focusInput();
      } else live.replaceChildren(errorBox(err));
    }
    cancelBtn.disabled = false;
    refresh();
  } }, "Cancel study");

  function renderHead() {
    const s = state.study;
    document.title = `${s.name} · fibrecut`;
    main.querySelector(".crumbs span").textContent = s.name;
    cancelBtn.hidden = TERMINAL.includes(s.status);
    if (!head.contains(cancelBtn)) head.append(titleBox, h("div", { class: "actions" }, cancelBtn));
    titleBox.replaceChildren(h("h1", {}, s.name, " ", badge(s.status)), h("p", { class: "muted" }, `${s.kind} · study #${s.id}`));
    const doc = s.document || {};
    const objs = objectivesOf(s);
    const dl = [
      ["Scene", typeof doc.scene === "string" ? doc.scene : "inline scene"],
      ["Fixed", Object.keys(doc.fixed || {}).length ? Object.entries(doc.fixed).map(([k, v]) => `${k} = ${v}`).join(", ") : "–"],
      [["optimize", "calibrate"].includes(s.kind) ? "Sampler" : "Design", ["optimize", "calibrate"].includes(s.kind) ? `${doc.sampler || "tpe"}, ${doc.n_trials ?? s.planned_jobs} trials` : doc.design || "grid"],
      ...((doc.replicas ?? 1) > 1 ? [["Replicas", `${doc.replicas} per ${s.kind === "convergence" ? "level" : s.kind === "calibrate" ? "trial and measured point" : "trial"} (means with standard errors)`]] : []),
      ...(doc.screen ? [["Screening", `${doc.screen.n_trials} trials on ${doc.screen.fidelity}, then the box around the best ${doc.screen.top_k}`]] : []),
      ...(doc.confirm ? [["Confirmation", `best ${doc.confirm.top_k} × ${doc.confirm.replicas} replicas${doc.confirm.fidelity ? ` on ${doc.confirm.fidelity}` : ""}${doc.confirm.scene ? ` (${typeof doc.confirm.scene === "string" ? doc.confirm.scene : "inline scene"})` : ""}`]] : []),
      ...(s.kind === "calibrate" ? [["Measurements", `${(doc.measurements || []).length} points`], ["Best so far", bestText(s, state.trials)]] : []),
      ["Parameters", Object.entries(doc.parameters || {}).map(([k, v]) => `${k} ${v.values ? `∈ {${v.values.join(", ")}}` : `${fmt(v.low)}…${fmt(v.high)}${v.step ? ` step ${fmt(v.step)}` : ""}${v.log ? " (log)" : ""}`}`).join("; ") || "–"],
      ...(s.kind === "optimize" || (s.kind === "sweep" && objs.length) ? [
        ["Objectives", objs.length ? objs.map((o) => `${o.direction === "maximize" ? "max" : "min"} ${shortMetric(o.metric)}`).join(", ") : "–"],
        ["Constraints", (doc.constraints || []).length ? doc.constraints.map((c) => `${shortMetric(c.metric)} ${c.op} ${c.value}`).join(", ") : "none"],
        ["Best so far", [bestText(s, state.trials), s.best?.length === 1 && s.best[0].run_id ? [" · ", h("a", { href: `#/runs/${s.best[0].run_id}?study=${id}` }, s.best[0].trial_number != null ? `trial ${s.best[0].trial_number} run` : "its first run")] : null]],
      ] : [["Metrics shown", studyMetrics(s, state.trials).map((o) => shortMetric(o.metric)).join(", ") || "–"]]),
      ["ETA", TERMINAL.includes(s.status) ? "–" : fmtDuration(s.eta_s)],
    ];
    overview.replaceChildren(...[progressBar(s), h("dl", { class: "facts" }, dl.flatMap(([k, v]) => [h("dt", {}, k), h("dd", {}, v)])), s.error ? errorBox(s.error) : null].filter(Boolean));
  }

  function chartCard(title, note, draw, { wide = false } = {}) {
    const body = h("div", { class: "chart-body" });
    const cardEl = h("section", { class: `card chart-card${wide ? " wide" : ""}` }, h("h2", {}, title), note ? h("p", { class: "hint" }, note) : null, body);
    charts.append(cardEl);
    draws.push(() => draw(body));
  }
  let draws = [];

  function renderCharts() {
    const s = state.study, trials = usePoints() ? stageRows("search") : state.trials;
    const done = trials.filter(finished);
    const meanPts = usePoints() && (s.document?.replicas ?? 1) > 1;
    const meanNote = meanPts ? " Points are means over each trial's replicas, bars ± one standard error; dashed rings mark trials statistically tied with the best." : "";
    const objs = studyMetrics(s, trials);
    const params = paramNames(s, trials).filter((p) => done.some((t) => isNum(t.params?.[p])));
    charts.replaceChildren();
    draws = [];
    stageCards(s);
    if (!done.length) {
      charts.append(h("section", { class: "card chart-card wide" }, h("p", { class: "chart-empty" }, "Charts appear as trials finish.")));
      for (const d of draws) d();
      return;
    }
    // optimisation history
    if (s.kind === "optimize" || s.kind === "calibrate") {
      for (const [i, o] of objs.entries()) {
        chartCard(`History: ${shortMetric(o.metric)}`, objs.length === 1 ? `Each trial's value in the order it was asked; the line is the best feasible value so far (${o.direction}).${meanNote}` : `Each trial's value in the order it was asked (${o.direction}; the trade-off between the objectives is in the Pareto front).${meanNote}`, (el) => {
          const ordered = [...done].sort((a, b) => trialLabel(a) - trialLabel(b));
          const xs = ordered.map(trialLabel), ys = ordered.map((t) => metricOf(t, o.metric));
          plot(el, {
            x: { label: "trial" }, y: { label: metricLabel(o.metric) },
            lines: objs.length === 1 ? [{ name: "best so far", x: xs, y: bestSoFar(ys.map((v, k) => (ordered[k].feasible === false ? null : v)), o.direction), step: true, color: PALETTE[1] }] : [],
            points: ordered.map((t, k) => ({ x: xs[k], y: ys[k], err: semOf(t, o.metric), tie: !!t.tied, ring: !!t.best && objs.length === 1, color: t.feasible === false ? "#9ca3af" : PALETTE[i % PALETTE.length],
              title: `trial ${xs[k]}: ${pm(ys[k], semOf(t, o.metric))}${t.isPoint ? ` (${t.replicas_ok} of ${t.replicas} replicas ok)` : ""}${t.best ? " · best" : t.tied ? " · tied with the best" : ""}${t.feasible === false ? " (infeasible)" : ""}`, href: t.run_id ? `#/runs/${t.run_id}?study=${id}` : null })),
            legend: done.some((t) => t.feasible === false) ? [{ name: "infeasible", color: "#9ca3af", kind: "point" }] : [],
          });
        });
      }
    }
    // Pareto front
    if (s.kind === "optimize" && objs.length >= 2) {
      const [a, b] = objs;
      chartCard(`Pareto front: ${shortMetric(a.metric)} against ${shortMetric(b.metric)}`,
        `Non-dominated trials (${a.direction} ${shortMetric(a.metric)}, ${b.direction} ${shortMetric(b.metric)}${objs.length > 2 ? ", over all objectives" : ""}) are ringed and joined.${meanPts ? " Points are means over the replicas, bars ± one standard error in both directions." : ""}`, (el) => {
          const feasible = done.filter((t) => t.feasible !== false);
          const pts = feasible.map((t) => objs.map((o) => metricOf(t, o.metric)));
          const front = new Set(paretoFront(pts, objs.map((o) => o.direction)).map((k) => feasible[k]));
          const fr = [...front].sort((p, q) => metricOf(p, a.metric) - metricOf(q, a.metric));
          plot(el, {
            x: { label: metricLabel(a.metric) }, y: { label: metricLabel(b.metric) },
            lines: objs.length === 2 ? [{ name: "Pareto front", x: fr.map((t) => metricOf(t, a.metric)), y: fr.map((t) => metricOf(t, b.metric)), color: PALETTE[1], step: false }] : [],
            points: done.map((t) => ({ x: metricOf(t, a.metric), y: metricOf(t, b.metric), err: semOf(t, b.metric), errX: semOf(t, a.metric), r: front.has(t) ? 5 : 3.5, ring: front.has(t), color: t.feasible === false ? "#d1d5db" : front.has(t) ? PALETTE[1] : "#93c5fd", title: `trial ${trialLabel(t)}${front.has(t) ? " (on the front)" : ""}`, href: t.run_id ? `#/runs/${t.run_id}?study=${id}` : null })),
            legend: [{ name: "trial", color: "#93c5fd", kind: "point" }, { name: "on the front", color: PALETTE[1], kind: "point" }],
          });
        });
    }
    // parallel coordinates
    if (params.length && objs.length) {
      chartCard("Parallel coordinates", null, (el) => {
        const axes = [
          ...params.map((p) => ({ name: p, short: shortParam(p), values: done.map((t) => (isNum(t.params?.[p]) ? t.params[p] : null)) })),
          ...objs.map((o) => ({ name: o.metric, short: shortMetric(o.metric), values: done.map((t) => metricOf(t, o.metric)) })),
        ];
        parallelCoordinates(el, axes, { colorBy: objs[0].metric, rowTitles: done.map((t) => `trial ${trialLabel(t)}`) });
      }, { wide: params.length + objs.length > 4 });
    }
    // importance: Spearman's rho of each parameter against each objective
    if (params.length && objs.length) {
      chartCard("Parameter importance",
        "Spearman's rank correlation ρ between each parameter and each metric over the finished trials: |ρ| near 1 means a strong monotonic influence, the sign its direction (positive: the metric grows with the parameter). It misses non-monotonic effects and interactions.", (el) => {
          const parts = objs.slice(0, 4).map((o) => {
            const ys = done.map((t) => metricOf(t, o.metric));
            const items = params.map((p) => ({ label: p, value: spearman(done.map((t) => t.params?.[p]), ys) }))
              .filter((it) => it.value !== null).sort((p, q) => Math.abs(q.value) - Math.abs(p.value));
            const box = h("div", { class: "subchart" });
            const wrap = h("div", {}, h("h3", {}, metricLabel(o.metric)), box);
            return [wrap, box, items];
          });
          el.replaceChildren(...parts.map((p) => p[0]));
          for (const [, box, items] of parts) barChart(box, items, { label: "Spearman ρ", empty: "No ranking: needs 3 finished trials in which both the parameters and this metric vary." });
        });
    }
    // responses (sweeps and convergence): each objective against each parameter
    if (s.kind !== "optimize" && params.length) {
      for (const o of objs) for (const p of params) {
        chartCard(`${shortMetric(o.metric)} against ${shortParam(p)}`, meanPts ? `Means over each point's replicas ± one standard error.${objs.length === 1 && objectivesOf(s).length ? " The best mean is ringed; dashed rings: statistically tied with it." : ""}` : null, (el) => {
          const others = params.filter((q) => q !== p);
          const groups = new Map();
          for (const t of done) {
            const key = others.map((q) => `${shortParam(q)}=${fmt(t.params?.[q])}`).join(", ");
            if (!groups.has(key)) groups.set(key, []);
            groups.get(key).push(t);
          }
          const many = groups.size > 8;
          const lines = many ? [] : [...groups.entries()].map(([key, ts], i) => {
            ts.sort((u, v) => u.params[p] - v.params[p]);
            return { name: key || null, x: ts.map((t) => t.params[p]), y: ts.map((t) => metricOf(t, o.metric)), color: PALETTE[i % PALETTE.length] };
          });
          plot(el, {
            x: { label: p }, y: { label: metricLabel(o.metric) },
            lines,
            points: done.map((t) => ({ x: t.params?.[p], y: metricOf(t, o.metric), err: semOf(t, o.metric), tie: !!t.tied && objectivesOf(s)[0]?.metric === o.metric, ring: !!t.best && objectivesOf(s)[0]?.metric === o.metric, r: 3.5, color: many ? PALETTE[0] : PALETTE[[...groups.keys()].indexOf(others.map((q) => `${shortParam(q)}=${fmt(t.params?.[q])}`).join(", ")) % PALETTE.length], title: `trial ${trialLabel(t)}: ${p} = ${fmt(t.params?.[p])}, ${shortMetric(o.metric)} = ${pm(metricOf(t, o.metric), semOf(t, o.metric))}${t.isPoint && t.replicas > 1 ? ` (mean of ${t.replicas_ok} replicas)` : ""}`, href: t.run_id ? `#/runs/${t.run_id}?study=${id}` : null })),
          });
        });
      }
    }
    // accuracy against cost
    const resolution = params.filter((p) => RESOLUTION_FIELDS.includes(p));
    const replicated = s.kind === "convergence" && (s.document?.replicas ?? 1) > 1;
    if (resolution.length || s.kind === "convergence") {
      const res = resolution.length ? resolution : params.filter((p) => p !== "replica");
      for (const p of res) {
        chartCard(`Accuracy against cost (${shortParam(p)})`, replicated
          ? `Relative error of each level's mean (over its replicas) against the finest level's mean, against the mean wall time of one run, log-log; hover a point for the error's standard error. The finest level is the reference and is not drawn.`
          : `Relative error of each run against the finest ${shortParam(p)} of the study (the smallest value, with the other parameters equal), against the run's wall time, log-log. The finest run is the reference and is not drawn.`, (el) => {
            const ms = objs.length ? objs.map((o) => o.metric) : DEFAULT_METRICS;
            const others = params.filter((q) => q !== p && q !== "replica");
            const lines = [], points = [];
            let exact = 0;
            ms.forEach((m, i) => {
              const groups = new Map();
              for (const t of done) {
                const key = others.map((q) => t.params?.[q]).join("|");
                if (!groups.has(key)) groups.set(key, []);
                groups.get(key).push({ level: t.params?.[p], wall: metricOf(t, "wall_time_s"), value: metricOf(t, m), t });
              }
              let first = true;
              const server = s.kind === "convergence" && done.some((t) => t.error_vs_finest);
              for (const rows of groups.values()) {
                // convergence studies: the service's error against its finest level; else our own
                const pts = replicated
                  // one point per level: its mean's error at the mean wall time of one run
                  ? [...new Map(rows.filter((r) => r.t.level && !r.t.level.is_finest && isNum(r.t.error_vs_finest?.[m]))
                    .map((r) => [r.level, { ...r, wall: r.t.level.wall_time_per_run_s, error: r.t.error_vs_finest[m], unc: r.t.error_uncertainty?.[m], n: r.t.level.replicas_ok }])).values()]
                    .filter((q) => isNum(q.wall))
                  : server
                  ? rows.filter((r) => r.t.job_id !== r.t.reference_job_id && isNum(r.t.error_vs_finest?.[m]) && isNum(r.wall)).map((r) => ({ ...r, error: r.t.error_vs_finest[m] }))
                  : errorAgainstFinest(rows).points;
                exact += pts.filter((q) => !(q.error > 0)).length;
                pts.splice(0, pts.length, ...pts.filter((q) => q.error > 0));
                pts.sort((u, v) => u.wall - v.wall);
                const color = PALETTE[i % PALETTE.length];
                lines.push({ name: first ? shortMetric(m) : null, x: pts.map((q) => q.wall), y: pts.map((q) => q.error), color, dash: "4 3" });
                first = false;
                for (const q of pts) points.push({ x: q.wall, y: q.error, color, title: replicated
                  ? `${p} = ${fmt(q.level)}: error of the mean ${fmt(q.error)}${isNum(q.unc) ? ` ± ${fmt(q.unc, 2)} (standard error)` : ""} over ${q.n} replicas, ${fmtDuration(q.wall)} per run`
                  : `${p} = ${fmt(q.level)}: error ${fmt(q.error)} in ${fmtDuration(q.wall)}`, href: q.t.run_id ? `#/runs/${q.t.run_id}?study=${id}` : null });
              }
            });
            plot(el, { x: { label: "wall time (s)", log: true }, y: { label: "relative error", log: true }, lines, points,
              empty: exact ? `Every level gives the same ${ms.map(shortMetric).join(", ")} as the finest (zero error, ${exact} run${exact > 1 ? "s" : ""}): this fidelity does not depend on ${shortParam(p)}.` : "Needs at least two finished levels with a wall time." });
          }, { wide: true });
      }
    }
    if (replicated) {
      chartCard("Levels: means over the replicas", "Each level's mean of every metric ± its standard error (standard deviation / √n over the replicas whose run ended ok), and the error of the mean against the finest level's mean ± the standard error of that error: an error smaller than about twice its standard error is not resolved.", (el) => {
        const ms = objs.length ? objs.map((o) => o.metric) : DEFAULT_METRICS;
        const levels = [...new Map(done.filter((t) => t.level).map((t) => [JSON.stringify(t.level.params), t])).values()];
        const pm = (a, b) => (isNum(a) ? `${fmt(a)}${isNum(b) ? ` ± ${fmt(b, 2)}` : ""}` : "–");
        el.replaceChildren(h("div", { class: "table-scroll" }, h("table", { class: "data levels" },
          h("thead", {}, h("tr", {}, h("th", { scope: "col" }, "level"), h("th", { scope: "col", class: "num" }, "replicas ok"),
            h("th", { scope: "col", class: "num" }, "wall per run"),
            ms.flatMap((m) => [h("th", { scope: "col", class: "num" }, `${shortMetric(m)} mean`), h("th", { scope: "col", class: "num" }, `${shortMetric(m)} error`)]))),
          h("tbody", {}, levels.map((t) => h("tr", {},
            h("td", {}, Object.entries(t.level.params).map(([k, v]) => `${shortParam(k)} = ${fmt(v)}`).join(", ") + (t.level.is_finest ? " (finest)" : "")),
            h("td", { class: "num" }, `${t.level.replicas_ok} / ${t.level.replicas}`),
            h("td", { class: "num" }, fmtDuration(t.level.wall_time_per_run_s)),
            ms.flatMap((m) => [h("td", { class: "num" }, pm(t.level.mean?.[m], t.level.sem?.[m])),
              h("td", { class: "num" }, t.level.is_finest ? "reference" : isNum(t.error_vs_finest?.[m]) ? `${fmt(100 * t.error_vs_finest[m], 3)} %${isNum(t.error_uncertainty?.[m]) ? ` ± ${fmt(100 * t.error_uncertainty[m], 2)} %` : ""}` : "–")])))))));
      }, { wide: true });
    }
    if (s.kind === "convergence") {
      for (const c of [...charts.children].filter((c) => /^(Accuracy against cost|Levels)/.test(c.querySelector("h2")?.textContent || "")).reverse()) charts.prepend(c);
    }
    for (const d of draws) d();
  }

  // confirmation, screening and calibration: what the study concludes beyond its trials
  function stageCards(s) {
    const table = (cls, head, rows) => h("div", { class: "table-scroll" }, h("table", { class: `data ${cls}` },
      h("thead", {}, h("tr", {}, head.map(([t, num]) => h("th", { scope: "col", class: num ? "num" : "" }, t)))),
      h("tbody", {}, rows)));
    const paramText = (params) => Object.entries(params || {}).map(([k, v]) => `${shortParam(k)} = ${fmt(v)}`).join(", ");
    const c = s.confirmation;
    if (c) {
      const where = [c.scene ? `scene ${c.scene}` : null, c.fidelity ? `fidelity ${c.fidelity}` : null].filter(Boolean).join(", ") || "the study's scene";
      chartCard(`Confirmation: the best ${c.top_k} re-run ${c.replicas} times (${where})`,
        c.status === "done"
          ? `Ranked by the confirmed means of ${shortMetric(c.metric)} (${c.direction}); this ranking is the study's answer. ${c.reranked ? "The confirmation changed the order of the search's ranking." : "The confirmation kept the search's order."}`
          : c.status === "running" ? "The best trials are running again; the table fills as their replicas finish." : "Starts when every trial of the search has finished.", (el) => {
          el.replaceChildren(table("confirmation", [["trial"], ["parameters"], ["search mean", 1], ["search rank", 1], ["confirmed mean", 1], ["replicas ok", 1], ["confirmed rank", 1], [""]],
            c.trials.map((r) => h("tr", { dataset: { best: r.best ? "1" : "", tied: r.tied ? "1" : "" } },
              h("td", {}, String(r.trial_number ?? "–")), h("td", {}, paramText(r.params)),
              h("td", { class: "num pm" }, pm(r.search?.mean, r.search?.sem)), h("td", { class: "num" }, String(r.search?.rank ?? "–")),
              h("td", { class: "num pm" }, pm(r.confirm.mean, r.confirm.sem)), h("td", { class: "num" }, `${r.confirm.replicas_ok} / ${r.confirm.replicas}`),
              h("td", { class: "num" }, String(r.confirm.rank ?? "–")),
              h("td", {}, r.best ? h("span", { class: "badge good" }, "best") : r.tied ? h("span", { class: "badge tie", title: "within two combined standard errors of the best" }, "tied") : null)))));
        }, { wide: true });
    }
    const sc = s.screening;
    if (sc) {
      chartCard(`Screen, then refine: ${sc.fidelity} first`, `${sc.finished} of ${sc.n_trials} screening trials on ${sc.fidelity}; the study's own fidelity searched the box around the best ${sc.top_k} (widened by ${fmt(100 * sc.margin)} % of each range). On the shared points (every refined trial also ran once on ${sc.fidelity}) Spearman's ρ near 1 says the cheap model ranks this region as the refined one does, even where it is offset.`, (el) => {
        const box = sc.box ? Object.entries(sc.box).map(([k, v]) => `${k} ${v.values ? `∈ {${v.values.map((x) => fmt(x)).join(", ")}}` : `${fmt(v.low)} … ${fmt(v.high)}`}`).join("; ") : "not yet (the screening is running)";
        const ag = Object.entries(sc.agreement || {});
        el.replaceChildren(h("p", { class: "stage-note" }, h("strong", {}, "Refinement box: "), box),
          table("agreement", [["metric"], ["shared points", 1], ["Spearman ρ", 1], ["mean offset (refined − screening)", 1], ["relative offset", 1]],
            ag.map(([m, a]) => h("tr", {}, h("td", {}, m === "misfit_sd" ? "misfit (sd)" : shortMetric(m)), h("td", { class: "num" }, String(a.n)),
              h("td", { class: "num" }, isNum(a.spearman) ? fmt(a.spearman, 3) : "–"), h("td", { class: "num pm" }, pm(a.mean_offset, a.offset_sem)),
              h("td", { class: "num pm" }, isNum(a.relative_offset) ? `${fmt(100 * a.relative_offset, 3)} %${isNum(a.relative_offset_sem) ? ` ± ${fmt(100 * a.relative_offset_sem, 2)} %` : ""}` : "–")))));
      }, { wide: true });
    }
    const cal = s.calibration;
    if (cal) {
      chartCard("Calibration: fitted values", `Weighted RMS misfit ${fmt(cal.misfit, 3)} standard deviations over ${cal.n_values} measured values (about 1: the model fits within the measurements' uncertainty); leave-one-out prediction error ${fmt(cal.loo_error.rms_sd, 3)} sd (${fmt(cal.loo_error.rms_N_per_mm, 3)} N/mm). ${cal.trials_evaluated} trials evaluated.`, (el) => {
        el.replaceChildren(
          table("calibration", [["field"], ["fitted value", 1], ["± sd", 1], ["trials within 1 sd: range", 1]],
            Object.entries(cal.values).map(([k, v]) => {
              const u = cal.uncertainty?.[k] || {};
              return h("tr", {}, h("td", {}, k), h("td", { class: "num" }, fmt(v)), h("td", { class: "num", title: u.method || "" }, isNum(u.sd) ? fmt(u.sd, 2) : "–"),
                h("td", { class: "num" }, isNum(u.low) ? `${fmt(u.low)} … ${fmt(u.high)}${u.at_bound ? " (at a bound)" : ""}` : "–"));
            })),
          h("p", {}, h("a", { class: "button", href: endpoints.calibratedSceneUrl(id), download: `study-${id}-calibrated-scene.yaml` }, "Download the calibrated scene (YAML)"),
            h("span", { class: "muted small" }, " for fibrecut run FILE.yaml")),
          h("h3", {}, "Residuals per measured point"),
          table("residuals", [["point"], ["force"], ["measured ± sd", 1], ["model", 1], ["residual", 1], ["in sd", 1]],
            cal.per_point.map((r) => h("tr", {}, h("td", {}, r.label || paramText(r.set) || `#${r.point}`), h("td", {}, shortMetric(r.force)),
              h("td", { class: "num pm" }, pm(r.measured, r.sd)), h("td", { class: "num pm" }, pm(r.model, r.model_sem)),
              h("td", { class: "num" }, fmt(r.residual, 3)), h("td", { class: "num" }, fmt(r.z, 3))))));
      }, { wide: true });
    }
  }

  const redraw = () => { for (const d of draws) d(); };
  window.addEventListener("fibrecut:resize", redraw);

  async function refresh() {
    try {
      const [study, trials, points] = await Promise.all([endpoints.study(id), endpoints.trials(id), endpoints.points(id)]);
      state.study = study;
      state.trials = Array.isArray(trials) ? trials : trials.trials || [];
      state.points = points?.points || [];
    } catch (e) {
      live.replaceChildren(errorBox(e));
      return !(e.status === 404);
    }
    // re-render only what changed, so keyboard focus and scroll survive the polling
    const headKey = JSON.stringify([state.study, state.trials.length]);
    if (headKey !== state.headKey) { state.headKey = headKey; renderHead(); }
    const tableKey = JSON.stringify([state.trials, state.points]);
    if (tableKey !== state.tableKey) { state.tableKey = tableKey; renderTable(); }
    const key = JSON.stringify([state.trials.filter(finished).map((t) => [t.job_id, t.run_id, t.feasible, t.on_pareto_front]),
      state.points.map((p) => [p.key, p.status, p.mean, p.sem, p.tied, p.best]), state.study.confirmation, state.study.screening, state.study.calibration]) + state.study.status;
    if (key !== state.chartsKey) {
      state.chartsKey = key;
      renderCharts();
    }
    const terminal = TERMINAL.includes(state.study.status);
    live.textContent = terminal ? `Study ${state.study.status}.` : `Updated ${new Date().toLocaleTimeString()} · refreshes every 2 s`;
    return !terminal;
  }
  const stop = poller(refresh, 2000);
  return () => { stop(); window.removeEventListener("fibrecut:resize", redraw); };
}
