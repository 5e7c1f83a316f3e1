"""Sweep designs: full grid, Latin hypercube and Sobol (scipy.stats.qmc) over named parameters.

A parameter is either explicit ``values`` or a range ``low``..``high`` (``log``, ``step``).
The unit hypercube maps to a range linearly (or in log space), is rounded to ``step`` when
given, and to an explicit list by equal-width bins.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np


def grid_values(spec) -> list[Any]:
    """The grid levels of one parameter; a range needs a step (or log with values)."""
    if spec.values is not None:
        return list(spec.values)
    if spec.step is None:
        raise ValueError("a grid over a range needs step (or give values: [...])")
    n = int(math.floor((spec.high - spec.low) / spec.step + 1e-9)) + 1
    return [_clean(spec.low + i * spec.step) for i in range(n)]


def grid_size(parameters: dict) -> float:
    """Points of the full grid (a float: it may be astronomically large, or inf)."""
    size = 1.0
    for spec in parameters.values():
        if spec.values is not None:
            size *= len(spec.values)
        elif spec.step:
            levels = (spec.high - spec.low) / spec.step
            size *= math.floor(levels + 1e-9) + 1 if math.isfinite(levels) and levels < 1e15 else math.inf
        else:
            size = 0.0
    return size


def grid(parameters: dict) -> list[dict[str, Any]]:
    names = list(parameters)
    levels = [grid_values(parameters[n]) for n in names]
    return [dict(zip(names, combo)) for combo in itertools.product(*levels)]


def from_unit(spec, u: float) -> Any:
    """Map u in [0, 1) to a parameter value."""
    if spec.values is not None:
        return spec.values[min(int(u * len(spec.values)), len(spec.values) - 1)]
    if spec.log:
        return _clean(math.exp(math.log(spec.low) + u * (math.log(spec.high) - math.log(spec.low))))
    x = spec.low + u * (spec.high - spec.low)
    if spec.step is not None:
        x = spec.low + round((x - spec.low) / spec.step) * spec.step
        x = min(x, spec.high)
    return _clean(x)


def sample(parameters: dict, design: str, n_points: int, seed: int | None) -> list[dict[str, Any]]:
    """``lhs`` or ``sobol`` points (scrambled Sobol; n_points need not be a power of two)."""
    from scipy.stats import qmc

    names = list(parameters)
    d = len(names)
    if design == "lhs":
        u = qmc.LatinHypercube(d=d, seed=seed).random(n_points)
    elif design == "sobol":
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # balance warning when n_points is not 2^m
            u = qmc.Sobol(d=d, scramble=True, seed=seed).random(n_points)
    else:
        raise ValueError(f"unknown design {design!r}")
    return [{n: from_unit(parameters[n], float(row[j])) for j, n in enumerate(names)} for row in np.asarray(u)]


def _clean(x: float) -> float:
    """Round away binary noise (0.30000000000000004 -> 0.3) so equal points hash equally."""
    return float(f"{x:.12g}")
