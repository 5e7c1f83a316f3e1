"""The study driver: moves optimisations, calibrations and staged sweeps forward.

One pass (:func:`drive_study`, under the study's driver lease taken by
:func:`store.studies.drive`) does, in order:

1. **tell**: every trial whose jobs (its replicas; a calibration trial: every measured point times
   its replicas) have all ended is told to optuna once: the mean over the replicas that ended ok
   (failed replicas are counted in the trial's ``replicas_ok``, not averaged), or a failure when
   none did. The trial carries its replica statistics as optuna user attributes (``replicas``,
   ``replicas_ok``, ``mean``, ``sd``, ``sem``, ``n`` per metric, ``job_ids``, ``run_ids``).
2. **screen** (``screen:``): ask for screening trials on the screening fidelity (one run each,
   optuna study ``fibrecut-<id>-screen``) until ``screen.n_trials`` are asked and told;
3. **search**: ask for the study's trials (``replicas`` jobs each, and with a screening one
   ``check`` run at the screening fidelity, so both fidelities share the refined points) inside
   the screening's box, the screening's best points first; at most ``parallelism`` trials in flight;
4. **confirm** (``confirm:``): when every trial is told, the ``top_k`` trials with the best means
   (feasible ones) run again, ``confirm.replicas`` times each on the confirmation's scene, with
   fresh replicas (numbered after the search's, so none repeats a search run's scene);
5. **end**: every job ended and every trial told: the study is ``done`` (``failed`` when no job
   ended ok).

A sweep with ``confirm`` has all its points from the start; the driver adds the confirmation
when the last point ended and ends the study after it.
"""

from __future__ import annotations

import time
from typing import Any

import sqlalchemy as sa

from . import replicas as rp
from .models import TERMINAL_JOB_STATES, Job, Run, Study
from .documents import StudyIn

FORCE_METRICS = ("cutting_force_N_per_mm", "thrust_force_N_per_mm")


def optuna_study_name(study_id: int, stage: str) -> str:
    from .studies import optuna_name

    return optuna_name(study_id) + ("-screen" if stage == "screen" else "")


def metric_names(doc: StudyIn) -> list[str]:
    return ["misfit_sd"] if doc.kind == "calibrate" else [o.metric for o in doc.objectives]


def directions(doc: StudyIn) -> list[str]:
    return ["minimize"] if doc.kind == "calibrate" else [o.direction for o in doc.objectives]


def create_optuna_study(db, study_id: int, doc: StudyIn, stage: str = "search"):
    import optuna

    from .studies import optuna_storage

    import warnings

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    warnings.filterwarnings("ignore", category=optuna.exceptions.ExperimentalWarning)
    study = optuna.create_study(storage=optuna_storage(db), study_name=optuna_study_name(study_id, stage),
                                directions=directions(doc), load_if_exists=True)
    study.set_metric_names(metric_names(doc))
    for k, v in (("fibrecut_study_id", study_id), ("stage", stage), ("replicas", doc.replicas if stage == "search" else 1)):
        study.set_user_attr(k, v)
    return study


# ------------------------------------------------------------------ reading the study
def load_jobs(s, study_id: int) -> list[dict[str, Any]]:
    rows = s.execute(sa.select(Job.id, Job.index, Job.trial_number, Job.params, Job.status, Job.told, Job.run_id, Job.error)
                     .where(Job.study_id == study_id).order_by(Job.index)).all()
    run_ids = [r.run_id for r in rows if r.run_id]
    runs = {}
    for i in range(0, len(run_ids), 900):
        runs.update({r.id: r for r in s.execute(sa.select(Run.id, Run.status, Run.summary, Run.wall_time_s)
                                                 .where(Run.id.in_(run_ids[i:i + 900]))).all()})
    out = []
    for r in rows:
        run = runs.get(r.run_id)
        out.append({"id": r.id, "index": r.index, "trial_number": r.trial_number, "params": r.params or {}, "status": r.status,
                    "told": r.told, "run_id": r.run_id, "error": r.error, "run_status": run.status if run else None,
                    "metrics": {k: v for k, v in (run.summary or {}).items() if rp.finite(v)} if run else None,
                    "wall_time_s": run.wall_time_s if run else None})
    return out


def groups_of(jobs: list[dict]) -> dict[tuple, list[dict]]:
    out: dict[tuple, list[dict]] = {}
    for j in jobs:
        out.setdefault(rp.group_key(j["params"], j["trial_number"]), []).append(j)
    return out


def is_open(gj: list[dict]) -> bool:
    return any(j["status"] not in TERMINAL_JOB_STATES for j in gj)


