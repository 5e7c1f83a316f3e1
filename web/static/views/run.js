// Run page: summary metrics, stability diagnosis, force history Fc(t), Ft(t) with the steady
// window marked, chip frames with a slider (coloured by material, state or damage), energy
// balance, time-step history, the scene that produced the run and the HDF5 download.

import { endpoints } from "../api.js";
import { fmt, fmtDuration, isNum } from "../analysis.js";
import { barChart, plot, PALETTE } from "../charts.js";
import { drawFrames } from "./frames.js";
import { badge, errorBox, h } from "../dom.js";

const HEADLINE = [
  ["cutting_force_N_per_mm", "Cutting force Fc", "N/mm"],
  ["thrust_force_N_per_mm", "Thrust force Ft", "N/mm"],
  ["damage_depth_um", "Damage depth", "µm"],
  ["bounce_back_um", "Bounce-back", "µm"],
  ["material_removal_rate_mm2_s", "Material removal rate", "mm²/s"],
  ["energy_error", "Energy error", ""],
];

/**
 * The steady-state window from a run's summary, whatever shape the solver gave it:
 * {axis: "travel" | "time", x0, x1, rule}. solver.cutting writes steady_window_from_um and
 * steady_window_to_um (tool travel) and steady_window (its rule, as text).
 */
export function steadyWindow(summary, series) {
  if (isNum(summary?.steady_window_from_um) && isNum(summary?.steady_window_to_um)) {
    const rule = typeof summary.steady_window === "string" ? summary.steady_window : summary.steady_window?.rule;
    return { axis: "travel", x0: summary.steady_window_from_um, x1: summary.steady_window_to_um, rule };
  }
  const cands = [summary?.steady_window, summary?.steady_window_s, series?.forces?.attrs?.steady_window];
  for (const c of cands) {
    if (Array.isArray(c) && c.length === 2 && c.every(isNum)) return { axis: "time", x0: c[0], x1: c[1] };
    if (c && typeof c === "object") {
      if (isNum(c.travel_from_um) && isNum(c.travel_to_um)) return { axis: "travel", x0: c.travel_from_um, x1: c.travel_to_um, rule: c.rule };
      const a = c.start ?? c.t0 ?? c.time_from_s ?? c.start_s, b = c.end ?? c.t1 ?? c.time_to_s ?? c.end_s;
      if (isNum(a) && isNum(b)) return { axis: "time", x0: a, x1: b, rule: c.rule };
    }
  }
  return null;
}

function timeAxis(group) {
  if (!group) return null;
  for (const k of ["time", "time_s", "t"]) if (Array.isArray(group[k])) return { key: k, values: group[k] };
  return null;
}

/** Plot time in microseconds when the series is in seconds and short. */
function timeScale(values) {
  const max = Math.max(...values.filter(isNum).map(Math.abs), 0);
  return max > 0 && max < 1e-2 ? { f: 1e6, label: "time (µs)" } : { f: 1, label: "time (s)" };
}

/** Set a dotted field of a nested object: setDotted(o, "tool.rake_angle_deg", 10). */
export function setDotted(obj, path, value) {
  const keys = path.split(".");
  let o = obj;
  for (const k of keys.slice(0, -1)) {
    if (!o[k] || typeof o[k] !== "object") o[k] = {};
    o = o[k];
  }
  o[keys[keys.length - 1]] = value;
  return obj;
}

/**
 * Where the server has no /context endpoint: the study named in the link (#/runs/ID?study=N)
 * gives the trial; its scene is the base scene with the fixed overrides and the parameters.
 */
async function contextFromStudy(runId) {
  const q = new URLSearchParams((location.hash.split("?")[1]) || "");
  const sid = q.get("study");
  if (!sid) return null;
  const [study, trials, scenes] = await Promise.all([endpoints.study(sid), endpoints.trials(sid), endpoints.scenes()]);
  const t = trials.find((x) => x.run_id === runId);
  if (!t) return { study_id: study.id, study_name: study.name };
  const doc = study.document || {};
  let scene = typeof doc.scene === "string" ? scenes.find((x) => x.name === doc.scene)?.scene : doc.scene;
  if (scene) {
    scene = JSON.parse(JSON.stringify(scene));
    for (const [k, v] of [...Object.entries(doc.fixed || {}), ...Object.entries(t.params || {})]) setDotted(scene, k, v);
  }
  return { study_id: study.id, study_name: study.name, job_id: t.job_id, params: t.params, trial_index: t.index, trial_number: t.trial_number, scene, reconstructed: true };
}

