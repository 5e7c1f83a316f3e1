"""The job queue under real concurrency, on SQLite and on PostgreSQL.

- 4 worker processes on 200 short analytic jobs: every job done exactly once (one run row,
  one HDF5 file, one attempt), several workers shared the work, no "database is locked".
- kill -9 of a worker in the middle of a job: after its lease expires the job finishes on
  another worker; exactly one run row and one HDF5 file, two attempts.
- cancelling a study reaches the worker that runs its job (heartbeat), which stops it.

The "slow job" is made slow by the worker's test-only hook FIBRECUT_TEST_JOB_DELAY_S (set only
in the environment of the worker these tests start); see worker/worker.py.
"""

from __future__ import annotations

import os
import signal
import time

import pytest
import sqlalchemy as sa

from service import studies
from store import queue
from service.config import Limits
from store import get_database
from store.migrate import upgrade
from store.models import Job, Run, Study, Worker
from store.documents import StudyIn
from harness import start_worker, stop_processes, sweep_doc, wait_for

pytestmark = pytest.mark.timeout(180)


def _study(db_url, doc) -> int:
    upgrade(db_url)
    return studies.create_study(get_database(db_url), StudyIn.model_validate(doc), Limits())


def _jobs(db_url, study_id):
    with get_database(db_url).read() as s:
        return s.execute(sa.select(Job).where(Job.study_id == study_id).order_by(Job.id)).scalars().all()


def _runs(db_url):
    with get_database(db_url).read() as s:
        return s.execute(sa.select(Run)).scalars().all()


def test_four_workers_200_jobs_each_done_exactly_once(db_url, data_dir, tmp_path):
    sid = _study(db_url, sweep_doc(200, "four-workers"))
    logs = [tmp_path / f"worker{i}.log" for i in range(4)]
    t0 = time.time()
    procs = [start_worker(db_url, data_dir, log, exit_when_idle=True) for log in logs]
    try:
        for p in procs:
            p.wait(150)
    finally:
        stop_processes(procs)
    elapsed = time.time() - t0
    assert all(p.returncode == 0 for p in procs), [log.read_text()[-2000:] for log in logs]
    text = "".join(log.read_text() for log in logs)
    assert "database is locked" not in text.lower()
    assert "Traceback" not in text, text[-3000:]

    jobs = _jobs(db_url, sid)
    assert len(jobs) == 200
    assert {j.status for j in jobs} == {"done"}
    assert all(j.attempts == 1 for j in jobs)
    runs = _runs(db_url)
    per_job = {}
    for r in runs:
        per_job[r.job_id] = per_job.get(r.job_id, 0) + 1
    assert len(runs) == 200 and set(per_job.values()) == {1} and set(per_job) == {j.id for j in jobs}
    assert {j.run_id for j in jobs} == {r.id for r in runs}
    files = sorted(p.name for p in (data_dir / "runs").iterdir())
    assert files == sorted(f"{r.id}.h5" for r in runs)  # one file per run, no temporary left over
    with get_database(db_url).read() as s:
        done_by = [w.jobs_done for w in s.execute(sa.select(Worker)).scalars()]
        st = s.get(Study, sid)
    assert sum(done_by) == 200 and sum(1 for n in done_by if n > 0) >= 2, done_by
    assert st.status == "done"
    print(f"{db_url.split(':')[0]}: 200 jobs on 4 workers in {elapsed:.1f} s (incl. start-up); per worker {done_by}")


def test_kill_9_mid_job_finishes_on_another_worker(db_url, data_dir, tmp_path):
    sid = _study(db_url, sweep_doc(1, "kill-9"))
    lease = 1.5
    slow = start_worker(db_url, data_dir, tmp_path / "slow.log", lease_s=lease, env={"FIBRECUT_TEST_JOB_DELAY_S": "60"})
    others = []
    try:
        # wait until the slow worker holds the job, then kill it without warning
        wait_for(lambda: _jobs(db_url, sid)[0].status == "running", 60, what="the slow worker's claim")
        time.sleep(0.5)
        os.kill(slow.pid, signal.SIGKILL)
        slow.wait(10)
        killed_at = time.time()
        others = [start_worker(db_url, data_dir, tmp_path / "other.log", lease_s=lease)]
        job = wait_for(lambda: (j := _jobs(db_url, sid)[0]).status == "done" and j, 60, what="the job done by another worker")
        assert time.time() - killed_at >= lease * 0.5  # not before the lease could expire
    finally:
        stop_processes([slow, *others])
    assert job.attempts == 2
    runs = _runs(db_url)
    assert len(runs) == 1 and runs[0].job_id == job.id and runs[0].status == "ok"
    with get_database(db_url).read() as s:
        owners = {w.id: w.jobs_done for w in s.execute(sa.select(Worker)).scalars()}
    assert runs[0].worker_id in owners and owners[runs[0].worker_id] == 1
    files = list((data_dir / "runs").iterdir())
    assert [f.name for f in files] == [f"{runs[0].id}.h5"]
    with get_database(db_url).read() as s:
        assert s.get(Study, sid).status == "done"


