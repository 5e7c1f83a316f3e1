"""Plots with matplotlib (Agg): the mesh a scene simulates, and a run's forces and chip frames.

``plot_mesh(scene, path)``: the workpiece coloured by material (fibre, matrix, EHM), the
cohesive interfaces as lines, the fixed nodes, the cut plane and the tool at its start.
``plot_strip(mesh, path, title)``: a 3D strip (:mod:`solver.fem3d.strip3d`) as a side view (the section
z = p/2 through the first fibres' axes) and a cross-section through the fibres at mid length, the cohesive fibre surfaces in red.
``plot_result(h5_path, out_prefix)``: ``<prefix>_forces.png`` (Fc, Ft against tool travel with
the steady window shaded) and ``<prefix>_frames.png`` (the chip frames stored in the file).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

COLOURS = {0: "#3b6fb6", 1: "#f2c14e", 2: "#b5b5b5"}
NAMES = {0: "fibre", 1: "matrix", 2: "EHM"}


def _mpl():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _draw_mesh(ax, x, y, quads, material, alive=None, coh=None, lw=0.15):
    from matplotlib.collections import LineCollection, PolyCollection

    sel = np.ones(len(quads), bool) if alive is None else alive.astype(bool)
    polys = np.stack([x[quads[sel]], y[quads[sel]]], axis=-1) * 1e6
    cols = [COLOURS.get(int(m), "#888888") for m in material[sel]]
    ax.add_collection(PolyCollection(polys, facecolors=cols, edgecolors="k", linewidths=lw))
    if coh is not None and len(coh):
        segs = np.stack([np.stack([x[coh[:, 0]], y[coh[:, 0]]], -1), np.stack([x[coh[:, 1]], y[coh[:, 1]]], -1)], 1) * 1e6
        ax.add_collection(LineCollection(segs, colors="#c0392b", linewidths=0.6))


def plot_mesh(scene, path) -> Path:
    """Render the mesh the scene builds (materials, cohesive lines, boundary conditions, tool)."""
    from matplotlib.patches import Patch

    from .mesher import build_mesh
    from .scene import FIDELITIES_3D
    from .tool import tool_array, tool_polygon

    si = scene.si()
    if scene.fidelity in FIDELITIES_3D:  # the 3D strip: a side view and a cross-section
        from .fem3d.strip3d import build_strip_mesh

        mesh3 = build_strip_mesh(si)
        return plot_strip(mesh3, path, f"{scene.name}: {mesh3.n_elems} hexahedra, {mesh3.n_nodes} nodes, {mesh3.n_cohesive} "
                                       f"cohesive, fibre angle {scene.workpiece.fibre_angle_deg:g} deg")
    plt = _mpl()
    mesh = build_mesh(si)
    tool = tool_array(si)
    fig, ax = plt.subplots(figsize=(9, 7))
    _draw_mesh(ax, mesh.x, mesh.y, mesh.quads, mesh.material, coh=mesh.cohesive)
    fixed = mesh.fixed_x | mesh.fixed_y
    ax.plot(mesh.x[fixed] * 1e6, mesh.y[fixed] * 1e6, "k^", ms=2, label="fixed nodes")
    poly = tool_polygon(tool, 1.5 * si.depth + 2 * si.edge_radius) * 1e6
    ax.fill(poly[:, 0], poly[:, 1], color="#555555", alpha=0.6, label="tool (start)")
    ax.axhline(-si.depth * 1e6, color="r", ls="--", lw=0.8, label="cut plane")
    ax.set_xlim(-5, (si.length + 1.5 * si.depth + 2 * si.edge_radius) * 1e6)
    ax.set_ylim(-si.height * 1e6 - 5, 1.2 * si.depth * 1e6)
    ax.set_aspect("equal")
    ax.set_xlabel("x [um] (tool moves in -x)")
    ax.set_ylabel("y [um]")
    handles = [Patch(color=COLOURS[k], label=NAMES[k]) for k in (0, 1, 2)]
    handles.append(plt.Line2D([], [], color="#c0392b", label=f"cohesive ({mesh.n_cohesive})"))
    ax.legend(handles=handles + ax.get_legend_handles_labels()[0], loc="upper left", fontsize=7)
    ax.set_title(f"{scene.name}: {mesh.n_elems} elements, {mesh.n_nodes} nodes, fibre angle "
                 f"{scene.workpiece.fibre_angle_deg:g} deg, h = {scene.numerics.element_size_um:g} um", fontsize=9)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=160, bbox_inches="tight")
    plt.close(fig)
    return path


def plot_strip(mesh, path, title: str = "") -> Path:
    """Side view (z = 0) and mid-length cross-section of a 3D strip (module docstring)."""
    from matplotlib.patches import Patch

    from .fem3d.strip3d import faces_on, mid_section_value

    plt = _mpl()
    X = mesh.X
    tol = 1e-9 * float(np.ptp(X))
    axis, value = mid_section_value(mesh)
    # the section's in-plane axes keep the right hand: fibres along x show (z, y), along y show (x, z)
    u, v = {0: (2, 1), 1: (0, 2)}.get(axis, (0, 1))
    zc = 0.5 * float(mesh.info["pitch_m"])  # through the axes of the first fibres across the strip
    views = ((f"side view, section z = {zc * 1e6:.3g} um", 2, zc, (0, 1)), (f"cross-section, {'xyz'[axis]} = {value * 1e6:.4g} um", axis, value, (u, v)))
    fig, axes = plt.subplots(1, 2, figsize=(13, 6), gridspec_kw={"width_ratios": [2.2, 1]})
    coh_nodes = np.zeros(X.shape[1], bool)
    coh_nodes[mesh.cohesive.ravel()] = True
    for ax, (name, ax_id, val, (a, b)) in zip(axes, views):
        quads, elems = faces_on(X, mesh.hexes, ax_id, val, tol)
        _draw_mesh(ax, X[a], X[b], quads, mesh.material[elems], lw=0.1)
        if ax_id == axis:  # the fibre surfaces cut by the section, as the cohesive elements' edges
            from matplotlib.collections import LineCollection

            on = np.abs(X[axis] - val) <= tol
            ring = [(c[0], c[1]) for c in mesh.cohesive[:, :4] if on[c[0]] and on[c[1]]]
            if ring:
                r = np.array(ring)
                segs = np.stack([np.stack([X[a, r[:, 0]], X[b, r[:, 0]]], -1), np.stack([X[a, r[:, 1]], X[b, r[:, 1]]], -1)], 1) * 1e6
                ax.add_collection(LineCollection(segs, colors="#c0392b", linewidths=0.8))
        ax.autoscale()
        ax.set_aspect("equal")
        ax.set_xlabel(f"{'xyz'[a]} [um]")
        ax.set_ylabel(f"{'xyz'[b]} [um]")
        ax.set_title(name, fontsize=9)
    handles = [Patch(color=COLOURS[k], label=NAMES[k]) for k in (0, 1, 2)]
    handles.append(plt.Line2D([], [], color="#c0392b", label=f"cohesive fibre surface ({mesh.n_cohesive} elements)"))
    axes[0].legend(handles=handles, loc="lower left", fontsize=7)
    fig.suptitle(title or f"3D strip: {mesh.n_elems} hexahedra, {mesh.n_nodes} nodes, {mesh.n_cohesive} cohesive", fontsize=9)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=160, bbox_inches="tight")
    plt.close(fig)
    return path


def _strip_section(mesh_group):
    """The side view of a 3D strip's frames (:func:`solver.fem3d.strip3d.side_section`): (node ids (k, 4),
    their elements, a title suffix)."""
    from .fem3d.strip3d import side_section

    X = np.stack([mesh_group[c][()] for c in "xyz"])
    quads, elems, zc = side_section(X, mesh_group["hexes"][()], float(mesh_group["fibre_pitch"][()]))
    return quads, elems, f", section z = {zc * 1e6:.3g} um"


def _particle_xy(g):
    """The particles' x and y of frame group g: 2D frames hold particles_x, particles_y, 3D frames
    particles_positions (n, 3); None without particles."""
    if "particles_positions" in g:
        pos = g["particles_positions"][()]
        return pos[:, 0], pos[:, 1]
    if "particles_x" in g:
        return g["particles_x"][()], g["particles_y"][()]
    return None


def plot_result(h5_path, out_prefix) -> list[Path]:
    """Force history with the steady window marked, and the chip frames, as PNG files."""
    import h5py

    plt = _mpl()
    out = []
    prefix = Path(out_prefix)
    prefix.parent.mkdir(parents=True, exist_ok=True)
    with h5py.File(h5_path, "r") as f:
        summary = json.loads(f.attrs["summary"])
        if "forces" in f:
            t = f["forces/time"][()]
            fc, ft = f["forces/Fc"][()], f["forces/Ft"][()]
            travel = f["forces/travel_um"][()] if "travel_um" in f["forces"] else None
            xs = travel if travel is not None else t * 1e6
            fig, ax = plt.subplots(figsize=(8, 4))
            ax.plot(xs, fc, label="Fc (cutting)")
            ax.plot(xs, ft, label="Ft (thrust)")
            win = summary.get("steady_window")
            if isinstance(win, dict) and travel is not None:
                ax.axvspan(win.get("travel_from_um", 0), win.get("travel_to_um", 0), color="0.85", label="steady window")
            for key, ls in (("cutting_force_N_per_mm", "--"), ("thrust_force_N_per_mm", ":")):
                if summary.get(key) is not None:
                    ax.axhline(summary[key], color="k", ls=ls, lw=0.8)
            ax.set_xlabel("tool travel [um]" if travel is not None else "time [us]")
            ax.set_ylabel("force [N/mm]")
            ax.legend(fontsize=8)
            ax.set_title(f"{summary.get('scene')}: Fc = {summary.get('cutting_force_N_per_mm')}, "
                         f"Ft = {summary.get('thrust_force_N_per_mm')} N/mm ({summary.get('status')})", fontsize=9)
            p = prefix.with_name(prefix.name + "_forces.png")
            fig.savefig(p, dpi=140, bbox_inches="tight")
            plt.close(fig)
            out.append(p)
            if "Ft_edge" in f["forces"]:  # the forces by the face of the tool they act on
                fig, axes = plt.subplots(1, 2, figsize=(11, 3.8), sharex=True)
                for ax, c, name in ((axes[0], "c", "Fc (cutting)"), (axes[1], "t", "Ft (thrust)")):
                    ax.plot(xs, f[f"forces/F{c}"][()], color="k", lw=1.2, label="all")
                    for face, col in (("rake", "C0"), ("edge", "C3"), ("clearance", "C2")):
                        ax.plot(xs, f[f"forces/F{c}_{face}"][()], color=col, lw=0.9, label=f"{face} face" if face != "edge" else "cutting edge")
                        if f"F{c}_particles_{face}" in f["forces"]:
                            ax.plot(xs, f[f"forces/F{c}_particles_{face}"][()], color=col, lw=0.8, ls="--",
                                    label=f"particles on {face}")
                    ax.axhline(0.0, color="0.6", lw=0.5)
                    ax.set_xlabel("tool travel [um]" if travel is not None else "time [us]")
                    ax.set_ylabel(f"{name} [N/mm]")
                axes[1].legend(fontsize=7)
                fig.suptitle(f"{summary.get('scene')}: where on the tool the forces act", fontsize=9)
                p = prefix.with_name(prefix.name + "_forces_by_face.png")
                fig.savefig(p, dpi=140, bbox_inches="tight")
                plt.close(fig)
                out.append(p)
        if "frames" in f and "mesh" in f:
            if "hexes" in f["mesh"]:  # a 3D strip: each frame as its section through the first fibre's axis
                quads, elems, plane = _strip_section(f["mesh"])
            else:
                quads, elems, plane = f["mesh/quads"][()], None, ""
            names = sorted(f["frames"])
            n = len(names)
            ncol = min(n, 3)
            nrow = (n + ncol - 1) // ncol
            fig, axes = plt.subplots(nrow, ncol, figsize=(5 * ncol, 4 * nrow), squeeze=False)
            mat0 = f["mesh/material"][()]
            for k, name in enumerate(names):
                g = f["frames"][name]
                ax = axes[k // ncol][k % ncol]
                pos = g["positions"][()] if "positions" in g else np.stack([f["mesh/x"][()], f["mesh/y"][()]], 1)
                mat = g["material"][()] if "material" in g else mat0
                alive = (g["state"][()] == 0) if "state" in g else None
                if elems is not None:  # the section's faces carry their element's material and state
                    mat = mat[elems]
                    alive = alive[elems] if alive is not None else None
                _draw_mesh(ax, pos[:, 0], pos[:, 1], quads, mat, alive=alive, lw=0.05)
                ppos = _particle_xy(g)
                if ppos is not None and len(ppos[0]):  # the hybrids' SPH particles (3D: seen from the side)
                    pm = g["particles_material"][()] if "particles_material" in g else np.zeros(len(ppos[0]), int)
                    ax.scatter(ppos[0] * 1e6, ppos[1] * 1e6, s=2.0, marker="o", linewidths=0,
                               c=[COLOURS.get(int(m), "#888888") for m in pm], edgecolors="none", zorder=3)
                    ax.text(0.02, 0.02, f"{len(ppos[0])} SPH particles", transform=ax.transAxes, fontsize=7)
                if "tool0" in f["mesh"]:
                    from .tool import tool_polygon

                    tool = np.array(f["mesh/tool0"][()])
                    tt = float(g.attrs.get("time", 0.0))
                    tool[0] += tool[2] * tt
                    tool[1] += tool[3] * tt
                    poly = tool_polygon(tool, 150e-6) * 1e6
                    ax.fill(poly[:, 0], poly[:, 1], color="#555555", alpha=0.5)
                ax.set_aspect("equal")
                ax.autoscale_view()
                ax.set_title(f"t = {g.attrs.get('time', 0) * 1e6:.3f} us{plane}", fontsize=8)
            for k in range(n, nrow * ncol):
                axes[k // ncol][k % ncol].axis("off")
            p = prefix.with_name(prefix.name + "_frames.png")
            fig.savefig(p, dpi=120, bbox_inches="tight")
            plt.close(fig)
            out.append(p)
    return out
