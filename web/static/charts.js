// Small SVG chart helpers, no dependencies: line/scatter plots with linear or log axes and
// shaded x-bands, horizontal bar charts and parallel coordinates. Each draws into a
// container element, sized to its current width; hover titles give exact values.

const NS = "http://www.w3.org/2000/svg";
export const PALETTE = ["#2563eb", "#dc2626", "#059669", "#d97706", "#7c3aed", "#0891b2", "#db2777", "#4b5563",
  "#65a30d", "#9f1239", "#0f766e", "#a16207", "#1e40af", "#c026d3"];

export function svgEl(tag, attrs = {}, parent) {
  const el = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs)) if (v !== undefined && v !== null) el.setAttribute(k, String(v));
  if (parent) parent.appendChild(el);
  return el;
}

function title(el, text) {
  const t = svgEl("title", {}, el);
  t.textContent = text;
  return el;
}

const finite = (v) => typeof v === "number" && Number.isFinite(v);

export function tickFormat(v) {
  if (v === 0) return "0";
  const a = Math.abs(v);
  if (a >= 1e5 || a < 1e-3) {
    const e = v.toExponential(1).replace("e+", "e").replace(".0e", "e");
    return e;
  }
  return String(Number(v.toPrecision(4)));
}

// "Nice" linear ticks covering [lo, hi] with about n intervals.
export function niceTicks(lo, hi, n = 5) {
  if (!(hi > lo)) return [lo];
  const raw = (hi - lo) / n;
  const mag = Math.pow(10, Math.floor(Math.log10(raw)));
  const step = [1, 2, 2.5, 5, 10].map((m) => m * mag).find((s) => s >= raw) || 10 * mag;
  const out = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9; v += step) out.push(Math.abs(v) < step * 1e-9 ? 0 : v);
  return out;
}

function logTicks(lo, hi) {
  const a = Math.floor(Math.log10(lo)), b = Math.ceil(Math.log10(hi));
  const out = [];
  const mult = b - a <= 2 ? [1, 2, 5] : [1];
  const stride = Math.max(1, Math.ceil((b - a) / 6));
  for (let e = a; e <= b; e += stride) for (const m of mult) {
    const v = m * Math.pow(10, e);
    if (v >= lo * 0.999 && v <= hi * 1.001) out.push(v);
  }
  return out.length >= 2 ? out : [lo, hi];
}

function extent(values, log) {
  let lo = Infinity, hi = -Infinity;
  for (const v of values) {
    if (!finite(v) || (log && v <= 0)) continue;
    if (v < lo) lo = v;
    if (v > hi) hi = v;
  }
  if (lo === Infinity) return null;
  if (lo === hi) {
    if (log) return [lo / 2, hi * 2];
    const d = Math.abs(lo) * 0.1 || 1;
    return [lo - d, hi + d];
  }
  if (log) return [lo / 1.15, hi * 1.15];
  const pad = (hi - lo) * 0.04;
  return [lo - pad, hi + pad];
}

function scale([d0, d1], [r0, r1], log) {
  if (log) {
    const l0 = Math.log10(d0), l1 = Math.log10(d1);
    return (v) => r0 + ((Math.log10(v) - l0) / (l1 - l0)) * (r1 - r0);
  }
  return (v) => r0 + ((v - d0) / (d1 - d0)) * (r1 - r0);
}

function emptyNote(container, text) {
  const p = document.createElement("p");
  p.className = "chart-empty";
  p.textContent = text;
  container.replaceChildren(p);
  return null;
}

function legendBox(items) {
  const div = document.createElement("div");
  div.className = "legend";
  for (const it of items) {
    const span = document.createElement("span");
    span.className = "legend-item";
    const sw = document.createElement("i");
    sw.className = "swatch" + (it.kind === "band" ? " band" : it.kind === "point" ? " point" : it.kind === "errbar" ? " errbar" : it.kind === "tie" ? " tie" : "");
    sw.style.background = it.color;
    span.append(sw, document.createTextNode(it.name));
    div.appendChild(span);
  }
  return div;
}