def test_cancel_reaches_the_running_worker(db_url, data_dir, tmp_path):
    sid = _study(db_url, sweep_doc(3, "cancel-me"))
    w = start_worker(db_url, data_dir, tmp_path / "w.log", lease_s=1.5, env={"FIBRECUT_TEST_JOB_DELAY_S": "60"})
    try:
        wait_for(lambda: any(j.status == "running" for j in _jobs(db_url, sid)), 60, what="a running job")
        assert queue.cancel_study(get_database(db_url), sid)
        jobs = wait_for(lambda: (js := _jobs(db_url, sid)) and all(j.status == "cancelled" for j in js) and js, 20,
                        what="every job cancelled")
    finally:
        stop_processes([w])
    ran = [j for j in jobs if j.attempts == 1]
    assert len(ran) == 1  # the one the worker had claimed; it stopped at a heartbeat, not after 60 s
    runs = _runs(db_url)
    assert len(runs) == 1 and runs[0].status == "cancelled" and runs[0].job_id == ran[0].id
    with get_database(db_url).read() as s:
        assert s.get(Study, sid).status == "cancelled"


def test_lost_leases_fail_the_job_after_max_attempts(db_url, data_dir, monkeypatch):
    """A job whose workers keep vanishing fails with its reason once max_attempts is reached."""
    from solver.result import SOLVER_VERSION

    monkeypatch.setattr(queue, "REAP_EVERY_S", 0.0)  # look for expired leases at every claim

    sid = _study(db_url, sweep_doc(1, "doomed", max_attempts=2))
    db = get_database(db_url)
    for _ in range(2):
        c = queue.claim(db, "ghost", lease_s=0.05, solver_version=SOLVER_VERSION)
        assert c is not None
        time.sleep(0.1)  # the ghost never heartbeats
    assert queue.claim(db, "ghost", lease_s=0.05, solver_version=SOLVER_VERSION) is None
    (job,) = _jobs(db_url, sid)
    assert job.status == "failed" and job.attempts == 2 and "max_attempts" in job.error
    with db.read() as s:
        assert s.get(Study, sid).status == "failed"
    # a late completion by the ghost is refused by the fencing token
    assert not queue.complete(db, c, "ghost", run_id="0" * 32, run_status="ok", summary={}, diagnosis=None, wall_time_s=0.0,
                              solver_version=SOLVER_VERSION, has_file=False)


def test_hung_solver_is_killed_and_the_worker_carries_on(sqlite_url, data_dir, tmp_path):
    """Process isolation: a solver that does not end within numerics.max_wall_time_s (+ grace) is
    killed; the run is recorded as failed with its diagnosis and the worker runs the next job.

    The hang is the worker's test-only delay hook inside the solver's child process (60 s), far
    beyond the job's 1 s wall-time cap. A second worker without the hook then runs two normal
    jobs in process mode and gets the same numbers as a direct solver run."""
    cap_s, hang_s = 1.0, 60.0
    doc = sweep_doc(1, "hang", fixed={"fidelity": "analytic", "numerics.max_wall_time_s": cap_s})
    sid = _study(sqlite_url, doc)
    w = start_worker(sqlite_url, data_dir, tmp_path / "w.log", lease_s=2.0, isolation="process", exit_when_idle=True,
                     env={"FIBRECUT_TEST_JOB_DELAY_S": str(hang_s), "FIBRECUT_KILL_GRACE_S": "0.5"})
    try:
        w.wait(60)
    finally:
        stop_processes([w])
    assert w.returncode == 0
    (job,) = _jobs(sqlite_url, sid)
    assert job.status == "failed" and "max_wall_time_s" in job.error
    (run_row,) = _runs(sqlite_url)
    assert run_row.status == "failed" and run_row.diagnosis["check"] == "wall_time" and run_row.has_file
    # the cap stopped it: it ran at least the cap, and was killed before the injected hang would have ended
    assert cap_s <= run_row.wall_time_s < hang_s
    # the same worker code in process mode runs a normal job to the same result as inline
    sid2 = _study(sqlite_url, sweep_doc(2, "after-hang"))
    w = start_worker(sqlite_url, data_dir, tmp_path / "w2.log", isolation="process", exit_when_idle=True)
    try:
        w.wait(60)
    finally:
        stop_processes([w])
    jobs = _jobs(sqlite_url, sid2)
    assert [j.status for j in jobs] == ["done", "done"]
    from solver import run
    from solver.scene import scene_from_dict

    with get_database(sqlite_url).read() as s:
        r = s.get(Run, jobs[0].run_id)
    direct = run(scene_from_dict(jobs[0].scene)).summary()
    assert r.summary["cutting_force_N_per_mm"] == pytest.approx(direct["cutting_force_N_per_mm"], rel=1e-12)


def test_heartbeat_keeps_the_lease_and_sigterm_gives_the_job_back(sqlite_url, data_dir, tmp_path):
    """A live worker keeps its job past several lease periods (heartbeats); SIGTERM makes it give
    the job back to the queue (not counted as an attempt) and stop without a run."""
    sid = _study(sqlite_url, sweep_doc(1, "sigterm"))
    lease = 0.6
    w = start_worker(sqlite_url, data_dir, tmp_path / "w.log", lease_s=lease, env={"FIBRECUT_TEST_JOB_DELAY_S": "60"})
    try:
        wait_for(lambda: _jobs(sqlite_url, sid)[0].status == "running", 60, what="the claim")
        time.sleep(5 * lease)
        (job,) = _jobs(sqlite_url, sid)
        assert job.status == "running" and job.attempts == 1 and job.lease_until > time.time()
        w.send_signal(signal.SIGTERM)
        w.wait(20)
    finally:
        stop_processes([w])
    assert w.returncode == 0
    (job,) = _jobs(sqlite_url, sid)
    assert job.status == "queued" and job.attempts == 0 and job.lease_owner is None
    assert _runs(sqlite_url) == [] and list((data_dir / "runs").iterdir()) == []
