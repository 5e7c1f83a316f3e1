"""The CLI on user errors: one line, exit 2 (1 for an unreachable service), never a traceback,
and never a hang: an alias bomb answers within 2 s, an oversized scene before it allocates."""

from __future__ import annotations

import re
import resource
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
FIBRECUT = [sys.executable, "-c", "import sys; from cli.main import main; sys.exit(main())"]
BOMB = "".join(f"{a}: &{a} [{', '.join([f'*{p}'] * 9 if p else ['lol'] * 9)}]\n"
               for p, a in zip([None, "a", "b", "c", "d", "e", "f", "g", "h"], "abcdefghi"))

pytestmark = pytest.mark.timeout(120)


def _limit_memory():  # today's parser would expand the bomb to gigabytes: fail fast instead
    resource.setrlimit(resource.RLIMIT_AS, (1_500_000_000, 1_500_000_000))


def _cli(*args, timeout=30.0, env=None, prefix=FIBRECUT):
    import os

    t0 = time.time()
    r = subprocess.run([*prefix, *args], capture_output=True, text=True, timeout=timeout, cwd=ROOT,
                       env={**os.environ, "PYTHONPATH": str(ROOT), **(env or {})}, preexec_fn=_limit_memory)
    return r, time.time() - t0


def _one_line_error(r, code=2):
    assert r.returncode == code, (r.returncode, r.stdout[-500:], r.stderr[-2000:])
    assert "Traceback" not in r.stderr, r.stderr[-2000:]
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fibrecut: error: "), r.stderr
    return lines[0]


@pytest.mark.parametrize("command", ["run", "submit"])
def test_a_yaml_alias_bomb_is_refused_within_2_s(tmp_path, command):
    f = tmp_path / "bomb.yaml"
    f.write_text(BOMB)
    try:
        r, elapsed = _cli(command, str(f), timeout=20)
    except subprocess.TimeoutExpired:
        pytest.fail(f"fibrecut {command} on an alias bomb did not answer within 20 s")
    line = _one_line_error(r)
    assert "alias" in line or "anchor" in line
    assert elapsed < 2.0 + 1.5  # 2 s, plus the interpreter's start-up on a loaded machine


def test_an_oversized_scene_file_is_refused_before_it_allocates(tmp_path):
    f = tmp_path / "big.yaml"
    f.write_text("base: seed-0deg-fem-quick\nworkpiece: {height_um: 5000, length_um: 10000}\n"
                 "numerics: {element_size_um: 0.25}\ncut: {length_um: 100}\n")
    r, elapsed = _cli("run", str(f), "--json", timeout=60)
    line = _one_line_error(r)
    assert "numerics.element_size_um = 0.25" in line and "elements" in line and "workpiece.height_um = 5000" in line
    assert re.search(r"estimated [0-9.e+]+ elements", line)
    assert elapsed < 20


def test_plot_on_a_file_that_is_not_hdf5(tmp_path):
    f = tmp_path / "notes.h5"
    f.write_text("not an HDF5 file")
    line = _one_line_error(_cli("plot", str(f))[0])
    assert "not an HDF5 file" in line and "notes.h5" in line


@pytest.mark.parametrize("url", ["bogus://x", "postgresql+nosuchdriver://u@h/db", "::::"])
def test_worker_with_a_bad_database_url(tmp_path, url):
    line = _one_line_error(_cli("worker", "--db", url, "--data", str(tmp_path))[0])
    assert "--db" in line and "allowed: sqlite:///PATH or postgresql+psycopg://" in line


def test_serve_without_the_postgresql_driver_names_the_extra(tmp_path):
    no_psycopg = [sys.executable, "-c", "import sys; sys.modules['psycopg'] = None; from cli.main import main; sys.exit(main())"]
    r, _ = _cli("serve", "--db", "postgresql+psycopg://u@127.0.0.1:1/x", "--data", str(tmp_path), "--workers", "0",
                prefix=no_psycopg)
    line = _one_line_error(r)
    assert "fibrecut[postgres]" in line


@pytest.mark.parametrize("args", [["--url", "http://127.0.0.1:9", "status"], ["status", "--url", "http://127.0.0.1:9"],
                                  ["--url", "http://127.0.0.1:9", "--token", "t", "cancel", "3"]])
def test_global_options_before_or_after_the_command(args):
    line = _one_line_error(_cli(*args)[0], code=1)
    assert "cannot reach the fibrecut service at http://127.0.0.1:9" in line


def test_a_boolean_for_a_number_in_set():
    line = _one_line_error(_cli("run", "seed-0deg-fem-quick", "--set", "fidelity=analytic", "--set", "cut.depth_um=true")[0])
    assert "cut.depth_um" in line and "boolean" in line


@pytest.mark.parametrize("value, says", [("abc", "valid number"), ("-5", "0.1 <= sigma_u_MPa"),
                                          ("700", "compressive_yield_MPa")])
def test_a_verification_case_setting_out_of_range(value, says):
    """The micro-zone cell's matrix yield is checked as the scene's field, before the cell runs."""
    r, _ = _cli("verify", "ply-transverse", "--set", f"matrix_sigma_u_MPa={value}")
    line = _one_line_error(r)
    assert "materials.matrix" in line and says in line, line


def test_the_readme_serve_command_installs_the_postgresql_driver():
    """scripts/serve.sh (the README's serve command) installs extras that bring psycopg, so
    `fibrecut serve --db postgresql+psycopg://...` works in the environment it creates."""
    text = (ROOT / "scripts" / "serve.sh").read_text()
    specs = re.findall(r"pip install -q -e (\S+)", text)
    assert specs, "serve.sh installs fibrecut with pip install -e"
    extras = set()
    for spec in specs:
        m = re.search(r"\[([^\]]*)\]", spec)
        extras |= set(x.strip() for x in m.group(1).split(",")) if m else set()
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    reqs = list(project["dependencies"]) + [r for e in extras for r in project["optional-dependencies"].get(e, [])]
    assert any(r.replace(" ", "").startswith("psycopg") for r in reqs), (specs, reqs)


@pytest.mark.postgres
def test_serve_on_postgresql_as_the_readme_says(pg_url, tmp_path):
    """`fibrecut serve --db postgresql+psycopg://...` starts and answers on PostgreSQL."""
    import os
    import socket

    import httpx

    from harness import stop_processes, wait_for

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc = subprocess.Popen([*FIBRECUT, "serve", "--db", pg_url, "--data", str(tmp_path), "--port", str(port), "--workers", "0"],
                            cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)}, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, start_new_session=True)
    try:
        def up():
            try:
                return httpx.get(f"http://127.0.0.1:{port}/api/health", timeout=2).json()
            except (httpx.HTTPError, ValueError):
                return None

        health = wait_for(up, 60, what="fibrecut serve on PostgreSQL answering")
    finally:
        stop_processes([proc])
    assert health["status"] == "ok" and health["database"] == "postgresql"
