"""``run_cutting(scene, progress=None) -> Result``: the 2D orthogonal cutting scene with classic FEM.

The run reads top to bottom like the algorithm:

1. mesh the workpiece (:mod:`solver.mesher`), build the tool (:mod:`solver.tool`) and the
   engine's state (:mod:`solver.fem`);
2. choose the step: the engine's stable step (material wave speeds, cohesive penalty), then the
   rigid tool's penalty 1.0 m_i / dt^2 on a node or particle of mass m_i (:func:`solver.contact.tool_contact`,
   :data:`solver.contact.TOOL_ALPHA`), which by construction does not limit it; k = 0.1 m_min / dt^2, the
   lightest node's (:func:`solver.contact.contact_stiffness`), is the fragment contact's and the hybrid's
   particle-edge coupling's;
3. run the compiled engine in chunks to the end of the cut, t_end = (cut length + start gap)
   / (cut speed x speed scaling); the engine deletes failed and crushed elements and applies
   the tool and fragment contacts at every step; between chunks rebuild the fragments' exposed
   boundary when elements were deleted, sample the tool force and the energies, store chip
   frames, report progress (a ``False`` answer cancels the run);
4. reduce: mean forces over the steady window (from the end of the engagement transient, found in
   the cutting force history, to the end of the cut; :func:`solver.outputs.steady_start`), in all and by the
   face of the tool they act on (rake face, cutting edge, clearance face), damage depth,
   bounce-back, and every accuracy indicator (energy error, kinetic/internal ratio, added
   mass, maximum penetration, hourglass energy ratio, time step and its limit).
"""

from __future__ import annotations

import math
import time

import numpy as np

from . import units as u
from .contact import TOOL_ALPHA, FragmentContact, contact_stiffness
from .mesh import EHM, FIBRE, MATRIX
from .mesher import build_mesh
from .outputs import bounce_back, damage_depth, frame, mean_forces, peak_forces, steady_start
from .result import Result
from .tool import tool_array

#: erosion of crushed elements (explicit codes' time-step erosion, e.g. LS-DYNA's ERODE/DTMIN):
#: with element deletion on, the engine deletes an element whose critical step falls below
#: ERODE_FRACTION x the run's initial critical step, long before its guard (1/100) would end the run
ERODE_FRACTION = 0.2
#: the exposed boundary of the fragment contact is rebuilt after every chunk of at most this many
#: steps in which elements were deleted (the engine applies the contact at every step)
FRAG_REBUILD_STEPS = 50

#: an ok run whose energy balance misses by more than this gets a warning in its summary
ENERGY_WARNING = 0.01

#: travel into the workpiece (in element sizes) after which the hourglass guard is armed
HG_ARM_TRAVEL_ELEMENTS = 2.0

#: the parts of the tool the force is split by (:func:`solver.tool.tool_face`): the rake face, the cutting
#: edge (the arc) and the clearance face. Material pressed under the edge and against the clearance face
#: pushes the tool up (positive thrust), a chip on a positive-rake face pushes it down
TOOL_FACES = ("rake", "edge", "clearance")
#: the force series' suffixes, in the order of state.tool_out[TOOL_FORCE_ROWS]: in all, then by face
FORCE_PARTS = ("", *(f"_{f}" for f in TOOL_FACES))


