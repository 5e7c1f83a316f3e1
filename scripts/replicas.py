"""Replicas of one scene: the tool speed scaling times (1 + k 1e-6) (the perturbation of
``fibrecut convergence --replicas``), one JSON line of forces, indicators and the force history (Fc and Ft
over 30 bins of tool travel, :func:`force_history`) per replica; and the mean +- standard error of replica
files.

    NUMBA_NUM_THREADS=1 python scripts/replicas.py SCENE N [dotted.field=value ...]      k = 0 .. N-1
    NUMBA_NUM_THREADS=1 python scripts/replicas.py SCENE K0:K1 [dotted.field=value ...]  k = K0 .. K1-1
    NUMBA_NUM_THREADS=1 python scripts/replicas.py --h5 PREFIX SCENE N numerics.n_frames=20 ...
                                                   also write each replica's run file, PREFIX-k.h5
    python scripts/replicas.py --summary NAME=FILE[,FILE...] [NAME=FILE ...]
    python scripts/replicas.py --table NAME=FILE[,FILE...] [NAME=FILE ...]      one markdown row per group

A range lets two processes share the replicas of one level (one per core). The summary prints, per
named group of JSON-line files, the mean, standard error and standard deviation of each metric, and
for a hybrid the part of the forces the finite elements carry (total minus the particles').

Cutting with fracture is chaotic (docs/numerics.md): one run is one sample; the mean over
replicas and its standard error are what compare between scenes (docs/validation.md).
"""

import json
import sys
import time

import numpy as np

from solver.convergence import combine_replicas, replica_speed_scalings

KEYS = ["cutting_force_N_per_mm", "thrust_force_N_per_mm", "peak_cutting_force_N_per_mm", "peak_cutting_force_travel_um",
        "peak_thrust_force_N_per_mm", "damage_depth_um", "n_failed_cohesive", "sph_cutting_force_N_per_mm", "sph_thrust_force_N_per_mm",
        "n_particles_active", "n_failed_elements", "energy_error", "energy_error_fem_part",
        "max_penetration_fraction_of_element",
        "sph_born_inside_moved", "sph_born_inside_tool", "sph_particles_inside_elements_max", "sph_max_depth_inside_elements_um",
        "sph_expelled_from_elements", "sph_max_expel_depth_um", "sph_expelled_onto_another_element",
        "sph_inside_with_no_boundary_in_reach", "sph_born_inside_max_shift_um",
        "sph_max_tool_penetration_um", "cohesive_unaccounted_J_per_m", "coupling_net_work_J_per_m",
        "coupling_work_on_particles_J_per_m", "steady_from_um", "ehm_overloaded_elements", "ehm_overloaded_in_steady_window",
        "bounce_back_um", "kinetic_internal_ratio", "compile_time_s", "steady_drift"]
KEYS += [f"{p}{f}_{c}_force_N_per_mm" for p in ("", "sph_") for f in ("rake", "edge", "clearance")
         for c in ("cutting", "thrust")]  # where on the tool the forces act


#: the force history each replica line carries: the mean Fc and Ft over this many equal bins of tool travel
#: across the cut, so that a steady-window rule can be judged again from the lines without running again
HISTORY_BINS = 30


def force_history(series: dict, cut_length_um: float, bins: int = HISTORY_BINS) -> dict:
    """The run's sampled Fc and Ft [N/mm] averaged over ``bins`` equal bins of tool travel in [0, cut length]:
    {"travel_um": bin centres, "Fc": ..., "Ft": ...} (None where a bin holds no sample)."""
    f = series.get("forces") or {}
    travel = np.asarray(f.get("travel_um", []), float)
    edges = np.linspace(0.0, cut_length_um, bins + 1)
    in_bin = [(travel >= a) & (travel < b) for a, b in zip(edges[:-1], edges[1:])]
    out = {"travel_um": [round(float(v), 3) for v in 0.5 * (edges[1:] + edges[:-1])]}
    for key in ("Fc", "Ft"):
        values = np.asarray(f.get(key, []), float)
        kept = (b & np.isfinite(values) for b in in_bin)
        out[key] = [round(float(values[m].mean()), 3) if m.any() else None for m in kept]
    return out


def _value(text: str):
    """A dotted override's value: a number where it reads as one, else the text (a preset's name)."""
    try:
        return float(text)
    except ValueError:
        return text