function size(container, height) {
  const w = Math.max(280, Math.round(container.clientWidth || container.parentElement?.clientWidth || 600));
  const h = height || (w < 480 ? 220 : 260);
  return [w, h];
}

/**
 * Line and scatter plot.
 * opts: {x: {label, log}, y: {label, log}, lines: [{name, x: [], y: [], color, dash, width}],
 *        points: [{x, y, color, r, title, href, ring, err, errX, tie}], bands: [{x0, x1, label, color}],
 *        (err / errX: half-length of a vertical / horizontal error bar, the standard error of a
 *        replicated mean; tie: a dashed ring marking a trial statistically tied with the best)
 *        height, empty: "message when there is nothing to draw", ariaLabel}
 */
export function plot(container, opts) {
  const lines = (opts.lines || []).filter((l) => l.x && l.y && l.x.length);
  const points = opts.points || [];
  const xl = !!opts.x?.log, yl = !!opts.y?.log;
  const bar = (v) => finite(v) && v > 0;
  const xs = [...lines.flatMap((l) => l.x), ...points.flatMap((p) => (bar(p.errX) ? [p.x - p.errX, p.x + p.errX] : [p.x]))];
  const ys = [...lines.flatMap((l) => l.y), ...points.flatMap((p) => (bar(p.err) ? [p.y - p.err, p.y + p.err] : [p.y]))];
  const xd = extent(xs, xl), yd0 = extent(ys, yl);
  if (!xd || !yd0) return emptyNote(container, opts.empty || "No data to plot yet.");
  let yd = yd0;
  if (opts.y?.zero && !yl) yd = [Math.min(yd[0], 0), Math.max(yd[1], 0)];
  const [W, H] = size(container, opts.height);
  const m = { l: 62, r: 14, t: 10, b: 44 };
  const sx = scale(xd, [m.l, W - m.r], xl), sy = scale(yd, [H - m.b, m.t], yl);
  const svg = svgEl("svg", { viewBox: `0 0 ${W} ${H}`, width: "100%", role: "img", "aria-label": opts.ariaLabel || `${opts.y?.label || "y"} against ${opts.x?.label || "x"}`, class: "chart" });
  const clipId = `clip${Math.random().toString(36).slice(2, 9)}`;
  const defs = svgEl("defs", {}, svg);
  svgEl("rect", { x: m.l, y: m.t, width: W - m.l - m.r, height: H - m.t - m.b }, svgEl("clipPath", { id: clipId }, defs));

  // grid and axes
  const gx = svgEl("g", { class: "axis" }, svg);
  const xTicks = xl && xd[1] / xd[0] >= 3 ? logTicks(...xd) : niceTicks(...xd, W < 480 ? 4 : 6).filter((t) => !xl || t > 0);
  for (const t of xTicks) {
    const X = sx(t);
    svgEl("line", { x1: X, x2: X, y1: m.t, y2: H - m.b, class: "grid" }, gx);
    svgEl("text", { x: X, y: H - m.b + 15, "text-anchor": "middle" }, gx).textContent = tickFormat(t);
  }
  // log axes over less than a factor 3 read better with linear tick values
  const yTicks = yl && yd[1] / yd[0] >= 3 ? logTicks(...yd) : niceTicks(...yd, 5).filter((t) => !yl || t > 0);
  for (const t of yTicks) {
    const Y = sy(t);
    svgEl("line", { x1: m.l, x2: W - m.r, y1: Y, y2: Y, class: "grid" }, gx);
    svgEl("text", { x: m.l - 6, y: Y + 4, "text-anchor": "end" }, gx).textContent = tickFormat(t);
  }
  svgEl("rect", { x: m.l, y: m.t, width: W - m.l - m.r, height: H - m.t - m.b, class: "frame" }, gx);
  if (opts.x?.label) svgEl("text", { x: (m.l + W - m.r) / 2, y: H - 8, "text-anchor": "middle", class: "label" }, gx).textContent = opts.x.label;
  if (opts.y?.label) svgEl("text", { x: 14, y: (m.t + H - m.b) / 2, "text-anchor": "middle", class: "label", transform: `rotate(-90 14 ${(m.t + H - m.b) / 2})` }, gx).textContent = opts.y.label;

  const body = svgEl("g", { "clip-path": `url(#${clipId})` }, svg);
  for (const b of opts.bands || []) {
    if (!finite(b.x0) || !finite(b.x1)) continue;
    const x0 = sx(Math.max(b.x0, xd[0])), x1 = sx(Math.min(b.x1, xd[1]));
    const r = svgEl("rect", { x: Math.min(x0, x1), y: m.t, width: Math.abs(x1 - x0), height: H - m.t - m.b, fill: b.color || "#fde68a", "fill-opacity": 0.45, class: "band" }, body);
    if (b.label) title(r, b.label);
  }
  if (opts.y?.zero && !yl && yd[0] < 0 && yd[1] > 0) svgEl("line", { x1: m.l, x2: W - m.r, y1: sy(0), y2: sy(0), class: "zero" }, body);
  lines.forEach((l, i) => {
    let d = "", pen = false;
    for (let k = 0; k < l.x.length; k++) {
      const x = l.x[k], y = l.y[k];
      if (!finite(x) || !finite(y) || (xl && x <= 0) || (yl && y <= 0)) { pen = false; continue; }
      const X = sx(x).toFixed(1), Y = sy(y).toFixed(1);
      if (l.step && pen) d += `H${X}V${Y}`;
      else d += `${pen ? "L" : "M"}${X},${Y}`;
      pen = true;
    }
    if (d) svgEl("path", { d, fill: "none", stroke: l.color || PALETTE[i % PALETTE.length], "stroke-width": l.width || 1.6, "stroke-dasharray": l.dash, class: "series" }, body);
  });
  for (const p of points) {
    if (!finite(p.x) || !finite(p.y) || (xl && p.x <= 0) || (yl && p.y <= 0)) continue;
    let parent = body;
    // clickable points; out of the Tab order (the trials table has the same links)
    if (p.href) parent = svgEl("a", { href: p.href, tabindex: "-1" }, body);
    const X = sx(p.x), Y = sy(p.y), stroke = p.color || PALETTE[0];
    if (bar(p.err)) {
      const y0 = sy(yl ? Math.max(p.y - p.err, yd[0]) : p.y - p.err), y1 = sy(p.y + p.err);
      const g = svgEl("g", { class: "errbar", stroke, "stroke-width": 1.2 }, parent);
      svgEl("line", { x1: X.toFixed(1), x2: X.toFixed(1), y1: y0.toFixed(1), y2: y1.toFixed(1) }, g);
      for (const yy of [y0, y1]) svgEl("line", { x1: (X - 3).toFixed(1), x2: (X + 3).toFixed(1), y1: yy.toFixed(1), y2: yy.toFixed(1) }, g);
      if (p.title) title(g, p.title);
    }
    if (bar(p.errX)) {
      const x0 = sx(xl ? Math.max(p.x - p.errX, xd[0]) : p.x - p.errX), x1 = sx(p.x + p.errX);
      const g = svgEl("g", { class: "errbar errbar-x", stroke, "stroke-width": 1.2 }, parent);
      svgEl("line", { x1: x0.toFixed(1), x2: x1.toFixed(1), y1: Y.toFixed(1), y2: Y.toFixed(1) }, g);
      for (const xx of [x0, x1]) svgEl("line", { x1: xx.toFixed(1), x2: xx.toFixed(1), y1: (Y - 3).toFixed(1), y2: (Y + 3).toFixed(1) }, g);
    }
    if (p.tie) {
      const t = svgEl("circle", { cx: X.toFixed(1), cy: Y.toFixed(1), r: (p.r || 4) + 3.5, fill: "none", stroke: "#d97706", "stroke-width": 1.6, "stroke-dasharray": "3 2", class: "tie" }, parent);
      title(t, "statistically tied with the best (within two combined standard errors)");
    }
    const c = svgEl("circle", { cx: sx(p.x).toFixed(1), cy: sy(p.y).toFixed(1), r: p.r || 4, fill: p.color || PALETTE[0], stroke: p.ring ? "#111827" : "#fff", "stroke-width": p.ring ? 1.8 : 1, class: "point" }, parent);
    if (p.title) title(c, p.title);
  }
  const nodes = [];
  const legendItems = [
    ...lines.filter((l) => l.name).map((l, i) => ({ name: l.name, color: l.color || PALETTE[i % PALETTE.length] })),
    ...(opts.legend || []),
  ];
  if (points.some((p) => bar(p.err) || bar(p.errX))) legendItems.push({ name: "± standard error", color: "#4b5563", kind: "errbar" });
  if (points.some((p) => p.tie)) legendItems.push({ name: "tied with the best", color: "#d97706", kind: "tie" });
  for (const b of opts.bands || []) if (b.label && finite(b.x0)) legendItems.push({ name: b.label, color: b.color || "#fde68a", kind: "band" });
  if (legendItems.length) nodes.push(legendBox(legendItems));
  nodes.push(svg);
  container.replaceChildren(...nodes);
  return svg;
}