def run_cutting(scene, progress=None) -> Result:
    if scene.fidelity not in ("fem2d", "hybrid2d"):
        raise ValueError(f"fidelity = {scene.fidelity!r}: run_cutting handles fem2d and hybrid2d only")
    t_wall = time.perf_counter()
    si = scene.si()
    t0 = time.perf_counter()
    mesh = build_mesh(si)
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
    from . import fem
    from .fem.state import E_FRAG, P_ERODE, P_HGMAX, S_DTCRIT, TOOL_FORCE_ROWS

    t_wall = time.perf_counter()
    num = scene.numerics
    build: dict = {"modules": ["solver.mesher", "solver.tool", "solver.contact", "solver.fem"], "arrays": {}}
    build["arrays"]["mesh"] = {"bytes": mesh.nbytes(), "seconds": 0.0,
                               "n_nodes": mesh.n_nodes, "n_elements": mesh.n_elems, "n_cohesive": mesh.n_cohesive}
    res = Result(scene=scene)
    x_tool0 = float(tool[0])
    orient = float(tool[11])
    gap = 0.5 * float(si.element_size)  # tool_array's start gap
    t0 = time.perf_counter()
    state = fem.build_state(mesh, si, tool=tool, hourglass_ratio_max=hourglass_limit(int(num.elements_across_fibre)))
    build["arrays"]["engine_state"] = {"bytes": _nbytes(state), "seconds": time.perf_counter() - t0}

    # 2. the time step and the contact stiffnesses (the tool's 1.0 m_min / dt^2, the deformable pairs'
    # 0.1 m_min / dt^2: neither limits the step)
    dt0, dt_limit = fem.stable_dt(state)
    mass = np.asarray(state.mass)
    m_min = float(mass[mass > 0].min())
    k_tool = contact_stiffness(m_min, dt0, num.contact_stiffness_factor, TOOL_ALPHA)
    k_pair = contact_stiffness(m_min, dt0, num.contact_stiffness_factor)
    mu = float(si.friction)
    dt0, dt_limit = fem.stable_dt(state, k_tool)
    dt0_crit = dt0 / float(state.params[0])  # the critical step at CFL 1
    if scene.physics.element_deletion:
        state.params[P_ERODE] = ERODE_FRACTION * dt0_crit
    frag = None
    if scene.physics.fragment_contact and scene.physics.element_deletion:
        # the deformable pairs' penalty (contact.PAIR_ALPHA), applied at every step
        frag = FragmentContact(mesh.quads, mesh.n_nodes, k_pen=k_pair)  # its arrays come with the first deletion

    # ---- hybrid2d (FEM-to-SPH conversion, solver.hybrid.coupler): dormant particles in the converting
    # elements; None for fem2d, which allocates no particles
    coupler = None
    if scene.uses_particles:  # fem2d never imports the SPH package
        from .hybrid.coupler import make_coupler
        coupler = make_coupler(scene, mesh, si, state, k_tool, k_pair, mu)
    if coupler is not None:
        build["modules"].append("solver.sph")
        build["arrays"]["particles"] = {"bytes": coupler.nbytes(), "seconds": 0.0, "n_dormant": coupler.particles.n}
    # ---- end hybrid2d

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
    if coupler is not None:  # hybrid2d: the particles' part of Fc and Ft, in all and by face
        hist.update({f"F{c}_particles{s}": np.full(n_samples, np.nan) for s in FORCE_PARTS for c in "ct"})
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
    # the hourglass check is armed once the tool has travelled HG_ARM_TRAVEL_ELEMENTS elements into
    # the workpiece: at first contact one node load on a nearly unstrained body makes the ratio of
    # hourglass to strain energy meaningless (both are tiny); the ratio is recorded throughout
    hg_limit = float(state.params[P_HGMAX])
    state.params[P_HGMAX] = 1.0
    hg_armed = False
    for s_i, t_target in enumerate(t_samples):
        s0 = state.steps
        forces0 = state.tool_out[TOOL_FORCE_ROWS]
        if coupler is not None:
            sph0 = coupler.tool_force_sum.copy()
        state.tool_out[2] = 0.0
        travel_now = orient * (x_tool0 - float(state.tool[0])) - gap
        if not hg_armed and travel_now >= HG_ARM_TRAVEL_ELEMENTS * float(si.element_size):
            state.params[P_HGMAX] = hg_limit
            hg_armed = True
        while state.time < t_target * (1 - 1e-12) and status == "ok":
            chunk = min(num.chunk_steps, FRAG_REBUILD_STEPS) if frag is not None else num.chunk_steps
            if coupler is not None:  # hybrid2d: engine sub-chunks + conversion + particles
                rec = coupler.advance(fem, state, t_target, chunk)
            else:
                rec = fem.advance(state, chunk, None, k_pen=k_tool, mu=mu, t_stop=t_target)
            if frag is not None:
                if frag.needs_rebuild(state):
                    t_fr = time.perf_counter()
                    frag.rebuild(state)
                    frag.seconds += time.perf_counter() - t_fr
                frag.grow(state)
            dt_step = float(state.scal[S_DTCRIT]) * float(state.params[0])  # CFL x critical (not a step cut short to land on a sample time)
            if 0.0 < dt_step < dt_min:
                dt_min, dt_min_limit = dt_step, rec.dt_limit
            if rec.status != "ok":
                status, diagnosis = "unstable", dict(rec.finding or {"check": "unknown"})
            elif state.steps > num.max_steps:
                status = "failed"
                diagnosis = {"check": "max_steps", "what": f"the cut needs more than numerics.max_steps = {num.max_steps} steps",
                             "time_s": state.time, "step": state.steps,
                             "change": "raise numerics.max_steps, or coarsen / speed-scale the scene"}
            elif time.perf_counter() - t_wall > num.max_wall_time_s:
                status = "failed"
                diagnosis = {"check": "max_wall_time", "what": f"wall time above numerics.max_wall_time_s = {num.max_wall_time_s:g} s",
                             "time_s": state.time, "step": state.steps,
                             "change": "raise numerics.max_wall_time_s, or make the run cheaper: numerics.speed_scaling, "
                                       "numerics.element_size_um or cut.length_um"}
        n = max(state.steps - s0, 1)
        pen = float(state.tool_out[2])
        max_pen = max(max_pen, pen)
        hist["time"][s_i] = state.time
        _sample_forces(hist, "", s_i, (state.tool_out[TOOL_FORCE_ROWS] - forces0) / n / u.N_PER_MM)
        if coupler is not None:
            _sample_forces(hist, "_particles", s_i, (coupler.tool_force_sum - sph0) / n / u.N_PER_MM)
        hist["travel_um"][s_i] = (orient * (x_tool0 - float(state.tool[0])) - gap) / u.UM
        hist["dt"][s_i] = float(state.scal[S_DTCRIT]) * float(state.params[0])  # the stable step in force at the sample
        hist["max_penetration_um"][s_i] = pen / u.UM
        hist["ehm_overloaded"][s_i] = np.count_nonzero(state.fail_mode < 0)  # far-field elements past their criterion
        for k, v in state.energies.items():
            energies.setdefault(k, []).append(v)
        if coupler is not None:  # hybrid2d: the particles' energies and the combined energy error
            for k, v in coupler.energy_terms().items():
                energies.setdefault(k, []).append(v)
            res_h, err_h = coupler.hybrid_balance(state.energies)
            energies.setdefault("energy_error_hybrid", []).append(err_h)
            energies.setdefault("residual_hybrid", []).append(res_h)
            coupler.check_inside(state)
        while t_frames and state.time >= t_frames[0] * (1 - 1e-9):
            t_frames.pop(0)
            fr = _frame(state, mesh, num.frame_fields)
            if coupler is not None:  # hybrid2d: the active particles
                fr.update(coupler.frame())
            frames.append(fr)
            frame_times.append(state.time)
        if status != "ok":
            break
        if progress is not None and progress((s_i + 1) / n_samples, f"t = {state.time * 1e6:.4g} us, step {state.steps}, "
                                             f"travel {hist['travel_um'][s_i]:.3g} um") is False:
            status = "cancelled"
            break
    steps = state.steps
    t = state.time
    done = ~np.isnan(hist["time"])
    for k in hist:
        hist[k] = hist[k][done]

    # 4. reductions
    elem_failed = _elem_failed(state, mesh)
    coh_failed = _coh_failed(state, mesh)
    y_cut = -float(si.depth)
    dd = damage_depth(mesh, elem_failed, coh_failed, y_cut, materials=(MATRIX,))
    px, py = _positions(state)
    node_alive = _node_alive(state, mesh, elem_failed)
    tool_now = np.asarray(state.tool)
    if orient < 0:  # measure the mirrored scene in its mirror image
        px, tool_now = 2.0 * x_mirror - px, tool_now.copy()
        tool_now[0] = 2.0 * x_mirror - tool_now[0]
    bb, _ = bounce_back(px, py, node_alive, tool_now, y_cut, window=max(2 * float(si.edge_radius), 5 * float(si.element_size)))
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
    m["damage_depth_any_material_um"] = damage_depth(mesh, elem_failed, coh_failed, y_cut, materials=(FIBRE, MATRIX, EHM)) / u.UM
    m["bounce_back_um"] = bb / u.UM
    m["energy_error"] = float(e_last.get("energy_error", math.nan))
    # the part of the residual the cohesive elements make (solver.fem.energy), already in energy_error
    m["cohesive_unaccounted_J_per_m"] = float(e_last.get("cohesive_unaccounted", 0.0))
    m["fragment_contact_work_J_per_m"] = float(state.en[E_FRAG])
    m["fragment_max_penetration_um"] = float(state.fr_out[0]) / u.UM
    m["kinetic_internal_ratio"] = float(e_last.get("kinetic_internal_ratio", math.nan))
    m["hourglass_guard"] = f"armed after {HG_ARM_TRAVEL_ELEMENTS:g} element sizes of travel, limit {hg_limit:g}"
    m["hourglass_energy_ratio"] = float(e_last.get("hourglass", math.nan) / max(e_last.get("internal", 0.0) + e_last.get("hourglass", 0.0), 1e-300))
    m["hourglass_energy_J_per_m"] = float(e_last.get("hourglass", math.nan))
    m["added_mass_fraction"] = float(state.added_mass_fraction)
    m["max_penetration_um"] = max_pen / u.UM
    m["max_penetration_fraction_of_element"] = max_pen / float(si.element_size)
    m["dt_s"] = dt0
    m["dt_min_s"] = dt_min
    m["dt_limited_by"] = dt_limit
    m["dt_min_limited_by"] = dt_min_limit
    m["contact_stiffness_N_per_m2"] = k_tool  # the tool's at the lightest node; a node of mass m_i has k_tool m_i / m_min
    m["pair_contact_stiffness_N_per_m2"] = k_pair  # fragments' and particle-edge springs' (deformable pairs)
    m["n_elements"] = mesh.n_elems
    m["n_nodes"] = mesh.n_nodes
    m["n_cohesive"] = mesh.n_cohesive
    m["n_failed_elements"] = int(elem_failed.sum())
    m["n_eroded_elements"] = int(np.sum((np.asarray(state.alive) == 0) & (np.asarray(state.fail_mode) == 9)))
    m["erosion"] = (f"elements whose critical step fell below {ERODE_FRACTION:g} x the initial one are deleted (crushed)"
                    if scene.physics.element_deletion else "off (no element deletion)")
    first = next((ev["time_s"] for ev in state.events), math.nan)
    m["first_failure_time_s"] = float(first)
    m["n_failed_cohesive"] = int(coh_failed.sum()) if coh_failed is not None else 0
    m["steady_window"] = f"{window.get('rule', 'last half of the cut')}: tool travel {window['travel_from_um']:.4g}-{window['travel_to_um']:.4g} um, {window['samples']} samples"
    m["steady_window_from_um"] = window["travel_from_um"]
    m["steady_window_to_um"] = window["travel_to_um"]
    m["steady_from_um"] = window["travel_from_um"]
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
    m["fragment_contact"] = ("off" if frag is None else
                             f"node-to-edge penalty at every step, k = the tool's; boundary rebuilt {frag.rebuilds} times")
    m["simulated_time_s"] = t
    if coupler is not None:  # hybrid2d: particle counts, energies; the energy error includes the particles
        m.update(coupler.metrics())
        # the part of the steady mean forces the particles carry, in all and by face
        for s in FORCE_PARTS:
            steady(f"_particles{s}", f"sph{s}_")
        m["energy_error_fem_part"] = m["energy_error"]
        m["energy_error"] = float(e_last.get("energy_error_hybrid", math.nan))
    e_err = m.get("energy_error")
    if status == "ok" and e_err is not None and math.isfinite(e_err) and abs(e_err) > ENERGY_WARNING:
        net = m.get("coupling_net_work_J_per_m")
        res_h = float(e_last.get("residual_hybrid", math.nan))
        if net is not None and math.isfinite(res_h) and abs(net) > 0.5 * abs(res_h):
            # hybrid2d: most of it is the particle-element coupling's own (solver.hybrid.coupler)
            res.warnings.append(f"energy error {e_err:.3g} is above {ENERGY_WARNING:.0%}: the particle-element coupling made "
                                f"{net:.3g} J/m; the particles' part of the forces carries that error (docs/validation.md; "
                                "with numerics.coupling_sync_steps above 1 the nodes take the reactions late)")
        else:
            res.warnings.append(f"energy error {e_err:.3g} is above {ENERGY_WARNING:.0%}: the energy balance does not close; "
                                "refine numerics.element_size_um or lower numerics.cfl / numerics.speed_scaling and compare")
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
        res.series["mesh"] = {"x": mesh.x, "y": mesh.y, "quads": mesh.quads, "material": mesh.material,
                              "cohesive": mesh.cohesive, "tool0": tool}
    if frag is not None and frag.rebuilds:  # built once an element was deleted (scenes with fragment contact)
        fr = [v for k, v in vars(state).items() if isinstance(v, np.ndarray) and (k.startswith("fr_") or k.startswith("ff"))]
        build["arrays"]["fragment_contact"] = {"bytes": int(sum(a.nbytes for a in fr)), "seconds": frag.seconds,
                                               "rebuilds": frag.rebuilds}
    res.build = build
    res.wall_time_s = time.perf_counter() - t_wall
    return res


