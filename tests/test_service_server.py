"""`fibrecut serve` as a real server (uvicorn + worker processes) and the study CLI against it.

- The server killed (kill -9 of the whole process group: API, driver and workers) in the
  middle of an optimisation and started again: the study continues and reaches n_trials, every
  optuna trial is told, no trial is left running.
- `fibrecut submit --wait`, `status`, `results --csv`, `cancel` against the REST API; bad
  input exits 2 with one line naming the field.

Jobs are slowed by the worker's test-only hook FIBRECUT_TEST_JOB_DELAY_S so that the kill lands
mid-study; leases are 2 s (FIBRECUT_LEASE_S) so the restart does not wait long.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time

import httpx
import optuna
import pytest
import sqlalchemy as sa

from harness import ROOT, sweep_doc, wait_for

pytestmark = pytest.mark.timeout(180)

# the `fibrecut` console script, run with this interpreter
FIBRECUT = [sys.executable, "-c", "import sys; from cli.main import main; sys.exit(main())"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Server:
    def __init__(self, db_url, data_dir, log, delay="0", workers=2):
        self.port = _free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.args = [*FIBRECUT, "serve", "--data", str(data_dir), "--db", db_url,
                     "--port", str(self.port), "--workers", str(workers)]
        self.env = dict(os.environ, PYTHONPATH=str(ROOT), FIBRECUT_LEASE_S="2", FIBRECUT_DRIVER_LEASE_S="3", FIBRECUT_TEST_JOB_DELAY_S=delay,
                        FIBRECUT_LOG="WARNING")
        self.env.pop("FIBRECUT_API_TOKEN", None)
        self.log = log
        self.proc = None

    def start(self):
        self.proc = subprocess.Popen(self.args, env=self.env, cwd=ROOT, stdout=open(self.log, "ab"), stderr=subprocess.STDOUT,
                                     start_new_session=True)

        def up():
            try:
                return httpx.get(self.url + "/api/health", timeout=1).status_code == 200
            except httpx.HTTPError:
                return False

        wait_for(up, 60, what="the server answering")
        return self

    def kill9(self):
        os.killpg(self.proc.pid, signal.SIGKILL)  # the server's own session: API, driver and its workers
        self.proc.wait(10)

    def stop(self):
        if self.proc and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(20)
            except subprocess.TimeoutExpired:
                self.kill9()


def test_server_killed_mid_optimisation_resumes_to_n_trials(db_url, data_dir, tmp_path):
    n_trials = 6
    server = Server(db_url, data_dir, tmp_path / "serve.log", delay="0.3").start()
    try:
        doc = {"name": "resume", "kind": "optimize", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
               "parameters": {"tool.edge_radius_um": {"low": 2, "high": 60}}, "sampler": "tpe", "n_trials": n_trials,
               "parallelism": 2, "seed": 11, "objectives": [{"metric": "thrust_force_N_per_mm", "direction": "minimize"}]}
        sid = httpx.post(server.url + "/api/studies", json=doc, timeout=30).json()["id"]
        wait_for(lambda: httpx.get(f"{server.url}/api/studies/{sid}").json()["counts"]["done"] >= 2, 90, what="2 trials done")
        server.kill9()
        before = _study_state(db_url, sid)
        assert before["done"] < n_trials
        server = Server(db_url, data_dir, tmp_path / "serve2.log", delay="0").start()
        st = wait_for(lambda: (s := httpx.get(f"{server.url}/api/studies/{sid}").json())["status"] in ("done", "failed") and s,
                      120, what="the study's end after the restart")
    finally:
        server.stop()
    assert st["status"] == "done" and st["counts"]["done"] == n_trials and st["counts"]["failed"] == 0
    from store import get_database
    from store.models import Job, Run
    from store.studies import optuna_name, optuna_storage

    db = get_database(db_url)
    with db.read() as s:
        jobs = s.execute(sa.select(Job).where(Job.study_id == sid)).scalars().all()
        runs = s.execute(sa.select(Run)).scalars().all()
    assert len(jobs) == n_trials and all(j.told for j in jobs)
    assert sorted(r.job_id for r in runs) == sorted(j.id for j in jobs)  # one run per job, even for the interrupted ones
    study = optuna.load_study(study_name=optuna_name(sid), storage=optuna_storage(db))
    complete = [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
    assert sorted(t.number for t in complete) == sorted(j.trial_number for j in jobs)
    # a trial asked just before the kill but never turned into a job is failed, not left running
    others = [t for t in study.trials if t.state != optuna.trial.TrialState.COMPLETE]
    assert all(t.state == optuna.trial.TrialState.FAIL for t in others)


def _study_state(db_url, sid):
    from store import get_database
    from store.models import Job

    with get_database(db_url).read() as s:
        rows = s.execute(sa.select(Job.status, sa.func.count()).where(Job.study_id == sid).group_by(Job.status)).all()
    return {k: v for k, v in rows} | {"done": dict(rows).get("done", 0)}


# ------------------------------------------------------------------ the CLI against a live server
@pytest.fixture(scope="module")
def live(tmp_path_factory):
    d = tmp_path_factory.mktemp("live")
    server = Server(f"sqlite:///{d / 'fibrecut.db'}", d / "data", d / "serve.log").start()
    yield server
    server.stop()


def _cli(live, *args, env=None):
    e = dict(os.environ, PYTHONPATH=str(ROOT), FIBRECUT_URL=live.url, **(env or {}))
    e.pop("FIBRECUT_API_TOKEN", None)
    return subprocess.run([*FIBRECUT, *args], env=e, cwd=ROOT, capture_output=True, text=True, timeout=120)


def test_cli_submit_wait_status_results(live, tmp_path):
    import yaml

    f = tmp_path / "study.yaml"
    f.write_text(yaml.safe_dump(sweep_doc(6, "cli-sweep")))
    r = _cli(live, "submit", str(f), "--wait")
    assert r.returncode == 0, r.stderr
    sid = int(r.stdout.split()[1])
    assert "done" in r.stdout.splitlines()[-1]
    r = _cli(live, "status", str(sid))
    assert r.returncode == 0 and "done 6" in r.stdout
    r = _cli(live, "results", str(sid), "--csv")
    assert r.returncode == 0 and len(r.stdout.strip().splitlines()) == 7 and "cutting_force_N_per_mm" in r.stdout
    r = _cli(live, "status")
    assert r.returncode == 0 and "cli-sweep" in r.stdout


def test_cli_results_of_a_convergence_study_with_replicas_list_its_levels(live, tmp_path):
    """2 levels x 3 replicas of the analytic model (it does not depend on the element size: every
    mean is the same, the errors are 0 and the standard errors 0)."""
    import yaml

    doc = {"name": "cli-conv-rep", "kind": "convergence", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
           "parameters": {"numerics.element_size_um": {"values": [5, 2.5]}}, "replicas": 3}
    f = tmp_path / "conv.yaml"
    f.write_text(yaml.safe_dump(doc))
    r = _cli(live, "submit", str(f), "--wait")
    assert r.returncode == 0, r.stderr
    sid = int(r.stdout.split()[1])
    r = _cli(live, "results", str(sid))
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert sum(1 for ln in lines if ln.split() and ln.split()[0].isdigit()) == 6  # one row per run
    levels = lines[lines.index(next(ln for ln in lines if ln.startswith("levels"))) + 1:]
    assert len(levels) == 2 and any("(finest)" in ln for ln in levels) and all("3/3 ok" in ln for ln in levels)
    coarse = next(ln for ln in levels if "element_size_um = 5" in ln)
    assert "(error 0 % +- 0 %)" in coarse, coarse


def test_cli_bad_input_exits_2_with_one_line(live, tmp_path):
    import yaml

    f = tmp_path / "bad.yaml"
    f.write_text(yaml.safe_dump({**sweep_doc(2, "bad"), "parameters": {"tool.rake_angle_deg": {"values": [0, 100]}}}))
    r = _cli(live, "submit", str(f))
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "parameters.tool.rake_angle_deg.values" in lines[0] and "100" in lines[0] and "60" in lines[0]
    r = _cli(live, "submit", str(tmp_path / "missing.yaml"))
    assert r.returncode == 2 and "missing.yaml" in r.stderr
    r = _cli(live, "status", "424242")
    assert r.returncode == 2 and "424242" in r.stderr
    r = _cli(live, "cancel", "zero")
    assert r.returncode == 2
    r = _cli(live, "status", "--url", "http://127.0.0.1:9", "1")
    assert r.returncode == 1 and "cannot reach" in r.stderr


def test_cli_cancel(live, tmp_path):
    import yaml

    f = tmp_path / "slow.yaml"
    # a convergence-free way to keep jobs queued: more jobs than the 2 workers finish at once
    f.write_text(yaml.safe_dump(sweep_doc(300, "to-cancel")))
    r = _cli(live, "submit", str(f))
    sid = int(r.stdout.split()[1])
    r = _cli(live, "cancel", str(sid))
    assert r.returncode == 0 and "cancelled" in r.stdout
    st = httpx.get(f"{live.url}/api/studies/{sid}").json()
    assert st["status"] == "cancelled"
    wait_for(lambda: httpx.get(f"{live.url}/api/studies/{sid}").json()["counts"]["running"] == 0, 30, what="running jobs stopped")
