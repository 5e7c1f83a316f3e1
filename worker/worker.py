"""A worker: claims jobs from the store's queue (:class:`store.Store`), runs the solver, writes one HDF5 file per
run, records the summary, and drives optimisations forward.

Each job runs either inline (the analytic fidelity: closed-form, microseconds) or in a child
process (FEM fidelities), so that a hung or crashing solver cannot take the worker with it:
the child is killed past the scene's ``numerics.max_wall_time_s`` plus a grace period, when the
study is cancelled, or when the lease is lost. A heartbeat thread renews the lease every
``lease_s / 3`` seconds and stores the progress (fraction of the cut, ETA). Solver failures and
unstable runs are recorded with their diagnosis; the worker carries on with the next job.

The worker owns its solver process and files: the child gets SIGKILL when the worker dies
(``PR_SET_PDEATHSIG``), the run's HDF5 file is written under ``<data>/partial/<worker id>/`` and
moved into ``runs/`` only once its row is committed, and at start-up a worker (and the server)
marks dead workers ``lost`` and cleans their partial folders (:meth:`store.Store.reap_lost_workers`).
A job's wall time is at most ``numerics.max_wall_time_s`` and ``FIBRECUT_MAX_JOB_WALL_TIME_S``;
a scene beyond the size limits (:mod:`solver.budget`) fails its job without running.

Test-only hook (clearly not for production): ``FIBRECUT_TEST_JOB_DELAY_S`` makes this worker
wait that many seconds inside each job before running the solver, so tests can kill a worker
in the middle of a job. Nothing else reads it.
"""

from __future__ import annotations

import logging
import math
import multiprocessing as mp
import os
import signal
import socket
import threading
import time
import traceback
import uuid
from dataclasses import dataclass
from pathlib import Path

from store import Store, get_database, max_job_wall_time_s

log = logging.getLogger("fibrecut.worker")

KILL_GRACE_S = float(os.environ.get("FIBRECUT_KILL_GRACE_S", "30"))  # beyond numerics.max_wall_time_s before the child is killed
TEST_DELAY_ENV = "FIBRECUT_TEST_JOB_DELAY_S"
# every job's wall-time cap on this worker, whatever its scene asks (numerics.max_wall_time_s)
MAX_JOB_WALL_TIME_S = max_job_wall_time_s()
WARMUP_WAIT_S = 900.0  # longest wait for the server's kernel warm-up before a child compiles itself


@dataclass
class WorkerConfig:
    db_url: str
    data_dir: Path
    lease_s: float = 30.0
    poll_s: float = 0.2  # idle wait between claims, doubled while idle up to max_poll_s
    max_poll_s: float = 2.0
    isolation: str = "auto"  # auto (analytic inline, FEM in a child process) | inline | process
    max_jobs: int | None = None  # stop after this many jobs (tests, benchmarks)
    exit_when_idle: bool = False  # stop when the queue is empty (tests, benchmarks)
    drive_studies: bool = True  # also drive optimisations (ask/tell) after jobs and when idle
    parent_pid: int | None = None  # stop when this process is gone (workers of `fibrecut serve`)


