"""The estimated discretisation error of a run, from a convergence study of its scene.

A convergence study varies only numerical fields (element size, mass scaling, speed scaling) of
one scene; every finished level carries its relative error against the finest finished level
(:func:`service.report.trials`). A run whose scene equals the study's scene in everything but
the varied fields gets, for its resolution:

- the error of the study's level with the same values (``basis = "level"``), or
- when the study varies one field and the run's value lies between levels, the error of the
  nearest coarser level (``basis = "nearest coarser level"``: an upper bound if the sequence
  converges monotonically).

The newest matching study wins. No match: ``None`` (the API then omits the estimate). A study
with replicas gives the error of the level's mean with its standard error (``uncertainty``); its
replica runs other than the first have a perturbed speed scaling and match no level themselves.
"""

from __future__ import annotations

import copy
from typing import Any

import sqlalchemy as sa

from store.models import Job, Run, Study


def _strip(scene: dict, fields: list[str]) -> dict:
    """The scene without the dotted fields (and without its free-text name)."""
    out = copy.deepcopy(scene)
    out.pop("name", None)
    for dotted in fields:
        node = out
        parts = dotted.split(".")
        for p in parts[:-1]:
            node = node.get(p, {}) if isinstance(node, dict) else {}
        if isinstance(node, dict):
            node.pop(parts[-1], None)
    return out


def _value(scene: dict, dotted: str):
    node: Any = scene
    for p in dotted.split("."):
        node = node.get(p) if isinstance(node, dict) else None
    return node


def estimate(s, run: Run) -> dict[str, Any] | None:
    """The estimated discretisation error of ``run`` (session ``s``), or None."""
    from . import report

    scene = s.execute(sa.select(Job.scene).where(Job.scene_hash == run.scene_hash).limit(1)).scalar()
    if not scene:
        return None
    studies = s.execute(sa.select(Study).where(Study.kind == "convergence").order_by(Study.id.desc())).scalars().all()
    for study in studies:
        varied = list((study.document or {}).get("parameters", {}))
        if not varied:
            continue
        key = _strip(scene, varied)
        jobs = s.execute(sa.select(Job).where(Job.study_id == study.id).order_by(Job.index)).scalars().all()
        if not jobs or _strip(jobs[0].scene, varied) != key:
            continue
        scenes = {j.id: j.scene for j in jobs}
        levels = [t for t in report.trials(s, study) if t.get("error_vs_finest") is not None]
        if not levels:
            continue
        mine = {f: _value(scene, f) for f in varied}
        match = [t for t in levels if all(_value(scenes[t["job_id"]], f) == mine[f] for f in varied)]
        basis = "level"
        if not match and len(varied) == 1 and isinstance(mine[varied[0]], (int, float)):
            f = varied[0]
            vals = [(t, _value(scenes[t["job_id"]], f)) for t in levels]
            vals = [(t, v) for t, v in vals if isinstance(v, (int, float))]
            coarser = [t for t, v in vals if v > mine[f]]
            finer_exists = any(v < mine[f] for _, v in vals)
            if coarser and finer_exists:
                match = [min(coarser, key=lambda t: _value(scenes[t["job_id"]], f))]
                basis = "nearest coarser level"
        if not match:
            continue
        t = match[0]
        out = {"study_id": study.id, "basis": basis, "level": {f: _value(scenes[t["job_id"]], f) for f in varied},
               "reference_job_id": t.get("reference_job_id"), "relative_error_vs_finest": t["error_vs_finest"]}
        if t.get("level"):  # a study with replicas: errors of the level means, with their standard errors
            out["replicas"] = t["level"]["replicas_ok"]
            out["uncertainty"] = t.get("error_uncertainty") or {}
        return out
    return None
