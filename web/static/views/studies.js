// Studies list: name, kind, status, progress by job state, best value so far and ETA,
// refreshed every 2 s without reloading the page.

import { endpoints } from "../api.js";
import { fmt, fmtDuration } from "../analysis.js";
import { badge, errorBox, h, poller } from "../dom.js";

const TERMINAL = ["done", "failed", "cancelled"];
const STATES = ["done", "cached", "running", "queued", "failed", "cancelled"];

export function progressBar(study) {
  const c = study.counts || {};
  const total = Math.max(study.planned_jobs || 0, STATES.reduce((a, s) => a + (s === "cached" ? 0 : c[s] || 0), 0), 1);
  // "done" counts include cached jobs in the service; show them apart.
  const cached = c.cached || 0;
  const parts = { done: Math.max(0, (c.done || 0) - cached), cached, running: c.running || 0, failed: c.failed || 0, cancelled: c.cancelled || 0 };
  const bar = h("div", { class: "progress", role: "progressbar", "aria-valuemin": 0, "aria-valuemax": total, "aria-valuenow": (c.done || 0) + (c.failed || 0), "aria-label": `${study.name} progress` });
  for (const [k, v] of Object.entries(parts)) if (v > 0) bar.append(h("span", { class: `seg ${k}`, style: `width:${(100 * v) / total}%`, title: `${k}: ${v}` }));
  const text = `${c.done || 0}/${total} done` + (cached ? ` (${cached} cached)` : "") + (c.running ? ` · ${c.running} running` : "") +
    (c.queued ? ` · ${c.queued} queued` : "") + (c.failed ? ` · ${c.failed} failed` : "") + (c.cancelled ? ` · ${c.cancelled} cancelled` : "");
  return h("div", { class: "progress-wrap" }, bar, h("div", { class: "progress-text" }, text));
}

export function objectivesOf(study) {
  const doc = study.document || {};
  if (Array.isArray(doc.objectives) && doc.objectives.length) return doc.objectives;
  return [];
}

/**
 * Best value so far: for optimisations the service's best trial (or the size of the Pareto
 * front); for sweeps with an objective, the best finished trial of the given list.
 */
export function bestText(study, trials) {
  const objs = objectivesOf(study);
  if (study.kind === "calibrate") {
    const b = study.best?.[0];
    return b && typeof b.objectives?.misfit_sd === "number" ? `misfit ${fmt(b.objectives.misfit_sd, 3)} sd (trial ${b.trial_number})` : "–";
  }
  if (!objs.length) return "–";
  const o = objs[0];
  if (study.kind === "optimize" || (study.best && study.best.length)) {
    const best = study.best;
    if (!best || !best.length) return "–";
    if (objs.length > 1) return `${best.length} on the Pareto front`;
    const v = best[0].objectives?.[o.metric] ?? best[0].value;
    const sem = best[0].sem?.[o.metric];
    const tied = best[0].tied?.length || 0;
    return `${fmt(v)}${typeof sem === "number" ? ` ± ${fmt(sem, 2)}` : ""} ${shortMetric(o.metric)}` +
      (best[0].replicas > 1 ? ` (mean of ${best[0].replicas_ok} replicas${best[0].confirmed ? ", confirmed" : ""})` : best[0].confirmed ? " (confirmed)" : "") +
      (typeof sem === "number" ? `, ${tied ? `${tied} trial${tied > 1 ? "s" : ""} statistically tied` : "no trial statistically tied"}` : "");
  }
  if (!trials) return "–";
  const max = o.direction === "maximize";
  let best = null;
  for (const t of trials) {
    const v = t.status === "done" && t.metrics ? t.metrics[o.metric] : null;
    if (typeof v === "number" && Number.isFinite(v) && (best === null || (max ? v > best : v < best))) best = v;
  }
  return best === null ? "–" : `${fmt(best)} ${shortMetric(o.metric)}${objs.length > 1 ? ` (${o.direction === "maximize" ? "max" : "min"})` : ""}`;
}

export function metricLabel(m) {
  return {
    cutting_force_N_per_mm: "cutting force Fc (N/mm)", thrust_force_N_per_mm: "thrust force Ft (N/mm)", damage_depth_um: "damage depth (µm)",
    bounce_back_um: "bounce-back (µm)", material_removal_rate_mm2_s: "removal rate (mm²/s)", energy_error: "energy error", wall_time_s: "wall time (s)", steps: "steps",
    misfit_sd: "misfit (standard deviations)",
  }[m] || m;
}