/** The tool force split into parts, when the summary has them: the analytic model's regions (chipping,
 * pressing, bouncing) or, for the finite-element runs, the faces of the tool the forces act on (rake face,
 * cutting edge, clearance face; a hybrid run also the particles' share on each). */
const SPLITS = [
  { parts: ["chipping", "pressing", "bouncing"], title: "Force components",
    text: "The analytic model's tool force split into its regions: chipping (material into the chip), pressing (material pushed under the edge) and bouncing (spring-back on the clearance face)." },
  { parts: ["rake", "edge", "clearance", "sph_rake", "sph_edge", "sph_clearance"], title: "Forces by tool face",
    text: "The steady mean forces split by the part of the tool they act on: the rake face (the chip; on a positive-rake tool it pushes the tool down), the cutting edge's arc and the clearance face (material pressed under the tool pushes it up). sph_: the particles' share of each (hybrid runs)." },
];

function breakdown(s, chart) {
  for (const split of SPLITS) {
    const parts = [];
    for (const region of split.parts) {
      for (const c of ["cutting", "thrust"]) {
        const k = `${region}_${c}_force_N_per_mm`;
        if (isNum(s[k])) parts.push({ label: `${region.replace("_", " ")} ${c === "cutting" ? "Fc" : "Ft"}`, value: s[k], title: `${k} = ${fmt(s[k])} N/mm` });
      }
    }
    if (!parts.length) continue;
    const hi = Math.max(...parts.map((p) => Math.abs(p.value)));
    const lo = Math.min(0, ...parts.map((p) => p.value));
    chart(split.title, split.text, (el) => barChart(el, parts, { min: lo, max: hi * 1.1, label: "force (N/mm)" }), true);
  }
}

function metricsTable(s) {
  const rows = Object.entries(s).filter(([, v]) => v === null || ["number", "string", "boolean"].includes(typeof v));
  return h("div", { class: "table-scroll" }, h("table", { class: "data compact" }, h("tbody", {}, rows.map(([k, v]) => h("tr", {}, h("th", { scope: "row" }, k), h("td", { class: typeof v === "number" ? "num" : "" }, fmt(v)))))),
    Object.entries(s).filter(([, v]) => v && typeof v === "object").map(([k, v]) => h("details", {}, h("summary", {}, k), h("pre", { class: "json" }, JSON.stringify(v, null, 2)))));
}

function section(title, ...children) {
  return h("section", { class: "card" }, h("h2", {}, title), ...children);
}

