"""A worker owns its solver process and its files.

- kill -9 of a worker while its solver child runs: the child dies with it (no process left
  busy), and the next worker to start marks the dead one ``lost`` and removes what it left
  unfinished; the job then finishes elsewhere with exactly one file per run row.
- a job's wall time is capped by the worker (FIBRECUT_MAX_JOB_WALL_TIME_S) whatever its scene asks.

The solver child is made slow by the worker's test-only hook FIBRECUT_TEST_JOB_DELAY_S (it
sleeps inside the child before the solver starts), with the analytic scene in process isolation:
the same child-process path as an FEM job, without compiling kernels.
"""

from __future__ import annotations

import os
import signal
import time
import uuid

import pytest
import sqlalchemy as sa
from fastapi.testclient import TestClient

from service import studies
from service.app import create_app
from service.config import Limits, Settings
from store import get_database
from store.migrate import upgrade
from store.models import Job, Run, Worker
from store.documents import StudyIn
from harness import start_worker, stop_processes, sweep_doc, wait_for

pytestmark = pytest.mark.timeout(180)


def _children(pid: int) -> list[int]:
    out = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as fh:
                    fields = fh.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid and fields[0] != "Z":
                out.append(int(d))
    return out


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _job(db_url, sid):
    with get_database(db_url).read() as s:
        return s.execute(sa.select(Job).where(Job.study_id == sid)).scalars().one()


FEM_DOC = {"name": "orphans-fem", "kind": "sweep", "scene": "seed-90deg-fem-quick",
           "fixed": {"numerics.n_frames": 0, "cut.length_um": 20.0}, "parameters": {"tool.rake_angle_deg": {"values": [10]}}}


@pytest.mark.parametrize("doc, env", [(sweep_doc(1, "orphans"), {"FIBRECUT_TEST_JOB_DELAY_S": "120"}), (FEM_DOC, {})],
                         ids=["child asleep", "tiny FEM cut"])
def test_kill_9_of_a_worker_leaves_no_solver_process_and_no_file_without_a_row(sqlite_url, data_dir, tmp_path, doc, env):
    upgrade(sqlite_url)
    db = get_database(sqlite_url)
    sid = studies.create_study(db, StudyIn.model_validate(doc), Limits())
    lease = 1.5
    w = start_worker(sqlite_url, data_dir, tmp_path / "w.log", lease_s=lease, isolation="process", env=env)
    other = None
    try:
        kids = wait_for(lambda: _job(sqlite_url, sid).status == "running" and _children(w.pid), 60, what="the solver child")
        (child,) = kids
        with db.read() as s:
            (dead_id,) = s.execute(sa.select(Worker.id)).scalars().all()
        # what the child would leave if killed while writing: a file in the worker's partial folder
        leftover = data_dir / "partial" / dead_id / f"{uuid.uuid4().hex}.h5"
        assert leftover.parent.is_dir(), "the run's file is written outside runs/ until its row is committed"
        leftover.write_bytes(b"half a file")
        assert _alive(child) and _job(sqlite_url, sid).status == "running"  # killed in the middle of its run
        os.kill(w.pid, signal.SIGKILL)
        w.wait(10)
        gone = wait_for(lambda: not _alive(child), 5, what="the solver child ending with its worker")
        assert gone
        # the dashboard's list shows the dead worker as lost at once (its process is gone)
        client = TestClient(create_app(Settings(data_dir=data_dir, db_url=sqlite_url), migrate=False))
        listed = {x["id"]: x["status"] for x in client.get("/api/workers").json()}
        assert listed[dead_id] == "lost", listed
        other = start_worker(sqlite_url, data_dir, tmp_path / "other.log", lease_s=lease, isolation="process")
        job = wait_for(lambda: (j := _job(sqlite_url, sid)).status == "done" and j, 60, what="the job done by another worker")
    finally:
        stop_processes([p for p in (w, other) if p is not None])
    assert job.attempts == 2
    with db.read() as s:
        runs = s.execute(sa.select(Run)).scalars().all()
        dead = s.get(Worker, dead_id)
    assert dead.status == "lost"
    assert not leftover.exists() and not leftover.parent.exists()
    files = sorted(p.name for p in (data_dir / "runs").iterdir())
    assert files == sorted(f"{r.id}.h5" for r in runs if r.has_file) and len(runs) == 1
    assert not any((data_dir / "partial").rglob("*.h5"))


