"""Kernel warm-up: compilation happens once per installation (``python -m solver.warmup``, started
by ``fibrecut serve``), its state is visible (``/api/health`` ``kernels``), and a run's
``wall_time_s`` excludes compiling or loading the kernels, which it reports as ``compile_time_s``."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from solver import cachestamp, warmup

ROOT = Path(__file__).resolve().parent.parent
pytestmark = pytest.mark.timeout(600)


def test_a_run_reports_compile_time_apart_from_its_wall_time():
    code = """
import json
from solver import load_scene, run
sc = load_scene("seed-90deg-fem-quick", {"cut.length_um": 4.0, "numerics.n_frames": 0})
a, b = run(sc).summary(), run(sc).summary()
print(json.dumps([{k: s[k] for k in ("compile_time_s", "wall_time_s", "status")} for s in (a, b)]))
"""
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=500,
                       env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert r.returncode == 0, r.stderr[-2000:]
    first, second = json.loads(r.stdout.strip().splitlines()[-1])
    assert first["compile_time_s"] > 0 and second["compile_time_s"] == 0
    # the first run's clock starts after the kernels are there: it is not the second's plus a compile
    assert first["wall_time_s"] < 3 * second["wall_time_s"] + 1.0, (first, second)


def test_the_warmup_state(tmp_path, monkeypatch):
    ready, lock = tmp_path / "ready", tmp_path / "lock"
    monkeypatch.setattr(warmup, "_paths", lambda: (str(ready), str(lock)))
    assert warmup.state() == "cold"
    lock.write_text(str(os.getpid()))
    assert warmup.state() == "compiling"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    lock.write_text(str(dead.pid))
    assert warmup.state() == "cold"  # a warm-up that died is not compiling
    ready.write_text("another version of the sources")
    assert warmup.state() == "cold"
    ready.write_text(cachestamp.source_hash(os.path.dirname(warmup.__file__)))
    assert warmup.state() == "ready"


def test_health_shows_the_kernels_state(tmp_path, monkeypatch):
    from fastapi.testclient import TestClient

    from service.app import create_app
    from service.config import Settings
    from service.routers import misc

    monkeypatch.setattr(warmup, "state", lambda: "compiling")
    misc._kernel_state[:] = [0.0, "cold"]
    c = TestClient(create_app(Settings(data_dir=tmp_path, db_url=f"sqlite:///{tmp_path / 'h.db'}")))
    assert c.get("/api/health").json()["kernels"] == "compiling"
    misc._kernel_state[:] = [0.0, "cold"]
    assert "compiling solver kernels" in (ROOT / "web" / "static" / "app.js").read_text()