export async function runPage(main, id) {
  const run = await endpoints.run(id).catch((e) => { main.append(errorBox(e)); return null; });
  if (!run) return null;
  document.title = `Run ${id.slice(0, 8)} · fibrecut`;
  const s = run.summary || {};
  const ctx = (await endpoints.context(id).catch(() => null)) || (await contextFromStudy(id).catch(() => null));
  const scene = run.scene || ctx?.scene || null;
  const sceneNote = ctx?.reconstructed ? " (rebuilt from the study: base scene, fixed overrides, then the trial's parameters)" : "";
  const sceneName = (scene && scene.name) || s.scene || "scene";
  const studyId = run.study_id ?? ctx?.study_id ?? null;
  const crumbs = h("nav", { class: "crumbs", "aria-label": "Breadcrumb" }, h("a", { href: "#/" }, "Studies"), " / ",
    studyId !== null ? [h("a", { href: `#/studies/${studyId}` }, ctx?.study_name || `study #${studyId}`), " / "] : null, h("span", {}, `run ${id.slice(0, 8)}`));
  const download = run.has_file !== false
    ? h("a", { class: "button primary", href: endpoints.hdf5Url(id), download: `run-${id}.h5` }, "Download HDF5")
    : h("span", { class: "muted small" }, "no HDF5 file for this run");
  const params = ctx?.params && Object.keys(ctx.params).length ? Object.entries(ctx.params).map(([k, v]) => `${k} = ${fmt(v)}`).join(", ") : null;
  main.append(crumbs, h("div", { class: "page-head" },
    h("div", {}, h("h1", {}, `Run ${id.slice(0, 8)} `, badge(run.status)),
      h("p", { class: "muted" }, `${sceneName} · ${s.fidelity || scene?.fidelity || ""} · ${fmtDuration(run.wall_time_s ?? s.wall_time_s)} wall · ${fmt(s.steps)} steps · solver ${run.solver_version || "?"}${run.host ? ` · ${run.host}` : ""}`),
      params ? h("p", { class: "small" }, h("span", { class: "muted" }, ctx.trial_number !== null && ctx.trial_number !== undefined ? `trial ${ctx.trial_number}: ` : `point ${ctx.trial_index ?? ""}: `), params) : null),
    h("div", { class: "actions" }, download)));

  // headline metrics, with the estimated discretisation error where a convergence study of the
  // same scene gives one (service/discretisation.py)
  const est = run.estimated_discretisation_error;
  const estErr = est?.relative_error_vs_finest || {};
  const estUnc = est?.uncertainty || {}; // a study with replicas: the standard error of each error
  const withUnc = (k, v) => `${fmt(100 * v, 3)} %${isNum(estUnc[k]) ? ` ± ${fmt(100 * estUnc[k], 2)} %` : ""}`;
  main.append(h("section", { class: "metrics", "aria-label": "Summary metrics" }, HEADLINE.filter(([k]) => k in s).map(([k, label, unit]) =>
    h("div", { class: "metric" }, h("div", { class: "metric-label" }, label),
      h("div", { class: "metric-value" }, fmt(s[k]), unit ? h("span", { class: "unit" }, ` ${unit}`) : null),
      isNum(estErr[k]) ? h("div", { class: "metric-note", title: "estimated discretisation error: relative error against the finest level of a convergence study" }, isNum(estUnc[k]) ? `± ${fmt(100 * estErr[k], 3)} % (discretisation; its standard error ${fmt(100 * estUnc[k], 2)} %)` : `± ${fmt(100 * estErr[k], 3)} % (discretisation)`) : null))));
  if (est) {
    const level = Object.entries(est.level || {}).map(([f, v]) => `${f} = ${fmt(v)}`).join(", ");
    main.append(h("section", { class: "card", "aria-labelledby": "est-h" }, h("h2", { id: "est-h" }, "Estimated discretisation error"),
      h("p", { class: "hint" }, "Relative error of each metric against the finest level of ",
        h("a", { href: `#/studies/${est.study_id}` }, `convergence study #${est.study_id}`),
        ` at this run's resolution (${level}${est.basis && est.basis !== "level" ? `; ${est.basis}, an upper bound when the sequence converges monotonically` : ""}).`,
        est.replicas ? ` Errors of the level's mean over ${est.replicas} replicas against the finest level's mean, ± their standard errors.` : ""),
      h("div", { class: "table-scroll" }, h("table", { class: "data compact" }, h("tbody", {},
        Object.entries(estErr).map(([m, v]) => h("tr", {}, h("th", { scope: "row" }, m), h("td", { class: "num" }, isNum(v) ? withUnc(m, v) : "–"))))))));
  }

  // diagnosis and warnings
  const diag = run.diagnosis || s.diagnosis;
  if (diag || run.status === "unstable" || run.status === "failed") {
    const d = diag || {};
    // what happened and what to change first, then the details
    const first = ["what", "change", "suggestion", "check", "where", "when"];
    const rows = Object.entries(d).filter(([k]) => k !== "traceback")
      .sort(([a], [b]) => (first.includes(a) ? first.indexOf(a) : 99) - (first.includes(b) ? first.indexOf(b) : 99));
    main.append(h("section", { class: `card diagnosis ${run.status === "failed" ? "bad" : "warn"}`, "aria-labelledby": "diag-h" },
      h("h2", { id: "diag-h" }, run.status === "unstable" ? "Stability diagnosis" : run.status === "failed" ? "Why the run failed" : "Diagnosis"),
      rows.length ? h("dl", { class: "facts" }, rows.flatMap(([k, v]) => [h("dt", {}, k), h("dd", {}, typeof v === "object" ? JSON.stringify(v) : fmt(v))])) : h("p", {}, "The run gave no diagnosis."),
      d.traceback ? h("details", {}, h("summary", {}, "Traceback"), h("pre", {}, d.traceback)) : null));
  }
  if (Array.isArray(s.warnings) && s.warnings.length) {
    main.append(section("Warnings", h("ul", { class: "warnings" }, s.warnings.map((w) => h("li", {}, w)))));
  }

  const grid = h("div", { class: "chart-grid" });
  main.append(grid);
  const [series, frames] = run.has_file === false ? [null, null] : await Promise.all([
    endpoints.series(id).catch(() => null),
    endpoints.frames(id).catch(() => null),
  ]);
  const draws = [];
  const chart = (title, note, draw, wide) => {
    const body = h("div", { class: "chart-body" });
    grid.append(h("section", { class: `card chart-card${wide ? " wide" : ""}` }, h("h2", {}, title), note ? h("p", { class: "hint" }, note) : null, body));
    draws.push(() => draw(body));
  };

  const hasHistories = !!(series && (series.forces || series.energies || series.diagnostics));
  const nFrames = frames ? (frames.count ?? frames.n ?? (frames.times || []).length) : 0;
  breakdown(s, chart);
  if (!hasHistories && !nFrames) {
    grid.append(h("section", { class: "card chart-card wide" }, h("h2", {}, "Histories and chip frames"),
      h("p", { class: "chart-empty" }, s.fidelity === "analytic"
        ? "The analytic model computes the steady forces directly: it writes no force, energy or time-step history and no chip frames. A fem2d or hybrid2d run of the same scene has them."
        : "This run stored no time history and no chip frame.")));
  } else {
    // forces: against tool travel when the run gives it (the steady window is defined on it)
    const forces = series?.forces;
    const ft = timeAxis(forces);
    const win = steadyWindow(s, series);
    chart("Force history", win ? `Forces per unit width on the tool. Shaded: the steady-state window the summary forces are averaged over (${win.rule || "steady part of the cut"}); dashed: those means.` : "Forces per unit width on the tool.", (el) => {
      if (!ft) return plot(el, { empty: `No force history: the ${s.fidelity || "run's"} fidelity writes none.`, ariaLabel: "force history" });
      const byTravel = Array.isArray(forces.travel_um) && (!win || win.axis === "travel");
      const ts = byTravel ? { f: 1, label: "tool travel (µm)" } : timeScale(ft.values);
      const xs = (byTravel ? forces.travel_um : ft.values).map((v) => v * ts.f);
      const lines = [];
      const fc = forces.Fc ?? forces.fc ?? forces.cutting;
      const fth = forces.Ft ?? forces.ft ?? forces.thrust;
      if (fc) lines.push({ name: "Fc (cutting)", x: xs, y: fc, color: PALETTE[0] });
      if (fth) lines.push({ name: "Ft (thrust)", x: xs, y: fth, color: PALETTE[1] });
      const band = win && (win.axis === "travel") === byTravel ? [win.x0 * ts.f, win.x1 * ts.f] : null;
      if (band && isNum(s.cutting_force_N_per_mm)) lines.push({ name: `mean Fc ${fmt(s.cutting_force_N_per_mm)}`, x: band, y: [s.cutting_force_N_per_mm, s.cutting_force_N_per_mm], color: PALETTE[0], dash: "6 4", width: 2 });
      if (band && isNum(s.thrust_force_N_per_mm)) lines.push({ name: `mean Ft ${fmt(s.thrust_force_N_per_mm)}`, x: band, y: [s.thrust_force_N_per_mm, s.thrust_force_N_per_mm], color: PALETTE[1], dash: "6 4", width: 2 });
      plot(el, { x: { label: ts.label }, y: { label: "force (N/mm)", zero: true }, lines, bands: band ? [{ x0: band[0], x1: band[1], label: "steady window" }] : [], ariaLabel: "force history Fc and Ft" });
    }, true);

    // frames
    if (nFrames > 0) drawFrames(grid, id, frames, nFrames);
    else grid.append(h("section", { class: "card chart-card" }, h("h2", {}, "Chip frames"), h("p", { class: "chart-empty" }, `No chip frames in this run${s.fidelity === "analytic" ? " (the analytic model has no mesh)" : ""}.`)));

    // energies
    const en = series?.energies;
    const et = timeAxis(en);
    // energies (J per m of width) apart from the dimensionless checks (ratios, fractions, errors)
    const series_ = (k) => Array.isArray(en?.[k]) && et && en[k].length === et.values.length;
    const checkKey = (k) => /ratio|fraction|error/.test(k);
    chart("Energy balance", "External work against the energies it went into (per unit width); the residual is what the balance misses.", (el) => {
      if (!et) return plot(el, { empty: "No energy history in this run." });
      const ts = timeScale(et.values);
      const t = et.values.map((v) => v * ts.f);
      const keys = Object.keys(en).filter((k) => k !== et.key && series_(k) && !checkKey(k));
      plot(el, { x: { label: ts.label }, y: { label: "energy (J/m)", zero: true }, lines: keys.map((k, i) => ({ name: k.replace(/_/g, " "), x: t, y: en[k], color: PALETTE[i % PALETTE.length], dash: /resid|balance/.test(k) ? "4 3" : null })) });
    });
    const checks = et ? Object.keys(en).filter((k) => k !== et.key && series_(k) && checkKey(k)) : [];
    if (checks.length) {
      chart("Energy checks", "Dimensionless accuracy indicators over time: the energy error (balance residual over external work), the kinetic/internal energy ratio (small when the cut is quasi-static) and the added mass fraction of mass scaling.", (el) => {
        const ts = timeScale(et.values);
        const t = et.values.map((v) => v * ts.f);
        plot(el, { x: { label: ts.label }, y: { label: "ratio (1)", zero: true }, lines: checks.map((k, i) => ({ name: k.replace(/_/g, " "), x: t, y: en[k], color: PALETTE[(i + 3) % PALETTE.length] })) });
      });
    }

    // time step
    const dg = series?.diagnostics;
    chart("Time-step history", "The stable step dt chosen by the solver; a collapse signals a distorted element or a close particle pair.", (el) => {
      const dt = dg && (dg.dt ?? dg.dt_s ?? dg.time_step);
      const dtAxis = timeAxis(dg) || (dg && Array.isArray(dg.step) ? { values: dg.step, key: "step" } : null);
      if (!dt || !dtAxis) return plot(el, { empty: "No time-step history in this run." });
      const ts = dtAxis.key === "step" ? { f: 1, label: "step" } : timeScale(dtAxis.values);
      plot(el, { x: { label: ts.label }, y: { label: "dt (s)", log: dt.every((v) => !isNum(v) || v > 0) }, lines: [{ name: "dt", x: dtAxis.values.map((v) => v * ts.f), y: dt, color: PALETTE[2] }] });
    });

  }
  for (const d of draws) d();
  const redraw = () => { for (const d of draws) d(); };
  window.addEventListener("fibrecut:resize", redraw);

  // scene
  main.append(h("section", { class: "card" }, h("h2", {}, "Scene"),
    scene ? h("details", { class: "scene-json" }, h("summary", {}, `The scene that produced this run (${sceneName}, user units)${sceneNote}`), h("pre", { class: "json" }, JSON.stringify(scene, null, 2))) : h("p", { class: "muted" }, "The server gives no scene for this run; it is in the HDF5 file's root attribute 'scene'."),
    h("details", {}, h("summary", {}, "All summary values"), metricsTable(s))));
  return () => window.removeEventListener("fibrecut:resize", redraw);
}