def test_the_server_at_start_up_moves_committed_files_and_deletes_the_rest(sqlite_url, data_dir):
    """A worker killed between its commit and the move: the committed file goes to runs/."""
    upgrade(sqlite_url)
    db = get_database(sqlite_url)
    t = time.time()
    committed, orphan = uuid.uuid4().hex, uuid.uuid4().hex
    with db.write() as s:
        s.add(Worker(id="gone-1", host="elsewhere", pid=1, started_at=t - 900, last_seen=t - 600, jobs_done=0, status="busy"))
        s.add(Worker(id="alive-1", host="elsewhere", pid=1, started_at=t, last_seen=t, jobs_done=0, status="busy"))
        s.add(Run(id=committed, job_id=None, scene_hash="-", solver_version="x", status="ok", summary={}, has_file=True,
                  created_at=t))
    for wid in ("gone-1", "alive-1"):
        d = data_dir / "partial" / wid
        d.mkdir(parents=True)
        for rid in (committed, orphan):
            (d / f"{rid}.h5").write_bytes(b"x")
    from store import queue

    assert queue.clean_dead_workers(db, data_dir) == {"lost": 1, "moved": 1, "deleted": 1}
    assert (data_dir / "runs" / f"{committed}.h5").is_file() and not (data_dir / "runs" / f"{orphan}.h5").exists()
    assert not (data_dir / "partial" / "gone-1").exists()
    assert len(list((data_dir / "partial" / "alive-1").iterdir())) == 2  # a live worker's files stay
    with db.read() as s:
        assert s.get(Worker, "gone-1").status == "lost" and s.get(Worker, "alive-1").status == "busy"


def test_every_job_has_a_wall_time_cap_on_the_worker(sqlite_url, data_dir, tmp_path):
    upgrade(sqlite_url)
    sid = studies.create_study(get_database(sqlite_url), StudyIn.model_validate(sweep_doc(1, "capped")), Limits())
    w = start_worker(sqlite_url, data_dir, tmp_path / "w.log", lease_s=2.0, isolation="process", exit_when_idle=True,
                     env={"FIBRECUT_TEST_JOB_DELAY_S": "60", "FIBRECUT_MAX_JOB_WALL_TIME_S": "1", "FIBRECUT_KILL_GRACE_S": "0.5"})
    t0 = time.time()
    try:
        w.wait(45)
    finally:
        stop_processes([w])
    job = _job(sqlite_url, sid)
    assert job.status == "failed" and "max_wall_time_s" in job.error, job.error
    assert time.time() - t0 < 40


def test_old_files_without_a_run_row_are_deleted_at_server_start(sqlite_url, data_dir):
    from store import queue

    upgrade(sqlite_url)
    db = get_database(sqlite_url)
    runs = data_dir / "runs"
    runs.mkdir()
    kept_row, orphan_old, orphan_new = uuid.uuid4().hex, uuid.uuid4().hex, uuid.uuid4().hex
    with db.write() as s:
        s.add(Run(id=kept_row, job_id=None, scene_hash="-", solver_version="x", status="ok", summary={}, has_file=True,
                  created_at=time.time()))
    two_hours_ago = time.time() - 7200
    for rid in (kept_row, orphan_old, orphan_new):
        (runs / f"{rid}.h5").write_bytes(b"x")
    for rid in (kept_row, orphan_old):
        os.utime(runs / f"{rid}.h5", (two_hours_ago, two_hours_ago))
    (runs / ".tmp-abc.h5").write_bytes(b"x")
    os.utime(runs / ".tmp-abc.h5", (two_hours_ago, two_hours_ago))
    assert queue.clean_orphan_run_files(db, data_dir) == 2
    assert sorted(p.name for p in runs.iterdir()) == sorted([f"{kept_row}.h5", f"{orphan_new}.h5"])
