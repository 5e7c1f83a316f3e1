"""``fibrecut serve``: migrations, a supervised pool of worker processes, the study driver and
the API (uvicorn), all on one database URL (default: SQLite in WAL mode in the data folder)."""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

log = logging.getLogger("fibrecut.serve")


class WorkerPool:
    """N ``python -m worker`` processes, restarted when one dies."""

    def __init__(self, n: int, db_url: str, data_dir: Path, lease_s: float):
        self.cmd = [sys.executable, "-m", "worker", "--db", db_url, "--data", str(data_dir), "--lease", str(lease_s),
                    "--exit-with-parent"]
        self.n = n
        self.procs: list[subprocess.Popen] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, daemon=True, name="worker-pool")

    def start(self):
        root = str(Path(__file__).resolve().parent.parent)
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [root, os.environ.get("PYTHONPATH")])))
        if self.n > 1:  # one worker per core: each solver uses one numba thread unless told otherwise
            env.setdefault("NUMBA_NUM_THREADS", "1")
        self.env = env
        self.procs = [subprocess.Popen(self.cmd, env=env) for _ in range(self.n)]
        self._thread.start()

    def _watch(self):
        while not self._stop.wait(2.0):
            for i, p in enumerate(self.procs):
                if p.poll() is not None and not self._stop.is_set():
                    log.warning("worker pid %s ended with code %s; starting another", p.pid, p.returncode)
                    self.procs[i] = subprocess.Popen(self.cmd, env=self.env)

    def stop(self, timeout: float = 15.0):
        if self._stop.is_set():
            return
        self._stop.set()
        for p in self.procs:
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
        deadline = time.time() + timeout
        for p in self.procs:
            try:
                p.wait(max(0.1, deadline - time.time()))
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def start_warmup(data_dir: Path) -> subprocess.Popen | None:
    """Compile the solver's kernels once for this installation (``python -m solver.warmup``) when
    they are not compiled yet; the workers wait for it before an FEM job. FIBRECUT_WARMUP=0 skips it."""
    from solver import warmup

    if os.environ.get("FIBRECUT_WARMUP", "1") == "0" or warmup.state() != "cold":
        return None
    log.info("compiling solver kernels (once per installation; /api/health shows kernels: compiling)")
    root = str(Path(__file__).resolve().parent.parent)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [root, os.environ.get("PYTHONPATH")])))
    logf = open(Path(data_dir) / "warmup.log", "ab")
    proc = subprocess.Popen([sys.executable, "-m", "solver.warmup"], env=env, stdout=logf, stderr=subprocess.STDOUT)
    # the workers check the state before forking their first FEM child: wait for the lock file
    deadline = time.time() + 10.0
    while warmup.state() == "cold" and proc.poll() is None and time.time() < deadline:
        time.sleep(0.05)
    return proc


def _driver_loop(db_url: str, stop: threading.Event) -> None:
    """Drive optimisations (ask/tell) every 2 s; workers also drive after each job."""
    from store import get_database

    store = get_database(db_url)
    owner = f"server-{os.getpid()}"
    while not stop.wait(2.0):
        try:
            store.drive_all(owner)
        except Exception as exc:  # noqa: BLE001 - retried at the next tick
            log.warning("study driver: %s", exc)


def serve(host: str = "127.0.0.1", port: int = 8000, data_dir: str | Path = "fibrecut-data", db_url: str | None = None,
          workers: int | None = None) -> int:
    import uvicorn

    from service.app import create_app
    from service.config import Settings

    logging.basicConfig(level=os.environ.get("FIBRECUT_LOG", "INFO"), format="%(asctime)s %(name)s %(levelname)s %(message)s")
    settings = Settings.from_env(data_dir=Path(data_dir), db_url=db_url)
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    from store import get_database

    store = get_database(settings.db_url)
    store.migrate()
    try:  # what workers killed since the last start left behind
        cleaned = store.reap_lost_workers(settings.data_dir)
        cleaned["orphan_files"] = store.clean_orphan_run_files(settings.data_dir)
        if any(cleaned.values()):
            log.info("cleaned after dead workers: %s", cleaned)
    except Exception as exc:  # noqa: BLE001 - the workers clean again at their start
        log.warning("cleaning after dead workers failed: %s", exc)
    warm = start_warmup(settings.data_dir)
    n = (os.cpu_count() or 1) if workers is None else max(0, workers)
    pool = WorkerPool(n, settings.db_url, settings.data_dir, settings.lease_s)
    stop = threading.Event()
    driver = threading.Thread(target=_driver_loop, args=(settings.db_url, stop), daemon=True, name="study-driver")
    app = create_app(settings, migrate=False)
    if host not in ("127.0.0.1", "localhost", "::1") and not settings.api_token:
        log.warning("listening on %s without FIBRECUT_API_TOKEN: anyone who reaches this port can submit studies", host)
    pool.start()
    driver.start()
    log.info("fibrecut on http://%s:%s (database %s, %d workers, data %s)", host, port,
             settings.db_url.split("@")[-1], n, settings.data_dir.resolve())
    def shutdown():
        stop.set()
        pool.stop()
        if warm is not None and warm.poll() is None:
            warm.terminate()

    class _Server(uvicorn.Server):
        # uvicorn re-raises SIGTERM/SIGINT after its graceful shutdown, which would skip a
        # `finally`; stop the workers inside its signal capture instead
        @contextlib.contextmanager
        def capture_signals(self):
            with super().capture_signals():
                try:
                    yield
                finally:
                    shutdown()

    server = _Server(uvicorn.Config(app, host=host, port=port, log_level=os.environ.get("FIBRECUT_UVICORN_LOG", "warning")))
    try:
        server.run()
    finally:
        shutdown()
    return 0
