"""Hygiene of numba's on-disk cache for the whole solver.

numba keys a cached kernel on the source file that defines it (its modification time and size).
A kernel that calls or inlines kernels and constants of *other* files (the FEM chunk inlines the
element, cohesive and contact kernels; the SPH step the tool contact and the particle coupling)
stays stale after an edit there: it runs old code, or crashes. Stale code is also silent: a
development tree once gave 2.42 and 3.46 N/mm on seed-0deg-fem-quick against 3.18 from a clean
compile.

:func:`check` (run by ``solver/__init__.py`` before any kernel is loaded) hashes the text of every
source file of the solver package, with the numba and Python versions, and, when the hash differs
from the stamp of the last check, deletes every cached kernel of the package (``*.nbi``/``*.nbc``
in the ``__pycache__`` folders next to the sources, or under ``NUMBA_CACHE_DIR``), then writes the
new stamp. An installed release never changes, so its caches live until the next upgrade; a
developer's edit costs one recompilation of everything (about a minute), never a stale kernel.
"""

from __future__ import annotations

import glob
import hashlib
import os
import sys

STAMP = "fibrecut-numba.stamp"


def source_hash(root: str) -> str:
    # numba's version from its metadata: importing numba here would load it into runs that never
    # compile anything (the analytic model)
    from importlib.metadata import version

    h = hashlib.sha1(f"{version('numba')} {version('llvmlite')} {sys.version}".encode())
    for p in sorted(glob.glob(os.path.join(root, "**", "*.py"), recursive=True)):
        h.update(os.path.relpath(p, root).encode())
        with open(p, "rb") as fh:
            h.update(fh.read())
    return h.hexdigest()


def cache_files(root: str) -> list[str]:
    """The solver's cached kernels: next to the sources, and under NUMBA_CACHE_DIR (which mirrors
    the source folders' absolute paths)."""
    found = []
    for ext in ("nbi", "nbc"):
        found += glob.glob(os.path.join(root, "**", "__pycache__", f"*.{ext}"), recursive=True)
    env = os.environ.get("NUMBA_CACHE_DIR")
    if env:
        mirror = os.path.join(env, os.path.abspath(root).lstrip(os.sep))
        for ext in ("nbi", "nbc"):
            found += glob.glob(os.path.join(mirror, "**", f"*.{ext}"), recursive=True)
    return found


def stamp_path(root: str) -> str:
    env = os.environ.get("NUMBA_CACHE_DIR")
    base = os.path.join(env, os.path.abspath(root).lstrip(os.sep)) if env else os.path.join(root, "__pycache__")
    return os.path.join(base, STAMP)


def check(root: str | None = None) -> bool:
    """Delete the solver's cached kernels if any source changed since the last check; True if it did."""
    try:
        root = root or os.path.dirname(os.path.abspath(__file__))
        stamp = source_hash(root)
        path = stamp_path(root)
        try:
            with open(path) as fh:
                if fh.read() == stamp:
                    return False
        except OSError:
            pass
        for f in cache_files(root):
            try:
                os.remove(f)
            except OSError:
                pass
        os.makedirs(os.path.dirname(path), exist_ok=True)
        tmp = f"{path}.{os.getpid()}"
        with open(tmp, "w") as fh:
            fh.write(stamp)
        os.replace(tmp, path)
        return True
    except Exception:  # cache hygiene must never break a run
        return False
