// Thin client of the fibrecut REST API (/api; README "REST", OpenAPI at /docs).
// Every call returns parsed JSON or throws an ApiError carrying the HTTP status and the
// server's detail (FastAPI's 422 list or a message).

export class ApiError extends Error {
  constructor(status, detail, url) {
    super(typeof detail === "string" ? detail : `HTTP ${status} from ${url}`);
    this.status = status;
    this.detail = detail;
    this.url = url;
  }
}

// The bearer token for writes (the server's FIBRECUT_API_TOKEN), kept in this browser only.
export function token() {
  try { return localStorage.getItem("fibrecut.token") || ""; } catch { return ""; }
}

export function setToken(t) {
  try { localStorage.setItem("fibrecut.token", t); } catch { /* private mode: the token lasts for this page */ }
}

export async function api(path, { method = "GET", body, signal, contentType = "application/json" } = {}) {
  const headers = { Accept: "application/json" };
  if (body !== undefined) headers["Content-Type"] = contentType;
  const t = token();
  if (t && method !== "GET") headers.Authorization = `Bearer ${t}`;
  const res = await fetch(path, { method, headers, signal, body: body === undefined ? undefined : contentType === "application/json" ? JSON.stringify(body) : body });
  const text = await res.text();
  let data = null;
  if (text) {
    try { data = JSON.parse(text); } catch { data = text; }
  }
  if (!res.ok) {
    const detail = data && typeof data === "object" && "detail" in data ? data.detail : data || res.statusText;
    throw new ApiError(res.status, detail, path);
  }
  return data;
}

// GET that answers null on 404 (an optional endpoint or a run without that data).
export async function apiOptional(path, opts) {
  try {
    return await api(path, opts);
  } catch (e) {
    if (e instanceof ApiError && (e.status === 404 || e.status === 409)) return null;
    throw e;
  }
}

// The API paths this server offers (from its OpenAPI document), so optional endpoints are
// only called where they exist (a 404 would show up as a console error).
let pathsPromise = null;
export function serverPaths() {
  if (!pathsPromise) {
    pathsPromise = api("/openapi.json").then((doc) => new Set(Object.keys(doc.paths || {}))).catch(() => new Set());
  }
  return pathsPromise;
}

export const endpoints = {
  health: () => api("/api/health"),
  scenes: () => api("/api/scenes"),
  studies: () => api("/api/studies"),
  study: (id) => api(`/api/studies/${encodeURIComponent(id)}`),
  trials: (id) => api(`/api/studies/${encodeURIComponent(id)}/trials`),
  // one entry per trial and stage (means over the replicas); none for studies judged run by run
  points: async (id) => ((await serverPaths()).has("/api/studies/{study_id}/points") ? api(`/api/studies/${encodeURIComponent(id)}/points?limit=10000`) : null),
  parseMeasurements: (text) => api("/api/measurements", { method: "POST", body: text, contentType: "text/csv" }),
  calibratedSceneUrl: (id) => `/api/studies/${encodeURIComponent(id)}/calibrated-scene.yaml`,
  createStudy: (doc) => api("/api/studies", { method: "POST", body: doc }),
  cancelStudy: (id) => api(`/api/studies/${encodeURIComponent(id)}/cancel`, { method: "POST" }),
  run: (id) => api(`/api/runs/${encodeURIComponent(id)}`),
  series: (id) => apiOptional(`/api/runs/${encodeURIComponent(id)}/series`),
  frames: (id) => apiOptional(`/api/runs/${encodeURIComponent(id)}/frames`),
  frame: (id, k) => api(`/api/runs/${encodeURIComponent(id)}/frames/${k}`),
  context: async (id) => ((await serverPaths()).has("/api/runs/{run_id}/context") ? apiOptional(`/api/runs/${encodeURIComponent(id)}/context`) : null),
  mesh: async (id) => ((await serverPaths()).has("/api/runs/{run_id}/mesh") ? apiOptional(`/api/runs/${encodeURIComponent(id)}/mesh`) : null),
  trialsCsvUrl: (id) => `/api/studies/${encodeURIComponent(id)}/trials.csv`,
  hdf5Url: (id) => `/api/runs/${encodeURIComponent(id)}/result.h5`,
};
