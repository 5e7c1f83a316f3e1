"""The engine's state: structure-of-arrays numpy arrays built from a Mesh and an SI scene.

``build_state(mesh, si, tool=None)`` returns a :class:`FemState`. Everything the compiled
loop touches is a numpy array on it (SI units, plane strain, unit width: masses in kg per m
of width, forces in N per m, energies in J per m). The names other modules may read:

nodes     ``X0, Y0`` reference and ``x, y`` current positions [m]; ``vx, vy`` velocities
          (half step n+1/2 after a step) [m/s]; ``fx, fy`` total nodal forces of the last
          step (elements + cohesive + tool) [N/m]; ``mass`` lumped masses [kg/m] (scaled);
          ``cnode`` the node's own mass-proportional damping [1/s] (0 but in an absorbing far field;
          added to the state's ``damping``);
          ``fix_x, fix_y`` (uint8) prescribed dofs whose velocity is ``vpx, vpy`` (0 = fixed);
          ``node_active`` (uint8) 1 while a living element holds the node.
elements  ``quads`` (n, 4) int32, ``mat`` (int32 material id), ``phi`` fibre angle [rad],
          ``alive`` (uint8), ``fail_mode`` (int32, 0 or the failure mode of
          :data:`solver.fem.materials.MODE_NAMES`), ``stress`` (n, 4) Sxx, Syy, Sxy, S33 [Pa]
          (2nd Piola-Kirchhoff), ``strain`` (n, 3) Green-Lagrange Exx, Eyy, Exy, ``eplast``
          fibre compressive plastic strain, ``eint`` stress work [J/m], ``ehg`` hourglass energy,
          ``hgd`` (n or 0) 1 - the smallest secant ratio of the centre (the hourglass stiffness's factor
          is 1 - hgd; no rows while the hourglass keeps the elastic stiffness).
cohesive  ``coh`` (nc, 4) a0, a1, b0, b1; ``coh_elems`` (nc, 2); ``dmg`` (nc, 2) damage at the
          two points; ``cstate`` 0 intact, 1 debonded (fully damaged; its faces are free surfaces),
          2 removed (a tied element was deleted); ``cfail_mode``; ``wcoh`` work of its forces and
          ``cdis`` energy its damage dissipated [J/m]; ``mhist`` (ne or 0, N_HIST) the matrix's history
          (plastic strain, equivalent plastic strains, crack-band kappa: solver.fem.materials H_* columns).
tool      ``tool`` (the contract's tool array, moved by the loop), ``has_tool``,
          ``tool_out`` float64[10]: [0] sum over steps of Fx on the tool [N/m], [1] sum of Fy,
          [2] deepest penetration [m] (max), [3] friction energy [J/m], [4:10] the sums of Fx, Fy
          from the rake face, the cutting edge and the clearance face; the caller divides
          [0], [1] by its number of steps (fixed dt) and resets them as it likes; TOOL_FORCE_ROWS
          picks the force sums [Fx, Fy in all, then by face].
external ``fext`` (4, n) nodal forces held over a chunk [N/m] (rows fx, fy, and the last step's
          fx, fy for their trapezoidal work, booked as external); (4, 0) when nothing couples.
bookkeeping ``time``, ``steps``, ``events`` (list of dicts), ``energies`` (dict, see
          :mod:`.energy`), ``added_mass``, ``added_mass_fraction``, ``dt_initial``.

Mass: lumped, a quarter of rho A0 to each node of a quad (rho x ``numerics.mass_scaling``;
the added mass is recorded). A deleted element's mass stays on its nodes (the nodes keep
moving with their momentum; a node left without a living element stops touching the tool).
"""

from __future__ import annotations

import math

import numpy as np

#: the rows of ``tool_out`` that sum forces: Fx, Fy in all, then on the rake face, the cutting edge and the
#: clearance face (:func:`solver.contact.tool_contact`); a particle chunk's tool force adds to the same rows
TOOL_FORCE_ROWS = np.array([0, 1, 4, 5, 6, 7, 8, 9])

from .cohesive import cohesive_geometry, cohesive_props
from .materials import CBAND, LAW, LAW_PARABOLOID, MODE_NAMES, N_HIST, RHO, material_table
from .quad import hourglass_stiffness

