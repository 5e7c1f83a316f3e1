// DOM helpers: h() builds elements, badges and small shared widgets.

export function h(tag, attrs = {}, ...children) {
  const el = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (v === undefined || v === null || v === false) continue;
    if (k === "class") el.className = v;
    else if (k === "text") el.textContent = v;
    else if (k === "html") throw new Error("no raw HTML");
    else if (k.startsWith("on") && typeof v === "function") el.addEventListener(k.slice(2), v);
    else if (k === "dataset") Object.assign(el.dataset, v);
    else if (k in el && typeof v !== "string") el[k] = v;
    else el.setAttribute(k, v === true ? "" : String(v));
  }
  for (const c of children.flat(Infinity)) {
    if (c === null || c === undefined || c === false) continue;
    el.appendChild(c instanceof Node ? c : document.createTextNode(String(c)));
  }
  return el;
}

export const STATUS_CLASS = {
  ok: "good", done: "good", cached: "info", running: "info", queued: "muted", claimed: "info",
  unstable: "warn", failed: "bad", cancelled: "muted", pruned: "muted", error: "bad",
};

export function badge(status) {
  const s = String(status || "unknown");
  return h("span", { class: `badge ${STATUS_CLASS[s] || "muted"}` }, s);
}

export function card(title, ...children) {
  const id = "h-" + String(title).toLowerCase().replace(/[^a-z0-9]+/g, "-");
  return h("section", { class: "card", "aria-labelledby": id }, h("h2", { id }, title), ...children);
}

export function errorBox(err) {
  const msg = err && err.message ? err.message : String(err);
  return h("div", { class: "error-box", role: "alert" }, msg);
}

// Repeated call of fn every ms milliseconds until stopped; waits for each call to finish.
export function poller(fn, ms) {
  let stopped = false, timer = null;
  const tick = async () => {
    if (stopped) return;
    let again = true;
    try { again = (await fn()) !== false; } catch (e) { console.error(e); again = true; }
    if (!stopped && again) timer = setTimeout(tick, ms);
  };
  tick();
  return () => { stopped = true; clearTimeout(timer); };
}

let tokenSeq = 0;
/**
 * A labelled password field for the API token, shown when a write answered 401. onSave(token)
 * is called when the user saves it (button or Enter).
 */
export function tokenBox(onSave, message = "This server requires an API token for changes (FIBRECUT_API_TOKEN).") {
  const id = `token-${++tokenSeq}`;
  const input = h("input", { type: "password", id, autocomplete: "off", spellcheck: "false" });
  const save = h("button", { type: "button", class: "button primary" }, "Save token");
  const doSave = () => { if (input.value.trim()) onSave(input.value.trim()); };
  save.addEventListener("click", doSave);
  input.addEventListener("keydown", (e) => { if (e.key === "Enter") { e.preventDefault(); doSave(); } });
  const box = h("div", { class: "token-box", role: "group", "aria-labelledby": `${id}-l` },
    h("p", { id: `${id}-l` }, message),
    h("div", { class: "field inline" }, h("label", { for: id }, "API token"), input, save));
  box.focusInput = () => input.focus();
  return box;
}