class Worker:
    def __init__(self, cfg: WorkerConfig):
        self.cfg = cfg
        self.id = f"{socket.gethostname()[:40]}-{os.getpid()}-{uuid.uuid4().hex[:6]}"
        self.store: Store = get_database(cfg.db_url)
        self.runs_dir = Path(cfg.data_dir) / "runs"
        self.runs_dir.mkdir(parents=True, exist_ok=True)
        self.stop = threading.Event()
        self.jobs_done = 0
        self._last_drive = 0.0
        self._driven_ids: dict[int, bool] = {}

    # ------------------------------------------------------------------ main loop
    def serve(self) -> int:
        from solver.result import SOLVER_VERSION

        self._retry(lambda: self.store.register_worker(self.id))
        log.info("worker %s on %s", self.id, self.store.url.split("@")[-1])
        try:  # what dead workers left: their rows become lost, their unfinished files go
            cleaned = self.store.reap_lost_workers(self.cfg.data_dir)
            if any(cleaned.values()):
                log.info("cleaned after dead workers: %s", cleaned)
        except Exception:  # noqa: BLE001 - cleaning must never stop a worker
            log.warning("cleaning after dead workers failed:\n%s", traceback.format_exc(limit=4))
        poll = self.cfg.poll_s
        while not self.stop.is_set():
            if self.cfg.parent_pid is not None and os.getppid() != self.cfg.parent_pid:
                log.info("the parent process %s ended; stopping", self.cfg.parent_pid)
                break
            claim = self._retry(lambda: self.store.claim(self.id, self.cfg.lease_s, SOLVER_VERSION))
            if claim is None:
                self._maybe_drive(force=False)
                if self.cfg.exit_when_idle:
                    break
                self.stop.wait(poll)
                poll = min(2 * poll, self.cfg.max_poll_s)
                continue
            poll = self.cfg.poll_s
            try:
                self.execute(claim)
            except self.store.unavailable as exc:  # the database went away mid-job: the lease will expire and requeue it
                log.warning("database error during job %s: %s", claim.job_id, exc)
                time.sleep(1.0)
            self.jobs_done += 1
            if self.cfg.max_jobs is not None and self.jobs_done >= self.cfg.max_jobs:
                break
        self._retry(lambda: self.store.worker_stopped(self.id), attempts=3)
        return 0

    def _retry(self, fn, attempts: int = 30):
        """Database calls survive a server restart or a transient error: retry with backoff."""
        for i in range(attempts):
            try:
                return fn()
            except self.store.unavailable as exc:
                if i == attempts - 1 or self.stop.is_set():
                    raise
                log.warning("database not available (%s); retrying", str(exc).splitlines()[0])
                time.sleep(min(0.2 * 2**i, 5.0))

    def _maybe_drive(self, force: bool, study_id: int | None = None) -> None:
        if not self.cfg.drive_studies:
            return
        try:
            if study_id is not None:
                self.store.drive(study_id, owner=self.id)
            elif force or time.time() - self._last_drive > 2.0:
                self._last_drive = time.time()
                self.store.drive_all(owner=self.id)
        except Exception:  # noqa: BLE001 - driving is retried by whoever drives next
            log.warning("driving studies failed:\n%s", traceback.format_exc(limit=4))

    # ------------------------------------------------------------------ one job
    def execute(self, claim) -> None:
        from solver.result import SOLVER_VERSION, Result
        from solver.scene import SceneError, scene_from_dict

        from solver.budget import check as budget_check

        try:
            scene = scene_from_dict(claim.scene)
        except SceneError as exc:
            self.store.fail(claim, self.id, f"invalid scene: {exc}")
            return
        too_large = budget_check(scene)
        if too_large:  # queued before the limits, or by a server with other limits
            self.store.fail(claim, self.id, "; ".join(f"{f} = {v!r}: {m}" for f, v, m in too_large))
            return
        run_id = self.store.new_run_id()
        final = self.runs_dir / f"{run_id}.h5"
        # written here, moved to runs/ only once the run's row is committed (a dead worker's
        # unfinished files are cleaned by Store.reap_lost_workers)
        partial = self.store.partial_dir(self.cfg.data_dir, self.id)
        partial.mkdir(parents=True, exist_ok=True)
        path = partial / f"{run_id}.h5"
        hb = _Heartbeat(self, claim)
        inline = self.cfg.isolation == "inline" or (self.cfg.isolation == "auto" and scene.fidelity == "analytic")
        try:
            if inline:
                hb.start()
                result = self._run_inline(scene, hb)
                if result is not None:
                    result.write_hdf5(path)
                    outcome = _outcome(result)
                else:
                    outcome = None
            else:
                outcome = self._run_in_child(scene, path, hb)  # starts the heartbeat after the fork
        except Exception as exc:  # noqa: BLE001 - the worker survives anything the job does
            tb = traceback.format_exc(limit=8)
            failed = Result(scene=scene, status="failed", diagnosis={"check": "worker", "what": f"{type(exc).__name__}: {exc}", "traceback": tb})
            try:
                failed.write_hdf5(path)
            except Exception:  # noqa: BLE001
                pass
            outcome = _outcome(failed)
        finally:
            hb.stop()
        if hb.lost.is_set() or outcome is None:
            # another worker owns the job now (or we are shutting down): our result is not the job's
            _unlink(path)
            if self.stop.is_set() and not hb.lost.is_set():
                self._retry(lambda: self.store.release(claim, self.id), attempts=3)
            return
        if hb.cancel.is_set():
            outcome = dict(outcome, status="cancelled")
        ok = self._retry(lambda: self.store.finish(claim, self.id, run_id=run_id, run_status=outcome["status"],
                                                summary=outcome["summary"], diagnosis=outcome["diagnosis"],
                                                wall_time_s=outcome["wall_time_s"], solver_version=SOLVER_VERSION,
                                                has_file=path.is_file()))
        if ok and path.is_file():
            os.replace(path, final)
        else:
            _unlink(path)
        if self.cfg.drive_studies and self._driven(claim.study_id):
            self._maybe_drive(force=True, study_id=claim.study_id)

    def _driven(self, study_id: int) -> bool:
        """Whether the study has a driver (optimize, calibrate, a stage after its jobs)."""
        if study_id not in self._driven_ids:
            self._driven_ids[study_id] = self.store.is_driven(study_id)
        return self._driven_ids[study_id]

    def _run_inline(self, scene, hb):
        from solver import run
        from solver.result import Result

        delay = float(os.environ.get(TEST_DELAY_ENV, "0") or 0)
        t0 = time.time()
        while time.time() - t0 < delay:  # TEST-ONLY: see the module docstring
            if hb.should_stop():
                break
            time.sleep(0.05)
        if hb.lost.is_set() or self.stop.is_set():
            return None
        if hb.cancel.is_set():
            return Result(scene=scene, status="cancelled", warnings=["cancelled before the solver started"])

        def progress(fraction: float, message: str = "") -> bool:
            hb.report(fraction, message)
            return not hb.should_stop()

        result = run(scene, progress=progress)
        if self.stop.is_set() and result.status == "cancelled":
            return None
        return result

    def _wait_for_kernels(self, hb) -> None:
        try:
            _wait_for_kernels_impl(self, hb)
        except Exception:  # noqa: BLE001 - at worst the child compiles
            log.warning("waiting for the kernels failed:\n%s", traceback.format_exc(limit=4))

    def _run_in_child(self, scene, path: Path, hb):
        from solver.result import Result

        self._wait_for_kernels(hb)
        ctx = mp.get_context("fork")
        parent_end, child_end = ctx.Pipe(duplex=False)
        proc = ctx.Process(target=_child_main, args=(scene.model_dump(mode="json"), str(path), child_end,
                                                     float(os.environ.get(TEST_DELAY_ENV, "0") or 0), os.getpid()), daemon=True)
        proc.start()
        child_end.close()
        hb.start()
        limit = min(scene.numerics.max_wall_time_s, MAX_JOB_WALL_TIME_S) + KILL_GRACE_S
        t0 = time.time()
        outcome = None
        reason = None
        while True:
            if parent_end.poll(0.2):
                try:
                    kind, payload = parent_end.recv()
                except EOFError:
                    break
                if kind == "progress":
                    hb.report(*payload)
                elif kind == "done":
                    outcome = payload
                    break
            elif not proc.is_alive():
                break
            if hb.should_stop() or self.stop.is_set():
                reason = "cancelled" if hb.cancel.is_set() else "stopped"
                break
            if time.time() - t0 > limit:
                reason = "timeout"
                break
        if proc.is_alive():
            proc.terminate()
            proc.join(5.0)
            if proc.is_alive():
                proc.kill()
        proc.join(5.0)
        if outcome is not None:
            return outcome
        if reason == "stopped" or hb.lost.is_set():
            return None
        if reason == "cancelled":
            res = Result(scene=scene, status="cancelled", warnings=["cancelled while running"], wall_time_s=time.time() - t0)
        elif reason == "timeout":
            res = Result(scene=scene, status="failed", wall_time_s=time.time() - t0,
                         diagnosis={"check": "wall_time", "what": f"the solver did not end within numerics.max_wall_time_s "
                                    f"= {min(scene.numerics.max_wall_time_s, MAX_JOB_WALL_TIME_S):g} s (+{KILL_GRACE_S:g} s grace); "
                                    "the worker killed it",
                                    "change": "raise numerics.max_wall_time_s or coarsen the scene"})
        else:
            res = Result(scene=scene, status="failed", wall_time_s=time.time() - t0,
                         diagnosis={"check": "solver_process", "what": f"the solver process died (exit code {proc.exitcode})"})
        res.write_hdf5(path)
        return _outcome(res)


