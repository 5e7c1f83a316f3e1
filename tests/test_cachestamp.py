"""numba cache hygiene (solver.cachestamp): an edit of any solver source clears every cached kernel,
so no kernel runs stale code inlined from another file."""

import os

import pytest

from solver import cachestamp


def _tree(root):
    (root / "sub" / "__pycache__").mkdir(parents=True)
    (root / "__pycache__").mkdir()
    (root / "a.py").write_text("X = 1\n")
    (root / "sub" / "b.py").write_text("Y = 2\n")
    cached = [root / "__pycache__" / "a.f-1.py311.nbi", root / "sub" / "__pycache__" / "b.g-3.py311.1.nbc"]
    for f in cached:
        f.write_bytes(b"code")
    return cached


def test_an_edit_in_any_file_clears_all_cached_kernels(tmp_path, monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    cached = _tree(tmp_path)
    assert cachestamp.check(str(tmp_path))  # first check: no stamp yet, clears
    assert not any(f.exists() for f in cached)
    for f in cached:
        f.write_bytes(b"code")  # compiled again
    assert not cachestamp.check(str(tmp_path))  # nothing changed: the caches stay
    assert all(f.exists() for f in cached)
    (tmp_path / "sub" / "b.py").write_text("Y = 3\n")  # an edit in another file than a.py's
    assert cachestamp.check(str(tmp_path))
    assert not any(f.exists() for f in cached)


def test_caches_under_numba_cache_dir_are_cleared_too(tmp_path, monkeypatch):
    src = tmp_path / "src"
    src.mkdir()
    (src / "a.py").write_text("X = 1\n")
    cache_dir = tmp_path / "numba"
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(cache_dir))
    mirror = cache_dir / os.path.abspath(src).lstrip(os.sep)
    mirror.mkdir(parents=True)
    f = mirror / "a.f-1.py311.nbi"
    f.write_bytes(b"code")
    cachestamp.check(str(src))
    f.write_bytes(b"code")
    (src / "a.py").write_text("X = 2\n")
    assert cachestamp.check(str(src)) and not f.exists()


def _package(root):
    """A tiny package like the solver: a cached kernel that inlines a constant of another file,
    with the solver's own cache hygiene run at import."""
    import shutil

    pkg = root / "kpkg"
    pkg.mkdir()
    shutil.copy(cachestamp.__file__, pkg / "cachestamp.py")
    (pkg / "__init__.py").write_text("from . import cachestamp\ncachestamp.check()\n")
    (pkg / "consts.py").write_text("K = 1\n")
    (pkg / "kern.py").write_text("from numba import njit\nfrom .consts import K\n\n\n@njit(cache=True)\ndef f():\n    return K\n")
    return pkg


def _run_kernel(root, env):
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-c", "from kpkg.kern import f; print(f())"], cwd=root, env=env,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    return int(r.stdout.strip())



@pytest.mark.parametrize("cache_dir", [True, False], ids=["NUMBA_CACHE_DIR set", "NUMBA_CACHE_DIR unset"])
def test_an_edit_runs_new_code_wherever_numba_caches(tmp_path, cache_dir):
    """Edit a constant a cached kernel inlines from another file: the next process runs the new
    value, with NUMBA_CACHE_DIR set (as the Dockerfile does) and unset (caches next to the sources)."""
    root = tmp_path / "tree"
    root.mkdir()
    pkg = _package(root)
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(PYTHONPATH=str(root), XDG_CACHE_HOME=str(tmp_path / "xdg"))
    if cache_dir:
        env["NUMBA_CACHE_DIR"] = str(tmp_path / "numba-cache")
    assert _run_kernel(root, env) == 1
    where = (tmp_path / "numba-cache") if cache_dir else (pkg / "__pycache__")
    assert list(where.rglob("*.nbi")), "numba cached the kernel where this test expects it"
    (pkg / "consts.py").write_text("K = 2\n")
    assert _run_kernel(root, env) == 2
