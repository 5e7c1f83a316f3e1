"""Service benchmark (a script, not a test): ``python scripts/service_bench.py [--db sqlite] [--workers 1,2,4,8]``.

1. Queue throughput: N trivial jobs (analytic runs, each also writing its HDF5 file and its
   summary) on 1, 2, 4, 8 worker processes already waiting; jobs per second from the study's
   creation to its last job done. Each count gets a fresh database.
2. API latency: p50/p99 of ``GET /api/studies/{id}`` at a steady 100 requests per second
   (open loop) for ``--seconds`` while worker processes of ``fibrecut serve`` compute a sweep.

Default database: a fresh database on the PostgreSQL server of the tests
(postgresql+psycopg://postgres@127.0.0.1:5432/test as admin); ``--db sqlite`` for SQLite.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import uuid
from pathlib import Path

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the repository: the project and its tests' harness
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from harness import ROOT, start_worker, stop_processes, sweep_doc, wait_for  # noqa: E402

PG_ADMIN = os.environ.get("FIBRECUT_TEST_PG_URL", "postgresql+psycopg://postgres@127.0.0.1:5432/test")


class FreshDatabase:
    def __init__(self, kind: str, folder: Path):
        self.kind, self.folder = kind, folder
        if kind == "sqlite":
            self.url = f"sqlite:///{folder / 'bench.db'}"
        else:
            import psycopg

            self.name = f"fc_bench_{uuid.uuid4().hex[:10]}"
            self.admin = psycopg.connect(PG_ADMIN.replace("postgresql+psycopg://", "postgresql://"), autocommit=True)
            self.admin.execute(f'CREATE DATABASE "{self.name}"')
            self.url = PG_ADMIN.rpartition("/")[0] + "/" + self.name

    def drop(self):
        from store import forget_databases

        forget_databases()
        if self.kind != "sqlite":
            self.admin.execute(f'DROP DATABASE IF EXISTS "{self.name}" WITH (FORCE)')
            self.admin.close()


def queue_throughput(kind: str, workers: list[int], n_jobs: int) -> list[dict]:
    import sqlalchemy as sa

    from service import studies
    from service.config import Limits
    from store import get_database
    from store.documents import StudyIn
    from store.migrate import upgrade
    from store.models import Job

    rows = []
    for n in workers:
        folder = Path(tempfile.mkdtemp(prefix="fc-bench-"))
        db = FreshDatabase(kind, folder)
        try:
            upgrade(db.url)
            procs = [start_worker(db.url, folder / "data", folder / f"w{i}.log") for i in range(n)]
            time.sleep(3.0 + n)  # let every worker start and poll the empty queue
            t0 = time.time()
            sid = studies.create_study(get_database(db.url), StudyIn.model_validate(sweep_doc(n_jobs, f"bench-{n}")), Limits())

            def finished():
                with get_database(db.url).read() as s:
                    return s.execute(sa.select(sa.func.count()).select_from(Job).where(
                        Job.study_id == sid, Job.status == "done")).scalar() == n_jobs

            wait_for(finished, 600, interval=0.05, what="all jobs done")
            dt = time.time() - t0
            stop_processes(procs)
            locked = sum("database is locked" in (folder / f"w{i}.log").read_text() for i in range(n))
            rows.append({"database": kind, "workers": n, "jobs": n_jobs, "seconds": round(dt, 3),
                         "jobs_per_s": round(n_jobs / dt, 1), "locked_errors": locked})
            print(json.dumps(rows[-1]), flush=True)
        finally:
            db.drop()
            shutil.rmtree(folder, ignore_errors=True)
    return rows


def api_latency(kind: str, workers: int, seconds: float, rate: float) -> dict:
    import socket

    folder = Path(tempfile.mkdtemp(prefix="fc-bench-api-"))
    db = FreshDatabase(kind, folder)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    url = f"http://127.0.0.1:{port}"
    env = dict(os.environ, PYTHONPATH=str(ROOT), FIBRECUT_LOG="WARNING")
    env.pop("FIBRECUT_API_TOKEN", None)
    server = subprocess.Popen([sys.executable, "-c", "import sys; from cli.main import main; sys.exit(main())", "serve",
                               "--data", str(folder / "data"), "--db", db.url, "--port", str(port), "--workers", str(workers)],
                              env=env, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        def up():
            try:
                return httpx.get(url + "/api/health", timeout=1).status_code == 200
            except httpx.HTTPError:
                return False

        wait_for(up, 60, what="server up")
        sid = httpx.post(url + "/api/studies", json=sweep_doc(400, "latency-load"), timeout=30).json()["id"]
        time.sleep(2.0)
        lat: list[float] = []
        errors = [0]
        lock = threading.Lock()
        client = httpx.Client(base_url=url, timeout=10, limits=httpx.Limits(max_connections=64))

        def one():
            t = time.perf_counter()
            try:
                ok = client.get(f"/api/studies/{sid}").status_code == 200
            except httpx.HTTPError:
                ok = False
            dt = time.perf_counter() - t
            with lock:
                lat.append(dt) if ok else None
                errors[0] += 0 if ok else 1

        threads = []
        start = time.perf_counter()
        n = int(seconds * rate)
        for i in range(n):  # open loop: request i leaves at start + i / rate whatever the answers do
            delay = start + i / rate - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
            th = threading.Thread(target=one)
            th.start()
            threads.append(th)
        for th in threads:
            th.join()
        st = httpx.get(f"{url}/api/studies/{sid}").json()
        lat.sort()
        return {"database": kind, "workers": workers, "requests": n, "rate_per_s": rate, "errors": errors[0],
                "p50_ms": round(1000 * statistics.median(lat), 2), "p99_ms": round(1000 * lat[int(0.99 * (len(lat) - 1))], 2),
                "max_ms": round(1000 * lat[-1], 2), "jobs_done_meanwhile": st["counts"]["done"]}
    finally:
        server.terminate()
        try:
            server.wait(20)
        except subprocess.TimeoutExpired:
            os.killpg(server.pid, 9)
        db.drop()
        shutil.rmtree(folder, ignore_errors=True)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python scripts/service_bench.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--db", choices=("postgresql", "sqlite"), default="postgresql")
    p.add_argument("--workers", default="1,2,4,8", help="worker counts for the throughput runs")
    p.add_argument("--jobs", type=int, default=400, help="jobs per throughput run (at most 400)")
    p.add_argument("--seconds", type=float, default=10.0, help="duration of the latency run")
    p.add_argument("--rate", type=float, default=100.0, help="requests per second of the latency run")
    p.add_argument("--api-workers", type=int, default=2, help="worker processes computing during the latency run")
    p.add_argument("--skip", choices=("queue", "api"), action="append", default=[])
    a = p.parse_args(argv)
    out = {}
    if "queue" not in a.skip:
        out["queue"] = queue_throughput(a.db, [int(x) for x in a.workers.split(",")], min(a.jobs, 400))
    if "api" not in a.skip:
        out["api"] = api_latency(a.db, a.api_workers, a.seconds, a.rate)
        print(json.dumps(out["api"]), flush=True)
    print(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
