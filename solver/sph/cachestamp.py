"""Hygiene of numba's on-disk cache for the SPH package.

numba keys a cached function on its own source file only; a kernel that calls (and inlines)
kernels or constants of other files stays stale after an edit there, which can end in a
segmentation fault. :func:`check` (run by ``solver/sph/__init__.py`` before any kernel is loaded)
hashes every source file of solver/sph plus solver/contact.py and solver/tool.py (the tool contact
the SPH loop calls) and, when the hash differs from the stamp of the last check, deletes the
package's cached kernels (``__pycache__`` next to the sources, or under ``NUMBA_CACHE_DIR``).
"""

from __future__ import annotations

import glob
import hashlib
import os


def check() -> None:
    try:
        here = os.path.dirname(os.path.abspath(__file__))
        paths = sorted(glob.glob(os.path.join(here, "*.py")))
        paths += [os.path.join(here, "..", "contact.py"), os.path.join(here, "..", "tool.py")]
        h = hashlib.sha1()
        for p in paths:
            if os.path.exists(p):
                with open(p, "rb") as fh:
                    h.update(fh.read())
        stamp = h.hexdigest()
        dirs = [os.path.join(here, "__pycache__")]
        env = os.environ.get("NUMBA_CACHE_DIR")
        if env:
            dirs += [d for d in glob.glob(os.path.join(env, "**", ""), recursive=True)
                     if "sph" in os.path.basename(d.rstrip(os.sep))]
        for d in dirs:
            path = os.path.join(d, "sph_deps.stamp")
            old = open(path).read() if os.path.exists(path) else ""
            if old == stamp:
                continue
            for f in glob.glob(os.path.join(d, "*.nbi")) + glob.glob(os.path.join(d, "*.nbc")):
                try:
                    os.remove(f)
                except OSError:
                    pass
            os.makedirs(d, exist_ok=True)
            with open(path, "w") as fh:
                fh.write(stamp)
    except Exception:  # cache hygiene must never break a run
        pass
