"""Calibration against measured forces (``kind: calibrate``).

A lab's measured points (each: the scene fields that differ from the study's scene, the measured
cutting and/or thrust force and their standard uncertainties) are matched by the model: every
trial of the optuna search sets the fitted fields (the study's ``parameters``), runs every
measured point (with ``replicas``: the mean over the replicas, whose standard error adds to the
measurement's), and is valued by the uncertainty-weighted misfit

    misfit = sqrt( sum_i r_i^2 / N ),  r_i = (model_i - measured_i) / sqrt(sd_i^2 + sem_i^2)

over the N measured force values: a weighted RMS in standard deviations (about 1 when the model
fits within the measurements' uncertainty). The result (:func:`result`):

- ``values``: the fitted fields of the best trial (dotted names);
- ``uncertainty``: per field ``sd`` from the curvature of chi^2 = N misfit^2 near its minimum (a
  quadratic fit over the evaluated trials nearest the minimum: chi^2 ~ c + (x - x0)' A (x - x0),
  covariance s A^-1 with s = max(1, chi^2_min / (N - p)), which widens it when the model does not
  fit within the measurements' uncertainty), and ``low``/``high``: the range of the evaluated
  trials within chi^2_min + s (the profile-likelihood interval at the resolution of the trials
  evaluated; ``sd`` falls back to half its width where the quadratic fit is not a minimum);
- ``misfit``, ``chi2``, ``dof``;
- ``per_point``: each measured value with the model's value, the residual in N/mm and in
  standard deviations;
- ``loo_error``: leave-one-out over the evaluated trials: for each measured point the trial that
  fits all other points best predicts it; the RMS of those prediction errors (in standard
  deviations, and in N/mm) says how well the fit predicts a point it was not fitted to;
- ``preset``: a scene document (``base:`` the study's scene plus the fitted and fixed fields) that
  ``fibrecut run`` takes as a file, and ``GET /api/studies/{id}/calibrated-scene.yaml`` serves.

The project's own comparison with the seed paper (docs/validation.md) is uncalibrated; this is a
user's tool.
"""

from __future__ import annotations

import csv
import io
import math
from typing import Any

from .replicas import finite

FORCES = ("cutting_force", "thrust_force")
VALUE_COLUMNS = ("cutting_force_N_per_mm", "thrust_force_N_per_mm", "sd_N_per_mm", "cutting_force_sd_N_per_mm",
                 "thrust_force_sd_N_per_mm")
MAX_ROWS = 500


# ------------------------------------------------------------------ measurements as CSV
def parse_csv(text: str, where: tuple[str, ...] = ("measurements_csv",)) -> list[dict[str, Any]]:
    """Measured points from CSV text: a header row of column names (dotted scene fields, the force
    and uncertainty columns, optional ``label``), then one row per point. Rows are numbered as in a
    spreadsheet (the header is row 1). Raises :class:`solver.scene.SceneError` naming the row
    and the column of every problem."""
    from solver.scene import Problem, SceneError, _field_info

    problems: list[Problem] = []
    if not text or not text.strip():
        raise SceneError([Problem(where, "", "the CSV is empty; give a header row and one row per measured point")])
    if text.startswith("\ufeff"):
        text = text[1:]
    first = text.lstrip("\r\n").splitlines()[0] if text.strip() else ""
    delimiter = max((",", ";", "\t"), key=first.count) if first else ","
    try:
        rows = list(csv.reader(io.StringIO(text), delimiter=delimiter))
    except csv.Error as exc:
        raise SceneError([Problem(where, "...", f"not a readable CSV: {exc}")]) from None
    rows = [r for r in rows if any(c.strip() for c in r)]
    if not rows:
        raise SceneError([Problem(where, "", "the CSV is empty; give a header row and one row per measured point")])
    header = [c.strip() for c in rows[0]]
    for col in header:
        if not col:
            problems.append(Problem(where + ("row 1",), header, "a column without a name"))
        elif col not in VALUE_COLUMNS and col != "label" and _field_info(col.split(".")) is None:
            problems.append(Problem(where + ("row 1", col), col, "unknown column; allowed: a dotted scene field (e.g. tool.rake_angle_deg), "
                                                                 + ", ".join(VALUE_COLUMNS) + ", label"))
    if len(set(header)) != len(header):
        dup = sorted({c for c in header if header.count(c) > 1})
        problems.append(Problem(where + ("row 1",), dup, "a column appears twice"))
    if not any(c in header for c in ("cutting_force_N_per_mm", "thrust_force_N_per_mm")):
        problems.append(Problem(where + ("row 1",), header, "give a cutting_force_N_per_mm and/or thrust_force_N_per_mm column"))
    if len(rows) < 2:
        problems.append(Problem(where, len(rows) - 1, "no measured points below the header"))
    if len(rows) - 1 > MAX_ROWS:
        problems.append(Problem(where, len(rows) - 1, f"at most {MAX_ROWS} measured points"))
    if problems:
        raise SceneError(problems)
    out = []
    for n, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            problems.append(Problem(where + (f"row {n}",), delimiter.join(row), f"{len(row)} cells; the header has {len(header)} columns"))
            continue
        point: dict[str, Any] = {"set": {}}
        for col, cell in zip(header, row):
            cell = cell.strip()
            if col == "label":
                if cell:
                    point["label"] = cell
                continue
            if cell == "":
                if col in VALUE_COLUMNS:
                    continue  # a point may measure only one of the forces
                problems.append(Problem(where + (f"row {n}", col), cell, "empty; give a number"))
                continue
            try:
                value = float(cell)
            except ValueError:
                problems.append(Problem(where + (f"row {n}", col), cell, "not a number"))
                continue
            if not math.isfinite(value):
                problems.append(Problem(where + (f"row {n}", col), cell, "not a finite number"))
                continue
            if col in VALUE_COLUMNS:
                if "sd" in col and value <= 0:
                    problems.append(Problem(where + (f"row {n}", col), cell, "an uncertainty must be > 0"))
                    continue
                point[col] = value
            else:
                point["set"][col] = value
        out.append((n, point))
    if problems:
        raise SceneError(problems)
    from pydantic import ValidationError

    from .documents import Measurement

    result = []
    for n, point in out:
        try:
            result.append(Measurement.model_validate(point).model_dump(exclude_none=True))
        except ValidationError as exc:
            for e in exc.errors():
                col = ".".join(str(x) for x in e["loc"]) or next((c for c in ("sd_N_per_mm",) if c in header), "sd_N_per_mm")
                problems.append(Problem(where + (f"row {n}", col), point.get(col, None), e["msg"].removeprefix("Value error, ")))
    if problems:
        raise SceneError(problems)
    return result


