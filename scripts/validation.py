"""The measured tables of docs/validation.md, docs/validation-details.md and docs/numerics.md, regenerated from replica files.

    python scripts/validation.py status                      each row: replicas on file, replicas wanted
    python scripts/validation.py measure [ROW ...] [--jobs 2] [--upto N]  run the missing replicas (all rows by default)
    python scripts/validation.py measure ROW --frames FOLDER N  ... and keep each replica's run file with N frames
    python scripts/validation.py measure verify              run `fibrecut verify --json` into the data folder
    python scripts/validation.py measure verify:CASE         run one case and update its entry there
    python scripts/validation.py render                      rewrite the generated tables in the docs

A row (ROWS below) is a scene with dotted overrides and a number of replicas. `measure` runs replica k
of a row as ``NUMBA_NUM_THREADS=1 python scripts/replicas.py SCENE k:k+1 OVERRIDES``, one process per job
and one job per core, and appends its JSON line to ``docs/data/ROW.jsonl``: the files are the
measurements, a killed measurement loses only the replicas in flight, and a later `measure` adds the
missing ones. `render` replaces every block between ``<!-- generated: TABLE -->`` and
``<!-- end generated -->`` in the docs with TABLE computed from those files, and the acceptance
criteria of the cutting physics are judged there from the same numbers: a change is "met" when its
whole two-standard-error interval lies inside the bound, "no" when it lies outside, "not resolved"
otherwise.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "docs" / "data"
DOCS = [ROOT / "docs" / "validation.md", ROOT / "docs" / "validation-details.md", ROOT / "docs" / "numerics.md"]

QUICK0, QUICK90 = "seed-0deg-fem-quick", "seed-90deg-fem-quick"
#: the quick scenes' speed scaling before it became 250 (their forces level off there, docs/numerics.md)
SS1000 = {"numerics.speed_scaling": 1000}
#: half the scenes' Courant factor, and the contact penalties held at those of the default factor (they are set
#: as alpha m / dt^2 from the step, so 0.25 x at half the step)
CFL025 = {"numerics.cfl": 0.25}
HELD_PENALTIES, HELD_LABEL = {"numerics.contact_stiffness_factor": 0.25}, "contact penalties x 0.25 (those of CFL 0.5)"

#: the full scene's 200-um cut on the quick scene, at the quick scenes' speed scaling and at the full scenes' (2000)
CUT200 = {"cut.length_um": 200}
CUT200_SS2000 = {**CUT200, "numerics.speed_scaling": 2000}
#: diagnoses, not data: a matrix that does not fail (crack band and ductile failure out of reach), and interfaces
#: four times as tough as the ply's (above the peel threshold G* of docs/validation-details.md)
NO_MATRIX_FAILURE = {"materials.matrix.fracture_energy_N_mm": 100, "materials.matrix.failure_plastic_strain": 100}
TOUGH_INTERFACE = {"materials.interface.GIc_N_mm": 1.2, "materials.interface.GIIc_N_mm": 3.2}
#: the far field damped (workpiece.far_field_damping_per_us; docs/model.md, "The scene"), off in the seed scenes
DAMPED = {"workpiece.far_field_damping_per_us": 10}
#: the preset t800s-m21-2d's matrix tensile yield before it became the strip stack's 2D equivalent (95 MPa, with
#: which the micro-zone cell reaches the ply's Y_T; docs/model.md): the epoxy's own 74.7 MPa
MATRIX_FIELD = "materials.matrix.sigma_u_MPa"
FORMER_MATRIX_MPA = 74.7
FORMER_MATRIX_SETTING = {MATRIX_FIELD: FORMER_MATRIX_MPA}

#: name -> (label, scene, overrides, replicas wanted); measured in this order
ROWS: dict[str, tuple[str, str, dict[str, float | str], int]] = {
    "quick-0": ("0 deg, rake 30, depth 100 (seed-0deg-fem-quick)", QUICK0, {}, 8),
    "quick-0-rake0": ("rake 0", QUICK0, {"tool.rake_angle_deg": 0}, 4),
    "quick-0-rake15": ("rake 15", QUICK0, {"tool.rake_angle_deg": 15}, 4),
    "quick-0-depth50": ("depth 50", QUICK0, {"cut.depth_um": 50}, 8),
    "quick-90-rake30": ("90 deg, rake 30, depth 50", QUICK90, {"tool.rake_angle_deg": 30}, 8),
    "quick-90": ("90 deg, rake 10, depth 50 (seed-90deg-fem-quick)", QUICK90, {}, 4),
    # the 90-degree micro zone's depth: the matrix between the fibre columns fails down to the zone's bottom
    "quick-90-h300": ("90 deg, rake 10, depth 50, workpiece 300 um high", QUICK90, {"workpiece.height_um": 300}, 4),
    "quick-90-zone80": ("90 deg, rake 10, depth 50, workpiece 300 um high, micro zone 80 um", QUICK90,
                        {"workpiece.height_um": 300, "workpiece.micro_zone_depth_um": 80}, 4),
    "quick-90-zone150": ("90 deg, rake 10, depth 50, workpiece 300 um high, micro zone 150 um", QUICK90,
                         {"workpiece.height_um": 300, "workpiece.micro_zone_depth_um": 150}, 4),
    "quick-90-absorbing": ("90 deg, rake 10, depth 50, far field damped (10 per us)", QUICK90,
                           DAMPED, 4),
    "quick-0-offset4": ("cut plane 4 um into the fibre stack", QUICK0, {"workpiece.fibre_offset_um": 4}, 4),
    "quick-0-offset8": ("cut plane 8 um into the fibre stack", QUICK0, {"workpiece.fibre_offset_um": 8}, 4),
    "quick-0-reading-a": ("the paper's interface and brittle matrix (preset t800s-m21-seed-reading-a)", QUICK0,
                          {"materials.preset": "t800s-m21-seed-reading-a"}, 4),
    "quick-0-hybrid": ("hybrid D 0.1 (seed-0deg-hybrid-d01-quick)", "seed-0deg-hybrid-d01-quick", {}, 8),
    "quick-90-hybrid": ("hybrid D 0.1, 90 deg (seed-90deg-hybrid-d01-quick)", "seed-90deg-hybrid-d01-quick", {}, 4),
    "quick-0-hybrid-rake0": ("hybrid D 0.1, rake 0", "seed-0deg-hybrid-d01-quick", {"tool.rake_angle_deg": 0}, 8),
    "quick-0-hybrid-rake15": ("hybrid D 0.1, rake 15", "seed-0deg-hybrid-d01-quick", {"tool.rake_angle_deg": 15}, 8),
    "quick-0-hybrid-depth50": ("hybrid D 0.1, depth 50", "seed-0deg-hybrid-d01-quick", {"cut.depth_um": 50}, 4),
    "quick-90-hybrid-rake30": ("hybrid D 0.1, 90 deg, rake 30, depth 50", "seed-90deg-hybrid-d01-quick",
                               {"tool.rake_angle_deg": 30}, 4),
    "quick-0-hybrid-rake0-cfl025": ("hybrid D 0.1, rake 0, CFL 0.25", "seed-0deg-hybrid-d01-quick",
                                    {"tool.rake_angle_deg": 0, **CFL025}, 8),
    "quick-0-hybrid-cfl025": ("hybrid D 0.1, CFL 0.25", "seed-0deg-hybrid-d01-quick", CFL025, 8),
    "quick-0-hybrid-cfl025-k": ("hybrid D 0.1, CFL 0.25, " + HELD_LABEL, "seed-0deg-hybrid-d01-quick",
                                {**CFL025, **HELD_PENALTIES}, 4),
    "quick-0-cfl025": ("CFL 0.25", QUICK0, CFL025, 4),
    "quick-0-cfl0125": ("CFL 0.125", QUICK0, {"numerics.cfl": 0.125}, 4),
    "quick-0-cfl025-k": ("CFL 0.25, " + HELD_LABEL, QUICK0, {**CFL025, **HELD_PENALTIES}, 4),
    "quick-0-h2": ("h 2.5 um, 6 across a fibre", QUICK0,
                   {"numerics.element_size_um": 2.5, "numerics.elements_across_fibre": 6}, 8),
    "quick-0-ss1000": ("speed scaling 1000", QUICK0, {"numerics.speed_scaling": 1000}, 8),
    "quick-0-ss500": ("speed scaling 500", QUICK0, {"numerics.speed_scaling": 500}, 8),
    "quick-0-ss125": ("speed scaling 125", QUICK0, {"numerics.speed_scaling": 125}, 8),
    "quick-0-h2-ss1000": ("h 2.5 um, 6 across a fibre, speed scaling 1000", QUICK0,
                          {"numerics.element_size_um": 2.5, "numerics.elements_across_fibre": 6, **SS1000}, 8),
    "quick-0-far-ss1000": ("workpiece 400 um long, micro zone 120 um, speed scaling 1000", QUICK0,
                           {"workpiece.length_um": 400, "workpiece.micro_zone_depth_um": 120, **SS1000}, 8),
    "quick-0-far": ("workpiece 400 um long, micro zone 120 um", QUICK0,
                    {"workpiece.length_um": 400, "workpiece.micro_zone_depth_um": 120}, 8),
    # diagnosis, not data: the interface's mode-I toughness raised to the peel threshold G* (docs/validation-details.md)
    "diagnosis-gic-rake0": ("rake 0, G_Ic 1.2 N/mm", QUICK0, {"tool.rake_angle_deg": 0, "materials.interface.GIc_N_mm": 1.2, **SS1000}, 4),
    "diagnosis-gic-rake15": ("rake 15, G_Ic 1.2 N/mm", QUICK0, {"tool.rake_angle_deg": 15, "materials.interface.GIc_N_mm": 1.2, **SS1000}, 4),
    "diagnosis-gic-rake30": ("rake 30, G_Ic 1.2 N/mm", QUICK0, {"materials.interface.GIc_N_mm": 1.2, **SS1000}, 4),
    "diagnosis-gic-matrix-rake0": ("rake 0, G_Ic and the matrix's fracture energy 1.2 N/mm", QUICK0,
                                   {"tool.rake_angle_deg": 0, "materials.interface.GIc_N_mm": 1.2,
                                    "materials.matrix.fracture_energy_N_mm": 1.2, **SS1000}, 4),
    "diagnosis-gic-matrix-rake30": ("rake 30, G_Ic and the matrix's fracture energy 1.2 N/mm", QUICK0,
                                    {"materials.interface.GIc_N_mm": 1.2, "materials.matrix.fracture_energy_N_mm": 1.2, **SS1000}, 4),
    "diagnosis-shear-rake0": ("rake 0, interface shear strength and G_IIc x 3", QUICK0,
                              {"tool.rake_angle_deg": 0, "materials.interface.shear_strength_MPa": 276.9,
                               "materials.interface.GIIc_N_mm": 2.364, **SS1000}, 4),
    "diagnosis-shear-rake30": ("rake 30, interface shear strength and G_IIc x 3", QUICK0,
                               {"materials.interface.shear_strength_MPa": 276.9, "materials.interface.GIIc_N_mm": 2.364, **SS1000}, 4),
    "diagnosis-matrix-rake0": ("rake 0, a matrix that does not fail", QUICK0,
                               {"tool.rake_angle_deg": 0, "materials.matrix.fracture_energy_N_mm": 100,
                                "materials.matrix.failure_plastic_strain": 100, **SS1000}, 4),
    "diagnosis-matrix-rake30": ("rake 30, a matrix that does not fail", QUICK0,
                                {"materials.matrix.fracture_energy_N_mm": 100, "materials.matrix.failure_plastic_strain": 100, **SS1000}, 4),
    "diagnosis-ductile-rake0": ("rake 0, the matrix's ductile failure strain 100 (no ductile failure)", QUICK0,
                                {"tool.rake_angle_deg": 0, "materials.matrix.failure_plastic_strain": 100, **SS1000}, 4),
    "diagnosis-ductile-rake30": ("rake 30, the matrix's ductile failure strain 100 (no ductile failure)", QUICK0,
                                 {"materials.matrix.failure_plastic_strain": 100, **SS1000}, 4),
    "quick-0-fem3d": ("3D strip, 0 deg (seed-0deg-fem3d-quick)", "seed-0deg-fem3d-quick", {}, 4),
    "quick-90-fem3d": ("3D strip, 90 deg (seed-90deg-fem3d-quick)", "seed-90deg-fem3d-quick", {}, 4),
    "quick-0-fem3d-ply": ("3D strip, 0 deg, the ply-consistent interface (preset t800s-m21-3d)", "seed-0deg-fem3d-quick",
                          {"materials.preset": "t800s-m21-3d"}, 4),
    "quick-0-fem3d-ply-rake0": ("3D strip, 0 deg, rake 0, preset t800s-m21-3d", "seed-0deg-fem3d-quick",
                                {"materials.preset": "t800s-m21-3d", "tool.rake_angle_deg": 0}, 4),
    "quick-90-fem3d-ply": ("3D strip, 90 deg, preset t800s-m21-3d", "seed-90deg-fem3d-quick",
                           {"materials.preset": "t800s-m21-3d"}, 4),
    # the 3D strip's 0-degree cut twice as long as its quick scene's: does its layer stay on the tool, or leave the
    # workpiece as the 2D stack's does on a long cut?
    "long120-0-fem3d-ply": ("3D strip, 0 deg, preset t800s-m21-3d, 120-um cut", "seed-0deg-fem3d-quick",
                            {"materials.preset": "t800s-m21-3d", "cut.length_um": 120}, 2),
    # a diagnosis, not data: the 3D strip's interfaces above the peel threshold G* (docs/validation-details.md)
    "diagnosis-long120-fem3d-tough": ("3D strip, 0 deg, preset t800s-m21-3d, 120-um cut, G_Ic 1.2 and G_IIc 3.2 N/mm "
                                      "(a diagnosis)", "seed-0deg-fem3d-quick",
                                      {"materials.preset": "t800s-m21-3d", "cut.length_um": 120, **TOUGH_INTERFACE}, 2),
    "quick-0-hybrid3d": ("3D strip, hybrid D 0.1, 0 deg (seed-0deg-hybrid3d-d01-quick)", "seed-0deg-hybrid3d-d01-quick", {}, 6),
    "quick-90-hybrid3d": ("3D strip, hybrid D 0.1, 90 deg (seed-90deg-hybrid3d-d01-quick)", "seed-90deg-hybrid3d-d01-quick",
                          {}, 4),
    "quick-0-hybrid3d-d08": ("3D strip, hybrid D 0.8, 0 deg (seed-0deg-hybrid3d-d08-quick)", "seed-0deg-hybrid3d-d08-quick",
                             {}, 4),
    "quick-0-hybrid3d-ply": ("3D strip, hybrid D 0.1, 0 deg, preset t800s-m21-3d", "seed-0deg-hybrid3d-d01-quick",
                             {"materials.preset": "t800s-m21-3d"}, 4),
    # the full scene's 200-um cut at the quick scene's numerics (h 5 um, speed scaling 250), and at the full scene's
    # speed scaling: what the full scene's low Fc owes to the cut's length and what to the tool's speed
    "long-0": ("0 deg, rake 30, depth 100, 200-um cut (seed-0deg-fem-quick, cut.length_um 200)", QUICK0,
               CUT200, 4),
    "long-0-ss2000": ("the same at speed scaling 2000 (the full scenes')", QUICK0,
                      CUT200_SS2000, 4),
    "long-0-ss2000-offset4": ("the same at speed scaling 2000, cut plane 4 um into the fibre stack", QUICK0,
                              {**CUT200_SS2000, "workpiece.fibre_offset_um": 4}, 4),
    # a diagnosis, not data: does a tougher interface (a stand-in for the bridging a real ply's crack meets) keep
    # the cut plane's crack from running ahead on the 200-um cut?
    "diagnosis-long-tough": ("the same at speed scaling 2000, G_Ic 1.2 and G_IIc 3.2 N/mm (a diagnosis)", QUICK0,
                             {**CUT200_SS2000, **TOUGH_INTERFACE}, 4),
    "diagnosis-long-shear": ("the same at speed scaling 2000, interface shear strength and G_IIc x 3 (a diagnosis)",
                             QUICK0, {**CUT200_SS2000, "materials.interface.shear_strength_MPa": 276.9,
                                      "materials.interface.GIIc_N_mm": 2.364}, 4),
    "diagnosis-long-rake0": ("the same at speed scaling 2000, rake 0 (a diagnosis: a face that does not lift the layer)",
                             QUICK0, {**CUT200_SS2000, "tool.rake_angle_deg": 0}, 4),
    # a diagnosis, not data: fibres that fail at Xc in compression (no plastic flow to 0.155) -- does the lifted
    # layer then break at its root, on its compressive face, instead of peeling off?
    "diagnosis-long-kink": ("the same at speed scaling 2000, fibres failing at Xc in compression (a diagnosis)",
                            QUICK0, {**CUT200_SS2000, "materials.fibre.compressive_failure_strain": 0.0115}, 4),
    # diagnoses, not data: the layer as one beam (its matrix walls do not fail), with the ply's interface and with an
    # interface above the peel threshold G* = E eps_f^2 t / 6 -- does the layer then break near the tool instead of
    # peeling off along the cut?
    "diagnosis-long-matrix": ("the same at speed scaling 2000, a matrix that does not fail (a diagnosis)", QUICK0,
                              {**CUT200_SS2000, **NO_MATRIX_FAILURE}, 4),
    "diagnosis-long-ductile": ("the same at speed scaling 2000, no ductile failure of the matrix (a diagnosis)", QUICK0,
                               {**CUT200_SS2000, "materials.matrix.failure_plastic_strain": 100}, 4),
    "diagnosis-long-crackband": ("the same at speed scaling 2000, the matrix's crack-band fracture energy 100 N/mm "
                                 "(a diagnosis)", QUICK0,
                                 {**CUT200_SS2000, "materials.matrix.fracture_energy_N_mm": 100}, 4),
    "diagnosis-long-beam": ("the same at speed scaling 2000, a matrix that does not fail, G_Ic 1.2 and G_IIc 3.2 N/mm "
                            "(a diagnosis)", QUICK0,
                            {**CUT200_SS2000, **NO_MATRIX_FAILURE, **TOUGH_INTERFACE}, 4),
    "diagnosis-long-beam-rake0": ("the same at speed scaling 2000, rake 0, a matrix that does not fail, G_Ic 1.2 and "
                                  "G_IIc 3.2 N/mm (a diagnosis)", QUICK0,
                                  {**CUT200_SS2000, "tool.rake_angle_deg": 0, **NO_MATRIX_FAILURE,
                                   **TOUGH_INTERFACE}, 4),
    # a cut long enough for several of the 0-degree layer's segments (each about 200 um long on the 200-um cut)
    "long600-0-ss2000": ("0 deg, rake 30, depth 100, 600-um cut at speed scaling 2000 (seed-0deg-fem-quick)", QUICK0,
                         {"cut.length_um": 600, "numerics.speed_scaling": 2000}, 4),
    "full-0-fem": ("seed-0deg-fem", "seed-0deg-fem", {}, 8),
    "full-0-hybrid-d01": ("seed-0deg-hybrid-d01", "seed-0deg-hybrid-d01", {}, 8),
    # the rake-angle trend on the full 200-um cut (the quick cut, 60 um at 100 um depth, is all engagement)
    "full-0-hybrid-d01-rake0": ("seed-0deg-hybrid-d01, rake 0", "seed-0deg-hybrid-d01", {"tool.rake_angle_deg": 0}, 4),
    "full-0-hybrid-d01-rake15": ("seed-0deg-hybrid-d01, rake 15", "seed-0deg-hybrid-d01", {"tool.rake_angle_deg": 15}, 4),
    "full-90-hybrid-d01": ("seed-90deg-hybrid-d01", "seed-90deg-hybrid-d01", {}, 8),
    "full-90-fem": ("seed-90deg-fem", "seed-90deg-fem", {}, 8),
    "full-0-hybrid-d08": ("seed-0deg-hybrid-d08", "seed-0deg-hybrid-d08", {}, 8),
    "full-0-fem-ss1000": ("seed-0deg-fem, speed scaling 1000", "seed-0deg-fem",
                          {"numerics.speed_scaling": 1000, "numerics.max_wall_time_s": 20000}, 4),
    # the far field damped (workpiece.far_field_damping_per_us; docs/model.md, "The scene"): what the waves
    # trapped in the cut-out block do to the forces and to the far field's overload
    "full-90-fem-absorbing": ("seed-90deg-fem, far field damped (10 per us)", "seed-90deg-fem",
                              DAMPED, 8),
    "full-0-fem-absorbing": ("seed-0deg-fem, far field damped (10 per us)", "seed-0deg-fem",
                             DAMPED, 8),
    "quick-0-absorbing": ("far field damped (10 per us)", QUICK0, DAMPED, 8),
    "quick-0-rake0-absorbing": ("rake 0, far field damped (10 per us)", QUICK0,
                                {"tool.rake_angle_deg": 0, **DAMPED}, 4),
    "quick-0-rake15-absorbing": ("rake 15, far field damped (10 per us)", QUICK0,
                                 {"tool.rake_angle_deg": 15, **DAMPED}, 4),
    "full-0-hybrid-d01-absorbing": ("seed-0deg-hybrid-d01, far field damped (10 per us)", "seed-0deg-hybrid-d01",
                                    DAMPED, 8),
    "full-90-hybrid-d01-absorbing": ("seed-90deg-hybrid-d01, far field damped (10 per us)", "seed-90deg-hybrid-d01",
                                     DAMPED, 4),
    "full-90-fem-absorbing30": ("seed-90deg-fem, far field damped (30 per us)", "seed-90deg-fem",
                                {"workpiece.far_field_damping_per_us": 30}, 4),
    "full-90-fem-far-absorbing": ("seed-90deg-fem, workpiece 556 um long, micro zone 80 um, far field damped (10 per us)",
                                  "seed-90deg-fem", {"workpiece.length_um": 556, "workpiece.micro_zone_depth_um": 80,
                                                     **DAMPED}, 4),
    # the far field at 90 degrees: the default workpiece (278 um long) and micro zone (40 um) doubled
    "full-90-fem-far": ("seed-90deg-fem, workpiece 556 um long, micro zone 80 um", "seed-90deg-fem",
                        {"workpiece.length_um": 556, "workpiece.micro_zone_depth_um": 80}, 4),
}

#: rows also kept at speed scaling 1000, the quick scenes' default before 250 (the tests' margins and the
#: diagnosis table were measured there): ROW-ss1000 is ROW with SS1000
AT_1000 = ["quick-0-rake0", "quick-0-rake15", "quick-0-depth50", "quick-90-rake30", "quick-0-offset4",
           "quick-0-offset8", "quick-0-reading-a", "quick-0-hybrid", "quick-0-hybrid-rake0", "quick-0-hybrid-rake15",
           "quick-0-hybrid-depth50", "quick-90-hybrid", "quick-90-hybrid-rake30"]


def _add_variants(rows: list[str], suffix: str, what: str, overrides: dict) -> None:
    """Rows ROW-suffix: ROW with ``overrides``, labelled with ``what`` (the seed scene's name left out)."""
    for row in rows:
        label, scene, over, n = ROWS[row]
        ROWS[f"{row}-{suffix}"] = (re.sub(r" \(seed-[^)]*\)$", "", label) + f", {what}", scene, {**over, **overrides}, n)


_add_variants(AT_1000, "ss1000", "speed scaling 1000", SS1000)

#: rows also measured with the 2D quads' hourglass following the material (``physics.hourglass_follows_material``,
#: off by default; docs/numerics.md, "The 2D quad's hourglass in inelastic elements"): ROW-hg is ROW with it on
HG = {"physics.hourglass_follows_material": True}
WITH_HG = ["quick-0", "quick-0-rake0", "quick-0-rake15", "quick-0-depth50", "quick-90-rake30", "quick-90", "quick-0-far",
           "quick-0-ss125", "quick-0-h2", "quick-0-hybrid", "quick-0-hybrid-rake0", "quick-0-hybrid-rake15",
           "quick-0-hybrid-depth50", "quick-90-hybrid-rake30"]
_add_variants(WITH_HG, "hg", "hourglass following the material", HG)
#: rows measured again since the preset's matrix tensile yield became 95 MPa; each keeps its former replicas as the
#: row ROW-matrix747 (the same scene with the former 74.7 MPa set), which the comparisons with rows still at the former
#: matrix use
REMEASURED = ["quick-0", "quick-0-rake0", "quick-0-rake15", "quick-0-depth50", "quick-90-rake30", "quick-90",
              "quick-0-ss1000", "quick-0-depth50-ss1000", "quick-90-rake30-ss1000", "quick-0-hybrid",
              "quick-0-hybrid-rake0", "quick-0-hybrid-rake15", "quick-0-hybrid-depth50", "quick-90-hybrid",
              "quick-90-hybrid-rake30", "full-0-fem", "full-90-fem", "full-0-hybrid-d01", "full-90-hybrid-d01",
              "quick-0-ss125", "quick-0-h2"]
_add_variants(REMEASURED, "matrix747", f"matrix tensile yield {FORMER_MATRIX_MPA} MPa", FORMER_MATRIX_SETTING)


def _ran_with_former_matrix(row: str) -> bool:
    """A row whose replicas ran with the preset t800s-m21-2d's former matrix: a 2D scene on that preset that does not
    set the matrix's tensile yield itself, not measured again since."""
    _, scene, over, _ = ROWS[row]
    return ("3d" not in scene and MATRIX_FIELD not in over and row not in REMEASURED
            and over.get("materials.preset", "t800s-m21-2d") == "t800s-m21-2d")


#: rows whose replicas ran with the former matrix (74.7 MPa) without setting it: their tables mark them
FORMER_MATRIX = frozenset(row for row in ROWS if _ran_with_former_matrix(row))

#: rows whose replicas ran with the friction whose stick trial left out the other forces on a node (a node that
#: should stick crept along the tool at dt f_t / m, docs/numerics.md "The time step"): their tables mark them,
#: and a row leaves this set when it is re-measured
CREEPING_FRICTION = frozenset({
    "quick-0-offset4", "quick-0-offset8", "quick-0-reading-a",
    "quick-0-hybrid-rake0-cfl025", "quick-0-hybrid-cfl025-k", "quick-0-cfl025-k",
    "quick-0-ss500", "quick-0-h2-ss1000", "quick-0-far-ss1000",
    "diagnosis-gic-rake0", "diagnosis-gic-rake15", "diagnosis-gic-rake30",
    "diagnosis-gic-matrix-rake0", "diagnosis-gic-matrix-rake30", "diagnosis-shear-rake0", "diagnosis-shear-rake30",
    "diagnosis-matrix-rake0", "diagnosis-matrix-rake30", "diagnosis-ductile-rake0", "diagnosis-ductile-rake30",
    "quick-0-fem3d", "quick-90-fem3d", "quick-0-fem3d-ply", "quick-0-fem3d-ply-rake0", "quick-90-fem3d-ply",
    "quick-0-hybrid3d", "quick-90-hybrid3d", "quick-0-hybrid3d-d08", "quick-0-hybrid3d-ply",
    "full-0-hybrid-d08", "quick-0-rake0-ss1000",
    "quick-0-rake15-ss1000", "quick-0-depth50-ss1000-matrix747", "quick-90-rake30-ss1000-matrix747",
    "quick-0-offset4-ss1000",
    "quick-0-offset8-ss1000", "quick-0-reading-a-ss1000", "quick-0-hybrid-ss1000", "quick-0-hybrid-rake0-ss1000",
    "quick-0-hybrid-rake15-ss1000", "quick-0-hybrid-depth50-ss1000", "quick-90-hybrid-ss1000",
    "quick-90-hybrid-rake30-ss1000"
})


CREEPING_MARK = " (creeping friction)"
MATRIX_MARK = f" (matrix {FORMER_MATRIX_MPA} MPa)"

#: ROW-hg rows whose replicas ran before the hourglass's factor had its floor (``quad.HOURGLASS_SECANT_FLOOR``;
#: the factor fell to the secant ratio itself): their tables mark them, and a row leaves this set when it is
#: re-measured
HG_NO_FLOOR = frozenset({"quick-90-hg", "quick-0-far-hg"})
NO_FLOOR_MARK = " (no floor)"


def mark(row: str) -> str:
    """The marks a row carries in the tables: its replicas ran with the creeping friction, with the former matrix,
    or (an -hg row) before the hourglass factor's floor; else ''."""
    return (CREEPING_MARK * (row in CREEPING_FRICTION) + MATRIX_MARK * (row in FORMER_MATRIX)
            + NO_FLOOR_MARK * (row in HG_NO_FLOOR))


def label(row: str) -> str:
    """A row's label in the tables, with its marks."""
    return ROWS[row][0] + mark(row)


def _matrix(row: str) -> float | None:
    """The matrix tensile yield a row ran with where it differs from the preset's (None: the preset's)."""
    return FORMER_MATRIX_MPA if row in FORMER_MATRIX else ROWS[row][2].get(MATRIX_FIELD)


def not_comparable(*rows: str) -> str:
    """Why no change is computed between these rows ('' when they ran with the same friction law and, a row not
    setting it itself, the same matrix): some ran with the creeping friction and some without, or some with the
    former matrix and some with the present one."""
    if len({row in CREEPING_FRICTION for row in rows}) > 1:
        return "creeping friction"
    if len({row in FORMER_MATRIX for row in rows}) > 1 and len({_matrix(row) for row in rows}) > 1:
        return f"matrix {FORMER_MATRIX_MPA} MPa"
    return ""


def mixed(*rows: str) -> str:
    """The verdict of a comparison between rows that are not comparable ('' when they are)."""
    why = not_comparable(*rows)
    return f"not comparable ({why} on one side)" if why else ""


def counterpart(row: str, against: str) -> str:
    """The row a change of ``row`` is measured against: ``against``, or its former-matrix twin when only that ran
    with the same matrix and friction as ``row``."""
    twin = f"{against}-matrix747"
    return twin if not_comparable(row, against) and twin in ROWS and not not_comparable(row, twin) else against


#: the table of the hourglass's effect: each row beside its -hg twin (measured with the same matrix)
HOURGLASS_TABLE = [name for row in WITH_HG for name in (counterpart(f"{row}-hg", row), f"{row}-hg")]


QUICK_TABLE = ["quick-0", "quick-0-rake0", "quick-0-rake15", "quick-0-depth50", "quick-90-rake30", "quick-90",
               "quick-0-offset4", "quick-0-offset8", "quick-0-reading-a", "quick-0-hybrid", "quick-0-hybrid-rake0",
               "quick-0-hybrid-rake15", "quick-0-hybrid-depth50", "quick-90-hybrid", "quick-90-hybrid-rake30",
               "quick-0-fem3d", "quick-90-fem3d", "quick-0-fem3d-ply", "quick-0-fem3d-ply-rake0", "quick-90-fem3d-ply",
               "quick-0-hybrid3d", "quick-90-hybrid3d", "quick-0-hybrid3d-d08", "quick-0-hybrid3d-ply"]
#: the quick rows at speed scaling 1000, the quick scenes' default before 250 (the tests' margins were measured there)
QUICK_1000_TABLE = ["quick-0-ss1000", "quick-0-rake0-ss1000", "quick-0-rake15-ss1000", "quick-0-depth50-ss1000",
                    "quick-90-rake30-ss1000", "quick-0-offset4-ss1000", "quick-0-offset8-ss1000",
                    "quick-0-reading-a-ss1000", "quick-0-hybrid-ss1000", "quick-0-hybrid-rake0-ss1000",
                    "quick-0-hybrid-rake15-ss1000", "quick-0-hybrid-depth50-ss1000", "quick-90-hybrid-ss1000",
                    "quick-90-hybrid-rake30-ss1000"]
DIAGNOSIS_TABLE = ["quick-0-rake0-ss1000", "quick-0-rake15-ss1000", "quick-0-ss1000-matrix747", "diagnosis-gic-rake0", "diagnosis-gic-rake15",
                   "diagnosis-gic-rake30", "diagnosis-gic-matrix-rake0", "diagnosis-gic-matrix-rake30",
                   "diagnosis-shear-rake0", "diagnosis-shear-rake30", "diagnosis-matrix-rake0", "diagnosis-matrix-rake30",
                   "diagnosis-ductile-rake0", "diagnosis-ductile-rake30"]
CONVERGENCE_TABLE = ["quick-0", "quick-0-matrix747", "quick-0-ss125", "quick-0-ss500", "quick-0-ss1000", "quick-0-h2", "quick-0-far",
                     "quick-0-absorbing", "quick-0-h2-ss1000", "quick-0-far-ss1000"]
#: the quick scenes at their Courant factor (0.5) and below it, classic FEM and the hybrid
TIMESTEP_TABLE = ["quick-0-hybrid-rake0-matrix747", "quick-0-hybrid-rake0-cfl025", "quick-0-hybrid-matrix747",
                  "quick-0-hybrid-cfl025", "quick-0-hybrid-cfl025-k", "quick-0-matrix747", "quick-0-cfl025",
                  "quick-0-cfl025-k", "quick-0-cfl0125"]
#: (level, the level it is compared with) of the changes table beyond "against the default": the speed scaling's
#: steps, the mesh and far-field levels against the default they were measured beside, and the Courant factor's
CHANGES_AGAINST = [("long-0-ss2000", "long-0"), ("full-0-fem-absorbing", "full-0-fem"),
                   ("full-0-hybrid-d01-absorbing", "full-0-hybrid-d01"), ("quick-0-rake0-absorbing", "quick-0-rake0"),
                   ("quick-0-rake15-absorbing", "quick-0-rake15"),
                   ("full-90-hybrid-d01-absorbing", "full-90-hybrid-d01"),
                   ("full-90-fem-absorbing", "full-90-fem"),
                   ("full-90-fem-absorbing30", "full-90-fem-absorbing"), ("full-90-fem-far", "full-90-fem"),
                   ("full-90-fem-far-absorbing", "full-90-fem-absorbing"), ("quick-0-ss500", "quick-0-ss1000"),
                   ("quick-0-h2-ss1000", "quick-0-ss1000"),
                   ("quick-0-far-ss1000", "quick-0-ss1000"), ("quick-0-hybrid-rake0-cfl025", "quick-0-hybrid-rake0"),
                   ("quick-0-hybrid-cfl025", "quick-0-hybrid"), ("quick-0-hybrid-cfl025-k", "quick-0-hybrid"),
                   ("quick-0-cfl025", "quick-0"), ("quick-0-cfl025-k", "quick-0"), ("quick-0-cfl0125", "quick-0")]
#: the 90-degree quick scene's micro zone deepened (the workpiece made higher to hold it), with its control
ZONE90_TABLE = ["quick-90-matrix747", "quick-90-h300", "quick-90-zone80", "quick-90-zone150", "quick-90-absorbing"]
#: the 0-degree scenes with the matrix at the tensile yield that brings the micro-zone cell to the ply's Y_T
MATRIX_YT_TABLE = [name for row in ("quick-0-rake0", "quick-0-rake15", "quick-0", "quick-0-depth50", "quick-90-rake30",
                                      "full-0-fem", "quick-90", "full-90-fem")
                   for name in (f"{row}-matrix747", row)]
FULL_TABLE = ["full-0-fem", "full-0-hybrid-d08", "full-0-hybrid-d01", "full-90-fem", "full-90-hybrid-d01"]
#: the full scenes beside their variants: the 200-um cut at the quick numerics, the far field damped, the rake
VARIANTS_TABLE = ["full-0-fem", "full-0-fem-matrix747", "long-0", "long-0-ss2000", "long-0-ss2000-offset4", "diagnosis-long-tough",
                  "diagnosis-long-shear", "diagnosis-long-rake0", "diagnosis-long-kink",
                  "diagnosis-long-matrix", "diagnosis-long-ductile", "diagnosis-long-crackband",
                  "diagnosis-long-beam", "diagnosis-long-beam-rake0",
                  "long600-0-ss2000", "long120-0-fem3d-ply", "diagnosis-long120-fem3d-tough",
                  "full-0-fem-absorbing",
                  "full-0-hybrid-d01", "full-0-hybrid-d01-matrix747", "full-0-hybrid-d01-absorbing",
                  "full-0-hybrid-d01-rake15", "full-0-hybrid-d01-rake0", "full-90-fem", "full-90-fem-matrix747",
                  "full-90-fem-absorbing",
                  "full-90-fem-absorbing30", "full-90-fem-far", "full-90-fem-far-absorbing", "full-90-hybrid-d01",
                  "full-90-hybrid-d01-matrix747", "full-90-hybrid-d01-absorbing"]
#: the paper's Table 2 (solver/reference/seed_results.json) per full row: (case, model key)
PAPER = {"full-0-fem": ("theta_0", "classic_fem"), "full-0-hybrid-d08": ("theta_0", "hybrid_d08"),
         "full-0-hybrid-d01": ("theta_0", "hybrid_d01"), "full-90-fem": ("theta_90", "classic_fem"),
         "full-90-hybrid-d01": ("theta_90", "hybrid_d01")}

FC, FT = "cutting_force_N_per_mm", "thrust_force_N_per_mm"


# ---------------------------------------------------------------------------------------------- measuring

def _file(row: str) -> Path:
    return DATA / f"{row}.jsonl"


def _rows_on_file(row: str) -> list[dict]:
    f = _file(row)
    return [json.loads(line) for line in f.read_text().splitlines() if line.strip()] if f.exists() else []


def _missing(row: str, upto: int | None = None) -> list[int]:
    have = {r["k"] for r in _rows_on_file(row)}
    n = ROWS[row][3] if upto is None else min(upto, ROWS[row][3])
    return [k for k in range(n) if k not in have]


def _one(row: str, k: int, frames: tuple[str, int] | None = None) -> str:
    """Run replica k of a row and append its line; with ``frames`` = (folder, n) also write its run file with n
    frames, folder/ROW-k.h5 (the line on file is the same as without: frames do not change the run)."""
    label, scene, over, _ = ROWS[row]
    h5 = ["--h5", str(Path(frames[0]) / row)] if frames else []
    cmd = [sys.executable, str(ROOT / "scripts" / "replicas.py"), *h5, scene, f"{k}:{k + 1}",
           *(f"{f}={v}" for f, v in over.items()), *([f"numerics.n_frames={frames[1]}"] if frames else [])]
    env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
    t = time.time()
    p = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    line = p.stdout.strip().splitlines()[-1] if p.returncode == 0 and p.stdout.strip() else ""
    if not line:
        print(f"{row} k={k}: replica failed (exit {p.returncode}): {p.stderr.strip()[-400:]}", flush=True)
        return ""
    if frames:
        record = json.loads(line)
        record.pop("h5", None)
        record.pop("numerics.n_frames", None)
        line = json.dumps(record)
    with open(_file(row), "a") as fh:  # one writer: this process, one line at a time
        fh.write(line + "\n")
    print(f"{row} k={k}: {time.time() - t:.0f} s, {line[:160]}", flush=True)
    return line


def measure(rows: list[str], jobs: int, upto: int | None = None, frames: tuple[str, int] | None = None) -> None:
    DATA.mkdir(parents=True, exist_ok=True)
    for case in [r.split(":", 1)[1] for r in rows if r.startswith("verify:")]:  # one case, updated in place
        env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
        out = subprocess.run([sys.executable, "-m", "cli.main", "verify", case, "--json"], cwd=ROOT, env=env,
                             capture_output=True, text=True)
        f = DATA / "verify.json"
        cases = [c for c in (json.loads(f.read_text()) if f.exists() else []) if c["case"] != case]
        cases += json.loads(out.stdout or "[]")
        f.write_text(json.dumps(cases, indent=2) + "\n")
        print(f"verify {case}: exit {out.returncode}", flush=True)
    rows = [r for r in rows if not r.startswith("verify:")]
    if "verify" in rows:
        rows = [r for r in rows if r != "verify"]
        env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
        out = subprocess.run([sys.executable, "-m", "cli.main", "verify", "--json"], cwd=ROOT, env=env,
                             capture_output=True, text=True)
        (DATA / "verify.json").write_text(out.stdout)
        print(f"verify: exit {out.returncode}, {len(json.loads(out.stdout or '[]'))} cases", flush=True)
    todo = [(r, k) for r in rows for k in _missing(r, upto)]
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        list(pool.map(lambda rk: _one(*rk, frames=frames), todo))


def status() -> None:
    for row, (label, scene, over, n) in ROWS.items():
        have = _rows_on_file(row)
        ok = sum(r["status"] == "ok" for r in have)
        print(f"{row:22s} {len(have)}/{n} on file ({ok} ok)  {scene} {over or ''}")


# ---------------------------------------------------------------------------------------------- statistics

@cache
def stats(row: str) -> dict:
    """Mean, standard error, sd and n over the ok replicas of a row, per metric (and the resultant); read
    once per process (the tables of one render share it)."""
    rows = [r for r in _rows_on_file(row) if r["status"] == "ok"]
    out: dict = {"n": len(rows), "n_all": len(_rows_on_file(row)), "wanted": ROWS[row][3], "samples": rows}
    for r in rows:
        r["resultant_force_N_per_mm"] = math.hypot(r[FC], r[FT])
        if "compile_time_s" in r and "wall_s" in r:  # run time, not the first process's compilation
            r["wall_s"] = r.pop("wall_s") - float(r["compile_time_s"] or 0.0)
    keys = {k for r in rows for k, v in r.items() if isinstance(v, (int, float)) and not isinstance(v, bool)}
    for key in keys:
        v = [float(r[key]) for r in rows if isinstance(r.get(key), (int, float)) and math.isfinite(r[key])]
        if not v:
            continue
        m = sum(v) / len(v)
        sd = math.sqrt(sum((x - m) ** 2 for x in v) / (len(v) - 1)) if len(v) > 1 else float("nan")
        out[key] = (m, sd / math.sqrt(len(v)), sd, len(v))
    return out


def fmt(s: dict, key: str, digits: int = 2) -> str:
    if key not in s:
        return "-"
    m, se, _, n = s[key]
    return f"{m:.{digits}f}" if n < 2 else f"{m:.{digits}f} +- {se:.{digits}f}"


def cov(s: dict) -> str:
    if FC not in s or s[FC][3] < 2:
        return "-"
    return f"{s[FC][2] / abs(s[FC][0]):.1%}"


def change(a: dict, b: dict, key: str) -> tuple[float, float] | None:
    """(b - a) / a and its standard error from both rows' standard errors (first order)."""
    if key not in a or key not in b or a[key][3] < 2 or b[key][3] < 2:
        return None
    (ma, sa, _, _), (mb, sb, _, _) = a[key], b[key]
    return (mb - ma) / ma, math.sqrt(sb ** 2 + (mb / ma) ** 2 * sa ** 2) / abs(ma)


def within(c: tuple[float, float] | None, bound: float) -> str:
    if c is None:
        return "not measured"
    lo, hi = c[0] - 2 * c[1], c[0] + 2 * c[1]
    return "yes" if -bound <= lo and hi <= bound else ("no" if hi < -bound or lo > bound else "not resolved")


def pct(c: tuple[float, float] | None) -> str:
    return "-" if c is None else f"{c[0]:+.1%} +- {c[1]:.1%}"


def falls(a: dict, b: dict, key: str = FC) -> str:
    """'yes' when a's mean exceeds b's by more than two standard errors of the difference."""
    if key not in a or key not in b or a[key][3] < 2 or b[key][3] < 2:
        return "not measured"
    d, se = a[key][0] - b[key][0], math.hypot(a[key][1], b[key][1])
    return "yes" if d > 2 * se else ("no" if d <= 0 else "not resolved")


def n_of(s: dict) -> str:
    return f"{s['n']}" + (f" of {s['n_all']}" if s["n_all"] != s["n"] else "")


# ---------------------------------------------------------------------------------------------- tables

def _markdown(head: list[str], rows: list[list[str]]) -> str:
    """A markdown table: the header, its rule and one line per row of cells."""
    return "\n".join(["| " + " | ".join(head) + " |", "|---" * len(head) + "|"] + ["| " + " | ".join(r) + " |" for r in rows])


def table_quick(names: list[str], bounce: bool = True) -> str:
    """The quick scenes' table; ``bounce`` off leaves out the bounce-back column (the diagnosis rows were measured
    when bounce-back was read over a window that could reach past the workpiece's entry face)."""
    head = ["level", "n ok", "Fc [N/mm]", "Ft [N/mm]", "CoV Fc", "peak Fc [N/mm]", "Ft edge", "Ft clearance", "Ft particles"]
    head += ["bounce-back [um]"] * bounce + ["steady from [um]", "energy error", "wall per run [s]"]
    rows = []
    for name in names:
        if not stats(name)["n_all"] and f"{name}-ss1000" in ROWS:  # not yet measured at 250: the row at 1000
            name = f"{name}-ss1000"
        s = stats(name)
        cells = [label(name), n_of(s), fmt(s, FC), fmt(s, FT), cov(s), fmt(s, 'peak_cutting_force_N_per_mm', 1),
                 fmt(s, 'edge_thrust_force_N_per_mm'), fmt(s, 'clearance_thrust_force_N_per_mm'),
                 fmt(s, 'sph_thrust_force_N_per_mm')]
        cells += [fmt(s, 'bounce_back_um')] * bounce + [fmt(s, 'steady_from_um', 1), fmt(s, 'energy_error', 4),
                                                        fmt(s, 'wall_s', 0)]
        rows.append(cells)
    return _markdown(head, rows)


def table_changes() -> str:
    lines = ["| level | against | Fc | Ft | resultant |", "|---|---|---|---|---|"]
    for name, against in [(n, CONVERGENCE_TABLE[0]) for n in CONVERGENCE_TABLE[1:]] + CHANGES_AGAINST:
        against = counterpart(name, against)
        base, s = stats(against), stats(name)
        if why := mixed(name, against):
            cells = [why, "-", "-"]
        else:
            cells = [pct(change(base, s, key)) for key in (FC, FT, "resultant_force_N_per_mm")]
        lines.append(f"| {label(name)} | {label(against).split(' (')[0]} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


@cache
def _reference() -> dict:
    """The paper's Table 2 by case (solver/reference/seed_results.json)."""
    return json.loads((ROOT / "solver" / "reference" / "seed_results.json").read_text())["cases"]


@cache
def _analytic(scene: str) -> dict:
    from solver.run import run
    from solver.scene import load_scene
    return run(load_scene(scene, {"fidelity": "analytic"})).metrics


def table_full() -> str:
    ref = _reference()
    lines = ["| scene | n ok | Fc [N/mm] | Ft [N/mm] | CoV Fc | peak Fc [N/mm] at travel [um] | paper Fc / Ft | "
             "experiment Ft | analytic Fc / Ft | "
             "Ft clearance | Ft particles | bounce-back [um] | steady from [um] | kinetic / internal | "
             "EHM elements overloaded in the steady window | wall per run [s] |", "|---" * 16 + "|"]
    for name in FULL_TABLE:
        s, (case, model) = stats(name), PAPER[name]
        c = ref[case]
        pfc, pft = c["cutting"].get(model), c["thrust"].get(model)
        a = _analytic(ROWS[name][1])
        paper = f"{pfc if pfc is not None else '-'} / {pft if pft is not None else '-'}"
        lines.append(f"| `{ROWS[name][1]}`{mark(name)} | {n_of(s)} | {fmt(s, FC)} | {fmt(s, FT)} | "
                     f"{cov(s)} | {fmt(s, 'peak_cutting_force_N_per_mm', 1)} at {fmt(s, 'peak_cutting_force_travel_um', 0)} | "
                     f"{paper} | {c['thrust']['experiment']} | {a[FC]:.1f} / {a[FT]:.1f} | "
                     f"{fmt(s, 'clearance_thrust_force_N_per_mm')} | {fmt(s, 'sph_thrust_force_N_per_mm')} | "
                     f"{fmt(s, 'bounce_back_um')} | {fmt(s, 'steady_from_um', 1)} | {fmt(s, 'kinetic_internal_ratio')} | "
                     f"{fmt(s, 'ehm_overloaded_in_steady_window', 0)} | {fmt(s, 'wall_s', 0)} |")
    return "\n".join(lines)


def table_variants(names: list[str]) -> str:
    """The full scenes' variants: forces, how dynamic the cut was and whether the far field held."""
    head = ["level", "n ok", "Fc [N/mm]", "Ft [N/mm]", "CoV Fc", "peak Fc [N/mm] at travel [um]", "steady from [um]",
            "kinetic / internal", "EHM elements overloaded in the steady window", "wall per run [s]"]
    rows = []
    for name in names:
        s = stats(name)
        cells = [f"`{name}`: {label(name)}", n_of(s), fmt(s, FC), fmt(s, FT), cov(s),
                 f"{fmt(s, 'peak_cutting_force_N_per_mm', 1)} at {fmt(s, 'peak_cutting_force_travel_um', 0)}",
                 fmt(s, 'steady_from_um', 1), fmt(s, 'kinetic_internal_ratio'),
                 fmt(s, 'ehm_overloaded_in_steady_window', 0), fmt(s, 'wall_s', 0)]
        rows.append(cells)
    return _markdown(head, rows)


def table_zone(names: list[str]) -> str:
    """The micro zone's depth: forces, how deep the damage reached (the zone bounds it) and the far field's overload."""
    head = ["level", "n ok", "Fc [N/mm]", "Ft [N/mm]", "CoV Fc", "Ft clearance", "damage depth [um]",
            "EHM elements overloaded in the steady window", "wall per run [s]"]
    rows = []
    for name in names:
        s = stats(name)
        cells = [f"`{name}`: {label(name)}", n_of(s), fmt(s, FC), fmt(s, FT), cov(s),
                 fmt(s, 'clearance_thrust_force_N_per_mm'), fmt(s, 'damage_depth_um', 1),
                 fmt(s, 'ehm_overloaded_in_steady_window', 0), fmt(s, 'wall_s', 0)]
        rows.append(cells)
    return _markdown(head, rows)


def table_regions() -> str:
    lines = ["| scene | rake face Fc / Ft | cutting edge Fc / Ft | clearance face Fc / Ft | total Fc / Ft |",
             "|---|---|---|---|---|"]
    for name in ["quick-0", "quick-90", "full-0-fem", "full-0-hybrid-d01", "full-90-fem", "full-90-hybrid-d01"]:
        s = stats(name)
        if not s["n"]:
            continue
        cells = [f"{fmt(s, f'{p}_cutting_force_N_per_mm')} / {fmt(s, f'{p}_thrust_force_N_per_mm')}"
                 for p in ("rake", "edge", "clearance")]
        lines.append(f"| `{ROWS[name][1]}`{mark(name)} | " + " | ".join(cells) + f" | {fmt(s, FC)} / {fmt(s, FT)} |")
    for scene in ("seed-0deg-fem", "seed-90deg-fem"):  # chipping, pressing, bouncing (docs/analytic-model.md)
        a = _analytic(scene)
        cells = [f"{a[f'{p}_cutting_force_N_per_mm']:.2f} / {a[f'{p}_thrust_force_N_per_mm']:.2f}"
                 for p in ("chipping", "pressing", "bouncing")]
        lines.append(f"| analytic model, `{scene}` | " + " | ".join(cells) + f" | {a[FC]:.2f} / {a[FT]:.2f} |")
    return "\n".join(lines)


def table_criteria() -> str:
    st = {name: stats(name) for name in ROWS}
    exp = _reference()
    ft0, ft90 = exp["theta_0"]["thrust"]["experiment"], exp["theta_90"]["thrust"]["experiment"]
    rows = []

    f0 = st["full-0-fem"]
    if FC in f0:
        m, se = f0[FC][0], f0[FC][1]
        ok = "yes" if 0.7 * 32 <= m - 2 * se and m + 2 * se <= 1.3 * 35 else (
            "no" if m + 2 * se < 0.7 * 32 or m - 2 * se > 1.3 * 35 else "not resolved")
    else:
        ok = "not measured"
    rows.append(("0 deg classic FEM Fc within 30 % of 32-35 N/mm", f"full {fmt(f0, FC)} (n = {f0['n']})"
                 f"{mark('full-0-fem')}; "
                 f"quick {fmt(st['quick-0'], FC)} (n = {st['quick-0']['n']})", ok))
    damped = ", the far field damped (10 per us; off in the seed scenes)"
    for deg, exp_ft, hy, fe, how in ((deg, exp_ft, f"full-{deg}-hybrid-d01{suffix}", f"full-{deg}-fem{suffix}", note)
                                     for deg, exp_ft in ((0, ft0), (90, ft90))
                                     for suffix, note in (("", ""), ("-absorbing", damped))):
        h, f = st[hy], st[fe]
        if FT in h:
            frac = (h[FT][0] / exp_ft, h[FT][1] / exp_ft)
            half = "yes" if frac[0] - 2 * frac[1] >= 0.5 else ("no" if frac[0] + 2 * frac[1] < 0.5 else "not resolved")
            above = falls(h, f, FT)
            ok = "yes" if half == "yes" and above == "yes" else ("no" if "no" in (half, above) else "not resolved")
            got = (f"{fmt(h, FT)} (n = {h['n']}){mark(hy)}, {frac[0]:.0%} +- "
                   f"{frac[1]:.0%} of {exp_ft}; classic FEM {fmt(f, FT)} (n = {f['n']}){mark(fe)}")
        else:
            ok, got = "not measured", "-"
        rows.append((f"hybrid thrust at {deg} deg >= 50 % of the experiment's and above classic FEM's{how}", got, ok))
    for what, names in (("quick, classic FEM", ("quick-0-rake0", "quick-0-rake15", "quick-0")),
                        ("quick, hybrid D 0.1", ("quick-0-hybrid-rake0", "quick-0-hybrid-rake15", "quick-0-hybrid")),
                        ("full, hybrid D 0.1", ("full-0-hybrid-d01-rake0", "full-0-hybrid-d01-rake15",
                                                "full-0-hybrid-d01"))):
        names = (names[0], counterpart(names[0], names[1]), counterpart(names[0], names[2]))
        r0, r15, r30 = (st[n] for n in names)
        step = [falls(r0, r15), falls(r15, r30)]
        whole = falls(r0, r30)
        rises = "yes" in (falls(r15, r0), falls(r30, r15))  # a step up resolved: the trend is wrong
        if step == ["yes", "yes"]:
            verdict = "yes"
        elif whole == "no" or rises:
            verdict = "no"
        elif whole == "yes":
            verdict = "0 -> 30: yes; the 15-degree steps not resolved"
        else:
            verdict = "not resolved"
        rows.append((f"Fc falls as the rake rises 0 -> 15 -> 30 deg ({what})",
                     ", ".join(f"{fmt(st[n], FC)}{mark(n)}" for n in names),
                     verdict if not mixed(*names) else mixed(names[0], names[2])
                     or f"0 -> 30: {falls(r0, r30)}; the 15-degree level ran with the {not_comparable(*names)}"))
    for what, d50, d100, n90 in (("classic FEM", "quick-0-depth50", "quick-0", "quick-90-rake30"),
                                 ("hybrid D 0.1", "quick-0-hybrid-depth50", "quick-0-hybrid", "quick-90-hybrid-rake30")):
        rows.append((f"Fc grows with depth of cut 50 -> 100 um (quick, {what})",
                     f"{fmt(st[d50], FC)}{mark(d50)} -> {fmt(st[d100], FC)}{mark(d100)}",
                     mixed(d50, d100) or falls(st[d100], st[d50])))
        rows.append((f"Fc at 90 deg above Fc at 0 deg (rake 30, depth 50, quick, {what})",
                     f"{fmt(st[n90], FC)}{mark(n90)} against {fmt(st[d50], FC)}{mark(d50)}",
                     mixed(n90, d50) or falls(st[n90], st[d50])))
    covs = [f"{name.replace('full-', '')} {cov(st[name])} (n = {st[name]['n']}){mark(name)}"
            for name in FULL_TABLE if st[name]["n"]]
    cv_ok = [st[n][FC][2] / abs(st[n][FC][0]) < 0.10 for n in FULL_TABLE if FC in st[n] and st[n][FC][3] >= 2]
    rows.append(("coefficient of variation of Fc below 10 % (full scenes)", "; ".join(covs) or "-",
                 "not measured" if not cv_ok else ("yes" if all(cv_ok) else "no")))
    def at_default(name):  # a level and its default: at the default speed scaling once measured there, else at 1000
        return (name, "quick-0", "") if st[name]["n"] >= 2 else (f"{name}-ss1000", "quick-0-ss1000", " (at speed scaling 1000)")
    for (name, against, where), what, bound in (
            (at_default("quick-0-h2"), "Fc and the resultant within 10 % between h and h/2 (quick)", 0.10),
            (at_default("quick-0-far"), "doubling workpiece length and micro-zone depth moves the forces < 5 %", 0.05),
            (("quick-0-ss125", "quick-0", ""), "forces within 5 % between the default speed scaling (250) and half of it",
             0.05)):
        what += where
        against = counterpart(name, against)
        if why := mixed(name, against):
            rows.append((what, f"`{name}` against `{against}`", why))
            continue
        cs = {k: change(st[against], st[name], k) for k in (FC, FT, "resultant_force_N_per_mm")}
        judged = [within(cs[FC], bound), within(cs["resultant_force_N_per_mm"], bound)]
        ok = "yes" if judged == ["yes", "yes"] else ("no" if "no" in judged else judged[0] if judged[0] == judged[1]
                                                     else "not resolved")
        rows.append((what, f"Fc {pct(cs[FC])}, resultant {pct(cs['resultant_force_N_per_mm'])}, Ft {pct(cs[FT])}"
                     + mark(name), ok))
    def slowest(names):
        if any(not st[n]["samples"] for n in names):  # every row measured, or no verdict
            return None
        return max(r["wall_s"] for n in names for r in st[n]["samples"])
    limits = ((["quick-0", "quick-90"], 60.0, "quick classic FEM"),
              (["quick-0-hybrid", "quick-90-hybrid"], 120.0, "quick hybrid"), (FULL_TABLE, 900.0, "full"))
    got = [(what, slowest(names), limit) for names, limit, what in limits]
    rows.append(("run time: quick scenes < 60 s (classic FEM) / 120 s (hybrid), full < 15 min (slowest replica, "
                 "both cores busy: an upper bound)",
                 "; ".join(f"{what} {w:.0f} s" for what, w, _ in got if w is not None) or "-",
                 "not measured" if any(w is None for _, w, _ in got) else
                 ("yes" if all(w < lim for _, w, lim in got) else "not resolved (an upper bound above the limit)")))
    lines = ["| criterion | measured (mean +- standard error) | met |", "|---|---|---|"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in rows]
    return "\n".join(lines)


def table_verify() -> str:
    f = DATA / "verify.json"
    if not f.exists():
        return "(not measured: `python scripts/validation.py measure verify`)"
    sys.path.insert(0, str(ROOT))
    from solver.verification import load_cases
    cases = load_cases()
    lines = ["| case | what is compared | error | tolerance | pass | wall [s] |", "|---|---|---|---|---|---|"]
    for c in json.loads(f.read_text()):
        desc = cases[c["case"]][1] if c["case"] in cases else ""
        passed = "yes" if c["passed"] else "**no**"
        lines.append(f"| {c['case']} | {desc} | {c['error']:.2g} | {c['tolerance']:.2g} | {passed} | "
                     f"{c['wall_time_s']:.1f} |")
    return "\n".join(lines)


TABLES = {"criteria": table_criteria, "quick": lambda: table_quick(QUICK_TABLE),
          "quick1000": lambda: table_quick(QUICK_1000_TABLE),
          "diagnosis": lambda: table_quick(DIAGNOSIS_TABLE, bounce=False),
          "convergence": lambda: table_quick(CONVERGENCE_TABLE),
          "timestep": lambda: table_quick(TIMESTEP_TABLE), "changes": table_changes, "full": table_full,
          "regions": table_regions, "variants": lambda: table_variants(VARIANTS_TABLE), "verify": table_verify,
          "hourglass": lambda: table_quick(HOURGLASS_TABLE), "zone90": lambda: table_zone(ZONE90_TABLE),
          "matrixyt": lambda: table_quick(MATRIX_YT_TABLE)}
BLOCK = re.compile(r"(<!-- generated: (\w+) -->\n).*?(<!-- end generated -->)", re.S)


def render() -> None:
    sys.path.insert(0, str(ROOT))
    made: dict[str, str] = {}
    for doc in DOCS:
        text = doc.read_text()

        def sub(m: re.Match) -> str:
            name = m.group(2)
            if name not in made:
                made[name] = TABLES[name]()
            return m.group(1) + made[name] + "\n" + m.group(3)

        new = BLOCK.sub(sub, text)
        if new != text:
            doc.write_text(new)
            print(f"rewrote {doc}")


def main(argv: list[str]) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    m = sub.add_parser("measure")
    m.add_argument("rows", nargs="*", help=f"rows (default all): verify, {', '.join(ROWS)}")
    m.add_argument("--jobs", type=int, default=2)
    m.add_argument("--upto", type=int, help="only replicas k < UPTO of each row (a first pass over many rows)")
    m.add_argument("--frames", nargs=2, metavar=("FOLDER", "N"),
                   help="also write each replica's run file with N frames, FOLDER/ROW-k.h5 (for scripts/crack_ahead.py "
                        "and fibrecut plot)")
    sub.add_parser("render")
    sub.add_parser("status")
    a = ap.parse_args(argv)
    if a.cmd == "measure":
        unknown = [r for r in a.rows if r not in ROWS and r != "verify" and not r.startswith("verify:")]
        if unknown:
            ap.error(f"unknown rows {unknown}; allowed: verify, {', '.join(ROWS)}")
        frames = None
        if a.frames:
            if not a.frames[1].isdigit() or not 1 <= int(a.frames[1]) <= 200:
                ap.error(f"--frames: N = {a.frames[1]!r} must be a whole number from 1 to 200")
            frames = (a.frames[0], int(a.frames[1]))
        measure(a.rows or list(ROWS), a.jobs, a.upto, frames)
    elif a.cmd == "render":
        render()
    else:
        status()


if __name__ == "__main__":
    main(sys.argv[1:])