# ------------------------------------------------------------------ the value of one trial
def evaluate(doc: StudyIn, gj: list[dict]) -> tuple[list[float] | None, list[float], dict[str, Any], str | None]:
    """(objective values or None, constraint values, user attributes, failure reason) of a trial."""
    from .studies import constraint_values

    attrs: dict[str, Any] = {"job_ids": [j["id"] for j in gj], "run_ids": [j["run_id"] for j in gj if j["run_id"]]}
    first_error = next((j["error"] for j in gj if j["status"] != "done" and j["error"]), None)
    if doc.kind == "calibrate":
        from . import calibration

        by_point: dict[int, list[dict]] = {}
        for j in gj:
            by_point.setdefault(int(j["params"].get("point", 0)), []).append(j)
        preds = {i: rp.aggregate(js, FORCE_METRICS) for i, js in by_point.items()}
        attrs["replicas"] = doc.replicas if rp.stage_of(gj[0]["params"]) == "search" else 1
        attrs["replicas_ok"] = {str(i): a["replicas_ok"] for i, a in preds.items()}
        res = calibration.residuals(doc, preds)
        if res is None:
            missing = sorted(i for i, a in preds.items() if not a["replicas_ok"])
            return None, [], attrs, f"measured point(s) {missing} have no replica that ended ok" + (f": {first_error}" if first_error else "")
        value = calibration.misfit(res)
        attrs.update({"misfit_sd": value, "z": [round(r["z"], 6) for r in res],
                      "model": {f"{r['point']}:{r['force']}": r["model"] for r in res}})
        return [value], [], attrs, None
    metrics = [o.metric for o in doc.objectives] + [c.metric for c in doc.constraints if c.metric not in {o.metric for o in doc.objectives}]
    agg = rp.aggregate(gj, metrics)
    attrs.update({k: agg[k] for k in ("replicas", "replicas_ok", "mean", "sd", "sem", "n")})
    if not agg["replicas_ok"]:
        return None, [], attrs, first_error or "no replica ended ok"
    values = [agg["mean"].get(o.metric) for o in doc.objectives]
    if not all(rp.finite(v) for v in values):
        return None, [], attrs, "an objective metric is missing"
    cv = constraint_values(doc, agg["mean"]) if doc.constraints else []
    if cv is None:
        return None, [], attrs, "a constraint metric is missing"
    return [float(v) for v in values], cv, attrs, None


def trial_items(doc: StudyIn, groups: dict[tuple, list[dict]], stage: str) -> list[dict[str, Any]]:
    """The finished trials of a stage as ranking items: key, params, mean/sem, feasible."""
    metrics = [o.metric for o in doc.objectives] + [c.metric for c in doc.constraints]
    out = []
    for key, gj in groups.items():
        if key[0] != stage or is_open(gj):
            continue
        agg = rp.aggregate(gj, metrics)
        feasible = True
        for c in doc.constraints:
            v = agg["mean"].get(c.metric)
            if not rp.finite(v) or (c.op == "<=" and v > c.value) or (c.op == ">=" and v < c.value):
                feasible = False
        out.append({"key": key, "trial_number": gj[0]["trial_number"], "params": rp.params_of(gj[0]["params"]),
                    "mean": agg["mean"], "sem": agg["sem"], "n": agg["n"], "feasible": feasible})
    return out


# ------------------------------------------------------------------ the jobs of one trial
def trial_jobs(doc: StudyIn, stage: str, params: dict, base: dict) -> list[tuple[dict, dict]]:
    """(job params, scene overrides) of one trial of ``stage``: replicas (the study's for search,
    the confirmation's for confirm, one for screen and check), times the measured points of a
    calibration."""
    from solver.convergence import replica_speed_scalings

    n_rep = {"search": doc.replicas, "confirm": doc.confirm.replicas if doc.confirm else 1}.get(stage, 1)
    # a confirmation draws fresh replicas (numbered after the search's): the samples that made a
    # trial look best must not vote again for it
    offset = doc.replicas if stage == "confirm" else 0
    perturb = n_rep > 1 or offset > 0
    points = list(enumerate(doc.measurements)) if doc.kind == "calibrate" else [(None, None)]
    out = []
    for i, m in points:
        over = {**(m.set if m is not None else {}), **params}
        ss = float(over.get("numerics.speed_scaling", base["numerics"]["speed_scaling"]))
        for k, ssk in list(enumerate(replica_speed_scalings(ss, offset + n_rep)))[offset:]:
            jp = dict(params)
            if stage != "search":
                jp["stage"] = stage
            if i is not None:
                jp["point"] = i
            if perturb:
                jp["replica"] = k
            out.append((jp, {**over, "numerics.speed_scaling": ssk} if perturb else over))
    return out