# ------------------------------------------------------------------ validation
def validate(doc, base_fixed: dict, limits) -> None:
    """Measurements present (the CSV parsed into ``doc.measurements``), their fields known, their
    scenes valid, no fitted field also set by a measurement."""
    from solver.scene import Problem, SceneError, _field_info, scene_from_dict

    from .documents import Measurement

    if doc.measurements_csv is not None:
        if doc.measurements:
            raise SceneError([Problem(("measurements_csv",), "...", "give measurements or measurements_csv, not both")])
        doc.measurements = [Measurement.model_validate(m) for m in parse_csv(doc.measurements_csv)]
        doc.measurements_csv = None
    problems: list[Problem] = []
    if not doc.measurements:
        raise SceneError([Problem(("measurements",), [], "a calibrate study needs measured points: measurements: [{set: {...}, "
                                                         "cutting_force_N_per_mm: ..., thrust_force_N_per_mm: ..., sd_N_per_mm: ...}] or measurements_csv")])
    for i, m in enumerate(doc.measurements):
        for name, v in m.set.items():
            loc = ("measurements", str(i), "set", name)
            if _field_info(name.split(".")) is None:
                problems.append(Problem(loc, v, "unknown scene field (use dotted names such as tool.rake_angle_deg)"))
            elif name in doc.parameters:
                problems.append(Problem(loc, v, "is a fitted parameter; a measurement sets only the conditions it was measured at"))
        if problems:
            continue
        try:
            scene_from_dict(base_fixed, dict(m.set))
        except SceneError as exc:
            for p in exc.problems:
                problems.append(Problem(("measurements", str(i), "set", p.field), p.value, p.message))
    if problems:
        raise SceneError(problems)


# ------------------------------------------------------------------ misfit of one trial
def targets(doc) -> list[tuple[int, str, float, float]]:
    """(point index, force, measured value, sd) of every measured force value."""
    out = []
    for i, m in enumerate(doc.measurements):
        for force in FORCES:
            v = getattr(m, f"{force}_N_per_mm")
            if v is not None:
                out.append((i, force, float(v), float(m.sd(force))))
    return out


def residuals(doc, predictions: dict[int, dict[str, Any]]) -> list[dict[str, Any]] | None:
    """Residual of every measured value given the trial's predictions per point ({point index:
    aggregate with ``mean``/``sem`` dicts}); None when a point has no finished replica."""
    out = []
    for i, force, measured, sd in targets(doc):
        agg = predictions.get(i)
        metric = f"{force}_N_per_mm"
        mean = (agg or {}).get("mean", {}).get(metric)
        if not finite(mean):
            return None
        sem = (agg.get("sem") or {}).get(metric)
        sigma = math.sqrt(sd**2 + (sem if finite(sem) else 0.0) ** 2)
        out.append({"point": i, "label": doc.measurements[i].label, "set": doc.measurements[i].set, "force": metric,
                    "measured": measured, "sd": sd, "model": mean, "model_sem": sem, "n": agg["n"].get(metric),
                    "residual": mean - measured, "z": (mean - measured) / sigma})
    return out


def misfit(res: list[dict]) -> float:
    return math.sqrt(sum(r["z"] ** 2 for r in res) / len(res))


