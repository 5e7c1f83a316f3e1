"""The 2D mesh container shared by the mesher, the FEM engine and the output code.

Structure of arrays, SI units, plane strain with unit width (1 m out of plane).
Material ids: FIBRE = 0, MATRIX = 1, EHM = 2 (equivalent homogeneous material).
Quads are counter-clockwise. A cohesive element joins two node pairs that start at the
same place: (a0, a1) on one side and (b0, b1) on the other, a0 facing b0, a1 facing b1;
``cohesive_elems`` names the bulk element on each side (-1 if none).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

FIBRE, MATRIX, EHM = 0, 1, 2
#: EHM_SUPPORT (3) is the engine's own id of the EHM elements on the fixed supports (solver.fem.state);
#: a mesh holds 0-2 only
EHM_SUPPORT = 3
MATERIAL_NAMES = ("fibre", "matrix", "ehm", "ehm support")


@dataclass
class Mesh:
    x: np.ndarray  # (n_nodes,) float64, initial x [m]
    y: np.ndarray  # (n_nodes,) float64, initial y [m]
    quads: np.ndarray  # (n_elems, 4) int32, counter-clockwise node ids
    material: np.ndarray  # (n_elems,) int8: FIBRE, MATRIX or EHM
    fibre_angle: np.ndarray  # (n_elems,) float64, material axis angle [rad] (fibres and EHM)
    fixed_x: np.ndarray  # (n_nodes,) bool
    fixed_y: np.ndarray  # (n_nodes,) bool
    cohesive: np.ndarray = field(default_factory=lambda: np.zeros((0, 4), np.int32))  # (n_coh, 4): a0, a1, b0, b1
    cohesive_elems: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int32))  # (n_coh, 2) bulk neighbours
    info: dict = field(default_factory=dict)  # mesher's notes: zone sizes, counts, cut plane y [m], ...

    @property
    def n_nodes(self) -> int:
        return int(self.x.shape[0])

    @property
    def n_elems(self) -> int:
        return int(self.quads.shape[0])

    @property
    def n_cohesive(self) -> int:
        return int(self.cohesive.shape[0])

    @property
    def elements(self) -> np.ndarray:
        """The elements' node ids (the quads)."""
        return self.quads

    def far_field_nodes(self) -> np.ndarray:
        """(n_nodes,) bool: the nodes that only EHM elements hold (the far field; the nodes it shares with the
        micro zone are not among them)."""
        held = np.zeros(self.n_nodes, bool)
        micro = np.zeros(self.n_nodes, bool)
        held[self.quads.reshape(-1)] = True
        micro[self.quads[self.material != EHM].reshape(-1)] = True
        return held & ~micro

    def series(self) -> dict:
        """The reference mesh as a run stores it beside its frames."""
        return {"x": self.x, "y": self.y, "quads": self.quads, "material": self.material, "cohesive": self.cohesive}

    def nbytes(self) -> int:
        return sum(a.nbytes for a in (self.x, self.y, self.quads, self.material, self.fibre_angle,
                                      self.fixed_x, self.fixed_y, self.cohesive, self.cohesive_elems))
