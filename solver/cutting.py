"""``run_cutting(scene, progress=None) -> Result``: the 2D orthogonal cutting scene.

The run reads top to bottom like the algorithm:

1. mesh the workpiece (:mod:`solver.mesher`), build the tool (:mod:`solver.tool`) and the engine
   of the scene's fidelity (:func:`solver.engine.build_engine`: classic FEM,
   :mod:`solver.fem.engine`, or the FEM-SPH hybrid, :mod:`solver.hybrid.engine`);
2. the engine chooses its step: the stable step (material wave speeds, cohesive penalty), then the
   rigid tool's penalty 1.0 m_i / dt^2 on a node or particle of mass m_i (:func:`solver.contact.tool_contact`,
   :data:`solver.contact.TOOL_ALPHA`), which by construction does not limit it; k = 0.1 m_min / dt^2, the
   lightest node's (:func:`solver.contact.contact_stiffness`), is the fragment contact's and the hybrid's
   particle-edge coupling's;
3. run the engine in chunks to the end of the cut, t_end = (cut length + start gap)
   / (cut speed x speed scaling); the engine deletes failed and crushed elements and applies
   the tool and fragment contacts at every step, and rebuilds the fragments' exposed boundary
   between chunks when elements were deleted; at each force sample read the tool force (in all,
   and the parts the engine reports apart) and the energies, store chip frames, report progress
   (a ``False`` answer cancels the run);
4. reduce: mean forces over the steady window (from the end of the engagement transient, found in
   the cutting force history, to the end of the cut; :func:`solver.outputs.steady_start`), in all and by the
   face of the tool they act on (rake face, cutting edge, clearance face), damage depth,
   bounce-back, and every accuracy indicator (energy error, kinetic/internal ratio, added
   mass, maximum penetration, hourglass energy ratio, time step and its limit).
"""

from __future__ import annotations

import math
import time
from importlib import import_module

import numpy as np

from . import units as u
from .engine import build_engine
from .mesh import EHM, FIBRE, MATRIX
from .outputs import (bounce_back, damage_depth, mean_forces, peak_forces, steady_drift, steady_settled, steady_start,
                      zone_depth)
from .result import Result
from .run import FIDELITIES
from .tool import tool_array

#: an ok run whose energy balance misses by more than this gets a warning in its summary
ENERGY_WARNING = 0.01

#: the parts of the tool the force is split by (:func:`solver.tool.tool_face`): the rake face, the cutting
#: edge (the arc) and the clearance face. Material pressed under the edge and against the clearance face
#: pushes the tool up (positive thrust), a chip on a positive-rake face pushes it down
TOOL_FACES = ("rake", "edge", "clearance")
#: the force series' suffixes, in the order of state.tool_out[TOOL_FORCE_ROWS]: in all, then by face
FORCE_PARTS = ("", *(f"_{f}" for f in TOOL_FACES))


def run_cutting(scene, progress=None) -> Result:
    if getattr(FIDELITIES.get(scene.fidelity), "engine", None) is None:
        engines = " and ".join(name for name, fid in FIDELITIES.items() if fid.engine)
        raise ValueError(f"fidelity = {scene.fidelity!r}: run_cutting handles {engines} only")
    t_wall = time.perf_counter()
    si = scene.si()
    t0 = time.perf_counter()
    module, name = FIDELITIES[scene.fidelity].mesher.split(":")
    mesh = getattr(import_module(module), name)(si)
    t_mesh = time.perf_counter() - t0
    tool = tool_array(si)
    res = simulate(scene, si, mesh, tool, progress=progress)
    res.build["arrays"]["mesh"]["seconds"] = t_mesh
    res.wall_time_s = time.perf_counter() - t_wall
    return res


