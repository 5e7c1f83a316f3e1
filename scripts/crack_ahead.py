"""How far the layer above the cut plane has come away ahead of the tool in a 0-degree run, per frame and over
replicas.

    python scripts/crack_ahead.py RUN.h5 [RUN.h5 ...] [--at 10,25,50,75,100]

Reads the frames of run files written with ``fibrecut run SCENE -o RUN.h5`` (``numerics.n_frames`` sets how
many) of a 2D scene with fibres at 0 deg. The layer is the material above the cut plane (the depth of cut); the
tool's front is at the workpiece's end minus the tool's travel. For each frame:

- ``damaged``: the distance ahead of the tool's front to the farthest interface along the fibres in the
  layer (from the free surface down to the cut plane) past its strength (damage >= 0.1: softening);
- ``open``: the distance ahead of the front to the farthest place where the layer has come apart: the
  height from the node row about one strip pitch below the cut plane to the free surface has grown by more than the
  interface's opening at full separation, 2 G_Ic / sigma_max (wherever the split runs: along the cut plane or
  higher; a cohesive element whose neighbour was deleted keeps its damage, so the damage alone does not say
  where the layer is open);
- ``lift 50`` and ``lift 100``: that height's growth 50 and 100 um ahead of the front [um];
- ``split``: the depth of the interface in the layer that has opened most over the 50 um ahead of the front
  (summed separation of its faces, where both faces are held by live elements) [um below the free surface];
- ``fibre +/-``: the largest tensile and compressive principal strain of the fibres of the layer within 15 um
  of the farthest open place (stress / E1), in percent: the layer's bending at the root of its lift.

With several files (replicas of one scene), the mean +- standard error of each column at the tool travels given
by ``--at`` (each replica interpolated between its frames). The fibre's failure strains to compare with are
Xt / E1 (tension) and the compressive yield / E1 (compression) of the scene's fibre (docs/model.md).
"""

from __future__ import annotations

import argparse
import json
import sys

import h5py
import numpy as np

DAMAGED = 0.1
ROOT_UM = 15.0


class NotReadable(ValueError):
    """A run file this script cannot read: what it is and what is needed."""


def frames(path: str) -> tuple[dict, list[dict]]:
    """The scene's fibre data and, per frame, the columns described in the module's docstring."""
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise NotReadable(f"{path}: not a readable run file ({exc})") from None
    with f:
        scene = json.loads(f.attrs["scene"])
        angle, fidelity = scene["workpiece"]["fibre_angle_deg"], scene["fidelity"]
        if fidelity not in ("fem2d", "hybrid2d") or angle != 0.0 or "cohesive" not in f["mesh"]:
            raise NotReadable(f"{path}: fidelity {fidelity}, fibre_angle_deg {angle:g}; a 2D run (fem2d, hybrid2d) "
                              "with fibres at 0 deg is needed")
        if "frames" not in f or not len(f["frames"]):
            raise NotReadable(f"{path}: the run has no frames; run it with numerics.n_frames set (e.g. 20)")
        depth = scene["cut"]["depth_um"]
        e1 = scene["materials"]["fibre"]["E1_GPa"] * 1e3  # MPa
        x, y = f["mesh/x"][:] * 1e6, f["mesh/y"][:] * 1e6
        coh, quads, mat = f["mesh/cohesive"][:], f["mesh/quads"][:], f["mesh/material"][:]
        time, travel = f["forces/time"][:], f["forces/travel_um"][:]
        x_end = x.max()
        yc, xc = y[coh[:, 0]], 0.5 * (x[coh[:, 0]] + x[coh[:, 1]])
        along = np.abs(y[coh[:, 0]] - y[coh[:, 1]]) < 1e-6  # interfaces along the fibres
        layer = np.where(along & (yc > -depth - 1e-6) & (yc < -1e-6))[0]
        wp = scene["workpiece"]
        pitch = wp["fibre_diameter_um"] / wp["fibre_volume_fraction"]
        rows_y, counts = np.unique(np.round(y, 6), return_counts=True)
        above = rows_y.max()  # the free surface
        single = rows_y[(counts == counts[-1]) & (rows_y < -depth)]  # rows inside a strip: one node per column
        below = single[np.argmin(np.abs(single - (-depth - pitch)))]
        upper, lower = np.where(np.abs(y - above) < 1e-6)[0], np.where(np.abs(y - below) < 1e-6)[0]
        upper, lower = upper[np.argsort(x[upper])], lower[np.argsort(x[lower])]
        if len(upper) != len(lower) or not np.allclose(x[upper], x[lower]):
            raise NotReadable(f"{path}: the node rows at y = {above:g} and {below:g} um do not pair up")
        xr = x[upper]
        inter = scene["materials"]["interface"]
        full_opening = 2e3 * inter["GIc_N_mm"] / inter["normal_strength_MPa"]  # um
        ex, ey = x[quads].mean(axis=1), y[quads].mean(axis=1)
        fibre_in_layer = (mat == 0) & (ey > -depth)
        rows = []
        for key in sorted(f["frames"]):
            g = f["frames"][key]
            t = float(g.attrs["time"])
            s = float(np.interp(t, time, travel))
            front = x_end - s
            d = g["cohesive_damage"][:]
            ahead = layer[xc[layer] < front]
            dam = ahead[d[ahead] >= DAMAGED]
            damaged = float(front - xc[dam].min()) if len(dam) else 0.0
            p = g["positions"][:] * 1e6
            gap = (p[upper, 1] - p[lower, 1]) - (above - below)
            ok = xr < front
            apart = ok & (gap > full_opening)
            tip = float(xr[apart].min()) if apart.any() else front
            lift50, lift100 = (float(np.interp(front - dist, xr[ok], gap[ok])) for dist in (50.0, 100.0))
            held = np.zeros(len(x), bool)
            held[quads[g["state"][:] == 0].ravel()] = True
            near = layer[(xc[layer] < front) & (xc[layer] > front - 50.0) & held[coh[layer]].all(axis=1)]
            sep = np.linalg.norm(p[coh[near, 2:]] - p[coh[near, :2]], axis=2).mean(axis=1)
            depths = np.round(-yc[near], 3)
            split = float("nan")
            if len(near):
                levels = np.unique(depths)
                split = float(levels[np.argmax([sep[depths == v].sum() for v in levels])])
            st = g["stress"][:] / 1e6
            mean = 0.5 * (st[:, 0] + st[:, 1])
            radius = np.sqrt((0.5 * (st[:, 0] - st[:, 1])) ** 2 + st[:, 2] ** 2)
            root = fibre_in_layer & (g["state"][:] == 0) & (np.abs(ex - tip) < ROOT_UM)
            measured = apart.any() and root.any()
            eps_t = float(100 * (mean + radius)[root].max() / e1) if measured else float("nan")
            eps_c = float(100 * (mean - radius)[root].min() / e1) if measured else float("nan")
            rows.append({"time_us": t * 1e6, "travel_um": s, "damaged_um": damaged, "open_um": front - tip,
                         "lift50_um": lift50, "lift100_um": lift100, "split_um": split, "fibre_t_pct": eps_t, "fibre_c_pct": eps_c})
        fibre = scene["materials"]["fibre"]
        limits = {"tension_pct": 100 * fibre["Xt_GPa"] * 1e3 / e1,
                  "compression_pct": 100 * fibre["compressive_yield_MPa"] / e1}
        return limits, rows


