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

Where numba puts a source folder D's kernels (numba.core.caching's locators, tried in order):
``$NUMBA_CACHE_DIR/<name of D>_<sha1 of D's absolute path>/`` (numba 0.57 on; before it
``$NUMBA_CACHE_DIR/<D's absolute path>/``), else ``D/__pycache__/`` when writable, else the user's
cache folder ``$XDG_CACHE_HOME/numba/<name of D>_<sha1>/`` (``~/.cache``). :func:`cache_files`
looks in all of them; the stamp is kept in the first of them that is writable.
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


def _source_dirs(root: str) -> list[str]:
    dirs = {os.path.dirname(os.path.abspath(p)) for p in glob.glob(os.path.join(root, "**", "*.py"), recursive=True)}
    return sorted(dirs | {os.path.abspath(root)})


def _subpath(d: str) -> str:
    """numba's cache sub-folder for the source folder ``d`` (_CacheLocator.get_suitable_cache_subpath)."""
    return "_".join([os.path.basename(d), hashlib.sha1(d.encode()).hexdigest()])


def _user_cache_dir() -> str:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "numba")


def cache_dirs(root: str) -> list[str]:
    """Every folder where numba may keep the cached kernels of the sources under ``root``."""
    out = []
    env = os.environ.get("NUMBA_CACHE_DIR")
    for d in _source_dirs(root):
        if env:
            out.append(os.path.join(env, _subpath(d)))
            out.append(os.path.join(env, d.lstrip(os.sep)))  # numba before 0.57
        out.append(os.path.join(d, "__pycache__"))
        out.append(os.path.join(_user_cache_dir(), _subpath(d)))
    return out


def cache_files(root: str) -> list[str]:
    """The solver's cached kernels, wherever numba put them (see the module docstring)."""
    found = []
    for d in cache_dirs(root):
        for ext in ("nbi", "nbc"):
            found += glob.glob(os.path.join(d, f"*.{ext}"))
    return sorted(set(found))


def stamp_path(root: str) -> str:
    """The stamp's place: the first writable of numba's folders for ``root`` itself."""
    d = os.path.abspath(root)
    env = os.environ.get("NUMBA_CACHE_DIR")
    candidates = ([os.path.join(env, _subpath(d))] if env else []) + [os.path.join(d, "__pycache__"),
                                                                     os.path.join(_user_cache_dir(), _subpath(d))]
    for c in candidates:
        try:
            os.makedirs(c, exist_ok=True)
            if os.access(c, os.W_OK):
                return os.path.join(c, STAMP)
        except OSError:
            continue
    return os.path.join(candidates[-1], STAMP)


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