# params[] (read by the loop)
P_CFL, P_DTCOH, P_IGNCOH, P_DAMP, P_DELETE, P_INVDEL, P_HGMAX, P_MMIN, P_EFLOOR, P_EMAX, P_ERODE, P_EDGEFAIL = range(12)
N_PARAMS = 12
# scal[]
S_TIME, S_STEPS, S_DTPREV, S_DT0, S_NEV, S_LIMIT, S_LIMIT_ID, S_DTCRIT, S_EHGMAX, S_EINIT, S_HGRUN, S_FTX, S_FTY, S_PFRIC = range(14)
N_SCAL = 14
# en[] accumulated energies [J/m]
E_EXT, E_FRICTION, E_VISCOUS, E_REMOVED, E_DAMAGE_REMOVED, E_CONTACT_BODY, E_TOOL, E_FRAG = range(8)
N_EN = 8
N_BLOCKS = 64


def _blocks(n: int, nb: int = N_BLOCKS) -> np.ndarray:
    nb = max(1, min(nb, n))
    return np.linspace(0, n, nb + 1).round().astype(np.int64)


def _csr(conn: np.ndarray, n_nodes: int, stride: int):
    """node -> flat index (row * stride + 2 * local) into a (rows, stride) force buffer."""
    rows, loc = np.nonzero(conn >= 0)
    nodes = conn[rows, loc].astype(np.int64)
    flat = rows.astype(np.int64) * stride + 2 * loc
    order = np.argsort(nodes, kind="stable")
    ptr = np.zeros(n_nodes + 1, np.int64)
    np.add.at(ptr, nodes + 1, 1)
    return np.cumsum(ptr), flat[order]


def no_fragments(s, n_nodes: int = 0):
    """The fragment-contact arrays (solver.contact.FragmentContact fills them): empty and off
    until a scene with element deletion asks for them (``n_nodes`` > 0 allocates the per-node ones)."""
    s.fr_on = 0
    s.fr_edges = np.zeros((0, 3), np.int32)
    s.fr_enodes = np.zeros((0, 4), np.int64)  # the four nodes of each exposed edge's element
    s.fr_nodes = np.zeros(0, np.int64)
    s.fr_grid = np.array([0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0])
    s.fr_cstart = np.zeros(2, np.int64)  # CSR of the edges binned per cell
    s.fr_cent = np.zeros(1, np.int64)
    s.fr_depth = np.zeros(n_nodes)  # penetration of each node at the last step [m]
    s.ffx = np.zeros(n_nodes)  # fragment forces of the step and of the step before (trapezoidal work)
    s.ffy = np.zeros(n_nodes)
    s.ffpx = np.zeros(n_nodes)
    s.ffpy = np.zeros(n_nodes)
    s.fr_out = np.zeros(3)  # [0] deepest penetration [m], [1] nodes in contact, [2] bin entries needed


class FemState:
    """Plain holder of the engine's arrays and parameters (see the module docstring)."""

    def __repr__(self):
        return (f"FemState(nodes={self.x.size}, elements={self.quads.shape[0]}, cohesive={self.coh.shape[0]}, "
                f"time={self.time:.4g} s, steps={self.steps})")

    @property
    def time(self) -> float:
        return float(self.scal[S_TIME])

    @property
    def steps(self) -> int:
        return int(self.scal[S_STEPS])

    @property
    def dt_initial(self) -> float:
        return float(self.scal[S_DT0])

    @property
    def energies(self) -> dict:
        from .energy import energies
        return energies(self)

    @property
    def events(self) -> list[dict]:
        """Failure events in order: kind (element|cohesive), id, material, mode, step, time."""
        from ..mesh import MATERIAL_NAMES
        out = []
        for k in range(int(self.scal[S_NEV])):
            kind, i, m, mode, step = (int(v) for v in self.ev[k])
            out.append({"kind": "element" if kind == 0 else "cohesive", "id": i,
                        "material": MATERIAL_NAMES[m] if m >= 0 else "interface",
                        "mode": MODE_NAMES[mode], "step": step, "time_s": float(self.ev_t[k])})
        return out


