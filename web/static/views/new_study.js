// New-study form: base scene from the catalogue, fixed overrides, parameters with ranges or
// values (dotted field names), sweep design or optuna sampler, objectives and constraints,
// replicas per trial, a confirmation of the best trials, a screening on a cheap fidelity, and
// for a calibration the measured points as a CSV file (checked by the API, row and column named).
// The API's 422 messages are shown next to the field they name, and in a summary on top.
// Plain form semantics: every control has a label, Tab order follows the page, Enter submits.

import { ApiError, endpoints, setToken } from "../api.js";
import { flatten } from "../analysis.js";
import { h, tokenBox } from "../dom.js";
import { shortMetric } from "./studies.js";

export const METRICS = [
  "thrust_force_N_per_mm", "cutting_force_N_per_mm", "damage_depth_um", "bounce_back_um",
  "material_removal_rate_mm2_s", "energy_error", "wall_time_s", "steps",
];
const RESOLUTION_FIELDS = ["numerics.element_size_um", "numerics.mass_scaling", "numerics.speed_scaling"];

let uid = 0;
const nextId = (p) => `${p}-${++uid}`;

function field(label, control, { hint, wide } = {}) {
  const id = control.id || (control.id = nextId("f"));
  const msg = h("p", { class: "field-error", id: `${id}-err`, hidden: true });
  const hintEl = hint ? h("p", { class: "hint", id: `${id}-hint` }, hint) : null;
  if (hintEl) control.setAttribute("aria-describedby", hintEl.id);
  return h("div", { class: `field${wide ? " wide" : ""}` }, h("label", { for: id }, label), control, hintEl, msg);
}

function select(options, value, attrs = {}) {
  return h("select", attrs, options.map((o) => {
    const [v, t] = Array.isArray(o) ? o : [o, o];
    return h("option", { value: v, selected: v === value }, t);
  }));
}

export function parseValue(text) {
  const s = String(text).trim();
  if (s === "") return undefined;
  if (/^(true|false)$/i.test(s)) return s.toLowerCase() === "true";
  const n = Number(s);
  return Number.isFinite(n) ? n : s;
}

function numberInput(attrs = {}) {
  return h("input", { type: "number", step: "any", inputmode: "decimal", ...attrs });
}