def _wait_for_kernels_impl(worker, hb) -> None:
    """While ``fibrecut serve``'s warm-up compiles the kernels, wait for it (renewing the lease
    from this thread: the heartbeat thread starts only after the fork) instead of compiling the
    same kernels again in this worker."""
    from solver import warmup

    if warmup.state() != "compiling":
        return
    log.info("waiting for the solver kernels to compile")
    deadline = time.time() + WARMUP_WAIT_S
    period = max(0.05, worker.cfg.lease_s / 3.0)
    while time.time() < deadline and warmup.state() == "compiling" and not worker.stop.is_set():
        try:
            if worker.store.heartbeat(hb.claim, worker.id, worker.cfg.lease_s, 0.0, None,
                               "waiting: compiling solver kernels") == "lost":
                hb.lost.set()
                return
        except worker.store.unavailable:
            pass
        worker.stop.wait(min(period, 2.0))


def _outcome(result) -> dict:
    summary = result.summary()
    return {"status": result.status, "summary": summary, "diagnosis": result.diagnosis, "wall_time_s": float(result.wall_time_s)}


def _unlink(path: Path) -> None:
    try:
        path.unlink()
    except FileNotFoundError:
        pass


def die_with_parent(parent_pid: int) -> None:
    """The calling process gets SIGKILL when its parent dies (Linux ``PR_SET_PDEATHSIG``), so a
    solver never outlives a worker killed with kill -9; elsewhere a watchdog thread ends it
    (within a second, once the solver releases the GIL)."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(1, signal.SIGKILL, 0, 0, 0) != 0:  # PR_SET_PDEATHSIG = 1
            raise OSError(ctypes.get_errno(), "prctl")
    except (OSError, AttributeError):
        def watch():
            while os.getppid() == parent_pid:
                time.sleep(1.0)
            os._exit(137)

        threading.Thread(target=watch, daemon=True, name="parent-watch").start()
    if os.getppid() != parent_pid:  # the parent died before the signal was armed
        os._exit(137)


def _child_main(scene_data: dict, path: str, conn, delay: float, parent_pid: int | None = None) -> None:
    """The solver in a child process: progress over the pipe, the HDF5 file, then the summary."""
    if parent_pid is not None:
        die_with_parent(parent_pid)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    from solver import run
    from solver.scene import scene_from_dict

    if delay:
        time.sleep(delay)  # TEST-ONLY hook, see the module docstring
    scene = scene_from_dict(scene_data)
    last = [0.0]

    def progress(fraction: float, message: str = "") -> bool:
        t = time.time()
        if t - last[0] > 0.25 or fraction >= 1.0:
            last[0] = t
            conn.send(("progress", (float(fraction), str(message)[:200])))
        return True

    result = run(scene, progress=progress)
    result.write_hdf5(path)
    conn.send(("done", _outcome(result)))
    conn.close()


class _Heartbeat:
    """Renews the lease every lease/3 s, stores progress and ETA, learns about cancel or loss."""

    def __init__(self, worker: Worker, claim):
        self.w, self.claim = worker, claim
        self.cancel = threading.Event()
        self.lost = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._progress: tuple[float, str] | None = None
        self._t0 = time.time()

    def start(self):
        self._t0 = time.time()
        self._thread = threading.Thread(target=self._loop, daemon=True, name="heartbeat")
        self._thread.start()

    def report(self, fraction: float, message: str = "") -> None:
        self._progress = (float(fraction), message)

    def should_stop(self) -> bool:
        return self.cancel.is_set() or self.lost.is_set() or self.w.stop.is_set()

    def stop(self):
        self._stop.set()
        if self._thread is not None:
            self._thread.join(10.0)

    def _loop(self):
        period = max(0.05, self.w.cfg.lease_s / 3.0)
        while not self._stop.wait(period):
            fraction, message, eta = None, None, None
            if self._progress is not None:
                fraction, message = self._progress
                elapsed = time.time() - self._t0
                if fraction and fraction > 0:
                    eta = elapsed * (1.0 - fraction) / fraction
                    eta = eta if math.isfinite(eta) else None
            try:
                state = self.w.store.heartbeat(self.claim, self.w.id, self.w.cfg.lease_s, fraction, eta, message)
            except self.w.store.unavailable as exc:
                log.warning("heartbeat failed: %s", str(exc).splitlines()[0])
                continue
            if state == "cancel":
                self.cancel.set()
            elif state == "lost":
                self.lost.set()
                return


def main(db_url: str, data_dir: str | Path, lease_s: float = 30.0, isolation: str = "auto", max_jobs: int | None = None,
         exit_when_idle: bool = False, migrate: bool = True, parent_pid: int | None = None) -> int:
    """Entry point of ``fibrecut worker`` and of each worker process of ``fibrecut serve``."""
    logging.basicConfig(level=os.environ.get("FIBRECUT_LOG", "INFO"), format="%(asctime)s %(name)s %(levelname)s %(message)s")
    w = Worker(WorkerConfig(db_url=db_url, data_dir=Path(data_dir), lease_s=lease_s, isolation=isolation, max_jobs=max_jobs,
                            exit_when_idle=exit_when_idle, parent_pid=parent_pid))
    if migrate:
        w.store.migrate()

    def _graceful(signum, _frame):
        if w.stop.is_set():
            raise SystemExit(128 + signum)
        w.stop.set()

    signal.signal(signal.SIGTERM, _graceful)
    signal.signal(signal.SIGINT, _graceful)
    return w.serve()