def build_state(mesh, si, tool=None, *, ignore_cohesive_dt: bool = False, props=None, cohesive=None,
                damping: float = 0.0, hourglass_ratio_max: float = 0.1, delete_inverted: bool = False,
                energy_error_max: float = 0.5):
    """Build the engine state from a :class:`solver.mesh.Mesh` and ``scene.si()``.

    Reads from ``si``: the materials (``fibre``, ``matrix``, ``interface``,
    ``fibre_volume_fraction`` for the EHM), ``numerics.cfl``, ``numerics.mass_scaling``,
    ``physics.element_deletion``, ``physics.fibre_plasticity``, ``physics.cohesive_interface``,
    ``physics.fibre_failure_at`` (absent: the centre), ``physics.hourglass_follows_material`` (absent: off)
    (``si.numerics``/``si.physics`` may be absent: defaults cfl 0.5, no mass scaling, deletion
    and plasticity on).

    tool: the contract's tool array (copied; the loop moves the copy ``state.tool``) or None.
    ignore_cohesive_dt: leave the cohesive penalty out of the stable step (to provoke the
        instability a too-stiff penalty causes; verification of the stability guard only).
    props: a (3, N_PROPS) material table overriding the one made from ``si``
        (:func:`solver.fem.materials.material_table`); cohesive: [K, sigma_n, tau, GIc, GIIc, eta].
    damping: mass-proportional damping c [1/s] (a = f/m - c v; quasi-static runs only).
    hourglass_ratio_max: the guard's limit on hourglass / (stress work + hourglass) energy.
    delete_inverted: delete an inverted element (failure mode 9) instead of ending the run
        ``unstable``.
    energy_error_max: the guard ends the run when the energy balance's residual exceeds this
        fraction of the energy in play (energy created by an unstable step; default 50 %).
    """
    num = getattr(si, "numerics", None)
    phys = getattr(si, "physics", None)
    cfl = float(getattr(num, "cfl", 0.5))
    ms = float(getattr(num, "mass_scaling", 1.0))
    deletion = bool(getattr(phys, "element_deletion", True))
    plastic = bool(getattr(phys, "fibre_plasticity", True))
    ehm_fail = bool(getattr(phys, "ehm_failure", True))
    use_coh = bool(getattr(phys, "cohesive_interface", True))
    edge_fail = getattr(phys, "fibre_failure_at", "centre") == "edge"
    hg_secant = bool(getattr(phys, "hourglass_follows_material", False))
    if not cfl > 0:
        raise ValueError(f"numerics.cfl = {cfl}: must be > 0")
    if not ms >= 1:
        raise ValueError(f"numerics.mass_scaling = {ms}: must be >= 1")

    s = FemState()
    n = mesh.n_nodes
    ne = mesh.n_elems
    s.X0 = np.ascontiguousarray(mesh.x, dtype=np.float64)
    s.Y0 = np.ascontiguousarray(mesh.y, dtype=np.float64)
    s.x = s.X0.copy()
    s.y = s.Y0.copy()
    s.vx = np.zeros(n)
    s.vy = np.zeros(n)
    s.fx = np.zeros(n)
    s.fy = np.zeros(n)
    s.cnode = np.zeros(n)
    s.fix_x = np.ascontiguousarray(mesh.fixed_x, dtype=np.uint8)
    s.fix_y = np.ascontiguousarray(mesh.fixed_y, dtype=np.uint8)
    s.vpx = np.zeros(n)
    s.vpy = np.zeros(n)

    s.quads = np.ascontiguousarray(mesh.quads, dtype=np.int32)
    s.mat = np.ascontiguousarray(mesh.material, dtype=np.int32)
    if ne and (s.mat.min() < 0 or s.mat.max() > 2):
        raise ValueError(f"mesh.material holds {sorted(set(s.mat.tolist()) - {0, 1, 2})}: allowed 0 (fibre), 1 (matrix), 2 (EHM)")
    s.phi = np.ascontiguousarray(mesh.fibre_angle, dtype=np.float64)
    s.cphi = np.cos(s.phi)
    s.sphi = np.sin(s.phi)
    s.props = material_table(si, ms, plastic, ehm_fail) if props is None else np.ascontiguousarray(props, dtype=np.float64)
    # the supports: an EHM element holding a fixed node stays elastic (engine material EHM_SUPPORT,
    # the EHM without a failure criterion): the workpiece is a cut-out of a larger body, and a
    # support row that tears off (it did, in transverse tension, under the 0-deg quick scene's
    # lifted layer) is an artefact of where the cut-out ends, not of the material
    fixed = (s.fix_x != 0) | (s.fix_y != 0)
    support = (s.mat == 2) & fixed[s.quads].any(axis=1) if ne else np.zeros(0, bool)
    if support.any() and s.props.shape[0] == 3:
        from .materials import H_SL, H_ST, H_XC, H_XT, H_YC, H_YT

        row = s.props[2].copy()
        row[[H_XT, H_XC, H_YT, H_YC, H_SL, H_ST]] = 1e30  # never reached
        s.props = np.vstack([s.props, row])
        s.mat[support] = 3
    a0 = 0.5 * ((s.X0[s.quads[:, 2]] - s.X0[s.quads[:, 0]]) * (s.Y0[s.quads[:, 3]] - s.Y0[s.quads[:, 1]])
                - (s.X0[s.quads[:, 3]] - s.X0[s.quads[:, 1]]) * (s.Y0[s.quads[:, 2]] - s.Y0[s.quads[:, 0]]))
    if ne and a0.min() <= 0:
        bad = int(np.argmin(a0))
        raise ValueError(f"mesh.quads[{bad}] has area {a0[bad]:.3g} m^2: quads must be counter-clockwise with positive area")
    s.area0 = a0
    s.khg = hourglass_stiffness(s.X0, s.Y0, s.quads, s.mat, s.phi, s.props)
    s.stress = np.zeros((ne, 4))
    s.strain = np.zeros((ne, 3))
    s.eplast = np.zeros(ne)
    # the matrix's history (plasticity, crack band; solver.fem.materials.material_stress); no rows when no
    # material keeps one (the paper's brittle matrix)
    keeps = (s.props[:, CBAND] > 0).any() or (s.props[:, LAW] == LAW_PARABOLOID).any()
    s.mhist = np.zeros((ne if keeps else 0, N_HIST))
    # 1 - the smallest secant ratio of each element's centre: its hourglass stiffness's factor is 1 - hgd
    # (solver.fem.quad.hourglass_scale); no rows when the hourglass keeps the elastic stiffness
    s.hgd = np.zeros(ne if hg_secant else 0)
    s.eint = np.zeros(ne)
    s.ehg = np.zeros(ne)
    s.hq = np.zeros((ne, 4))  # hourglass amplitude q and generalised force G of the last step
    s.alive = np.ones(ne, np.uint8)
    s.fail_mode = np.zeros(ne, np.int32)
    s.fe = np.zeros((ne, 8))

    # lumped mass (scaled) and the physical mass
    rho = s.props[s.mat, RHO]
    s.mass = np.zeros(n)
    np.add.at(s.mass, s.quads.reshape(-1), np.repeat(0.25 * rho * a0, 4))
    s.mass_physical = float((rho * a0).sum() / ms)
    s.added_mass = float(s.mass.sum() - s.mass_physical)
    s.added_mass_fraction = s.added_mass / max(s.mass_physical, 1e-300)
    s.nlive = np.zeros(n, np.int32)
    np.add.at(s.nlive, s.quads.reshape(-1), 1)
    s.node_active = (s.nlive > 0).astype(np.uint8)

    # cohesive elements
    if use_coh and mesh.n_cohesive:
        s.coh = np.ascontiguousarray(mesh.cohesive, dtype=np.int32)
        s.coh_elems = np.ascontiguousarray(mesh.cohesive_elems, dtype=np.int32)
    else:
        s.coh = np.zeros((0, 4), np.int32)
        s.coh_elems = np.zeros((0, 2), np.int32)
    nc = s.coh.shape[0]
    s.cL0, s.csign = cohesive_geometry(s.X0, s.Y0, s.quads, s.coh, s.coh_elems)
    if cohesive is not None:
        s.cprops = np.asarray(cohesive, dtype=np.float64)
    elif hasattr(si, "interface"):
        s.cprops = cohesive_props(si)
    else:  # no interface data: only allowed without cohesive elements
        if nc:
            raise ValueError("the mesh has cohesive elements but si has no 'interface' section (and no cohesive= given)")
        s.cprops = np.ones(6)
    if s.cprops.shape != (6,) or not np.all(s.cprops[:5] > 0):
        raise ValueError(f"cohesive properties {s.cprops.tolist()}: need [K, sigma_n, tau, G_Ic, G_IIc, eta] all > 0")
    for name in ("dmg", "cdn", "cds", "ctn", "cts"):
        setattr(s, name, np.zeros((nc, 2)))
    s.wcoh = np.zeros(nc)
    s.cdis = np.zeros(nc)  # energy dissipated by damage growth (solver.fem.cohesive.cohesive_update)
    s.cstate = np.zeros(nc, np.uint8)
    s.cfail_mode = np.zeros(nc, np.int32)
    s.fc = np.zeros((nc, 8))

    # node -> force-buffer maps (race-free gather) and work blocks
    s.nptr, s.nidx = _csr(s.quads, n, 8)
    s.cptr, s.cidx = _csr(s.coh, n, 8)
    s.eb, s.cb, s.nb = _blocks(ne), _blocks(nc), _blocks(n)
    nbmax = N_BLOCKS
    s.bl_f = np.zeros((nbmax, 9))  # per-block scratch (float): dt, eint, ehg, wext, viscous, ..., fragment work
    s.bl_i = np.zeros((nbmax, 8), np.int64)  # per-block scratch (int): ids and counts

    # cohesive critical step (CFL 1): two masses on a spring k = K w, w = L0/2 (normal and shear alike)
    if nc:
        k = s.cprops[0] * 0.5 * s.cL0
        inv_m = np.zeros((nc, 2))
        for kk in range(2):
            ma, mb = s.mass[s.coh[:, kk]], s.mass[s.coh[:, 2 + kk]]
            inv_m[:, kk] = 1.0 / ma + 1.0 / mb
        dtc = 2.0 / np.sqrt(k[:, None] * inv_m)
        s.dt_cohesive = float(dtc.min())
        s.dt_cohesive_id = int(np.argmin(dtc.min(axis=1)))
    else:
        s.dt_cohesive, s.dt_cohesive_id = math.inf, -1

    s.params = np.zeros(N_PARAMS)
    s.params[P_CFL] = cfl
    s.params[P_DTCOH] = s.dt_cohesive if math.isfinite(s.dt_cohesive) else 1e300
    s.params[P_IGNCOH] = 1.0 if ignore_cohesive_dt else 0.0
    s.params[P_DAMP] = float(damping)
    s.params[P_DELETE] = 1.0 if deletion else 0.0
    s.params[P_INVDEL] = 1.0 if delete_inverted else 0.0
    s.params[P_EDGEFAIL] = 1.0 if edge_fail else 0.0
    s.params[P_HGMAX] = float(hourglass_ratio_max)
    pos = s.mass[s.mass > 0]
    s.params[P_MMIN] = float(pos.min()) if pos.size else 1.0
    # the guard's energy checks wait until the energy in play exceeds that of a uniform strain of 1e-3 (about a tenth of the matrix failure strain over the whole mesh)
    s.params[P_EFLOOR] = 0.5e-6 * float((s.props[s.mat, 1] * a0).sum())
    s.params[P_EMAX] = float(energy_error_max)
    s.scal = np.zeros(N_SCAL)
    s.en = np.zeros(N_EN)
    s.guard = np.zeros(8)
    cap = ne + nc + 1
    s.ev = np.zeros((cap, 5), np.int64)
    s.ev_t = np.zeros(cap)

    s.has_tool = 0 if tool is None else 1
    s.tool = np.zeros(12) if tool is None else np.array(tool, dtype=np.float64)
    s.tool_out = np.zeros(10)
    s.fcx = np.zeros(n if tool is not None else 0)  # the tool's forces of the step (kept apart)
    s.fcy = np.zeros(n if tool is not None else 0)
    s.fcpx = np.zeros(n if tool is not None else 0)  # ... and of the step before (trapezoidal work)
    s.fcpy = np.zeros(n if tool is not None else 0)
    s.fpx = np.zeros(n)  # previous total force at prescribed dofs (the supports' work)
    s.fpy = np.zeros(n)
    # external nodal forces a coupled solver sets between chunks (the hybrid's particle reactions):
    # rows fx, fy and the previous step's fx, fy (trapezoidal work); (4, 0) until one allocates them
    s.fext = np.zeros((4, 0))
    no_fragments(s)
    s.e_initial = None  # energy held at the first step (set by advance; initial velocities count here)
    s.k_pen = 0.0
    s.mu = 0.0

    from .timestep import stable_dt
    dt, _ = stable_dt(s)
    s.scal[S_DT0] = dt
    return s
