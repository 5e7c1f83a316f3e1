"""Compiling the solver's numba kernels once per installation, not in every worker, and keeping
compilation out of a run's wall time.

- :func:`compile_kernels` (called by :func:`solver.run` before a numerical fidelity starts its
  clock) runs a tiny cut of that fidelity once per process: the first time after an install or an
  edit it compiles the kernels into numba's cache, after that it loads them. Its seconds are the
  run's ``compile_time_s``; ``wall_time_s`` is the run alone.
- ``python -m solver.warmup`` compiles every fidelity's kernels and writes a marker keyed on the
  sources (solver.cachestamp's hash): ``fibrecut serve`` starts it at its first start after an
  install (``/api/health`` and the dashboard show ``kernels: compiling`` meanwhile) and its workers
  wait for it before an FEM job instead of each compiling the same kernels.
- :func:`state`: ``ready`` (the marker matches the sources), ``compiling`` (a warm-up process is
  running), or ``cold``.
"""

from __future__ import annotations

import os
import sys
import time

from . import cachestamp
from .run import FIDELITIES as _RUN

#: the fidelities whose kernels are compiled (solver.run.FIDELITIES)
FIDELITIES = tuple(name for name, fid in _RUN.items() if fid.compiled)
_TINY = {"fem2d": "seed-0deg-fem-quick", "hybrid2d": "seed-0deg-hybrid-d01-quick", "fem3d": "seed-0deg-fem3d-quick",
         "hybrid3d": "seed-0deg-hybrid3d-d01-quick"}
_done: dict[str, float] = {}
_ROOT = os.path.dirname(os.path.abspath(__file__))


def tiny_scene(fidelity: str, cut_um: float = 2.0):
    """A cut of a few micrometres on the quick scene (6 um: elements fail, fragments touch and,
    in the hybrid, particles are born, so every kernel runs once)."""
    from .scene import load_scene

    return load_scene(_TINY[fidelity], {"cut.length_um": cut_um, "numerics.n_frames": 1, "numerics.n_force_samples": 10})


def compile_kernels(fidelity: str, cut_um: float = 2.0) -> float:
    """Compile (or load from the cache) the kernels of ``fidelity`` in this process; the seconds
    it took the first time, 0 after. The short default cut loads the main loop's kernels; the
    rest load (from the cache that :func:`main` filled) when a run first needs them."""
    if fidelity not in FIDELITIES or fidelity in _done:
        return 0.0
    t0 = time.perf_counter()
    try:
        from .cutting import run_cutting

        run_cutting(tiny_scene(fidelity, cut_um))
    except Exception:  # noqa: BLE001 - the run itself reports what fails
        pass
    _done[fidelity] = time.perf_counter() - t0
    return _done[fidelity]


def _paths() -> tuple[str, str]:
    d = os.path.dirname(cachestamp.stamp_path(_ROOT))
    return os.path.join(d, "fibrecut-kernels.ready"), os.path.join(d, "fibrecut-kernels.compiling")


def pid_alive(pid: int) -> bool:
    """Whether a process of this host is running (a zombie is not)."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False
    except (OSError, IndexError):
        try:
            os.kill(pid, 0)
            return True
        except ProcessLookupError:
            return False
        except PermissionError:
            return True


def state() -> str:
    ready, lock = _paths()
    try:
        with open(ready) as fh:
            if fh.read().strip() == cachestamp.source_hash(_ROOT):
                return "ready"
    except OSError:
        pass
    try:
        with open(lock) as fh:
            if pid_alive(int(fh.read().strip() or 0)):
                return "compiling"
    except (OSError, ValueError):
        pass
    return "cold"


def wait_ready(timeout: float, should_stop=lambda: False) -> str:
    """Wait while another process compiles; the state when it ends (or at the timeout)."""
    deadline = time.time() + timeout
    s = state()
    while s == "compiling" and time.time() < deadline and not should_stop():
        time.sleep(0.5)
        s = state()
    return s


def main() -> int:
    """Compile every fidelity's kernels into numba's cache and write the ready marker."""
    ready, lock = _paths()
    if state() == "ready":
        print("solver kernels: ready")
        return 0
    with open(lock, "w") as fh:
        fh.write(str(os.getpid()))
    try:
        print("compiling solver kernels ...", flush=True)
        t0 = time.perf_counter()
        for fid in FIDELITIES:
            compile_kernels(fid, cut_um=6.0)
        tmp = f"{ready}.{os.getpid()}"
        with open(tmp, "w") as fh:
            fh.write(cachestamp.source_hash(_ROOT))
        os.replace(tmp, ready)
        print(f"solver kernels: ready ({time.perf_counter() - t0:.0f} s)")
    finally:
        try:
            os.remove(lock)
        except OSError:
            pass
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
