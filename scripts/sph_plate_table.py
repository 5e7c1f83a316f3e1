"""The oscillating plate of ``fibrecut verify sph-plate``: frequency error against thin-plate theory for
each resolution and variant, one run at a time, one thread.

    NUMBA_NUM_THREADS=1 python scripts/sph_plate_table.py --n 8,10,12,16 --variants fixed:0.3:0.6,fixed:0.3:0
    (variant = clamp:eps:quadratic; clamp fixed | mirror | mirror-linear)
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # this tree's solver

from solver.verification import sph_cases as sc  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", default="8,10,12,16")
    ap.add_argument("--variants", default="fixed:0.3:0.6")
    ap.add_argument("--vf", type=float, default=0.05)
    a = ap.parse_args()
    for v in a.variants.split(","):
        clamp, eps, quad = v.split(":")
        for n in map(int, a.n.split(",")):
            t0 = time.perf_counter()
            w, om, d = sc.run_plate(n_thick=n, clamp=clamp, eps=float(eps), quadratic=float(quad), Vf=a.vf)
            print(f"n={n:3d} clamp={clamp:13s} eps={eps} quadratic={quad}: omega error {100 * (w - om) / om:+6.2f} % "
                  f"(vs 2D continuum {100 * d['error_vs_2d_continuum']:+6.2f} %), status {d['status']}, "
                  f"crossings {len(d['crossings_s'])}, nearest neighbour {d['min_distance_over_dp']:.2f} dp, "
                  f"viscous {100 * d['viscous_fraction']:.1f} % of E0, wall {time.perf_counter() - t0:.0f} s", flush=True)


if __name__ == "__main__":
    main()
