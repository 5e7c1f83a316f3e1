"""Benchmarks (not timed tests): ``fibrecut bench NAME``.

Each benchmark module registers a function ``bench(threads: list[int], sizes: list[int]) -> list[dict]``
returning one row per measurement (size, threads, updates per second, ...).
"""

from __future__ import annotations

import importlib
from typing import Callable

_MODULES = {"fem": "solver.bench_fem", "sph": "solver.bench_sph", "analytic": "solver.bench_analytic"}


def available() -> list[str]:
    out = []
    for name, mod in _MODULES.items():
        if importlib.util.find_spec(mod) is not None:
            out.append(name)
    return out


def get(name: str) -> Callable[..., list[dict]]:
    return importlib.import_module(_MODULES[name]).bench
