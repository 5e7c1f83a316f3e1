// Study page: progress, trials table (sortable, filterable, rows link to their run),
// optimisation history, Pareto front, parallel coordinates, parameter importance, response
// plots for sweeps, accuracy against cost for resolution studies, CSV export.

import { ApiError, endpoints, setToken } from "../api.js";
import { bestSoFar, errorAgainstFinest, fmt, fmtDuration, isNum, paretoFront, spearman } from "../analysis.js";
import { barChart, parallelCoordinates, plot, PALETTE } from "../charts.js";
import { badge, errorBox, h, poller, tokenBox } from "../dom.js";
import { bestText, metricLabel, objectivesOf, progressBar, shortMetric } from "./studies.js";

export const RESOLUTION_FIELDS = ["numerics.element_size_um", "numerics.mass_scaling", "numerics.speed_scaling"];
const DEFAULT_METRICS = ["cutting_force_N_per_mm", "thrust_force_N_per_mm", "damage_depth_um"];
const TERMINAL = ["done", "failed", "cancelled"];
const MAX_ROWS = 500;

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

/** The metrics a study is about: its objectives, else the usual force and damage metrics. */
export function studyMetrics(study, trials) {
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

  const state = { sortKey: "index", sortDir: 1, filter: "", status: "", study: null, trials: [], chartsKey: "" };
  const filterInput = h("input", { type: "search", id: "trial-filter", placeholder: "e.g. 20 or failed", autocomplete: "off" });
  const statusSelect = h("select", { id: "trial-status" }, ["", "done", "running", "queued", "failed", "cancelled"].map((s) => h("option", { value: s }, s || "any status")));
  const table = h("table", { class: "data trials" });
  const count = h("span", { class: "muted small" });
  filterInput.addEventListener("input", () => { state.filter = filterInput.value.trim().toLowerCase(); renderTable(); });
  statusSelect.addEventListener("change", () => { state.status = statusSelect.value; renderTable(); });
  const csvLink = h("a", { class: "button", href: endpoints.trialsCsvUrl(id), download: `study-${id}-trials.csv` }, "Export CSV");
  tableCard.append(
    h("div", { class: "card-head" }, h("h2", { id: "trials-h" }, "Trials"), csvLink),
    h("div", { class: "filters" },
      h("div", { class: "field inline" }, h("label", { for: "trial-filter" }, "Filter"), filterInput),
      h("div", { class: "field inline" }, h("label", { for: "trial-status" }, "Status"), statusSelect), count),
    h("div", { class: "table-scroll" }, table));

  function columns() {
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
    const rows = state.trials.filter((t) => {
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
    const shown = rows.slice(0, MAX_ROWS); // a very large study: the first rows, the filter narrows the rest
    const tbody = h("tbody", {}, shown.map((t) => h("tr", { dataset: { status: t.status } }, cols.map((c) => {
      const v = c.render ? c.render(t) : shownText(c, t);
      return h("td", { class: c.num ? "num" : "", "data-label": c.label }, v);
    }))));
    table.replaceChildren(h("caption", { class: "sr-only" }, "Trials of the study; column headers sort"), thead, tbody);
    count.textContent = `${rows.length} of ${state.trials.length} trials` + (rows.length > shown.length ? ` (showing the first ${shown.length}; filter or sort to see others, or export CSV)` : "");
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
      [s.kind === "optimize" ? "Sampler" : "Design", s.kind === "optimize" ? `${doc.sampler || "tpe"}, ${doc.n_trials ?? s.planned_jobs} trials` : doc.design || "grid"],
      ["Parameters", Object.entries(doc.parameters || {}).map(([k, v]) => `${k} ${v.values ? `∈ {${v.values.join(", ")}}` : `${fmt(v.low)}…${fmt(v.high)}${v.step ? ` step ${fmt(v.step)}` : ""}${v.log ? " (log)" : ""}`}`).join("; ") || "–"],
      ...(s.kind === "optimize" ? [
        ["Objectives", objs.length ? objs.map((o) => `${o.direction === "maximize" ? "max" : "min"} ${shortMetric(o.metric)}`).join(", ") : "–"],
        ["Constraints", (doc.constraints || []).length ? doc.constraints.map((c) => `${shortMetric(c.metric)} ${c.op} ${c.value}`).join(", ") : "none"],
        ["Best so far", [bestText(s, state.trials), s.best?.length === 1 && s.best[0].run_id ? [" · ", h("a", { href: `#/runs/${s.best[0].run_id}?study=${id}` }, `trial ${s.best[0].trial_number ?? ""} run`)] : null]],
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
    const s = state.study, trials = state.trials;
    const done = trials.filter(finished);
    const objs = studyMetrics(s, trials);
    const params = paramNames(s, trials).filter((p) => done.some((t) => isNum(t.params?.[p])));
    charts.replaceChildren();
    draws = [];
    if (!done.length) {
      charts.append(h("section", { class: "card chart-card wide" }, h("p", { class: "chart-empty" }, "Charts appear as trials finish.")));
      return;
    }
    // optimisation history
    if (s.kind === "optimize") {
      for (const [i, o] of objs.entries()) {
        chartCard(`History: ${shortMetric(o.metric)}`, objs.length === 1 ? `Each trial's value in the order it was asked; the line is the best feasible value so far (${o.direction}).` : `Each trial's value in the order it was asked (${o.direction}; the trade-off between the objectives is in the Pareto front).`, (el) => {
          const ordered = [...done].sort((a, b) => trialLabel(a) - trialLabel(b));
          const xs = ordered.map(trialLabel), ys = ordered.map((t) => metricOf(t, o.metric));
          plot(el, {
            x: { label: "trial" }, y: { label: metricLabel(o.metric) },
            lines: objs.length === 1 ? [{ name: "best so far", x: xs, y: bestSoFar(ys.map((v, k) => (ordered[k].feasible === false ? null : v)), o.direction), step: true, color: PALETTE[1] }] : [],
            points: ordered.map((t, k) => ({ x: xs[k], y: ys[k], color: t.feasible === false ? "#9ca3af" : PALETTE[i % PALETTE.length], title: `trial ${xs[k]}: ${fmt(ys[k])}${t.feasible === false ? " (infeasible)" : ""}`, href: t.run_id ? `#/runs/${t.run_id}?study=${id}` : null })),
            legend: done.some((t) => t.feasible === false) ? [{ name: "infeasible", color: "#9ca3af", kind: "point" }] : [],
          });
        });
      }
    }
    // Pareto front
    if (s.kind === "optimize" && objs.length >= 2) {
      const [a, b] = objs;
      chartCard(`Pareto front: ${shortMetric(a.metric)} against ${shortMetric(b.metric)}`,
        `Non-dominated trials (${a.direction} ${shortMetric(a.metric)}, ${b.direction} ${shortMetric(b.metric)}${objs.length > 2 ? ", over all objectives" : ""}) are ringed and joined.`, (el) => {
          const feasible = done.filter((t) => t.feasible !== false);
          const pts = feasible.map((t) => objs.map((o) => metricOf(t, o.metric)));
          const front = new Set(paretoFront(pts, objs.map((o) => o.direction)).map((k) => feasible[k]));
          const fr = [...front].sort((p, q) => metricOf(p, a.metric) - metricOf(q, a.metric));
          plot(el, {
            x: { label: metricLabel(a.metric) }, y: { label: metricLabel(b.metric) },
            lines: objs.length === 2 ? [{ name: "Pareto front", x: fr.map((t) => metricOf(t, a.metric)), y: fr.map((t) => metricOf(t, b.metric)), color: PALETTE[1], step: false }] : [],
            points: done.map((t) => ({ x: metricOf(t, a.metric), y: metricOf(t, b.metric), r: front.has(t) ? 5 : 3.5, ring: front.has(t), color: t.feasible === false ? "#d1d5db" : front.has(t) ? PALETTE[1] : "#93c5fd", title: `trial ${trialLabel(t)}${front.has(t) ? " (on the front)" : ""}`, href: t.run_id ? `#/runs/${t.run_id}?study=${id}` : null })),
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
        chartCard(`${shortMetric(o.metric)} against ${shortParam(p)}`, null, (el) => {
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
            points: done.map((t) => ({ x: t.params?.[p], y: metricOf(t, o.metric), r: 3.5, color: many ? PALETTE[0] : PALETTE[[...groups.keys()].indexOf(others.map((q) => `${shortParam(q)}=${fmt(t.params?.[q])}`).join(", ")) % PALETTE.length], title: `trial ${trialLabel(t)}: ${p} = ${fmt(t.params?.[p])}, ${shortMetric(o.metric)} = ${fmt(metricOf(t, o.metric))}`, href: t.run_id ? `#/runs/${t.run_id}?study=${id}` : null })),
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

  const redraw = () => { for (const d of draws) d(); };
  window.addEventListener("fibrecut:resize", redraw);

  async function refresh() {
    try {
      const [study, trials] = await Promise.all([endpoints.study(id), endpoints.trials(id)]);
      state.study = study;
      state.trials = Array.isArray(trials) ? trials : trials.trials || [];
    } catch (e) {
      live.replaceChildren(errorBox(e));
      return !(e.status === 404);
    }
    // re-render only what changed, so keyboard focus and scroll survive the polling
    const headKey = JSON.stringify([state.study, state.trials.length]);
    if (headKey !== state.headKey) { state.headKey = headKey; renderHead(); }
    const tableKey = JSON.stringify(state.trials);
    if (tableKey !== state.tableKey) { state.tableKey = tableKey; renderTable(); }
    const key = JSON.stringify(state.trials.filter(finished).map((t) => [t.job_id, t.run_id, t.feasible, t.on_pareto_front])) + state.study.status;
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
