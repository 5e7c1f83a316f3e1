"""The result of one run and its HDF5 form (README "Results": root attributes, /forces, /energies, /frames, /diagnostics).

A :class:`Result` holds the summary metrics (user-facing units), the status
(``ok``, ``unstable``, ``failed``, ``cancelled``), warnings, the stability diagnosis and
the time series and frames a fidelity produced. Only what a scene asked for is stored:
empty groups are not written.
"""

from __future__ import annotations

import json
import math
import os
import socket
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

SOLVER_VERSION = "0.1.0"
STATUSES = ("ok", "unstable", "failed", "cancelled")

#: The numeric metrics of a run: what a study may optimise, constrain or report (the REST
#: contract's ``Metric``). Every summary carries all but the last (NaN where a fidelity has no
#: value); ``material_removal_rate_mm2_s`` comes from the scene's cut (solver.run).
METRICS = (
    "cutting_force_N_per_mm",
    "thrust_force_N_per_mm",
    "damage_depth_um",
    "bounce_back_um",
    "energy_error",
    "wall_time_s",
    "steps",
    "material_removal_rate_mm2_s",
)
#: Keys every summary carries (the CLI/REST contract).
CONTRACT_KEYS = METRICS[:-1] + ("status", "warnings")


@dataclass
class Result:
    scene: Any  # solver.scene.Scene
    status: str = "ok"
    metrics: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    diagnosis: dict[str, Any] | None = None  # stability or failure finding: check, where, when, what to change
    series: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)  # HDF5 group -> datasets
    frames: list[dict[str, np.ndarray]] = field(default_factory=list)
    frame_times: list[float] = field(default_factory=list)
    build: dict[str, Any] = field(default_factory=dict)  # what the scene built: modules, arrays, bytes, seconds
    wall_time_s: float = 0.0
    steps: int = 0

    def __post_init__(self):
        if self.status not in STATUSES:
            raise ValueError(f"status {self.status!r} not in {STATUSES}")

    # ------------------------------------------------------------------ summary
    def summary(self) -> dict[str, Any]:
        """The JSON summary of the contract, plus every other metric of the run."""
        out: dict[str, Any] = {}
        for key in CONTRACT_KEYS[:5]:
            out[key] = _finite_or_none(self.metrics.get(key, math.nan))
        out.update({k: _finite_or_none(v) if isinstance(v, (float, int, np.floating)) and not isinstance(v, bool) else v
                    for k, v in self.metrics.items() if k not in out})
        out["wall_time_s"] = round(float(self.wall_time_s), 6)
        out["steps"] = int(self.steps)
        out["status"] = self.status
        out["warnings"] = list(self.warnings)
        out["fidelity"] = self.scene.fidelity
        out["scene"] = self.scene.name
        if self.diagnosis:
            out["diagnosis"] = self.diagnosis
        return out

    # ------------------------------------------------------------------ HDF5
    def write_hdf5(self, path: str | os.PathLike) -> Path:
        """Write the run atomically: a temporary file in the same folder, then a rename; a 3D run also gets
        ``<run>.xdmf`` beside it (:mod:`solver.xdmf`)."""
        import h5py

        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".h5", dir=path.parent)
        os.close(fd)
        try:
            with h5py.File(tmp, "w") as f:
                f.attrs["scene"] = self.scene.model_dump_json()
                f.attrs["solver_version"] = SOLVER_VERSION
                f.attrs["summary"] = json.dumps(self.summary(), default=_json_default)
                f.attrs["status"] = self.status
                f.attrs["wall_time_s"] = float(self.wall_time_s)
                f.attrs["host"] = socket.gethostname()
                if self.build:
                    f.attrs["build"] = json.dumps(self.build, default=_json_default)
                for group, datasets in self.series.items():
                    if not datasets:
                        continue
                    g = f.create_group(group)
                    for name, arr in datasets.items():
                        g.create_dataset(name, data=np.asarray(arr), compression="gzip" if np.size(arr) > 4096 else None)
                if self.diagnosis:
                    g = f.require_group("diagnostics")
                    g.attrs["finding"] = json.dumps(self.diagnosis, default=_json_default)
                if self.frames:
                    g = f.create_group("frames")
                    for i, frame in enumerate(self.frames):
                        fg = g.create_group(f"{i:04d}")
                        if i < len(self.frame_times):
                            fg.attrs["time"] = self.frame_times[i]
                        for name, arr in frame.items():
                            fg.create_dataset(name, data=np.asarray(arr), compression="gzip" if np.size(arr) > 4096 else None)
            os.replace(tmp, path)
        except BaseException:
            if os.path.exists(tmp):
                os.unlink(tmp)
            raise
        if "hexes" in self.series.get("mesh", {}):  # a 3D run: its frames (and particles) as time series for ParaView
            from .xdmf import write_particles_xdmf, write_xdmf

            write_xdmf(path)
            write_particles_xdmf(path)
        return path


def read_summary(path: str | os.PathLike) -> dict[str, Any]:
    """The summary stored in a result file's root attributes."""
    import h5py

    with h5py.File(path, "r") as f:
        return json.loads(f.attrs["summary"])


def _finite_or_none(v):
    v = float(v)
    return v if math.isfinite(v) else None


def _json_default(o):
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o) if math.isfinite(o) else None
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)