/** Horizontal bars, values in [min, max] (default [-1, 1]); items: [{label, value, title}]. */
export function barChart(container, items, { min = -1, max = 1, label = "", empty = "No data yet." } = {}) {
  const rows = items.filter((it) => finite(it.value));
  if (!rows.length) return emptyNote(container, empty);
  const [W] = size(container);
  const rowH = 24, m = { l: Math.min(190, Math.round(W * 0.42)), r: 44, t: 6, b: 34 };
  const H = m.t + m.b + rowH * rows.length;
  const sx = scale([min, max], [m.l, W - m.r], false);
  const svg = svgEl("svg", { viewBox: `0 0 ${W} ${H}`, width: "100%", role: "img", "aria-label": label || "bar chart", class: "chart" });
  const g = svgEl("g", { class: "axis" }, svg);
  for (const t of niceTicks(min, max, 4)) {
    svgEl("line", { x1: sx(t), x2: sx(t), y1: m.t, y2: H - m.b, class: "grid" }, g);
    svgEl("text", { x: sx(t), y: H - m.b + 14, "text-anchor": "middle" }, g).textContent = tickFormat(t);
  }
  if (label) svgEl("text", { x: (m.l + W - m.r) / 2, y: H - 6, "text-anchor": "middle", class: "label" }, g).textContent = label;
  rows.forEach((it, i) => {
    const y = m.t + i * rowH;
    const x0 = sx(Math.max(min, Math.min(0, it.value))), x1 = sx(Math.min(max, Math.max(0, it.value)));
    const r = svgEl("rect", { x: x0, y: y + 4, width: Math.max(1, x1 - x0), height: rowH - 8, fill: it.value >= 0 ? PALETTE[0] : PALETTE[1], rx: 2, class: "bar" }, svg);
    title(r, it.title || `${it.label}: ${tickFormat(it.value)}`);
    const name = svgEl("text", { x: m.l - 6, y: y + rowH / 2 + 4, "text-anchor": "end", class: "barlabel" }, svg);
    name.textContent = it.label.length > 30 ? "…" + it.label.slice(-29) : it.label;
    svgEl("text", { x: x1 + 4, y: y + rowH / 2 + 4, class: "barvalue" }, svg).textContent = tickFormat(Number(it.value.toFixed(2)));
  });
  svgEl("line", { x1: sx(0), x2: sx(0), y1: m.t, y2: H - m.b, class: "zero" }, svg);
  container.replaceChildren(svg);
  return svg;
}