export function shortMetric(m) {
  return {
    cutting_force_N_per_mm: "Fc N/mm", thrust_force_N_per_mm: "Ft N/mm", damage_depth_um: "damage µm",
    bounce_back_um: "bounce-back µm", material_removal_rate_mm2_s: "MRR mm²/s", energy_error: "energy error",
    wall_time_s: "wall s", steps: "steps", misfit_sd: "misfit sd",
  }[m] || m;
}

function when(t) {
  if (!t) return "–";
  const d = new Date(t * 1000);
  return d.toLocaleString(undefined, { month: "short", day: "numeric", hour: "2-digit", minute: "2-digit" });
}

export async function studiesPage(main) {
  document.title = "Studies · fibrecut";
  const tbody = h("tbody", {}, h("tr", {}, h("td", { colspan: 7, class: "muted" }, "Loading studies…")));
  const status = h("p", { class: "muted small", role: "status", "aria-live": "polite" });
  const table = h("table", { class: "data studies" },
    h("caption", { class: "sr-only" }, "Studies, newest first"),
    h("thead", {}, h("tr", {}, ["Study", "Kind", "Status", "Progress", "Best so far", "ETA", "Created"].map((t) => h("th", { scope: "col" }, t)))),
    tbody);
  const empty = h("div", { class: "empty", hidden: true },
    h("p", {}, "No study yet."), h("a", { class: "button primary", href: "#/new" }, "Create the first study"));
  main.append(
    h("div", { class: "page-head" }, h("h1", {}, "Studies"), h("a", { class: "button primary", href: "#/new" }, "New study")),
    h("div", { class: "card flush" }, h("div", { class: "table-scroll" }, table), empty),
    status,
  );
  // the list answer carries no document; fetch the details (objectives, best) of the newest
  // studies, again while they run, once when they are finished
  const details = new Map();
  let lastKey = "";
  async function detailOf(st) {
    const known = details.get(st.id);
    if (known && TERMINAL.includes(known.study.status)) return known;
    try {
      const study = await endpoints.study(st.id);
      const objs = objectivesOf(study);
      const trials = study.kind !== "optimize" && objs.length ? await endpoints.trials(st.id) : null;
      const d = { study, trials };
      details.set(st.id, d);
      return d;
    } catch {
      return known || null;
    }
  }
  const refresh = async () => {
    let list;
    try {
      list = await endpoints.studies();
    } catch (e) {
      status.replaceChildren(errorBox(e));
      return true;
    }
    const studies = Array.isArray(list) ? list : list.studies || list.items || [];
    studies.sort((a, b) => (b.created_at || 0) - (a.created_at || 0) || b.id - a.id);
    const detailList = await Promise.all(studies.slice(0, 20).map(detailOf));
    const key = JSON.stringify([studies, detailList.map((d) => d && bestText(d.study, d.trials))]);
    status.textContent = `Updated ${new Date().toLocaleTimeString()} · refreshes every 2 s`;
    if (key === lastKey) return true; // unchanged: keep the rows (and the keyboard focus)
    lastKey = key;
    empty.hidden = studies.length > 0;
    table.hidden = studies.length === 0;
    tbody.replaceChildren(...studies.map((s, i) => h("tr", { dataset: { studyId: s.id } },
      h("td", { "data-label": "Study" }, h("div", {}, h("a", { href: `#/studies/${s.id}`, class: "strong" }, s.name), h("div", { class: "muted small" }, `#${s.id}`))),
      h("td", { "data-label": "Kind" }, s.kind),
      h("td", { "data-label": "Status" }, h("div", {}, badge(s.status))),
      h("td", { "data-label": "Progress", class: "wide" }, progressBar(s)),
      h("td", { "data-label": "Best so far" }, detailList[i] ? bestText(detailList[i].study, detailList[i].trials) : "–"),
      h("td", { "data-label": "ETA" }, ["done", "failed", "cancelled"].includes(s.status) ? "–" : fmtDuration(s.eta_s)),
      h("td", { "data-label": "Created" }, when(s.created_at)),
    )));
    status.textContent = `Updated ${new Date().toLocaleTimeString()} · refreshes every 2 s`;
    return true;
  };
  return poller(refresh, 2000);
}
