"""What a cutting run reports: mean forces, damage depth, bounce-back and chip frames.

All functions take SI arrays and return SI values unless their name says otherwise; the
conversion to user units happens in :mod:`solver.cutting` when the metrics are assembled.
"""

from __future__ import annotations

import numpy as np

from .mesh import EHM, FIBRE, MATRIX

#: the steady part of the cut: the last half of the tool's travel (SOLVER_NOTES.md 1; the
#: first half contains the entry transient while the chip forms)
STEADY_FROM = 0.5


def steady_mask(travel: np.ndarray, cut_length: float, start_fraction: float = STEADY_FROM) -> np.ndarray:
    """Samples whose tool travel lies in [start_fraction x cut_length, cut_length]."""
    return (travel >= start_fraction * cut_length * (1 - 1e-9)) & (travel <= cut_length * (1 + 1e-9))


def mean_forces(travel, fc, ft, cut_length, start_fraction: float = STEADY_FROM):
    """Mean Fc, Ft over the steady window and the window's description (travel in um, samples)."""
    m = steady_mask(np.asarray(travel), cut_length, start_fraction)
    if not m.any():
        return float("nan"), float("nan"), {"travel_from_um": start_fraction * cut_length * 1e6,
                                             "travel_to_um": cut_length * 1e6, "samples": 0}
    win = {"travel_from_um": float(start_fraction * cut_length * 1e6), "travel_to_um": float(cut_length * 1e6),
           "samples": int(m.sum()), "rule": f"last {100 * (1 - start_fraction):.0f} % of the cut length"}
    return float(np.mean(fc[m])), float(np.mean(ft[m])), win


def peak_forces(travel, fc, ft) -> dict:
    """The largest sampled cutting and thrust forces and the tool travel (in the units of ``travel``) at
    which each is reached.

    A fracturing cut is not steady: the force builds up while the tool engages, until the material
    ahead of it gives way, and then falls (docs/validation.md, "What sets the steady forces"). The
    peak is the load the tool must carry at least once; the steady mean (:func:`mean_forces`) is
    what it carries on average. NaN when nothing was sampled.
    """
    out = {}
    for name, f in (("cutting", np.asarray(fc)), ("thrust", np.asarray(ft))):
        ok = np.isfinite(f)
        if not ok.any():
            out[name], out[f"{name}_travel"] = float("nan"), float("nan")
            continue
        i = int(np.flatnonzero(ok)[np.argmax(f[ok])])
        out[name], out[f"{name}_travel"] = float(f[i]), float(np.asarray(travel)[i])
    return out


def damage_depth(mesh, elem_failed: np.ndarray, coh_failed: np.ndarray | None, y_cut: float,
                 materials=(MATRIX,)) -> float:
    """Deepest failed matrix element or cohesive element below the cut plane [m], >= 0.

    Uses the reference (initial) positions: the depth is that of the material point that
    failed, measured from the cut plane y_cut downward (element: lowest node; cohesive element:
    lowest of its two initial end points). 0 when nothing failed below the plane.
    """
    deepest = y_cut
    sel = elem_failed.astype(bool) & np.isin(mesh.material, materials)
    if sel.any():
        deepest = min(deepest, float(mesh.y[mesh.quads[sel]].min()))
    if coh_failed is not None and mesh.n_cohesive and np.any(coh_failed):
        c = mesh.cohesive[coh_failed.astype(bool)]
        deepest = min(deepest, float(mesh.y[c[:, :2]].min()))
    return max(0.0, y_cut - deepest)


def bounce_back(px, py, node_alive, tool, y_cut: float, window: float, n_bins: int = 8):
    """Elastic recovery of the machined surface behind the cutting edge [m].

    Behind the edge (x from the arc centre + r to + r + ``window``) and below the arc centre,
    the machined surface in each of ``n_bins`` x-bins is the highest living node; the
    bounce-back is the mean height of that surface above the tool's lowest point (the cut
    plane y_cut): material that sprang back up after the edge passed. Returns (value, bins used);
    NaN when no surface lies behind the edge (e.g. before the tool entered).
    """
    xc, yc, r = tool[0], tool[1], tool[4]
    x0, x1 = xc + r, xc + r + window
    sel = node_alive.astype(bool) & (px >= x0) & (px < x1) & (py < yc)
    if not sel.any():
        return float("nan"), 0
    b = np.minimum(((px[sel] - x0) / (x1 - x0) * n_bins).astype(int), n_bins - 1)
    top = np.full(n_bins, -np.inf)
    np.maximum.at(top, b, py[sel])
    ok = np.isfinite(top)
    return float(np.mean(top[ok]) - y_cut), int(ok.sum())


def frame(fields, px, py, material, elem_failed, damage, stress) -> dict[str, np.ndarray]:
    """One chip frame holding only the requested fields (numerics.frame_fields).

    positions: (n_nodes, 2) current [m]; material: (n_elems,) 0 fibre / 1 matrix / 2 EHM;
    state: (n_elems,) 0 alive / 1 failed (deleted); damage: (n_elems,) in [0, 1];
    stress: (n_elems, 3) sigma_xx, sigma_yy, sigma_xy [Pa].
    """
    out: dict[str, np.ndarray] = {}
    for f in fields:
        if f == "positions":
            out[f] = np.stack([px, py], axis=1).astype(np.float64)
        elif f == "material":
            out[f] = np.asarray(material, np.int8).copy()
        elif f == "state":
            out[f] = np.asarray(elem_failed, np.uint8).copy()
        elif f == "damage":
            out[f] = np.asarray(damage, np.float32).copy()
        elif f == "stress":
            out[f] = np.asarray(stress, np.float32).copy()
    return out


def frame_times(t_end: float, n_frames: int) -> np.ndarray:
    """Evenly spaced frame times ending at t_end (none when n_frames = 0)."""
    if n_frames <= 0:
        return np.zeros(0)
    return t_end * np.arange(1, n_frames + 1) / n_frames


__all__ = ["STEADY_FROM", "steady_mask", "mean_forces", "damage_depth", "bounce_back", "frame", "frame_times",
           "FIBRE", "MATRIX", "EHM"]