def replicas(argv: list[str], h5_prefix: str | None = None) -> None:
    from solver.run import run
    from solver.scene import load_scene

    scene, ks = argv[0], argv[1]
    k0, k1 = (int(v) for v in ks.split(":")) if ":" in ks else (0, int(ks))
    extra = {k: _value(v) for k, v in (a.split("=", 1) for a in argv[2:])}
    base = load_scene(scene, {"numerics.n_frames": 0, **extra}).numerics.speed_scaling
    for k, ss in enumerate(replica_speed_scalings(base, k1)):  # fibrecut convergence's perturbation
        if k < k0:
            continue
        sc = load_scene(scene, {"numerics.n_frames": 0, **extra, "numerics.speed_scaling": ss})
        t = time.perf_counter()
        r = run(sc)
        row = {"scene": scene, "k": k, **extra, "status": r.status, "wall_s": round(time.perf_counter() - t, 1)}
        row.update({q: r.metrics[q] for q in KEYS if q in r.metrics})
        row["history"] = force_history(r.series, sc.cut.length_um)
        if h5_prefix:
            row["h5"] = str(r.write_hdf5(f"{h5_prefix}-{k}.h5"))
        if r.status != "ok":  # what ended it, where and when (the run's diagnosis)
            row["diagnosis"] = {k: v for k, v in (r.diagnosis or {}).items() if k != "traceback"}
        print(json.dumps(row, default=str), flush=True)


def _groups(argv: list[str]):
    """(name, rows, combined summary) per NAME=FILE[,FILE...] argument."""
    for arg in argv:
        name, files = arg.split("=", 1)
        rows = [json.loads(line) for f in files.split(",") for line in open(f) if line.strip()]
        for r in rows:  # a hybrid's elements carry the total minus the particles' part
            for f in ("cutting", "thrust"):
                if r.get(f"sph_{f}_force_N_per_mm") is not None:
                    r[f"elements_{f}_force_N_per_mm"] = r[f"{f}_force_N_per_mm"] - r[f"sph_{f}_force_N_per_mm"]
        keys = ["wall_s"] + KEYS + ["elements_cutting_force_N_per_mm", "elements_thrust_force_N_per_mm"]
        yield name, rows, keys, combine_replicas(rows, tuple(keys))  # mean, sd and sem over the ok replicas


def table(argv: list[str]) -> None:
    """One markdown row per group: n ok, Fc, Ft (mean +- standard error), Fc's coefficient of variation, the
    thrust on the edge and the clearance face, the particles' thrust (hybrid), steady_from_um."""
    def cell(s, key):
        if not s.get(f"{key}_samples"):
            return "-"
        sem = s.get(f"{key}_sem")
        return f"{s[key]:.2f} +- {sem:.2f}" if sem is not None else f"{s[key]:.2f}"

    print("| level | n ok | Fc [N/mm] | Ft [N/mm] | CoV Fc | Ft edge | Ft clearance | Ft particles | steady from [um] |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, rows, keys, s in _groups(argv):
        fc, sd = s.get("cutting_force_N_per_mm"), s.get("cutting_force_N_per_mm_sd")
        cov = f"{sd / fc:.1%}" if fc and sd is not None else "-"
        print(f"| {name} | {s.get('replicas_ok', len(rows))} | {cell(s, 'cutting_force_N_per_mm')} | "
              f"{cell(s, 'thrust_force_N_per_mm')} | {cov} | {cell(s, 'edge_thrust_force_N_per_mm')} | "
              f"{cell(s, 'clearance_thrust_force_N_per_mm')} | {cell(s, 'sph_thrust_force_N_per_mm')} | "
              f"{cell(s, 'steady_from_um')} |")


def summary(argv: list[str]) -> None:
    for name, rows, keys, s in _groups(argv):
        print(f"{name}: {len(rows)} replicas, status {', '.join(sorted({r['status'] for r in rows}))}")
        for key in keys:
            v = s[f"{key}_samples"]
            if v:
                sd, sem = s[f"{key}_sd"], s[f"{key}_sem"]
                print(f"  {key:38s}{s[key]:10.4g} +- {sem if sem is not None else float('nan'):.3g} "
                      f"(sd {sd if sd is not None else float('nan'):.3g}, {min(v):.3g} .. {max(v):.3g})")


def main(argv: list[str]) -> None:
    if argv[:1] == ["--summary"] and len(argv) > 1:
        summary(argv[1:])
    elif argv[:1] == ["--table"] and len(argv) > 1:
        table(argv[1:])
    elif argv[:1] == ["--h5"] and len(argv) >= 4:
        replicas(argv[2:], h5_prefix=argv[1])
    elif len(argv) >= 2 and not argv[0].startswith("-"):
        replicas(argv)
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])
