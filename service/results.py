"""Reading run files for the API: time series (downsampled) and frames as JSON-ready lists.

Paths are built only from a run id read from the database (``runs/<uuid hex>.h5`` under the
data folder), never from a request value.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

RUN_ID = re.compile(r"^[0-9a-f]{32}$")
SERIES_GROUPS = ("forces", "energies", "diagnostics")


def run_path(runs_dir: Path, run_id: str) -> Path:
    if not RUN_ID.match(run_id):  # run ids are uuid4 hex written by our workers
        raise ValueError(f"not a run id: {run_id!r}")
    return Path(runs_dir) / f"{run_id}.h5"


def _jsonable(arr: np.ndarray) -> Any:
    a = np.asarray(arr)
    if a.dtype.kind in "fc":
        a = a.astype(float)
        lst = a.tolist()
        if np.isfinite(a).all():
            return lst
        return _replace_nonfinite(lst)
    if a.dtype.kind in "iub":
        return a.tolist()
    if a.dtype.kind in "SOU":
        return [x.decode() if isinstance(x, bytes) else str(x) for x in a.ravel().tolist()]
    return a.tolist()


def _replace_nonfinite(x):
    if isinstance(x, list):
        return [_replace_nonfinite(v) for v in x]
    return x if math.isfinite(x) else None


def _downsample(arr: np.ndarray, max_points: int) -> np.ndarray:
    n = arr.shape[0] if arr.ndim else 0
    if n <= max_points:
        return arr
    idx = np.unique(np.linspace(0, n - 1, max_points).round().astype(int))
    return arr[idx]


def series(path: Path, max_points: int) -> dict[str, Any]:
    import h5py

    out: dict[str, Any] = {}
    with h5py.File(path, "r") as f:
        for group in SERIES_GROUPS:
            if group not in f:
                continue
            g = f[group]
            entry: dict[str, Any] = {}
            for name, ds in g.items():
                if isinstance(ds, h5py.Dataset):
                    data = ds[()]
                    entry[name] = _jsonable(_downsample(np.asarray(data), max_points)) if np.ndim(data) else _jsonable(np.asarray(data))
            for k, v in g.attrs.items():
                entry.setdefault("attrs", {})[k] = _attr(v)
            out[group] = entry
        out["summary"] = json.loads(f.attrs["summary"]) if "summary" in f.attrs else None
    return out


def _attr(v):
    if isinstance(v, bytes):
        v = v.decode()
    if isinstance(v, str):
        try:
            return json.loads(v)
        except ValueError:
            return v
    if isinstance(v, np.ndarray):
        return _jsonable(v)
    if isinstance(v, (np.floating, float)):
        return float(v) if math.isfinite(v) else None
    if isinstance(v, np.integer):
        return int(v)
    return v


def frame_index(path: Path) -> dict[str, Any]:
    import h5py

    with h5py.File(path, "r") as f:
        if "frames" not in f:
            return {"count": 0, "times": [], "fields": []}
        names = sorted(f["frames"].keys())
        times = [_attr(f["frames"][n].attrs.get("time", float("nan"))) for n in names]
        fields = sorted(f["frames"][names[0]].keys()) if names else []
        return {"count": len(names), "times": times, "fields": fields}


def frame(path: Path, k: int) -> dict[str, Any] | None:
    import h5py

    with h5py.File(path, "r") as f:
        if "frames" not in f:
            return None
        name = f"{k:04d}"
        if name not in f["frames"]:
            return None
        g = f["frames"][name]
        out: dict[str, Any] = {"index": k, "time": _attr(g.attrs.get("time", float("nan")))}
        for field, ds in g.items():
            arr = np.asarray(ds[()])
            out[field] = {"shape": list(arr.shape), "data": _jsonable(arr)}
        pos = None
        if "particles_positions" in g:  # hybrid3d: (n, 3), the dashboard draws the side view
            pos = np.asarray(g["particles_positions"][()])[:, :2]
        elif "particles_x" in g and "particles_y" in g:  # hybrid2d
            pos = np.stack([np.asarray(g["particles_x"][()]), np.asarray(g["particles_y"][()])], axis=1)
        if pos is not None:
            # the active SPH particles, in the shape the dashboard draws (positions as (n, 2) rows)
            out["particles"] = {"positions": {"shape": list(pos.shape), "data": _jsonable(pos)}}
            for key in ("material", "damage"):
                if f"particles_{key}" in g:
                    arr = np.asarray(g[f"particles_{key}"][()])
                    out["particles"][key] = {"shape": list(arr.shape), "data": _jsonable(arr)}
        return out
