// Chip frames of a run: the mesh's elements (quads from /api/runs/{id}/mesh) at the frame's
// node positions, coloured by material, state (alive / failed / particle), damage or stress,
// with the tool drawn at the frame's time and a slider over the frames.

import { endpoints } from "../api.js";
import { fmt, isNum } from "../analysis.js";
import { seqColor } from "../charts.js";
import { errorBox, h } from "../dom.js";

// Codes the solver writes in /frames/NNNN/material and /state (solver.cutting); a frame or
// the series answer may carry its own legend, which wins.
export const MATERIAL_NAMES = { 0: "fibre", 1: "matrix", 2: "EHM (homogenised ply)" };
export const STATE_NAMES = { 0: "alive", 1: "failed", 2: "particle" };
const MATERIAL_COLORS = ["#1e293b", "#f59e0b", "#94a3b8", "#6366f1", "#ec4899"];
const STATE_COLORS = ["#3b82f6", "#dc2626", "#a855f7", "#6b7280"];

/** A frame field: the API sends {shape, data}; plain arrays are accepted too. */
export function arrayOf(v) {
  if (v === null || v === undefined) return null;
  if (Array.isArray(v)) return v;
  if (typeof v === "object" && Array.isArray(v.data)) return v.data;
  return null;
}

export function positionsOf(frame) {
  const p = arrayOf(frame.positions ?? frame.position);
  if (!p || !p.length) return null;
  if (Array.isArray(p[0])) return { x: p.map((q) => q[0]), y: p.map((q) => q[1]) };
  if (typeof p[0] === "number") return { x: p.filter((_, i) => i % 2 === 0), y: p.filter((_, i) => i % 2 === 1) };
  return null;
}

/** A scalar per entry; stress rows (sxx, syy, sxy) become the plane von Mises stress. */
export function scalarOf(v) {
  const arr = arrayOf(v);
  if (!arr) return null;
  if (Array.isArray(arr[0])) return arr.map((r) => Math.sqrt(r[0] * r[0] - r[0] * r[1] + r[1] * r[1] + 3 * (r[2] || 0) * (r[2] || 0)));
  return arr;
}

/**
 * Outline of the tool at time t (m): the edge arc of radius r around the centre C, the rake
 * face leaning back by alpha and the clearance face rising by gamma (solver/tool.py layout:
 * [xC, yC, vx, vy, r, alpha, gamma, cos a, sin a, cos g, sin g, side]); C moves with (vx, vy).
 */
export function toolOutline(tool, t, len) {
  const [x0, y0, vx, vy, r, a, g] = tool;
  const side = tool[11] || 1;
  const cx = x0 + vx * t, cy = y0 + vy * t;
  const pts = [];
  const rakeN = [-Math.cos(a), Math.sin(a)], rakeD = [Math.sin(a), Math.cos(a)];
  const clearN = [Math.sin(g), -Math.cos(g)], clearD = [Math.cos(g), Math.sin(g)];
  pts.push([cx + r * rakeN[0] + len * rakeD[0], cy + r * rakeN[1] + len * rakeD[1]]);
  const t1 = Math.PI - a, t2 = 1.5 * Math.PI + g;
  for (let i = 0; i <= 24; i++) {
    const th = t1 + ((t2 - t1) * i) / 24;
    pts.push([cx + r * Math.cos(th), cy + r * Math.sin(th)]);
  }
  pts.push([cx + r * clearN[0] + len * clearD[0], cy + r * clearN[1] + len * clearD[1]]);
  pts.push([cx + len, cy + len]);
  return side < 0 ? pts.map(([x, y]) => [2 * cx - x, y]) : pts;
}