COLUMNS = [("travel_um", "travel [um]", "{:7.1f}"), ("damaged_um", "damaged [um]", "{:7.1f}"),
           ("open_um", "open [um]", "{:7.1f}"), ("lift50_um", "lift 50 [um]", "{:6.2f}"),
           ("lift100_um", "lift 100 [um]", "{:6.2f}"), ("split_um", "split [um]", "{:6.1f}"),
           ("fibre_t_pct", "fibre + [%]", "{:5.2f}"), ("fibre_c_pct", "fibre - [%]", "{:5.2f}")]


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("runs", nargs="+", metavar="RUN.h5")
    ap.add_argument("--at", default="10,25,50,75,100,150", help="tool travels [um] for the replicas' means")
    args = ap.parse_args(argv)
    try:
        at = [float(v) for v in args.at.split(",")]
    except ValueError:
        print(f"--at: {args.at!r} is not a comma-separated list of travels in um", file=sys.stderr)
        return 2
    try:
        runs = [frames(p) for p in args.runs]
    except NotReadable as exc:
        print(exc, file=sys.stderr)
        return 2
    limits = runs[0][0]
    print(f"fibre failure strains: tension {limits['tension_pct']:.2f} %, compressive yield "
          f"{limits['compression_pct']:.2f} %")
    if len(runs) == 1:
        print(" | ".join(label for _, label, _ in COLUMNS))
        for r in runs[0][1]:
            print(" | ".join(fmt.format(r[k]) for k, _, fmt in COLUMNS))
        return 0
    print(f"n = {len(runs)} replicas, mean +- standard error at each travel")
    print(" | ".join(label for _, label, _ in COLUMNS))
    for s in at:
        cells = [f"{s:7.1f}"]
        for key, _, fmt in COLUMNS[1:]:
            v = []
            for _, rows in runs:
                tr = np.array([r["travel_um"] for r in rows])
                val = np.array([r[key] for r in rows])
                ok = np.isfinite(val)
                if ok.sum() >= 2 and tr[ok].min() <= s <= tr[ok].max():
                    v.append(float(np.interp(s, tr[ok], val[ok])))
            v = np.array(v)
            cells.append(f"{fmt.format(v.mean())} +- {fmt.format(v.std(ddof=1) / np.sqrt(len(v))).strip()} (n {len(v)})"
                         if len(v) >= 2 else "-")
        print(" | ".join(cells))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