# ------------------------------------------------------------------ the study's result
def result(doc, trials: list[dict], scene_name: str | None) -> dict[str, Any] | None:
    """The calibration from its evaluated trials (dicts with ``params``, ``residuals``,
    ``trial_number``), or None before the first trial is in."""
    done = [t for t in trials if t.get("residuals")]
    if not done:
        return None
    n_values = len(done[0]["residuals"])
    p = len(doc.parameters)
    for t in done:
        t["chi2"] = sum(r["z"] ** 2 for r in t["residuals"])
    best = min(done, key=lambda t: t["chi2"])
    chi2_min = best["chi2"]
    dof = n_values - p
    scale = max(1.0, chi2_min / dof) if dof > 0 else 1.0
    near = [t for t in done if t["chi2"] <= chi2_min + scale]
    curvature = _curvature_sd(doc, done, best, scale)
    uncertainty = {}
    for name, spec in doc.parameters.items():
        vals = [t["params"].get(name) for t in near if finite(t["params"].get(name))]
        if spec.values is None and vals:
            lo, hi = min(vals), max(vals)
            u = {"low": lo, "high": hi, "trials_within": len(vals), "at_bound": bool(lo <= spec.low or hi >= spec.high)}
            if curvature and finite(curvature.get(name)):
                u.update(sd=curvature[name], method="curvature of chi^2 over the trials near the minimum")
            else:
                u.update(sd=(hi - lo) / 2, method="half the range of the trials within chi^2_min + s")
            uncertainty[name] = u
    # leave-one-out over the evaluated trials: the trial that fits every other point best
    loo = []
    for k in range(n_values):
        pick = min(done, key=lambda t: t["chi2"] - t["residuals"][k]["z"] ** 2)
        r = pick["residuals"][k]
        loo.append({"point": r["point"], "force": r["force"], "trial_number": pick.get("trial_number"),
                    "prediction": r["model"], "measured": r["measured"], "error": r["residual"], "z": r["z"]})
    loo_error = {"rms_sd": math.sqrt(sum(x["z"] ** 2 for x in loo) / len(loo)),
                 "rms_N_per_mm": math.sqrt(sum(x["error"] ** 2 for x in loo) / len(loo)), "per_point": loo}
    values = {k: best["params"][k] for k in doc.parameters}
    return {
        "values": values, "uncertainty": uncertainty, "misfit": math.sqrt(chi2_min / n_values), "chi2": chi2_min, "dof": dof,
        "n_values": n_values, "n_points": len(doc.measurements), "trials_evaluated": len(done),
        "trial_number": best.get("trial_number"), "per_point": best["residuals"], "loo_error": loo_error,
        "preset": preset(doc, values, scene_name),
    }


def _curvature_sd(doc, done: list[dict], best: dict, scale: float) -> dict[str, float] | None:
    """Standard deviations of the fitted (continuous) fields from a quadratic fit of chi^2 over the
    trials nearest the minimum: chi^2 ~ c + (x - x0)' A (x - x0), covariance = s A^-1 (s the
    reduced-chi^2 scale). None when too few trials or the fit is not a minimum."""
    import numpy as np

    names = [n for n, spec in doc.parameters.items() if spec.values is None]
    if not names:
        return None
    p = len(names)
    n_coef = 1 + p + p * (p + 1) // 2
    spans = {n: (doc.parameters[n].high - doc.parameters[n].low) for n in names}
    x0 = {n: float(best["params"][n]) for n in names}

    def coords(t):
        return [(float(t["params"][n]) - x0[n]) / spans[n] for n in names]

    usable = [t for t in done if all(finite(t["params"].get(n)) for n in names)]
    usable.sort(key=lambda t: t["chi2"])
    m = max(3 * n_coef, 12)
    if len(usable) < n_coef + 2:
        return None
    near = usable[:m]
    rows, ys = [], []
    for t in near:
        x = coords(t)
        quad = [x[i] * x[j] for i in range(p) for j in range(i, p)]
        rows.append([1.0, *x, *quad])
        ys.append(t["chi2"])
    coef, *_ = np.linalg.lstsq(np.asarray(rows), np.asarray(ys), rcond=None)
    A = np.zeros((p, p))
    k = 1 + p
    for i in range(p):
        for j in range(i, p):
            if i == j:
                A[i, i] = coef[k]
            else:
                A[i, j] = A[j, i] = coef[k] / 2
            k += 1
    try:
        if np.any(np.linalg.eigvalsh(A) <= 0):
            return None
        cov = scale * np.linalg.inv(A)
    except np.linalg.LinAlgError:
        return None
    return {n: float(np.sqrt(cov[i, i]) * spans[n]) for i, n in enumerate(names)}


def preset(doc, values: dict, scene_name: str | None) -> dict[str, Any]:
    """A scene document with the fitted values: ``base`` the study's built-in scene (or the inline
    scene in full), then the fixed and fitted fields, nested as a scene file is."""
    out: dict[str, Any] = {}
    if isinstance(doc.scene, str):
        out["base"] = doc.scene
    else:
        out.update(_nest({}, dict(doc.scene)))
    for name, v in {**doc.fixed, **values}.items():
        node = out
        parts = name.split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
        node[parts[-1]] = v
    out["name"] = f"{scene_name or 'scene'}-calibrated"
    return out


def _nest(dst: dict, src: dict) -> dict:
    for k, v in src.items():
        dst[k] = _nest({}, v) if isinstance(v, dict) else v
    return dst