def simulate(scene, si, mesh, tool, progress=None, x_mirror=None) -> Result:
    """Run the engine on a given mesh and tool (``run_cutting`` without the building).

    The tool's travel is measured along its motion (tool[11] = -1: a mirrored tool moving +x);
    ``x_mirror`` (tests) names the mirror line so that bounce-back looks behind the edge.
    """
    t_wall = time.perf_counter()
    num = scene.numerics
    res = Result(scene=scene)
    x_tool0 = float(tool[0])
    orient = float(tool[11])
    gap = 0.5 * float(si.element_size)  # tool_array's start gap
    build: dict = {"arrays": {"mesh": {"bytes": mesh.nbytes(), "seconds": 0.0, "n_nodes": mesh.n_nodes,
                                       "n_elements": mesh.n_elems, "n_cohesive": mesh.n_cohesive}}}

    # 1.-2. the engine of the fidelity (solver.engine): its state, its step and contact stiffnesses
    engine = build_engine(scene, si, mesh, tool)
    dt0, dt_limit = engine.dt0, engine.dt_limit

    # 3. the chunked loop: the engine takes CFL x the current critical step at every step
    speed = float(si.speed) * float(num.speed_scaling)
    travel_end = float(si.cut_length) + gap
    t_end = travel_end / speed
    n_samples = int(num.n_force_samples)
    t_samples = t_end * np.arange(1, n_samples + 1) / n_samples
    t_frames = list(t_end * np.arange(1, num.n_frames + 1) / num.n_frames) if num.n_frames else []
    hist = {k: np.full(n_samples, np.nan) for k in ("time", "Fc", "Ft", "travel_um", "dt", "max_penetration_um",
                                                     "ehm_overloaded")}
    # the tool force by the face it acts on (rake face, cutting edge, clearance face: state.tool_out[4:10])
    hist.update({f"F{c}{s}": np.full(n_samples, np.nan) for s in FORCE_PARTS[1:] for c in "ct"})
    # the parts of Fc and Ft the engine reports apart (the hybrid's particles), in all and by face
    hist.update({f"F{c}{p}{s}": np.full(n_samples, np.nan) for p in engine.force_parts for s in FORCE_PARTS for c in "ct"})
    energies: dict[str, list] = {}
    frames, frame_times = [], []
    max_pen = 0.0
    status, diagnosis = "ok", None
    # the step count is known before the first step: reject a cut that cannot fit numerics.max_steps
    # (e.g. 0.01 m/s without speed scaling) at once instead of running into the cap hours later
    steps_needed = t_end / dt0
    if steps_needed > num.max_steps:
        status = "failed"
        diagnosis = {"check": "max_steps", "step": 0, "time_s": 0.0,
                     "what": f"the cut needs about {steps_needed:.3g} steps of {dt0:.3g} s (limited by {dt_limit}), "
                             f"more than numerics.max_steps = {num.max_steps}",
                     "change": f"raise numerics.speed_scaling (now {num.speed_scaling:g}) or numerics.mass_scaling, "
                               f"shorten cut.length_um, coarsen numerics.element_size_um, or raise numerics.max_steps"}
        t_samples = t_samples[:0]
    dt_min, dt_min_limit = dt0, dt_limit
    for s_i, t_target in enumerate(t_samples):
        s0 = engine.steps
        forces0 = {p: engine.tool_force(p) for p in ("", *engine.force_parts)}
        engine.start_sample(orient * (x_tool0 - float(engine.tool[0])) - gap)
        while engine.time < t_target * (1 - 1e-12) and status == "ok":
            rec = engine.advance(t_target, num.chunk_steps)
            dt_step = engine.stable_step()
            if 0.0 < dt_step < dt_min:
                dt_min, dt_min_limit = dt_step, rec.dt_limit
            if rec.status != "ok":
                status, diagnosis = "unstable", dict(rec.finding or {"check": "unknown"})
            elif engine.steps > num.max_steps:
                status = "failed"
                diagnosis = {"check": "max_steps", "what": f"the cut needs more than numerics.max_steps = {num.max_steps} steps",
                             "time_s": engine.time, "step": engine.steps,
                             "change": "raise numerics.max_steps, or coarsen / speed-scale the scene"}
            elif time.perf_counter() - t_wall > num.max_wall_time_s:
                status = "failed"
                diagnosis = {"check": "max_wall_time", "what": f"wall time above numerics.max_wall_time_s = {num.max_wall_time_s:g} s",
                             "time_s": engine.time, "step": engine.steps,
                             "change": "raise numerics.max_wall_time_s, or make the run cheaper: numerics.speed_scaling, "
                                       "numerics.element_size_um or cut.length_um"}
        n = max(engine.steps - s0, 1)
        pen = engine.max_penetration()
        max_pen = max(max_pen, pen)
        hist["time"][s_i] = engine.time
        for p, f0 in forces0.items():
            _sample_forces(hist, p, s_i, (engine.tool_force(p) - f0) / n / u.N_PER_MM)
        hist["travel_um"][s_i] = (orient * (x_tool0 - float(engine.tool[0])) - gap) / u.UM
        hist["dt"][s_i] = engine.stable_step()  # the stable step in force at the sample
        hist["max_penetration_um"][s_i] = pen / u.UM
        hist["ehm_overloaded"][s_i] = engine.overloaded()  # far-field elements past their criterion
        for k, v in engine.energies().items():
            energies.setdefault(k, []).append(v)
        engine.check()
        while t_frames and engine.time >= t_frames[0] * (1 - 1e-9):
            t_frames.pop(0)
            frames.append(engine.frame(num.frame_fields))
            frame_times.append(engine.time)
        if status != "ok":
            break
        if progress is not None and progress((s_i + 1) / n_samples, f"t = {engine.time * 1e6:.4g} us, step {engine.steps}, "
                                             f"travel {hist['travel_um'][s_i]:.3g} um") is False:
            status = "cancelled"
            break
    steps = engine.steps
    t = engine.time
    done = ~np.isnan(hist["time"])
    for k in hist:
        hist[k] = hist[k][done]

    # 4. reductions
    elem_failed = engine.failed_elements()
    coh_failed = engine.failed_cohesive()
    y_cut = -float(si.depth)
    dd = damage_depth(mesh, elem_failed, coh_failed, y_cut, materials=(MATRIX,))
    px, py = engine.node_positions()
    node_alive = engine.node_alive()
    tool_now = engine.tool
    x_entry = float(np.max(mesh.x))  # the workpiece's face where the tool entered
    if orient < 0:  # measure the mirrored scene in its mirror image
        px, tool_now = 2.0 * x_mirror - px, tool_now.copy()
        tool_now[0] = 2.0 * x_mirror - tool_now[0]
        x_entry = 2.0 * x_mirror - float(np.min(mesh.x))
    bb, _ = bounce_back(px, py, node_alive, tool_now, y_cut, window=max(2 * float(si.edge_radius), 5 * float(si.element_size)),
                        x_end=x_entry, min_length=float(si.element_size))
    e_last = {k: v[-1] for k, v in energies.items()} if energies else {}
    m = res.metrics

    # the steady window: from the end of the engagement transient in the total cutting force to the end of the cut
    travel_m = hist["travel_um"] * u.UM
    start = steady_start(travel_m, hist["Fc"], float(si.cut_length))

    def steady(series: str, metric: str) -> dict:
        """The steady means of the series F{c,t}<series> as the metrics <metric>{cutting,thrust}_force_N_per_mm;
        returns the steady window."""
        m[f"{metric}cutting_force_N_per_mm"], m[f"{metric}thrust_force_N_per_mm"], win = mean_forces(
            travel_m, hist[f"Fc{series}"], hist[f"Ft{series}"], float(si.cut_length), start)
        win["rule"] = "from the end of the engagement transient (MSER-5 on Fc)"
        return win

    window = steady("", "")  # the tool force in all
    peak = peak_forces(hist["travel_um"], hist["Fc"], hist["Ft"])  # the engagement peak, before the material gives way
    for f in ("cutting", "thrust"):
        m[f"peak_{f}_force_N_per_mm"] = peak[f]
        m[f"peak_{f}_force_travel_um"] = peak[f"{f}_travel"]
    for f in TOOL_FACES:  # where on the tool the steady forces act
        steady(f"_{f}", f"{f}_")
    m["damage_depth_um"] = dd / u.UM
    zd = zone_depth(mesh, y_cut)
    if zd > 0.0 and dd >= zd - 0.5 * float(si.element_size):
        res.warnings.append(f"the matrix failed down to the micro zone's bottom ({zd / u.UM:.3g} um below the cut plane): "
                            "damage_depth_um is a lower bound, and the far field, not the material, stopped the damage "
                            "(deepen workpiece.micro_zone_depth_um, with workpiece.height_um)")
    m["damage_depth_any_material_um"] = damage_depth(mesh, elem_failed, coh_failed, y_cut, materials=(FIBRE, MATRIX, EHM)) / u.UM
    m["bounce_back_um"] = bb / u.UM
    m["energy_error"] = engine.energy_error(e_last)
    m.update(engine.metrics(e_last))  # the engine's own
    m["max_penetration_um"] = max_pen / u.UM
    m["max_penetration_fraction_of_element"] = max_pen / float(si.element_size)
    m["dt_s"] = dt0
    m["dt_min_s"] = dt_min
    m["dt_limited_by"] = dt_limit
    m["dt_min_limited_by"] = dt_min_limit
    m["n_elements"] = mesh.n_elems
    m["n_nodes"] = mesh.n_nodes
    m["n_cohesive"] = mesh.n_cohesive
    m["n_failed_elements"] = int(elem_failed.sum())
    m["n_failed_cohesive"] = int(coh_failed.sum()) if coh_failed is not None else 0
    m["steady_window"] = f"{window.get('rule', 'last half of the cut')}: tool travel {window['travel_from_um']:.4g}-{window['travel_to_um']:.4g} um, {window['samples']} samples"
    m["steady_window_from_um"] = window["travel_from_um"]
    m["steady_window_to_um"] = window["travel_to_um"]
    m["steady_from_um"] = window["travel_from_um"]
    drift, z = steady_drift(travel_m, hist["Fc"], start, float(si.cut_length))
    m["steady_drift"] = drift  # (second half - first half) / mean of the window's Fc
    if not steady_settled(drift, z):
        res.warnings.append(f"the cutting force did not settle in the steady window ({window['travel_from_um']:.4g}-"
                            f"{window['travel_to_um']:.4g} um): its second half's mean differs from its first half's by "
                            f"{100 * drift:+.0f} % ({z:+.1f} standard errors), so the steady means are those of a cut still "
                            "changing (a layer breaking off, a cut shorter than a chip's cycle); lengthen cut.length_um "
                            "or read the force history")
    # the far field (EHM, elastic by default): elements past their Hashin criterion, in all and during the steady window
    over = hist["ehm_overloaded"]
    before = over[hist["travel_um"] < window["travel_from_um"]]
    m["ehm_overloaded_elements"] = int(over[-1]) if over.size else 0
    m["ehm_overloaded_in_steady_window"] = int(over[-1] - (before[-1] if before.size else 0)) if over.size else 0
    if m["ehm_overloaded_in_steady_window"] > 0:
        res.warnings.append(f"{m['ehm_overloaded_in_steady_window']} elements of the equivalent homogeneous material "
                            "(the far field) passed their Hashin criterion during the steady window: the far field, not "
                            "only the material at the tool, carries the forces (enlarge workpiece.micro_zone_depth_um, "
                            "workpiece.height_um or workpiece.length_um)")
    m["simulated_time_s"] = t
    for p, prefix in engine.force_parts.items():  # the part of the steady mean forces it carries, in all and by face
        for s in FORCE_PARTS:
            steady(f"{p}{s}", f"{prefix}{s}_")
    e_err = m.get("energy_error")
    if status == "ok" and e_err is not None and math.isfinite(e_err) and abs(e_err) > ENERGY_WARNING:
        res.warnings.append(f"energy error {e_err:.3g} is above {ENERGY_WARNING:.0%}: "
                            + engine.energy_warning(e_err, e_last, m))
    e_hg, e_in = float(e_last.get("hourglass", 0.0)), float(e_last.get("internal", 0.0))
    if e_hg < -0.01 * max(e_in, 1e-300):
        # the assumed-strain hourglass forces are rotated with the element's polar rotation, not derived
        # from a rotation-invariant potential: in a spinning, badly distorted element they do net work
        res.warnings.append(f"hourglass energy is negative ({e_hg:.3g} J/m against {e_in:.3g} J/m internal): the hourglass "
                            "forces did net work on rotating, distorted elements; the balance books it, but the energy "
                            "in the chip is not trustworthy (refine numerics.element_size_um)")
    if m["max_penetration_fraction_of_element"] > 0.1:
        res.warnings.append(f"maximum tool penetration {max_pen / u.UM:.3g} um is above 10 % of the element size")
    res.status, res.diagnosis = status, diagnosis
    res.steps = steps
    res.series["forces"] = {"time": hist["time"], "Fc": hist["Fc"], "Ft": hist["Ft"], "travel_um": hist["travel_um"]}
    res.series["forces"].update({k: hist[k] for k in hist if k[:3] in ("Fc_", "Ft_")})
    res.series["energies"] = {"time": hist["time"], **{k: np.asarray(v) for k, v in energies.items()}}
    res.series["diagnostics"] = {"time": hist["time"], "dt": hist["dt"], "max_penetration_um": hist["max_penetration_um"],
                                 "ehm_overloaded": hist["ehm_overloaded"]}
    if frames:
        res.frames, res.frame_times = frames, frame_times
        res.series["mesh"] = {**mesh.series(), "tool0": tool}
    build["arrays"].update(engine.arrays())
    # how many threads the compiled chunks ran on, as their timing chose (solver.threads)
    coupler = getattr(engine, "coupler", None)
    choices = (("engine", getattr(getattr(engine, "state", None), "thread_choice", None)),
               ("lockstep", getattr(coupler, "threads", None)),
               ("particles", getattr(getattr(coupler, "particles", None), "threads", None)))
    threads = {name: c.summary() for name, c in choices if c is not None and c.calls}
    if threads:
        build["threads"] = threads
    res.build = {"modules": [FIDELITIES[scene.fidelity].mesher.split(":")[0], "solver.tool", *engine.modules], **build}
    res.wall_time_s = time.perf_counter() - t_wall
    return res


def _sample_forces(hist: dict, series: str, s_i: int, f: np.ndarray) -> None:
    """One force sample [N/mm] in the layout of state.tool_out[TOOL_FORCE_ROWS] (Fx, Fy in all, then by face)
    into the series F{c,t}<series><part>."""
    for j, part in enumerate(FORCE_PARTS):
        hist[f"Fc{series}{part}"][s_i], hist[f"Ft{series}{part}"][s_i] = f[2 * j], f[2 * j + 1]
