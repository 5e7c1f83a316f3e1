// Pure helpers for the study and run pages: ranks, rank correlation, Pareto front,
// best-so-far, accuracy against cost, formatting and CSV. No DOM here, so the browser
// tests can check these against references computed in Python.

export function isNum(v) {
  return typeof v === "number" && Number.isFinite(v);
}

// Average ranks (1-based), ties share the mean of their positions.
export function ranks(values) {
  const idx = values.map((v, i) => [v, i]).sort((a, b) => a[0] - b[0]);
  const out = new Array(values.length);
  let i = 0;
  while (i < idx.length) {
    let j = i;
    while (j + 1 < idx.length && idx[j + 1][0] === idx[i][0]) j++;
    const r = (i + j) / 2 + 1;
    for (let k = i; k <= j; k++) out[idx[k][1]] = r;
    i = j + 1;
  }
  return out;
}

export function pearson(x, y) {
  const n = x.length;
  if (n < 3) return null;
  const mx = x.reduce((a, b) => a + b, 0) / n;
  const my = y.reduce((a, b) => a + b, 0) / n;
  let sxy = 0, sxx = 0, syy = 0;
  for (let i = 0; i < n; i++) {
    const dx = x[i] - mx, dy = y[i] - my;
    sxy += dx * dy; sxx += dx * dx; syy += dy * dy;
  }
  if (sxx <= 0 || syy <= 0) return null;
  return sxy / Math.sqrt(sxx * syy);
}

// Spearman's rank correlation rho of y against x over the pairs where both are finite
// (Pearson's correlation of the average ranks). null with fewer than 3 pairs or no spread.
export function spearman(x, y) {
  const xs = [], ys = [];
  for (let i = 0; i < x.length; i++) {
    if (isNum(x[i]) && isNum(y[i])) { xs.push(x[i]); ys.push(y[i]); }
  }
  if (xs.length < 3) return null;
  return pearson(ranks(xs), ranks(ys));
}

// Indices of the non-dominated points. points: arrays of objective values;
// directions: "minimize" | "maximize" per objective. Points with a missing value are left out.
export function paretoFront(points, directions) {
  const sign = directions.map((d) => (String(d).startsWith("max") ? -1 : 1));
  const ok = points.map((p) => p.length === sign.length && p.every(isNum));
  const front = [];
  for (let i = 0; i < points.length; i++) {
    if (!ok[i]) continue;
    let dominated = false;
    for (let j = 0; j < points.length && !dominated; j++) {
      if (i === j || !ok[j]) continue;
      let allLe = true, oneLt = false;
      for (let k = 0; k < sign.length; k++) {
        const a = sign[k] * points[j][k], b = sign[k] * points[i][k];
        if (a > b) { allLe = false; break; }
        if (a < b) oneLt = true;
      }
      dominated = allLe && oneLt;
    }
    if (!dominated) front.push(i);
  }
  return front;
}

// Running best of a sequence (null entries keep the previous best).
export function bestSoFar(values, direction = "minimize") {
  const max = String(direction).startsWith("max");
  let best = null;
  return values.map((v) => {
    if (isNum(v) && (best === null || (max ? v > best : v < best))) best = v;
    return best;
  });
}

// Accuracy against cost. rows: [{level, wall, value}] for one metric; the reference is the
// finest level (smallest value of the resolution parameter: element size, mass or speed
// scaling all get finer as they get smaller). Answers [{level, wall, error}] for the
// other levels with error = |value - ref| / |ref|, and the reference row.
export function errorAgainstFinest(rows) {
  const ok = rows.filter((r) => isNum(r.level) && isNum(r.value) && isNum(r.wall));
  if (ok.length < 2) return { reference: null, points: [] };
  const ref = ok.reduce((a, b) => (b.level < a.level ? b : a));
  const scale = Math.max(Math.abs(ref.value), 1e-12);
  const points = ok
    .filter((r) => r !== ref && r.level !== ref.level)
    .map((r) => ({ ...r, error: Math.abs(r.value - ref.value) / scale }));
  return { reference: ref, points };
}

// Flatten a nested object into dotted names: {tool: {rake_angle_deg: 30}} -> {"tool.rake_angle_deg": 30}.
export function flatten(obj, prefix = "", out = {}) {
  for (const [k, v] of Object.entries(obj || {})) {
    const key = prefix ? `${prefix}.${k}` : k;
    if (v && typeof v === "object" && !Array.isArray(v)) flatten(v, key, out);
    else out[key] = v;
  }
  return out;
}

export function fmt(v, digits = 4) {
  if (v === null || v === undefined || v === "") return "–";
  if (typeof v === "boolean") return v ? "yes" : "no";
  if (typeof v !== "number") return String(v);
  if (!Number.isFinite(v)) return String(v);
  if (v === 0) return "0";
  const a = Math.abs(v);
  if (a >= 1e5 || a < 1e-3) return v.toExponential(digits - 1).replace("e+", "e");
  return String(Number(v.toPrecision(digits)));
}

export function fmtDuration(s) {
  if (!isNum(s)) return "–";
  if (s < 1e-3) return `${Math.max(1, Math.round(s * 1e6))} µs`;
  if (s < 1) return `${Math.round(s * 1000)} ms`;
  if (s < 60) return `${s.toFixed(s < 10 ? 1 : 0)} s`;
  const m = Math.floor(s / 60), r = Math.round(s % 60);
  if (m < 60) return `${m} min ${r} s`;
  return `${Math.floor(m / 60)} h ${m % 60} min`;
}

function csvCell(v) {
  if (v === null || v === undefined) return "";
  const s = typeof v === "object" ? JSON.stringify(v) : String(v);
  return /[",\n\r]/.test(s) ? `"${s.replace(/"/g, '""')}"` : s;
}

export function toCSV(columns, rows) {
  const lines = [columns.map((c) => csvCell(c.label || c.key)).join(",")];
  for (const r of rows) lines.push(columns.map((c) => csvCell(c.get(r))).join(","));
  return lines.join("\n") + "\n";
}