class _Inserter:
    def __init__(self, db, study_id: int, doc: StudyIn, jobs: list[dict]):
        self.db, self.study_id, self.doc = db, study_id, doc
        self.next_index = max((j["index"] for j in jobs), default=-1) + 1
        self.bases: dict[str, dict] = {}

    def base(self, stage: str) -> dict:
        from .studies import stage_scene

        if stage not in self.bases:
            self.bases[stage] = stage_scene(self.doc, stage)
        return self.bases[stage]

    def add(self, stage: str, params: dict, trial_number: int | None, told: bool) -> str | None:
        """Insert the jobs of one trial; answers the reason when the parameters make no valid scene
        (then one failed job records it)."""
        from solver.budget import check as budget_check
        from solver.scene import Problem, SceneError, scene_from_dict

        from .studies import scene_hash

        base = self.base(stage)
        t = time.time()
        try:
            specs = [(jp, scene_from_dict(base, ov)) for jp, ov in trial_jobs(self.doc, stage, params, base)]
            for _, scene in specs[:1]:  # the replicas share their size: a trial too large for the server fails
                too_large = budget_check(scene)
                if too_large:
                    raise SceneError([Problem(f, v, m) for f, v, m in too_large])
        except SceneError as exc:
            with self.db.write() as s:
                s.add(Job(study_id=self.study_id, index=self.next_index, trial_number=trial_number,
                          params={**params, **({"stage": stage} if stage != "search" else {})}, scene=base, scene_hash="-",
                          status="failed", attempts=0, max_attempts=self.doc.max_attempts, cancel_requested=False, progress=0.0,
                          cached=False, told=True, created_at=t, finished_at=t, error=f"invalid scene: {exc}"))
            self.next_index += 1
            return str(exc)
        with self.db.write() as s:
            for jp, scene in specs:
                s.add(Job(study_id=self.study_id, index=self.next_index, trial_number=trial_number, params=jp,
                          scene=scene.model_dump(mode="json"), scene_hash=scene_hash(scene), status="queued", attempts=0,
                          max_attempts=self.doc.max_attempts, cancel_requested=False, progress=0.0, cached=False, told=told,
                          created_at=t))
                self.next_index += 1
        return None


# ------------------------------------------------------------------ one pass
def drive_study(db, study_id: int) -> None:
    with db.read() as s:
        st = s.get(Study, study_id)
        doc = StudyIn.model_validate(st.document)
        status, kind = st.status, st.kind
        jobs = load_jobs(s, study_id)
    if kind == "sweep":
        _drive_sweep(db, study_id, doc, status, jobs)
    else:
        _drive_search(db, study_id, doc, status, jobs)


def _drive_sweep(db, study_id: int, doc: StudyIn, status: str, jobs: list[dict]) -> None:
    groups = groups_of(jobs)
    if any(is_open(gj) for key, gj in groups.items() if key[0] == "search"):
        return
    if status != "cancelled" and doc.confirm is not None and not any(key[0] == "confirm" for key in groups):
        _start_confirmation(db, study_id, doc, jobs, groups)
        return
    _finish(db, study_id)


def _start_confirmation(db, study_id: int, doc: StudyIn, jobs: list[dict], groups) -> None:
    o = doc.objectives[0]
    items = trial_items(doc, groups, "search")
    rp.rank_one_objective(items, o.metric, o.direction)
    ranked = sorted((it for it in items if it["rank"] is not None), key=lambda it: it["rank"])[: doc.confirm.top_k]
    ins = _Inserter(db, study_id, doc, jobs)
    for it in ranked:
        ins.add("confirm", it["params"], it["trial_number"], told=True)
    if not ranked:
        _finish(db, study_id)


