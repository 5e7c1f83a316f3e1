"""Helpers for fibrecut's own tests and its service benchmark (scripts/service_bench.py): worker
subprocesses, waiting, study documents, working a study to its end in this process."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def worker_cmd(db_url: str, data_dir: Path, lease_s: float = 30.0, exit_when_idle: bool = False,
               max_jobs: int | None = None, isolation: str = "auto") -> list[str]:
    cmd = [sys.executable, "-m", "worker", "--db", db_url, "--data", str(data_dir), "--lease", str(lease_s),
           "--isolation", isolation]
    if exit_when_idle:
        cmd.append("--exit-when-idle")
    if max_jobs:
        cmd += ["--max-jobs", str(max_jobs)]
    return cmd


def start_worker(db_url: str, data_dir: Path, log_path: Path, *, lease_s: float = 30.0, exit_when_idle: bool = False,
                 env: dict | None = None, max_jobs: int | None = None, isolation: str = "auto") -> subprocess.Popen:
    full_env = dict(os.environ, PYTHONPATH=str(ROOT), FIBRECUT_LOG="INFO", **(env or {}))
    if "FIBRECUT_TEST_JOB_DELAY_S" not in (env or {}):
        full_env.pop("FIBRECUT_TEST_JOB_DELAY_S", None)
    fh = open(log_path, "ab")
    return subprocess.Popen(worker_cmd(db_url, data_dir, lease_s, exit_when_idle, max_jobs, isolation), env=full_env, cwd=ROOT,
                            stdout=fh, stderr=subprocess.STDOUT)


def wait_for(predicate, timeout: float, interval: float = 0.2, what: str = "condition"):
    deadline = time.time() + timeout
    while time.time() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(interval)
    raise TimeoutError(f"{what} not reached within {timeout:g} s")


def stop_processes(procs, timeout: float = 10.0) -> None:
    for p in procs:
        if p.poll() is None:
            p.terminate()
    deadline = time.time() + timeout
    for p in procs:
        try:
            p.wait(max(0.1, deadline - time.time()))
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def sweep_doc(n: int, name: str = "sweep", **extra) -> dict:
    """A sweep of n distinct analytic jobs (rake angle from -40 deg in steps of 0.25 deg)."""
    assert n <= 400
    doc = {"name": name, "kind": "sweep", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
           "parameters": {"tool.rake_angle_deg": {"values": [-40.0 + 0.25 * i for i in range(n)]}},
           "design": "grid"}
    doc.update(extra)
    return doc


def run_inline_until_done(db_url: str, data_dir: Path, study_id: int, timeout: float = 120.0) -> None:
    """Work a study to its end in this process (one inline worker that also drives optimisations)."""
    from store import get_database
    from store.models import Study
    from worker.worker import Worker, WorkerConfig

    db = get_database(db_url)
    w = Worker(WorkerConfig(db_url=db_url, data_dir=Path(data_dir), lease_s=10.0, isolation="inline", exit_when_idle=True))
    deadline = time.time() + timeout
    while time.time() < deadline:
        w.serve()
        db.drive(study_id, owner=w.id)
        with db.read() as s:
            if s.get(Study, study_id).status in ("done", "failed", "cancelled"):
                return
    raise TimeoutError(f"study {study_id} did not end within {timeout:g} s")


def run_with_fake_solver(db_url: str, study_id: int, solve, timeout: float = 120.0) -> None:
    """Work a study to its end in this process with ``solve(scene: dict, params: dict) -> (status,
    summary)`` in place of the solver (a noisy function with a known optimum, a model run without
    files): jobs are claimed and completed through the real queue, and the study is driven
    whenever the queue is empty, as the service's driver does."""
    import uuid

    from store import get_database, queue
    from store.models import Study
    from solver.result import SOLVER_VERSION

    db = get_database(db_url)
    worker_id = f"fake-{uuid.uuid4().hex[:8]}"
    deadline = time.time() + timeout
    while time.time() < deadline:
        c = db.claim(worker_id, 30.0, SOLVER_VERSION)
        if c is None:
            db.drive(study_id, owner=worker_id)
            with db.read() as s:
                st = s.get(Study, study_id)
                if st.status in ("done", "failed", "cancelled"):
                    return
                open_jobs = queue.counts(s, study_id)
            if not (open_jobs["queued"] or open_jobs["running"]):
                db.drive(study_id, owner=worker_id)
            continue
        status, summary = solve(c.scene, c.params)
        db.finish(c, worker_id, run_id=db.new_run_id(), run_status=status, summary=summary,
                       diagnosis=None if status == "ok" else {"check": "fake", "what": "a failed replica"},
                       wall_time_s=0.0, solver_version=SOLVER_VERSION, has_file=False)
    raise TimeoutError(f"study {study_id} did not end within {timeout:g} s")
