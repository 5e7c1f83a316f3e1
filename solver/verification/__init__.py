"""Verification cases: each compares a solver result with an analytic reference.

A case is a function ``case(overrides: dict) -> CaseResult`` registered with
:func:`register`. Modules holding cases are listed in ``_MODULES`` and imported lazily,
so ``fibrecut verify`` pays only for what it runs.
"""

from __future__ import annotations

import importlib
from dataclasses import asdict, dataclass, field
from typing import Any, Callable

_MODULES = ("solver.verification.fem_cases", "solver.verification.contact_cases", "solver.verification.sph_cases",
            "solver.verification.ply_cases", "solver.verification.ploughing_cases",
            "solver.verification.fibre_cases", "solver.verification.fem3d_cases",
            "solver.verification.contact3d_cases", "solver.verification.sph3d_cases",
            "solver.verification.hybrid3d_cases", "solver.verification.ply3d_cases")
CASES: dict[str, tuple[Callable[[dict], "CaseResult"], str]] = {}


@dataclass
class CaseResult:
    case: str
    quantity: str  # what was compared, e.g. "P-wave speed"
    value: float  # what the solver gave
    reference: float  # the analytic reference
    error: float  # relative error |value - reference| / |reference| (or as the case defines)
    tolerance: float  # pass when error <= tolerance
    wall_time_s: float
    details: dict[str, Any] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return bool(self.error <= self.tolerance)

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["passed"] = self.passed
        return d


def register(name: str, description: str):
    def deco(fn):
        CASES[name] = (fn, description)
        return fn

    return deco


def _keys(overrides: dict, allowed: tuple):
    """Reject override names a case does not know (the error names the allowed ones)."""
    bad = sorted(set(overrides) - set(allowed))
    if bad:
        raise ValueError(f"{bad[0]} = {overrides[bad[0]]!r}: unknown setting for this case; allowed: {', '.join(allowed)}")


def _opt(overrides: dict, key: str, default, cast=float):
    """A case's setting ``key`` from the overrides (else ``default``), as ``cast``; a ValueError names it."""
    v = overrides.get(key, default)
    try:
        return cast(v)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{key} = {v!r}: must be {cast.__name__}") from exc


def _settings(overrides: dict, defaults: dict, positive=()) -> dict:
    """A case's settings: its ``defaults`` with the overrides (cast to float; names it does not know are
    rejected, :func:`_keys`), and those named in ``positive`` (all of them when True) checked > 0."""
    _keys(overrides, tuple(defaults))
    kw = {k: _opt(overrides, k, v) for k, v in defaults.items()}
    for k in (tuple(kw) if positive is True else positive):
        if not kw[k] > 0:
            raise ValueError(f"{k} = {kw[k]:g}: must be > 0")
    return kw


def load_cases() -> dict[str, tuple[Callable[[dict], CaseResult], str]]:
    for mod in _MODULES:
        try:
            importlib.import_module(mod)
        except ModuleNotFoundError as exc:
            if exc.name != mod:
                raise
    return CASES