export async function newStudyPage(main) {
  document.title = "New study · fibrecut";
  let scenes = [];
  try {
    scenes = await endpoints.scenes();
  } catch (e) {
    scenes = [];
  }
  const sceneNames = scenes.map((s) => s.name);
  const form = h("form", { class: "study-form", novalidate: true, "aria-labelledby": "new-study-title" });
  const summary = h("div", { class: "error-summary", role: "alert", tabindex: "-1", hidden: true });
  const targets = []; // {path, control, msg}

  // ---------------------------------------------------------------- basics
  const name = h("input", { type: "text", name: "name", autocomplete: "off", required: true, value: "rake-angle-sweep", spellcheck: "false" });
  const kindBox = h("fieldset", { class: "segmented" }, h("legend", {}, "Kind"));
  const kinds = [["sweep", "Sweep"], ["optimize", "Optimise"], ["convergence", "Convergence"], ["calibrate", "Calibrate"]];
  for (const [v, t] of kinds) {
    const id = nextId("kind");
    kindBox.append(h("input", { type: "radio", name: "kind", id, value: v, checked: v === "sweep" }), h("label", { for: id }, t));
  }
  const kindMsg = h("p", { class: "field-error", hidden: true });
  kindBox.append(kindMsg);
  const defaultScene = sceneNames.includes("seed-0deg-fem-quick") ? "seed-0deg-fem-quick" : sceneNames[0];
  const scene = select(sceneNames.length ? sceneNames : [["", "(catalogue unavailable)"]], defaultScene, { name: "scene" });
  const sceneDesc = h("p", { class: "hint" });
  const fidelity = select([["", "the scene's own"], ["analytic", "analytic (fast model)"], ["fem2d", "fem2d (classic FEM)"], ["hybrid2d", "hybrid2d (FEM-SPH)"], ["fem3d", "fem3d (3D strip, classic FEM)"], ["hybrid3d", "hybrid3d (3D strip, FEM-SPH)"]], "", { name: "fidelity" });
  const datalist = h("datalist", { id: nextId("fields") });

  const sceneInfo = () => scenes.find((s) => s.name === scene.value);
  const updateScene = () => {
    const s = sceneInfo();
    sceneDesc.textContent = s ? `${s.description} · fidelity ${s.fidelity}` : "";
    fidelity.options[0].textContent = s ? `the scene's own (${s.fidelity})` : "the scene's own";
    const names = Object.keys(flatten(s?.scene || {})).filter((k) => !["name", "fidelity"].includes(k)).sort();
    datalist.replaceChildren(...names.map((n) => h("option", { value: n })));
  };
  scene.addEventListener("change", updateScene);

  const fScene = field("Base scene", scene, {});
  fScene.insertBefore(sceneDesc, fScene.querySelector(".field-error"));
  sceneDesc.id = `${scene.id}-hint`;
  scene.setAttribute("aria-describedby", sceneDesc.id);
  const basics = h("section", { class: "card" }, h("h2", {}, "Study"),
    h("div", { class: "grid2" },
      field("Study name", name, { hint: "Letters, digits, spaces and . : + = , ( ) / - _" }),
      h("div", { class: "field" }, kindBox),
      fScene,
      field("Fidelity", fidelity, { hint: "Overrides the scene's fidelity for every run (fixed.fidelity); analytic runs take milliseconds." })),
    datalist);
  targets.push({ path: "name", control: name }, { path: "kind", control: kindBox.querySelector("input"), msg: kindMsg },
    { path: "scene", control: scene }, { path: "fixed.fidelity", control: fidelity });

  // ---------------------------------------------------------------- rows helper
  function rowList(title, addLabel, makeRow, hint) {
    const list = h("div", { class: "rows" });
    const add = h("button", { type: "button", class: "button" }, `+ ${addLabel}`);
    const section = h("section", { class: "card" }, h("h2", {}, title), hint ? h("p", { class: "hint" }, hint) : null, list, add);
    const api = {
      section, list,
      add(init) {
        const row = makeRow(init || {});
        const n = list.children.length + 1;
        const remove = h("button", { type: "button", class: "button icon", "aria-label": `Remove ${addLabel} ${n}`, title: `Remove this ${addLabel}` }, "×");
        remove.addEventListener("click", () => {
          const next = row.el.nextElementSibling || row.el.previousElementSibling;
          row.el.remove();
          api.rows = api.rows.filter((r) => r !== row);
          form.dispatchEvent(new Event("change"));
          (next?.querySelector("input, select") || add).focus();
        });
        row.el.append(h("div", { class: "row-actions" }, remove));
        list.append(row.el);
        api.rows.push(row);
        return row;
      },
      rows: [],
    };
    add.addEventListener("click", () => {
      const row = api.add();
      form.dispatchEvent(new Event("change"));
      row.el.querySelector("input, select")?.focus();
    });
    return api;
  }

  // ---------------------------------------------------------------- parameters
  const params = rowList("Parameters", "parameter", (init) => {
    const pname = h("input", { type: "text", list: datalist.id, value: init.name || "", placeholder: "tool.rake_angle_deg", spellcheck: "false", autocomplete: "off" });
    const mode = select([["values", "values"], ["range", "range"]], init.values ? "values" : init.low !== undefined ? "range" : "values");
    const values = h("input", { type: "text", value: (init.values || []).join(", "), placeholder: "0, 10, 20, 30", inputmode: "decimal" });
    const low = numberInput({ value: init.low ?? "" });
    const high = numberInput({ value: init.high ?? "" });
    const step = numberInput({ value: init.step ?? "", min: 0 });
    const log = h("input", { type: "checkbox", checked: !!init.log });
    const fValues = field("Values (comma-separated)", values);
    fValues.classList.add("span3");
    const fLow = field("Low", low), fHigh = field("High", high), fStep = field("Step", step);
    const fLog = h("div", { class: "field check" }, h("label", {}, log, " log scale"));
    const sync = () => {
      const r = mode.value === "range";
      fValues.hidden = r;
      for (const f of [fLow, fHigh, fStep, fLog]) f.hidden = !r;
    };
    mode.addEventListener("change", sync);
    sync();
    const el = h("div", { class: "row param-row" }, field("Field (dotted name)", pname, { wide: true }), field("Given as", mode), fValues, fLow, fHigh, fStep, fLog);
    return {
      el, pname, mode, values, low, high, step, log,
      targets: () => {
        const p = `parameters.${pname.value.trim()}`;
        // problems of the whole parameter (unknown field, low above high) go under the row, focus on its name
        return [{ path: p, control: pname, msg: el.querySelector(".row-msg") || el.appendChild(h("p", { class: "field-error row-msg", hidden: true })) },
          { path: `${p}.values`, control: values }, { path: `${p}.low`, control: low }, { path: `${p}.high`, control: high },
          { path: `${p}.step`, control: step }, { path: `${p}.log`, control: log }];
      },
    };
  }, "Any scene field by its dotted name, with explicit values or a range (a grid over a range needs a step).");

  // ---------------------------------------------------------------- fixed overrides
  const fixed = rowList("Fixed overrides", "override", (init) => {
    const fname = h("input", { type: "text", list: datalist.id, value: init.name || "", placeholder: "tool.edge_radius_um", spellcheck: "false", autocomplete: "off" });
    const fval = h("input", { type: "text", value: init.value ?? "", placeholder: "20" });
    const el = h("div", { class: "row" }, field("Field (dotted name)", fname, { wide: true }), field("Value", fval));
    return { el, fname, fval, targets: () => [{ path: `fixed.${fname.value.trim()}`, control: fval }] };
  }, "Applied to every run of the study.");

  // ---------------------------------------------------------------- design / sampler
  const design = select([["grid", "grid (every combination)"], ["lhs", "Latin hypercube"], ["sobol", "Sobol"]], "grid", { name: "design" });
  const nPoints = numberInput({ name: "n_points", min: 1, step: 1, value: "" });
  const sampler = select([["tpe", "TPE (default)"], ["cmaes", "CMA-ES"], ["gp", "Gaussian process"], ["nsga2", "NSGA-II (several objectives)"]], "tpe", { name: "sampler" });
  const nTrials = numberInput({ name: "n_trials", min: 1, step: 1, value: 20 });
  const parallelism = numberInput({ name: "parallelism", min: 1, step: 1, value: 4 });
  const seed = numberInput({ name: "seed", min: 0, step: 1, value: "" });
  const fPoints = field("Points (LHS, Sobol)", nPoints);
  const sweepBox = h("div", { class: "grid2" }, field("Design", design), fPoints);
  const optBox = h("div", { class: "grid2" }, field("Sampler", sampler), field("Trials", nTrials), field("Trials in parallel", parallelism), field("Random seed (optional)", seed));
  const convNote = h("p", { class: "hint" }, `A convergence study runs the scene at several levels of a resolution field (${RESOLUTION_FIELDS.join(", ")}): give it as a parameter with values, coarse to fine. The study page plots each level's error against its wall time.`);
  const replicas = numberInput({ name: "replicas", min: 1, max: 100, step: 1, value: 1 });
  const replicasLabel = h("span", {}, "Replicas per level");
  const fReplicas = field("Replicas", replicas);
  fReplicas.querySelector("label").replaceChildren(replicasLabel);
  const convBox = h("div", { class: "grid2" }, fReplicas,
    h("p", { class: "hint" }, "Cutting with fracture is chaotic: one run is one sample of a spread. With n replicas every trial runs n times (the speed scaling changed by k·1e-6, physically nothing) and the study compares means, with standard errors; trials within two combined standard errors of the best are marked as tied."));
  // confirmation of the best trials (sweep, optimize)
  const confirmOn = h("input", { type: "checkbox", id: nextId("confirm") });
  const cTopK = numberInput({ name: "confirm.top_k", min: 1, max: 50, step: 1, value: 3 });
  const cReplicas = numberInput({ name: "confirm.replicas", min: 1, max: 100, step: 1, value: 4 });
  const cFidelity = select([["", "the study's"], ["analytic", "analytic"], ["fem2d", "fem2d"], ["hybrid2d", "hybrid2d"], ["fem3d", "fem3d"], ["hybrid3d", "hybrid3d"]], "", { name: "confirm.fidelity" });
  const cScene = select([["", "the study's"], ...sceneNames], "", { name: "confirm.scene" });
  const confirmFields = h("div", { class: "grid2" }, field("Best trials to confirm", cTopK), field("Replicas each", cReplicas), field("Confirmation fidelity", cFidelity), field("Confirmation scene", cScene));
  const confirmBox = h("fieldset", { class: "subsection" }, h("legend", {}, h("label", { for: confirmOn.id }, confirmOn, " Confirm the best trials (run again with more replicas, e.g. on the full scene)")), confirmFields,
    h("p", { class: "hint" }, "Needs one objective; the ranking after confirmation is what the study reports."));
  // screening on a cheap fidelity (optimize, calibrate)
  const screenOn = h("input", { type: "checkbox", id: nextId("screen") });
  const sTrials = numberInput({ name: "screen.n_trials", min: 2, step: 1, value: 200 });
  const sTopK = numberInput({ name: "screen.top_k", min: 1, step: 1, value: 10 });
  const sMargin = numberInput({ name: "screen.margin", min: 0, max: 1, step: "any", value: 0.1 });
  const screenFields = h("div", { class: "grid2" }, field("Screening trials (analytic)", sTrials), field("Best screening trials spanning the box", sTopK), field("Box margin (fraction of each range)", sMargin));
  const screenBox = h("fieldset", { class: "subsection" }, h("legend", {}, h("label", { for: screenOn.id }, screenOn, " Screen on the analytic model first, then search only the box around its best trials")), screenFields);
  const strategyTitle = h("h2", {}, "Design");
  const strategy = h("section", { class: "card" }, strategyTitle, sweepBox, optBox, convNote, convBox, confirmBox, screenBox);
  targets.push({ path: "confirm", control: cTopK }, { path: "confirm.top_k", control: cTopK }, { path: "confirm.replicas", control: cReplicas },
    { path: "confirm.fidelity", control: cFidelity }, { path: "confirm.scene", control: cScene },
    { path: "screen", control: sTrials }, { path: "screen.n_trials", control: sTrials }, { path: "screen.top_k", control: sTopK }, { path: "screen.margin", control: sMargin });

  // ---------------------------------------------------------------- measurements (calibrate)
  const csvFile = h("input", { type: "file", accept: ".csv,text/csv,text/plain", id: nextId("csvfile") });
  const csvText = h("textarea", { name: "measurements_csv", rows: 6, spellcheck: "false", placeholder: "tool.rake_angle_deg,cut.depth_um,cutting_force_N_per_mm,thrust_force_N_per_mm,sd_N_per_mm\n10,50,20.1,18.0,1.0" });
  const csvCheck = h("button", { type: "button", class: "button" }, "Check the measurements");
  const csvStatus = h("p", { class: "muted small", role: "status", "aria-live": "polite" });
  csvFile.addEventListener("change", async () => {
    const f = csvFile.files?.[0];
    if (f) { csvText.value = await f.text(); csvCheck.click(); }
  });
  csvCheck.addEventListener("click", async () => {
    clearErrors();
    csvStatus.textContent = "Checking…";
    try {
      const r = await endpoints.parseMeasurements(csvText.value);
      csvStatus.textContent = `${r.measurements.length} measured point${r.measurements.length === 1 ? "" : "s"}, every row valid.`;
    } catch (e) {
      csvStatus.textContent = "";
      if (e instanceof ApiError && e.status === 422) showErrors(problemsOf(e));
      else showErrors([{ path: "", msg: e.message }]);
    }
  });
  const measureSection = h("section", { class: "card" }, h("h2", {}, "Measurements"),
    h("p", { class: "hint" }, "One row per measured point: the scene fields it was measured at (dotted names, e.g. tool.rake_angle_deg, cut.depth_um, workpiece.fibre_angle_deg, cut.speed_mm_s, tool.edge_radius_um), the measured cutting_force_N_per_mm and/or thrust_force_N_per_mm, and their standard uncertainty sd_N_per_mm (or cutting_force_sd_N_per_mm, thrust_force_sd_N_per_mm); optional label. The parameters above are the fields to fit, with their bounds."),
    field("CSV file", csvFile), field("CSV text", csvText, { wide: true }), h("div", {}, csvCheck, csvStatus));
  targets.push({ path: "measurements_csv", control: csvText }, { path: "measurements", control: csvText });
  targets.push({ path: "design", control: design }, { path: "n_points", control: nPoints }, { path: "sampler", control: sampler },
    { path: "n_trials", control: nTrials }, { path: "parallelism", control: parallelism }, { path: "seed", control: seed },
    { path: "replicas", control: replicas });

  // ---------------------------------------------------------------- objectives and constraints
  const metricOptions = METRICS.map((m) => [m, `${m} (${shortMetric(m)})`]);
  const objectives = rowList("Objectives", "objective", (init) => {
    // a new row takes the first metric not yet used (the removal rate is maximised)
    const used = new Set((objectives?.rows || []).map((r) => r.metric.value));
    const order = ["thrust_force_N_per_mm", "material_removal_rate_mm2_s", "damage_depth_um", ...METRICS];
    const m0 = init.metric || order.find((m) => !used.has(m)) || METRICS[0];
    const metric = select(metricOptions, m0);
    const dir = select([["minimize", "minimise"], ["maximize", "maximise"]], init.direction || (m0 === "material_removal_rate_mm2_s" ? "maximize" : "minimize"));
    const el = h("div", { class: "row" }, field("Metric", metric, { wide: true }), field("Direction", dir));
    return { el, metric, dir, targets: (i) => [{ path: `objectives.${i}`, control: metric }, { path: `objectives.${i}.metric`, control: metric }, { path: `objectives.${i}.direction`, control: dir }] };
  }, "Several objectives give a Pareto front.");
  const constraints = rowList("Constraints", "constraint", (init) => {
    const metric = select(metricOptions, init.metric || "material_removal_rate_mm2_s");
    const op = select([[">=", "at least (>=)"], ["<=", "at most (<=)"]], init.op || ">=");
    const value = numberInput({ value: init.value ?? "" });
    const el = h("div", { class: "row" }, field("Metric", metric, { wide: true }), field("Condition", op), field("Value", value));
    return { el, metric, op, value, targets: (i) => [{ path: `constraints.${i}`, control: value }, { path: `constraints.${i}.metric`, control: metric }, { path: `constraints.${i}.op`, control: op }, { path: `constraints.${i}.value`, control: value }] };
  }, "Optimisation only: a trial that breaks one is infeasible.");

  const submit = h("button", { type: "submit", class: "button primary" }, "Create study");
  const busy = h("span", { class: "muted", role: "status", "aria-live": "polite" });
  const size = h("span", { class: "muted small", id: "study-size" });
  form.append(summary, basics, params.section, fixed.section, measureSection, strategy, objectives.section, constraints.section,
    h("div", { class: "form-actions" }, submit, size, h("a", { href: "#/", class: "button subtle" }, "Cancel"), busy));
  submit.setAttribute("aria-describedby", size.id);
  main.append(h("div", { class: "page-head" }, h("h1", { id: "new-study-title" }, "New study")), form);

  // defaults: a small rake-angle sweep
  params.add({ name: "tool.rake_angle_deg", values: [0, 10, 20, 30] });
  objectives.add({ metric: "thrust_force_N_per_mm" });

  const kindValue = () => form.querySelector('input[name="kind"]:checked').value;
  // a sweep ranks its points (best, ties) when it has replicas or a confirmation
  const sweepRanked = () => confirmOn.checked || Number(replicas.value) > 1;
  const syncKind = () => {
    const k = kindValue();
    sweepBox.hidden = k !== "sweep";
    fPoints.hidden = design.value === "grid";
    optBox.hidden = !["optimize", "calibrate"].includes(k);
    convNote.hidden = k !== "convergence";
    replicasLabel.textContent = { convergence: "Replicas per level", calibrate: "Replicas per trial and measured point" }[k] || "Replicas per trial";
    confirmBox.hidden = !["sweep", "optimize"].includes(k);
    confirmFields.hidden = !confirmOn.checked;
    screenBox.hidden = !["optimize", "calibrate"].includes(k);
    screenFields.hidden = !screenOn.checked;
    measureSection.hidden = k !== "calibrate";
    strategyTitle.textContent = { sweep: "Design", optimize: "Optimiser", convergence: "Levels", calibrate: "Fit" }[k];
    constraints.section.hidden = k !== "optimize";
    objectives.section.hidden = !(k === "optimize" || (k === "sweep" && sweepRanked()));
  };
  // how many runs the study asks for (the service checks it against its limits)
  function updateSize() {
    const doc = buildDocument();
    let n = null;
    if (doc.kind === "optimize") n = doc.n_trials != null ? doc.n_trials * (doc.replicas ?? 1) : null;
    else if (doc.kind === "calibrate") n = null;
    else if (doc.kind === "sweep" && doc.design !== "grid") n = doc.n_points ?? null;
    else {
      n = 1;
      for (const spec of Object.values(doc.parameters)) {
        const k = spec.values ? spec.values.length
          : spec.step > 0 && spec.high > spec.low ? Math.floor((spec.high - spec.low) / spec.step + 1e-9) + 1 : NaN;
        n *= k;
      }
      if (!Object.keys(doc.parameters).length) n = null;
      if (n !== null) n *= doc.replicas ?? 1;
    }
    size.textContent = Number.isFinite(n) && n > 0 ? `${n} run${n === 1 ? "" : "s"}` : "";
  }
  form.addEventListener("change", syncKind);
  replicas.addEventListener("input", syncKind);
  form.addEventListener("input", updateSize);
  form.addEventListener("change", updateSize);
  syncKind();
  updateScene();
  updateSize();

  // ---------------------------------------------------------------- document
  function buildDocument() {
    const kind = kindValue();
    const doc = { name: name.value.trim(), kind, scene: scene.value, fixed: {}, parameters: {} };
    if (fidelity.value) doc.fixed.fidelity = fidelity.value;
    for (const r of fixed.rows) {
      const k = r.fname.value.trim();
      if (k) doc.fixed[k] = parseValue(r.fval.value);
    }
    for (const r of params.rows) {
      const k = r.pname.value.trim();
      if (!k) continue;
      const spec = {};
      if (r.mode.value === "values") {
        spec.values = r.values.value.split(",").map(parseValue).filter((v) => v !== undefined);
      } else {
        for (const [key, inp] of [["low", r.low], ["high", r.high], ["step", r.step]]) {
          if (inp.value !== "") spec[key] = Number(inp.value);
        }
        if (r.log.checked) spec.log = true;
      }
      doc.parameters[k] = spec;
    }
    const num = (inp) => (inp.value === "" ? undefined : Number(inp.value));
    if (kind === "sweep") {
      doc.design = design.value;
      if (design.value !== "grid" && num(nPoints) !== undefined) doc.n_points = num(nPoints);
    }
    if (num(replicas) !== undefined && num(replicas) !== 1) doc.replicas = num(replicas);
    if (["sweep", "optimize"].includes(kind) && confirmOn.checked) {
      doc.confirm = { top_k: num(cTopK), replicas: num(cReplicas) };
      if (cFidelity.value) doc.confirm.fidelity = cFidelity.value;
      if (cScene.value) doc.confirm.scene = cScene.value;
    }
    if (["optimize", "calibrate"].includes(kind) && screenOn.checked) doc.screen = { fidelity: "analytic", n_trials: num(sTrials), top_k: num(sTopK), margin: num(sMargin) };
    if (kind === "calibrate") {
      doc.sampler = sampler.value;
      if (num(nTrials) !== undefined) doc.n_trials = num(nTrials);
      if (num(parallelism) !== undefined) doc.parallelism = num(parallelism);
      if (num(seed) !== undefined) doc.seed = num(seed);
      doc.measurements_csv = csvText.value;
    }
    if (kind === "optimize") {
      doc.sampler = sampler.value;
      if (num(nTrials) !== undefined) doc.n_trials = num(nTrials);
      if (num(parallelism) !== undefined) doc.parallelism = num(parallelism);
      if (num(seed) !== undefined) doc.seed = num(seed);
      doc.constraints = constraints.rows.map((r) => ({ metric: r.metric.value, op: r.op.value, value: r.value.value === "" ? null : Number(r.value.value) }));
    }
    if (kind === "optimize" || (kind === "sweep" && sweepRanked() && objectives.rows.length)) doc.objectives = objectives.rows.map((r) => ({ metric: r.metric.value, direction: r.dir.value }));
    return doc;
  }

  // ---------------------------------------------------------------- errors
  function allTargets() {
    return [
      ...targets,
      ...params.rows.flatMap((r) => r.targets()),
      ...fixed.rows.flatMap((r) => r.targets()),
      ...objectives.rows.flatMap((r, i) => r.targets(i)),
      ...constraints.rows.flatMap((r, i) => r.targets(i)),
    ];
  }

  function clearErrors() {
    summary.hidden = true;
    summary.replaceChildren();
    for (const el of form.querySelectorAll(".field-error")) { el.hidden = true; el.textContent = ""; }
    for (const el of form.querySelectorAll("[aria-invalid]")) el.removeAttribute("aria-invalid");
    for (const el of form.querySelectorAll(".invalid")) el.classList.remove("invalid");
  }

  function problemsOf(err) {
    const d = err.detail;
    const list = Array.isArray(d) ? d : Array.isArray(d?.problems) ? d.problems : Array.isArray(d?.errors) ? d.errors : [d];
    return list.map((p) => {
      if (p && typeof p === "object") {
        let path = p.field ?? (Array.isArray(p.loc) ? p.loc.filter((x) => x !== "body").join(".") : "");
        let msg = p.msg || p.message || p.detail || JSON.stringify(p);
        msg = msg.replace(/^Value error, /, "");
        if (p.allowed !== undefined && !String(msg).includes(String(p.allowed))) msg += `; allowed: ${p.allowed}`;
        return { path: String(path || ""), msg };
      }
      return { path: "", msg: String(p ?? err.message) };
    });
  }

  function locate(path, targetsNow) {
    const candidates = [path, `fixed.${path}`, `parameters.${path}`];
    let best = null;
    for (const t of targetsNow) {
      for (const c of candidates) {
        if ((c === t.path || c.startsWith(t.path + ".")) && (!best || t.path.length > best.path.length)) best = t;
      }
    }
    return best;
  }

  function showErrors(problems) {
    const targetsNow = allTargets();
    const items = [];
    let first = null;
    for (const p of problems) {
      const t = p.path ? locate(p.path, targetsNow) : null;
      const label = p.path || "study";
      if (t) {
        const wrap = t.control.closest(".field") || t.control.parentElement;
        const msg = t.msg || wrap.querySelector(".field-error");
        if (msg) {
          msg.hidden = false;
          msg.textContent = msg.textContent ? `${msg.textContent} ${p.msg}` : p.msg;
          const ids = new Set((t.control.getAttribute("aria-describedby") || "").split(" ").filter(Boolean));
          if (!msg.id) msg.id = nextId("err");
          ids.add(msg.id);
          t.control.setAttribute("aria-describedby", [...ids].join(" "));
        }
        t.control.setAttribute("aria-invalid", "true");
        wrap.classList.add("invalid");
        first = first || t.control;
        const a = h("a", { href: "#", onclick: (e) => { e.preventDefault(); t.control.focus(); } }, `${label}: ${p.msg}`);
        items.push(h("li", {}, a));
      } else {
        items.push(h("li", {}, `${label}: ${p.msg}`));
      }
    }
    summary.replaceChildren(h("h2", {}, problems.length === 1 ? "The study has a problem" : `The study has ${problems.length} problems`), h("ul", {}, items));
    summary.hidden = false;
    (first || summary).focus();
  }

  form.addEventListener("submit", async (ev) => {
    ev.preventDefault();
    clearErrors();
    const doc = buildDocument();
    submit.disabled = true;
    busy.textContent = "Submitting…";
    try {
      const study = await endpoints.createStudy(doc);
      busy.textContent = "Created.";
      location.hash = `#/studies/${study.id}`;
    } catch (e) {
      busy.textContent = "";
      if (e instanceof ApiError && e.status === 422) showErrors(problemsOf(e));
      else if (e instanceof ApiError && e.status === 401) {
        const box = tokenBox((t) => { setToken(t); box.remove(); form.requestSubmit(); });
        summary.replaceChildren(h("h2", {}, "A token is needed"), box);
        summary.hidden = false;
        box.focusInput();
      } else showErrors([{ path: "", msg: e.message }]);
    } finally {
      submit.disabled = false;
    }
  });
  name.focus();
  return null;
}