export function drawFrames(grid, id, info, n) {
  const times = info.times || [];
  const fields = info.fields || [];
  const canvas = h("canvas", { class: "frame-canvas", role: "img", "aria-label": "chip frame" });
  const slider = h("input", { type: "range", min: 0, max: n - 1, step: 1, value: n - 1, id: "frame-slider" });
  const modes = [["material", "material"], ["state", "state (alive / failed / particle)"], ["damage", "damage"], ["stress", "stress (von Mises)"]]
    .filter(([m]) => !fields.length || fields.includes(m) || (m === "material"));
  const mode = h("select", { id: "frame-colour" }, modes.map(([v, t]) => h("option", { value: v }, t)));
  const label = h("span", { class: "muted small frame-label", "aria-live": "polite" });
  const legend = h("div", { class: "legend" });
  const card = h("section", { class: "card chart-card wide", "aria-labelledby": "frames-h" }, h("h2", { id: "frames-h" }, "Chip frames"),
    h("p", { class: "hint" }, "The workpiece as the tool cuts it, frame by frame; failed (deleted) elements are hidden unless coloured by state."),
    h("div", { class: "frame-controls" },
      h("div", { class: "field inline grow" }, h("label", { for: "frame-slider" }, "Frame"), slider, label),
      h("div", { class: "field inline" }, h("label", { for: "frame-colour" }, "Colour by"), mode)),
    legend, canvas);
  grid.append(card);
  const cache = new Map();
  let bounds = null;
  let seq = 0;
  const meshPromise = endpoints.mesh(id).catch(() => null);

  async function show() {
    const k = Number(slider.value);
    const my = ++seq;
    const t = times[k];
    const text = `${k + 1} of ${n}${isNum(t) ? ` · t = ${t < 1e-2 ? fmt(t * 1e6) + " µs" : fmt(t) + " s"}` : ""}`;
    label.textContent = text;
    slider.setAttribute("aria-valuetext", text);
    let frame = cache.get(k);
    if (!frame) {
      try { frame = await endpoints.frame(id, k); } catch (e) { card.append(errorBox(e)); return; }
      cache.set(k, frame);
    }
    const mesh = await meshPromise;
    if (my !== seq) return;
    render(frame, mesh);
  }

  function colouring(frame, m, nItems, meshMaterial) {
    if (m === "material" || m === "state") {
      const codes = arrayOf(frame[m]) || (m === "material" ? meshMaterial : null);
      const names = { ...(m === "material" ? MATERIAL_NAMES : STATE_NAMES), ...(frame.legend?.[m] || {}) };
      const palette = m === "material" ? MATERIAL_COLORS : STATE_COLORS;
      if (codes && codes.length === nItems) {
        const items = [...new Set(codes)].sort((a, b) => a - b).map((c) => ({ name: names[c] ?? `code ${c}`, color: palette[(c | 0) % palette.length] }));
        return { colour: (i) => palette[(codes[i] | 0) % palette.length], items };
      }
      return null;
    }
    const vals = scalarOf(frame[m]);
    if (!vals || vals.length !== nItems) return null;
    let lo = Infinity, hi = -Infinity;
    for (const v of vals) if (isNum(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
    const span = hi > lo ? hi - lo : 1;
    const unit = m === "stress" ? " Pa" : "";
    return { colour: (i) => seqColor((vals[i] - lo) / span), items: [{ name: `${m} ${fmt(lo)}${unit}`, color: seqColor(0) }, { name: `${fmt(hi)}${unit}`, color: seqColor(1) }] };
  }

  function render(frame, mesh) {
    const pos = positionsOf(frame);
    const w = Math.max(260, Math.floor(card.clientWidth - 36));
    if (!pos || !pos.x.length) { canvas.width = w; canvas.height = 40; canvas.style.width = `${w}px`; canvas.style.height = "40px"; legend.replaceChildren(h("span", { class: "muted" }, "This frame has no positions.")); return; }
    if (!bounds) {
      let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
      for (let i = 0; i < pos.x.length; i++) { x0 = Math.min(x0, pos.x[i]); x1 = Math.max(x1, pos.x[i]); y0 = Math.min(y0, pos.y[i]); y1 = Math.max(y1, pos.y[i]); }
      const pad = 0.04 * Math.max(x1 - x0, y1 - y0);
      bounds = [x0 - pad, x1 + pad, y0 - pad, y1 + pad];
    }
    const [x0, x1, y0, y1] = bounds;
    const hgt = Math.min(560, Math.max(160, Math.round((w * (y1 - y0)) / Math.max(x1 - x0, 1e-30))));
    const dpr = window.devicePixelRatio || 1;
    canvas.width = Math.round(w * dpr); canvas.height = Math.round(hgt * dpr);
    canvas.style.width = `${w}px`; canvas.style.height = `${hgt}px`;
    const ctx = canvas.getContext("2d");
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.fillStyle = "#f8fafc"; ctx.fillRect(0, 0, w, hgt);
    const sc = Math.min(w / (x1 - x0), hgt / (y1 - y0));
    const ox = (w - sc * (x1 - x0)) / 2, oy = (hgt - sc * (y1 - y0)) / 2;
    const X = (x) => ox + (x - x0) * sc, Y = (y) => hgt - oy - (y - y0) * sc;
    const m = mode.value;
    const quads = mesh && arrayOf(mesh.quads);
    // a 3D run's mesh is its side view: each face names its element (the frames' fields are per element)
    const elems = mesh && arrayOf(mesh.elements);
    const elemOf = (e) => (elems ? elems[e] : e);
    const state = arrayOf(frame.state);
    let items;
    if (quads && quads.length && quads.every((q) => q.every((k) => k < pos.x.length))) {
      const nElems = elems ? (arrayOf(mesh.material) || []).length : quads.length;
      const c = colouring(frame, m, nElems, arrayOf(mesh.material)) || { colour: () => "#64748b", items: [{ name: `${m}: not stored in this run`, color: "#64748b" }] };
      items = c.items;
      ctx.lineWidth = 0.35;
      ctx.strokeStyle = "rgba(15,23,42,0.25)";
      for (let e = 0; e < quads.length; e++) {
        if (m !== "state" && state && state[elemOf(e)]) continue; // deleted elements leave the picture
        const q = quads[e];
        ctx.beginPath();
        ctx.moveTo(X(pos.x[q[0]]), Y(pos.y[q[0]]));
        for (let j = 1; j < q.length; j++) ctx.lineTo(X(pos.x[q[j]]), Y(pos.y[q[j]]));
        ctx.closePath();
        ctx.fillStyle = c.colour(elemOf(e));
        ctx.fill();
        if (sc * (x1 - x0) / Math.sqrt(quads.length) > 6) ctx.stroke();
      }
    } else {
      // no connectivity: draw the points themselves
      const c = colouring(frame, m, pos.x.length, null) || { colour: () => "#475569", items: [{ name: "nodes (no mesh from the server: element colours need GET /api/runs/{id}/mesh)", color: "#475569" }] };
      items = c.items;
      const r = Math.max(1, Math.min(4, 0.5 * sc * Math.sqrt(((x1 - x0) * (y1 - y0)) / pos.x.length)));
      for (let i = 0; i < pos.x.length; i++) {
        ctx.fillStyle = c.colour(i);
        ctx.fillRect(X(pos.x[i]) - r, Y(pos.y[i]) - r, 2 * r, 2 * r);
      }
    }
    // the tool at the frame's time (solver.tool array: centre, velocity, radius, angles, side)
    const tool0 = mesh && arrayOf(mesh.tool0);
    const tf = isNum(frame.time) ? frame.time : times[Number(slider.value)];
    if (tool0 && tool0.length >= 12 && isNum(tf)) {
      const pts = toolOutline(tool0, tf, 2 * Math.max(x1 - x0, y1 - y0));
      ctx.beginPath();
      pts.forEach(([x, y], i) => (i ? ctx.lineTo(X(x), Y(y)) : ctx.moveTo(X(x), Y(y))));
      ctx.closePath();
      ctx.fillStyle = "rgba(100,116,139,0.35)";
      ctx.strokeStyle = "#334155";
      ctx.lineWidth = 1.5;
      ctx.fill();
      ctx.stroke();
      items = [...items, { name: "tool", color: "rgba(100,116,139,0.6)" }];
    }
    // SPH particles (hybrid2d) when the frame carries them
    const pp = frame.particles ? positionsOf({ positions: frame.particles.positions ?? frame.particles }) : positionsOf({ positions: frame.particle_positions });
    if (pp) {
      ctx.fillStyle = STATE_COLORS[2];
      const r = Math.max(1.2, Math.min(3, sc * 0.7e-6));
      for (let i = 0; i < pp.x.length; i++) { ctx.beginPath(); ctx.arc(X(pp.x[i]), Y(pp.y[i]), r, 0, 2 * Math.PI); ctx.fill(); }
      items = [...items, { name: `SPH particles (${pp.x.length})`, color: STATE_COLORS[2] }];
    }
    // scale bar
    const target = (x1 - x0) * 1e6 / 5; // about a fifth of the width, rounded to 1, 2 or 5 x 10^k um
    const mag = 10 ** Math.floor(Math.log10(Math.max(target, 1e-3)));
    const um = [5, 2, 1].map((f) => f * mag).find((v) => v <= target) || mag;
    const len = um * 1e-6 * sc;
    ctx.fillStyle = "#111827"; ctx.fillRect(12, hgt - 14, len, 3);
    ctx.font = "11px system-ui, sans-serif"; ctx.fillText(`${um} µm`, 12, hgt - 19);
    legend.replaceChildren(...items.map((it) => h("span", { class: "legend-item" }, h("i", { class: "swatch point", style: `background:${it.color}` }), it.name)));
  }

  const rerender = () => { const f = cache.get(Number(slider.value)); if (f && canvas.isConnected) meshPromise.then((mesh) => render(f, mesh)); };
  slider.addEventListener("input", show);
  mode.addEventListener("change", rerender);
  window.addEventListener("fibrecut:resize", rerender);
  show();
}