def _drive_search(db, study_id: int, doc: StudyIn, status: str, jobs: list[dict]) -> None:
    import optuna
    from optuna.trial import TrialState

    from .studies import distributions, make_sampler, optuna_storage

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    storage = optuna_storage(db)
    groups = groups_of(jobs)
    stages = (["screen"] if doc.screen else []) + ["search"]
    ostudies = {}
    # 1. tell optuna every trial whose jobs have all ended
    for stage in stages:
        if stage == "screen":
            create_optuna_study(db, study_id, doc, "screen")
        study = optuna.load_study(study_name=optuna_study_name(study_id, stage), storage=storage,
                                  sampler=make_sampler(doc, len(jobs)))
        ostudies[stage] = study
        trials = {t.number: t for t in study.get_trials(deepcopy=False)}
        told_ids = []
        for key, gj in groups.items():
            if key[0] != stage or key[1] != "trial" or all(j["told"] for j in gj) or is_open(gj):
                continue
            ft = trials.get(key[2])
            if ft is not None and ft.state == TrialState.RUNNING:
                values, cv, attrs, reason = evaluate(doc, gj)
                for k, v in attrs.items():
                    storage.set_trial_user_attr(ft._trial_id, k, v)
                if values is not None:
                    if cv:
                        trial = optuna.trial.Trial(study, ft._trial_id)
                        for i, (c, v) in enumerate(zip(doc.constraints, cv)):
                            trial.set_constraint(f"c{i}_{c.metric}", v)  # optuna: <= 0 is feasible
                    study.tell(key[2], values)
                else:
                    storage.set_trial_user_attr(ft._trial_id, "fail_reason", str(reason)[:1000])
                    study.tell(key[2], state=TrialState.FAIL)
            told_ids += [j["id"] for j in gj if not j["told"]]
            for j in gj:
                j["told"] = True
        if told_ids:
            with db.write() as s:
                s.execute(sa.update(Job).where(Job.id.in_(told_ids)).values(told=True))
        # trials asked but never turned into jobs (a crash between ask and insert): fail them
        with_job = {key[2] for key in groups if key[0] == stage and key[1] == "trial"}
        for number, ft in trials.items():
            if ft.state == TrialState.RUNNING and number not in with_job:
                study.tell(number, state=TrialState.FAIL)
    if status == "cancelled":
        return

    ins = _Inserter(db, study_id, doc, jobs)

    def asked(stage):
        return [key for key in groups if key[0] == stage and key[1] == "trial"]

    def in_flight(stage):
        return sum(1 for key, gj in groups.items() if key[0] == stage and is_open(gj))

    # 2. screening on the cheap fidelity over the whole ranges
    if doc.screen:
        n, flying = len(asked("screen")), in_flight("screen")
        if n < doc.screen.n_trials or flying:
            dists = distributions(doc)
            while n < doc.screen.n_trials and flying < doc.screen.parallelism:
                trial = ostudies["screen"].ask(dists)
                reason = ins.add("screen", dict(trial.params), trial.number, told=False)
                if reason:
                    storage.set_trial_user_attr(trial._trial_id, "fail_reason", reason[:1000])
                    ostudies["screen"].tell(trial.number, state=TrialState.FAIL)
                else:
                    flying += 1
                n += 1
            return

    # 3. the study's own search (inside the screening's box)
    n, flying = len(asked("search")), in_flight("search")
    if n < doc.n_trials:
        params = doc.parameters
        if doc.screen:
            box, top = screening_box(doc, ostudies["screen"])
            params = box
            if n == 0:
                for p in top[: max(1, min(doc.screen.top_k, doc.n_trials // 4))]:
                    ostudies["search"].enqueue_trial(p, skip_if_exists=True)
        dists = distributions(doc, params)
        while n < doc.n_trials and flying < doc.parallelism:
            trial = ostudies["search"].ask(dists)
            p = dict(trial.params)
            reason = ins.add("search", p, trial.number, told=False)
            if reason:
                storage.set_trial_user_attr(trial._trial_id, "fail_reason", reason[:1000])
                ostudies["search"].tell(trial.number, state=TrialState.FAIL)
            else:
                flying += 1
                if doc.screen:
                    ins.add("check", p, trial.number, told=True)
            n += 1
        return
    if flying or any(is_open(gj) for key, gj in groups.items() if key[0] == "check"):
        return

    # 4. confirmation of the best trials
    if doc.confirm is not None and not any(key[0] == "confirm" for key in groups):
        _start_confirmation(db, study_id, doc, jobs, groups)
        return
    _finish(db, study_id)


def screening_box(doc: StudyIn, screen_study) -> tuple[dict, list[dict]]:
    """The refinement box and the screening's top trials' params (best first)."""
    from optuna.trial import TrialState

    from . import screening
    from .studies import _is_int_field

    rows = []
    for t in screen_study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,)):
        cons = t.system_attrs.get("constraints")
        feasible = cons is None or all(c <= 0 for c in cons)
        rows.append((dict(t.params), list(t.values), feasible))
    top = screening.top_trials(rows, directions(doc), doc.screen.top_k)
    ints = {n for n in doc.parameters if _is_int_field(n)}
    return screening.box(doc.parameters, top, doc.screen.margin, ints), top


def _finish(db, study_id: int) -> None:
    """End the study when every job has ended and every trial was told."""
    with db.write() as s:
        s.execute(sa.select(Study.id).where(Study.id == study_id).with_for_update())
        open_jobs = s.execute(sa.select(sa.func.count()).select_from(Job).where(
            Job.study_id == study_id, (Job.status.not_in(TERMINAL_JOB_STATES)) | (~Job.told & Job.trial_number.is_not(None)))).scalar()
        n_done = s.execute(sa.select(sa.func.count()).select_from(Job).where(Job.study_id == study_id, Job.status == "done")).scalar()
        st = s.get(Study, study_id)
        if open_jobs == 0 and st.status not in ("cancelled", "done", "failed"):
            t = time.time()
            st.status = "done" if n_done else "failed"
            st.error = None if n_done else "no trial finished successfully"
            st.finished_at = t
            st.updated_at = t

