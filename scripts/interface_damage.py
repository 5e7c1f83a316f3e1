"""Where along the workpiece the cohesive interfaces above the cut plane have started to soften, frame by frame.

    python scripts/interface_damage.py RUN.h5 [--bins 8]

RUN.h5 is a 2D run file written with frames (``fibrecut run SCENE --set numerics.n_frames=N -o RUN.h5``). For
each frame: its time, the tool's travel, and per bin of the workpiece's length (x = 0 is the clamped end, the
tool enters at x = L) the mean damage of the interfaces between the cut plane and the top surface and the
share of them past their onset (damage > 0; the bilinear law, docs/model.md).
"""

import argparse
import json

import h5py
import numpy as np


def damage_map(path: str, bins: int) -> list[str]:
    out = []
    with h5py.File(path, "r") as f:
        scene = json.loads(f.attrs["scene"])
        coh = f["mesh/cohesive"][()]
        x, y = f["mesh/x"][()], f["mesh/y"][()]
        cx, cy = x[coh].mean(axis=1), y[coh].mean(axis=1)
        layer = cy > -scene["cut"]["depth_um"] * 1e-6
        edges = np.linspace(x.min(), x.max(), bins + 1)
        # each interface of the layer in one bin (the last one closed at x = L)
        where = np.minimum(np.searchsorted(edges, cx, side="right") - 1, bins - 1)
        in_bin = [layer & (where == b) for b in range(bins)]
        tool0 = f["mesh/tool0"][()]
        out.append(f"{path}: {int(layer.sum())} interfaces above the cut plane; bins of x [um]: "
                   + " ".join(f"{a * 1e6:.0f}-{b * 1e6:.0f}" for a, b in zip(edges[:-1], edges[1:])))
        for name in sorted(f["frames"]):
            g = f["frames"][name]
            if "cohesive_damage" not in g:
                raise SystemExit(f"{path}: frame {name} has no cohesive damage (a run with interfaces and the "
                                 "damage field in numerics.frame_fields)")
            d, t = g["cohesive_damage"][()], float(g.attrs["time"])
            cells = [f"{d[m].mean():.2f}/{100 * (d[m] > 0).mean():.0f}%" if m.any() else "-" for m in in_bin]
            out.append(f"t {t * 1e6:.2f} us, travel {abs(tool0[2]) * t * 1e6:.1f} um: " + " ".join(cells))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("run", help="a 2D run file with frames")
    ap.add_argument("--bins", type=int, default=8, help="bins along the workpiece's length (default 8)")
    a = ap.parse_args()
    print("\n".join(damage_map(a.run, a.bins)))


if __name__ == "__main__":
    main()