// Sequential colour map (viridis stops) for t in [0, 1].
const VIRIDIS = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
export function seqColor(t) {
  if (!finite(t)) return "#9ca3af";
  t = Math.max(0, Math.min(1, t)) * (VIRIDIS.length - 1);
  const i = Math.min(VIRIDIS.length - 2, Math.floor(t)), f = t - i;
  const c = VIRIDIS[i].map((a, k) => Math.round(a + f * (VIRIDIS[i + 1][k] - a)));
  return `rgb(${c[0]},${c[1]},${c[2]})`;
}

/**
 * Parallel coordinates: axes [{name, values: [] (one per row)}]; rows coloured by the values
 * of the axis named colorBy (the first objective). rowTitles: hover text per row.
 */
export function parallelCoordinates(container, axes, { colorBy = null, rowTitles = [], height, empty = "No finished trials yet." } = {}) {
  const n = axes.length ? axes[0].values.length : 0;
  if (axes.length < 2 || n === 0) return emptyNote(container, empty);
  const [W, H0] = size(container, height);
  const H = Math.max(H0, 240);
  const spacing = (W - 60) / Math.max(1, axes.length - 1);
  const stagger = spacing < 110; // labels on two rows when the axes are close
  const m = { l: 30, r: 30, t: stagger ? 48 : 34, b: 14 };
  const ax = axes.map((a, i) => {
    const d = extent(a.values, false) || [0, 1];
    return { ...a, x: m.l + (i * (W - m.l - m.r)) / (axes.length - 1), d, sy: scale(d, [H - m.b, m.t], false) };
  });
  const svg = svgEl("svg", { viewBox: `0 0 ${W} ${H}`, width: "100%", role: "img", "aria-label": "parallel coordinates of parameters and objectives", class: "chart" });
  const cAxis = ax.find((a) => a.name === colorBy) || ax[ax.length - 1];
  const g = svgEl("g", { class: "pc-lines" }, svg);
  for (let r = 0; r < n; r++) {
    let d = "", pen = false;
    for (const a of ax) {
      const v = a.values[r];
      if (!finite(v)) { pen = false; continue; }
      d += `${pen ? "L" : "M"}${a.x.toFixed(1)},${a.sy(v).toFixed(1)}`;
      pen = true;
    }
    const cv = cAxis.values[r];
    const t = finite(cv) ? (cv - cAxis.d[0]) / (cAxis.d[1] - cAxis.d[0]) : NaN;
    const p = svgEl("path", { d, fill: "none", stroke: seqColor(t), "stroke-width": 1.5, "stroke-opacity": 0.8 }, g);
    if (rowTitles[r]) title(p, rowTitles[r]);
  }
  const ga = svgEl("g", { class: "axis" }, svg);
  ax.forEach((a, i) => {
    svgEl("line", { x1: a.x, x2: a.x, y1: m.t, y2: H - m.b, class: "pc-axis" }, ga);
    for (const t of niceTicks(...a.d, 4)) {
      if (t < a.d[0] || t > a.d[1]) continue;
      svgEl("line", { x1: a.x - 3, x2: a.x + 3, y1: a.sy(t), y2: a.sy(t), class: "pc-axis" }, ga);
      const anchor = i === ax.length - 1 ? "end" : "start";
      svgEl("text", { x: a.x + (anchor === "end" ? -5 : 5), y: a.sy(t) + 3, "text-anchor": anchor, class: "pc-tick" }, ga).textContent = tickFormat(t);
    }
    const anchor = i === 0 ? "start" : i === ax.length - 1 ? "end" : "middle";
    const lab = svgEl("text", { x: a.x, y: m.t - 12 - (stagger && i % 2 ? 14 : 0), "text-anchor": anchor, class: "label" }, ga);
    const text = a.short || a.name;
    lab.textContent = stagger && text.length > 14 ? text.slice(0, 13) + "…" : text;
    title(lab, a.name);
  });
  const note = document.createElement("p");
  note.className = "chart-note";
  note.textContent = `Each line is one trial; colour: ${cAxis.short || cAxis.name} (dark = low, yellow = high).`;
  container.replaceChildren(svg, note);
  return svg;
}
