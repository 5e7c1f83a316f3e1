"""An XDMF 3 file beside a 3D run's HDF5 file: the chip frames as a time series ParaView opens.

XDMF (eXtensible Data Model and Format, www.xdmf.org, version 3) keeps the light data (what each array
means) in XML and the heavy data in the HDF5 file itself, by reference (``run.h5:/frames/0003/positions``),
so nothing is copied. The file holds one temporal collection; each frame is a uniform grid with

* the topology: the hexahedra (``/mesh/hexes``; XDMF's Hexahedron numbers its nodes as :mod:`solver.fem3d.hex8`);
* the geometry: the frame's node positions (``/frames/NNNN/positions``, XYZ, m), or the reference ones;
* cell attributes ``material`` (0 fibre, 1 matrix, 2 EHM), ``state`` (1 deleted), ``damage`` where the
  frame holds them (ParaView's Calculator gives the displacement from the coordinates if wanted).

ParaView shows the deleted elements unless told otherwise: a Threshold on ``state`` (0 to 0) hides them.

A hybrid run's SPH particles go into ``<run>-particles.xdmf`` beside it (:func:`write_particles_xdmf`): one
poly-vertex grid per frame that holds particles (their number changes from frame to frame, so they are a
time series of their own), with the point attributes ``material`` and ``damage``; ParaView opens both
files and plays them together by time (the particles as points: its Point Gaussian representation
draws them as spheres).
"""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

_NUMBER = {"f": "Float", "i": "Int", "u": "UInt"}


def _item(h5_name: str, path: str, arr) -> str:
    kind = _NUMBER[np.dtype(arr.dtype).kind]
    dims = " ".join(str(d) for d in arr.shape)
    return (f'<DataItem Dimensions="{dims}" NumberType="{kind}" Precision="{np.dtype(arr.dtype).itemsize}" '
            f'Format="HDF">{h5_name}:{path}</DataItem>')


def _attribute(h5_name: str, path: str, label: str, arr, center: str) -> str:
    """A scalar attribute ``label`` of the grid's cells or nodes (``center``), by reference to ``path``."""
    return (f'<Attribute Name="{label}" AttributeType="Scalar" Center="{center}">{_item(h5_name, path, arr)}'
            '</Attribute>')


def write_xdmf(h5_path) -> Path | None:
    """Write ``<run>.xdmf`` beside the 3D run file ``<run>.h5``; returns its path, or None when the run holds
    no 3D mesh (a 2D or analytic run) or no frames."""
    import h5py

    h5_path = Path(h5_path)
    with h5py.File(h5_path, "r") as f:
        if "mesh" not in f or "hexes" not in f["mesh"] or "frames" not in f:
            return None
        mesh = f["mesh"]
        hexes = mesh["hexes"]
        name = h5_path.name
        topo = (f'<Topology TopologyType="Hexahedron" NumberOfElements="{hexes.shape[0]}">'
                f'{_item(name, "/mesh/hexes", hexes)}</Topology>')
        ref = ('<Geometry GeometryType="X_Y_Z">' + "".join(_item(name, f"/mesh/{c}", mesh[c]) for c in "xyz")
               + "</Geometry>")
        grids = []
        for key in sorted(f["frames"]):
            g = f["frames"][key]
            t = float(g.attrs.get("time", 0.0))
            parts = [f'<Grid Name={quoteattr("frame " + key)} GridType="Uniform">', f'<Time Value="{t!r}"/>', topo]
            if "positions" in g:
                pos = g["positions"]
                parts.append(f'<Geometry GeometryType="XYZ">{_item(name, f"/frames/{key}/positions", pos)}</Geometry>')
            else:
                parts.append(ref)
            for field in ("material", "state", "damage"):
                if field in g:
                    parts.append(_attribute(name, f"/frames/{key}/{field}", field, g[field], "Cell"))
            parts.append("</Grid>")
            grids.append("".join(parts))
    if not grids:
        return None
    return _write(h5_path.with_suffix(".xdmf"), "chip frames", grids)


def write_particles_xdmf(h5_path) -> Path | None:
    """Write ``<run>-particles.xdmf`` beside the 3D run file ``<run>.h5``: its SPH particles per frame (module
    docstring); returns its path, or None when no frame holds particles."""
    import h5py

    h5_path = Path(h5_path)
    grids = []
    with h5py.File(h5_path, "r") as f:
        if "frames" not in f:
            return None
        name = h5_path.name
        for key in sorted(f["frames"]):
            g = f["frames"][key]
            if "particles_positions" not in g or g["particles_positions"].shape[0] == 0:
                continue
            pos = g["particles_positions"]
            n = pos.shape[0]
            t = float(g.attrs.get("time", 0.0))
            parts = [f'<Grid Name={quoteattr("particles " + key)} GridType="Uniform">', f'<Time Value="{t!r}"/>',
                     f'<Topology TopologyType="Polyvertex" NumberOfElements="{n}" NodesPerElement="1">'
                     f'<DataItem Dimensions="{n} 1" NumberType="Int" Precision="4" Format="XML">'
                     + " ".join(map(str, range(n))) + "</DataItem></Topology>",
                     f'<Geometry GeometryType="XYZ">{_item(name, f"/frames/{key}/particles_positions", pos)}</Geometry>']
            for field in ("material", "damage"):
                if f"particles_{field}" in g:
                    parts.append(_attribute(name, f"/frames/{key}/particles_{field}", field, g[f"particles_{field}"],
                                            "Node"))
            parts.append("</Grid>")
            grids.append("".join(parts))
    if not grids:
        return None
    return _write(h5_path.with_name(h5_path.stem + "-particles.xdmf"), "particles", grids)


def _write(out: Path, title: str, grids: list[str]) -> Path:
    """The XDMF file ``out``: one temporal collection of ``grids``, written whole or not at all."""
    xml = ('<?xml version="1.0"?>\n<Xdmf Version="3.0"><Domain>'
           f'<Grid Name={quoteattr(title)} GridType="Collection" CollectionType="Temporal">'
           + "\n".join(grids) + "</Grid></Domain></Xdmf>\n")
    tmp = out.with_name(".tmp-" + out.name)
    tmp.write_text(xml)
    tmp.replace(out)
    return out
