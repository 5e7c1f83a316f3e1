// The dashboard's entry point: a hash router over four pages (studies, new study, study,
// run). Each page is a function (main, ...params) -> dispose, which stops its polling.

import { endpoints } from "./api.js";
import { errorBox, h } from "./dom.js";
import { studiesPage } from "./views/studies.js";
import { newStudyPage } from "./views/new_study.js";
import { studyPage } from "./views/study.js";
import { runPage } from "./views/run.js";

const ROUTES = [
  [/^#?\/?$/, studiesPage, "studies"],
  [/^#\/new$/, newStudyPage, "new"],
  [/^#\/studies\/([^/?]+)(?:\?.*)?$/, studyPage, "studies"],
  [/^#\/runs\/([^/?]+)(?:\?.*)?$/, runPage, "studies"],
];

let dispose = null;
let first = true;

async function route() {
  if (dispose) { try { dispose(); } catch { /* a page's cleanup never blocks navigation */ } dispose = null; }
  const main = document.getElementById("main");
  const hash = location.hash || "#/";
  const match = ROUTES.map(([re, page, nav]) => [hash.match(re), page, nav]).find(([m]) => m);
  main.replaceChildren();
  for (const a of document.querySelectorAll("[data-nav]")) a.removeAttribute("aria-current");
  if (!match) {
    main.append(h("h1", {}, "Page not found"), h("p", {}, h("a", { href: "#/" }, "Back to the studies")));
    return;
  }
  const [m, page, nav] = match;
  document.querySelector(`[data-nav="${nav}"]`)?.setAttribute("aria-current", "page");
  if (!first) main.focus({ preventScroll: true });
  first = false;
  window.scrollTo(0, 0);
  try {
    dispose = (await page(main, ...m.slice(1).map(decodeURIComponent))) || null;
  } catch (e) {
    main.append(errorBox(e));
  }
}

async function health() {
  const el = document.getElementById("health");
  try {
    const hres = await endpoints.health();
    const w = hres && (hres.workers_seen ?? hres.workers);
    let text = w !== undefined && w !== null ? `online · ${typeof w === "object" ? Object.keys(w).length : w} worker${w === 1 ? "" : "s"}` : "online";
    if (hres && hres.workers_lost) text += ` · ${hres.workers_lost} lost`;
    if (hres && hres.kernels === "compiling") text += " · compiling solver kernels";
    el.textContent = text;
    el.className = "health ok";
  } catch {
    el.textContent = "offline";
    el.className = "health bad";
  }
}

window.addEventListener("hashchange", route);
let resizeTimer = null;
window.addEventListener("resize", () => {
  clearTimeout(resizeTimer);
  resizeTimer = setTimeout(() => window.dispatchEvent(new CustomEvent("fibrecut:resize")), 200);
});
route();
health();
setInterval(health, 15000);
