"""Replicas of one scene: the tool speed scaling times (1 + k 1e-6), k = 0 .. N-1 (the perturbation of
``fibrecut convergence --replicas``), one JSON line of forces and indicators per replica.

    NUMBA_NUM_THREADS=1 python scripts/replicas.py SCENE N [dotted.field=value ...]

Cutting with fracture is chaotic (docs/convergence.md): one run is one sample; the mean over
replicas and its standard error are what compare between scenes (docs/validation.md).
"""

import json
import sys
import time

from solver.run import run
from solver.scene import load_scene

KEYS = ["cutting_force_N_per_mm", "thrust_force_N_per_mm", "sph_cutting_force_N_per_mm", "sph_thrust_force_N_per_mm",
        "n_particles_active", "energy_error", "max_penetration_fraction_of_element", "sph_born_inside_moved",
        "sph_particles_inside_elements_max", "sph_max_depth_inside_elements_um", "cohesive_unaccounted_J_per_m"]


def main(argv: list[str]) -> None:
    if len(argv) < 2:
        sys.exit(__doc__)
    scene, n = argv[0], int(argv[1])
    extra = {k: float(v) for k, v in (a.split("=", 1) for a in argv[2:])}
    ss = load_scene(scene, {"numerics.n_frames": 0, **extra}).numerics.speed_scaling
    for k in range(n):
        sc = load_scene(scene, {"numerics.n_frames": 0, "numerics.speed_scaling": ss * (1 + k * 1e-6), **extra})
        t = time.perf_counter()
        r = run(sc)
        row = {"scene": scene, "k": k, "status": r.status, "wall_s": round(time.perf_counter() - t, 1)}
        row.update({q: r.metrics[q] for q in KEYS if q in r.metrics})
        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
