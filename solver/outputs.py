"""What a cutting run reports: mean forces, damage depth, bounce-back and chip frames.

All functions take SI arrays and return SI values unless their name says otherwise; the
conversion to user units happens in :mod:`solver.cutting` when the metrics are assembled.
"""

from __future__ import annotations

import math

import numpy as np

from .mesh import EHM, FIBRE, MATRIX

#: the latest start of the steady window as a fraction of the cut length: the window is never shorter
#: than the last half of the cut (the truncation rule below may not discard more than half the samples)
STEADY_FROM = 0.5
#: batch size of the truncation rule (MSER-5)
MSER_BATCH = 5


def window_mask(travel: np.ndarray, start: float, cut_length: float) -> np.ndarray:
    """Samples whose tool travel lies in the window [start, cut_length] (round-off tolerant at both ends)."""
    return (travel >= start * (1 - 1e-9)) & (travel <= cut_length * (1 + 1e-9))


def steady_mask(travel: np.ndarray, cut_length: float, start_fraction: float = STEADY_FROM) -> np.ndarray:
    """Samples whose tool travel lies in [start_fraction x cut_length, cut_length]."""
    return window_mask(travel, start_fraction * cut_length, cut_length)


def steady_start(travel, fc, cut_length, batch: int = MSER_BATCH) -> float:
    """Where the steady cut begins [units of ``travel``]: the end of the engagement transient in the
    cutting force history, by the marginal standard error rule (MSER-5; White 1997, Simulation 69:323;
    Hoad, Robinson & Davies 2010, J. Oper. Res. Soc. 61:1389).

    The samples with the tool in the cut (0 <= travel <= cut_length) are grouped in batches of
    ``batch``; the truncation point d (in batches) minimises s^2(y_d..y_m) / (m - d)^2, the squared
    standard error of the mean of what is kept. d is searched from the first batch at which the force
    has risen to half the mean of the last half of the cut (the entry's rise is never kept) to half of
    the batches, so the window keeps at least the last half of the cut (:data:`STEADY_FROM`). Returns the travel of
    the first kept sample; ``STEADY_FROM x cut_length`` when too few samples exist to judge.
    """
    travel = np.asarray(travel, float)
    fc = np.asarray(fc, float)
    sel = (travel >= 0.0) & (travel <= cut_length * (1 + 1e-9)) & np.isfinite(fc)
    t, f = travel[sel], fc[sel]
    m = f.size // batch
    if m < 4:
        return STEADY_FROM * cut_length
    f, t = f[f.size - m * batch:], t[t.size - m * batch:]  # batches aligned on the end of the cut
    y = f.reshape(m, batch).mean(axis=1)
    # never before the force has built up: the first batch reaching half the mean of the last half of the cut
    level = 0.5 * y[m - m // 2:].mean()
    rise = np.flatnonzero(y >= level)
    d0 = min(int(rise[0]) if rise.size and level > 0 else 0, m // 2)
    best, d_best = np.inf, d0
    for d in range(d0, m // 2 + 1):
        rest = y[d:]
        score = rest.var() / (rest.size ** 2)
        if score < best:
            best, d_best = score, d
    return float(t[d_best * batch])


#: the steady window is reported as drifting when the means of its two halves differ by more than this many
#: standard errors (of batch means) and by more than :data:`DRIFT_RELATIVE` of the window's mean
DRIFT_Z = 3.0
DRIFT_RELATIVE = 0.1


def steady_drift(travel, fc, start, cut_length, batch: int = MSER_BATCH) -> tuple[float, float]:
    """Whether the force settled in the steady window [start, cut_length]: (drift, z), drift = (mean of the
    window's second half - mean of its first half) / mean of the window, z = that difference over its standard
    error from the batch means of ``batch`` samples in each half (Geweke's comparison of the early and late
    parts of a series, Bayesian Statistics 4 (1992) 169, with batch means for the variances; Schruben,
    Oper. Res. 30 (1982) 569). A cut whose force still rises or falls in its window (a layer breaking off
    near its end, a history shorter than a chip's cycle) has |z| large: its mean is not that of a steady cut.
    (nan, nan) when a half holds fewer than two batches."""
    travel = np.asarray(travel, float)
    fc = np.asarray(fc, float)
    f = fc[window_mask(travel, start, cut_length) & np.isfinite(fc)]
    half = f.size // 2
    k = half // batch
    if k < 2:
        return float("nan"), float("nan")
    a = f[:k * batch].reshape(k, batch).mean(axis=1)  # the first half's batches, from the window's start
    b = f[f.size - k * batch:].reshape(k, batch).mean(axis=1)  # the second half's, to the cut's end
    diff = float(b.mean() - a.mean())
    se = math.sqrt((a.var(ddof=1) + b.var(ddof=1)) / k)
    mean = float(f.mean())
    drift = diff / abs(mean) if mean != 0.0 else float("nan")
    z = diff / se if se > 0.0 else (0.0 if diff == 0.0 else math.copysign(math.inf, diff))
    return drift, z


def steady_settled(drift: float, z: float) -> bool:
    """False when the window's halves differ beyond :data:`DRIFT_Z` standard errors and :data:`DRIFT_RELATIVE`
    of its mean (:func:`steady_drift`); True otherwise, also when it cannot be judged."""
    return not (abs(z) > DRIFT_Z and abs(drift) > DRIFT_RELATIVE)


def mean_forces(travel, fc, ft, cut_length, start=None):
    """Mean Fc, Ft over the steady window [start, cut_length] and the window's description (travel in um,
    samples). ``start`` (units of ``travel``): None finds it from Fc (:func:`steady_start`)."""
    travel = np.asarray(travel)
    rule = "given start"
    if start is None:
        start, rule = steady_start(travel, fc, cut_length), "from the force history (MSER-5)"
    m = window_mask(travel, start, cut_length)
    win = {"travel_from_um": float(start * 1e6), "travel_to_um": float(cut_length * 1e6), "samples": int(m.sum()),
           "rule": rule}
    if not m.any():
        return float("nan"), float("nan"), win
    return float(np.mean(np.asarray(fc)[m])), float(np.mean(np.asarray(ft)[m])), win


def peak_forces(travel, fc, ft) -> dict:
    """The largest sampled cutting and thrust forces and the tool travel (in the units of ``travel``) at
    which each is reached.

    A fracturing cut is not steady: the force builds up while the tool engages, until the material
    ahead of it gives way, and then falls (docs/validation-details.md, "What sets the full scenes' forces"). The
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
        deepest = min(deepest, float(mesh.y[mesh.elements[sel]].min()))
    if coh_failed is not None and mesh.n_cohesive and np.any(coh_failed):
        c = mesh.cohesive[coh_failed.astype(bool)]
        deepest = min(deepest, float(mesh.y[c[:, :c.shape[1] // 2]].min()))  # side A's nodes
    return max(0.0, y_cut - deepest)


def zone_depth(mesh, y_cut: float) -> float:
    """How far the micro zone (the fibre and matrix elements) reaches below the cut plane [m], from the reference
    positions; 0 without a micro zone. The damage depth cannot exceed it: where :func:`damage_depth` reaches it
    (within half an element), the far field below, not the material, stopped the damage."""
    sel = np.isin(mesh.material, (FIBRE, MATRIX))
    if not sel.any():
        return 0.0
    return max(0.0, y_cut - float(mesh.y[mesh.elements[sel]].min()))


def bounce_back(px, py, node_alive, tool, y_cut: float, window: float, n_bins: int = 8, x_end: float = math.inf,
                min_length: float = 0.0):
    """Elastic recovery of the machined surface behind the cutting edge [m].

    Behind the edge (x from the arc centre + r to + r + ``window``, and not past ``x_end``, the workpiece's face
    where the tool entered: beyond it lies no machined surface, only material pushed out of the cut) and below
    the arc centre, the machined surface in each x-bin (``n_bins`` of them over the whole window, fewer when the
    surface behind the edge is shorter) is the highest living node; the
    bounce-back is the mean height of that surface above the tool's lowest point (the cut plane y_cut): material
    that sprang back up after the edge passed. Returns (value, bins used); NaN when less than ``min_length`` of
    machined surface lies behind the edge (before the tool entered, or a cut shorter than the edge radius plus
    that length) or no living node lies there.
    """
    xc, yc, r = tool[0], tool[1], tool[4]
    x0, x1 = xc + r, min(xc + r + window, x_end)
    if not x1 - x0 >= max(min_length, 1e-300):
        return float("nan"), 0
    sel = node_alive.astype(bool) & (px >= x0) & (px < x1) & (py < yc)
    if not sel.any():
        return float("nan"), 0
    width = window / n_bins  # the bins keep their width when the machined surface is shorter than the window
    n_bins = max(1, min(n_bins, int(math.ceil((x1 - x0) / width - 1e-9))))
    b = np.minimum(((px[sel] - x0) / width).astype(int), n_bins - 1)
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


__all__ = ["STEADY_FROM", "window_mask", "steady_mask", "steady_start", "steady_drift", "steady_settled", "mean_forces",
           "damage_depth", "bounce_back", "frame", "frame_times", "FIBRE", "MATRIX", "EHM"]
