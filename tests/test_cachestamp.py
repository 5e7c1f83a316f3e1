"""numba cache hygiene (solver.cachestamp): an edit of any solver source clears every cached kernel,
so no kernel runs stale code inlined from another file."""

import os

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