def _sample_forces(hist: dict, series: str, s_i: int, f: np.ndarray) -> None:
    """One force sample [N/mm] in the layout of state.tool_out[TOOL_FORCE_ROWS] (Fx, Fy in all, then by face)
    into the series F{c,t}<series><part>."""
    for j, part in enumerate(FORCE_PARTS):
        hist[f"Fc{series}{part}"][s_i], hist[f"Ft{series}{part}"][s_i] = f[2 * j], f[2 * j + 1]


# ---------------------------------------------------------------------------- engine views
def _get(obj, name, default):
    if isinstance(obj, dict):
        return obj.get(name, default)
    return getattr(obj, name, default)


def _nbytes(state) -> int:
    return int(sum(v.nbytes for v in vars(state).values() if isinstance(v, np.ndarray)))


def hourglass_limit(n_across: int) -> float:
    """The hourglass guard's limit for a cutting scene: max(0.1, min(0.5, 2 / n^2)).

    The engine's quads use physical (assumed-strain) hourglass stabilisation: a beam bent
    with n elements across stores 1/n^2 of its exact bending energy in the hourglass modes
    (each element's linear part sees only its layer's mean strain). Fibres fail by bending at
    0 deg, so a correct bending solution with 3 elements across already sits at 11 %, above the
    generic 10 % limit. Twice the bending share (at least 10 %, at most 50 %) still catches
    spurious hourglassing, which grows without bound.
    """
    return max(0.1, min(0.5, 2.0 / max(n_across, 1) ** 2))


def _positions(state):
    return np.asarray(state.x), np.asarray(state.y)


def _elem_failed(state, mesh):
    return np.asarray(state.alive) == 0


def _coh_failed(state, mesh):
    """Cohesive elements that failed: fully debonded (1) or removed with a deleted neighbour (2)."""
    return np.asarray(state.cstate) >= 1 if mesh.n_cohesive and np.asarray(state.cstate).size else np.zeros(mesh.n_cohesive, bool)


def _node_alive(state, mesh, elem_failed):
    return np.asarray(state.node_active).astype(bool)


def _frame(state, mesh, fields):
    """A chip frame: element damage is 1 for a deleted element, else the largest damage of its interfaces."""
    px, py = _positions(state)
    failed = _elem_failed(state, mesh)
    dmg = failed.astype(np.float64)
    if mesh.n_cohesive and "damage" in fields:
        cd = np.asarray(state.dmg).max(axis=1)
        for side in range(2):
            np.maximum.at(dmg, mesh.cohesive_elems[:, side], cd)
        dmg[failed] = 1.0
    stress = np.asarray(state.stress)[:, :3] if "stress" in fields else None
    out = frame(fields, px, py, mesh.material, failed, dmg, stress)
    if "damage" in fields and mesh.n_cohesive:
        out["cohesive_damage"] = np.asarray(state.dmg).max(axis=1).astype(np.float32)
    return out
