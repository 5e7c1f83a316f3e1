"""The scene: everything one cutting simulation needs, as a validated pydantic model.

Sections (the scene contract, README "Scenes"): ``workpiece``, ``materials``, ``tool``, ``cut``,
``physics``, ``numerics`` and ``fidelity``. Fields carry user-facing units (um, degrees,
mm/s, GPa/MPa, N/mm); :meth:`Scene.si` converts them to SI in one place.

Any field is addressable by its dotted name (``tool.rake_angle_deg``); see
:func:`apply_overrides`. Every rejected input becomes a :class:`SceneError` whose
problems each name the field, the value given and what is allowed.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator
from pydantic_core import PydanticCustomError

from . import units as u

FIDELITIES = ("analytic", "fem2d", "hybrid2d", "fem3d", "hybrid3d")
#: the fidelities that simulate the 3D strip (their own fields: workpiece.strip_pitches, numerics.elements_round_fibre)
FIDELITIES_3D = ("fem3d", "hybrid3d")
IMPLEMENTED_FIDELITIES = ("analytic", "fem2d", "hybrid2d")
FRAME_FIELDS = ("positions", "material", "state", "damage", "stress")


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, validate_assignment=True)


def _f(default, lo=None, hi=None, *, unit="", doc="", gt=False, lt=False):
    """A float/int field with bounds, a unit and a description (shown in errors and docs)."""
    kw: dict[str, Any] = {"description": doc, "json_schema_extra": {"unit": unit}}
    if lo is not None:
        kw["gt" if gt else "ge"] = lo
    if hi is not None:
        kw["lt" if lt else "le"] = hi
    return Field(default, **kw)


# --------------------------------------------------------------------------- workpiece
class Workpiece(_Section):
    fibre_angle_deg: float = _f(0.0, 0.0, 180.0, unit="deg",
                                doc="Angle between the fibres and the cutting direction (0 = along the cut, 90 = normal to the cut surface).")
    fibre_diameter_um: float = _f(7.5, 1.0, 50.0, unit="um", doc="Fibre diameter (paper: 7.5 um); in 2D the width of a fibre strip.")
    fibre_volume_fraction: float = _f(0.6, 0.05, 0.85, unit="1", doc="Fibre volume fraction V_f (paper: 60 %); strip pitch = d_f / V_f.")
    height_um: float = _f(250.0, 10.0, 5000.0, unit="um", doc="Workpiece height, free top surface to the fixed bottom.")
    length_um: float | None = _f(None, 10.0, 10000.0, unit="um",
                                 doc="Workpiece length along the cut; default: the cut length plus a margin of the depth of cut and the edge radius.")
    micro_zone_depth_um: float = _f(60.0, 0.0, 5000.0, unit="um",
                                    doc="Depth of the explicit fibre/matrix micro zone below the cut plane; below it the equivalent homogeneous material (EHM).")
    fibre_offset_um: float = _f(0.0, 0.0, 500.0, unit="um",
                                doc="Shift of the fibre/matrix strip pattern perpendicular to the fibres, into the workpiece, below one "
                                    "pitch (d_f / V_f). At 0: a fibre strip starts at the corner where the cut starts (at 0 deg the free "
                                    "surface), so the cut plane falls where depth mod pitch puts it (the paper's 100 um: on a fibre's "
                                    "lower interface). In a laminate that place is random; a sweep over one pitch averages over it.")


    strip_pitches: int | None = _f(None, 1, 8, unit="1", doc=(
        "3D only (fem3d, hybrid3d): the strip's width in fibre pitches (default 1); its sides are symmetry planes."))
    far_field_damping_per_us: float = _f(0.0, 0.0, 1000.0, unit="1/us", doc=(
        "2D engines (fem2d, hybrid2d): mass-proportional damping c on the far field's nodes (those whose elements "
        "are all equivalent homogeneous material), a = f/m - c v. The cut-out block's supports and faces reflect the "
        "waves that the cut sends out, which the real, unbounded workpiece lets leave; the damping absorbs them "
        "(docs/model.md, 'The scene'). 0: undamped."))


# --------------------------------------------------------------------------- materials
class Fibre(_Section):
    """Carbon fibre T800S, transversely isotropic (the paper's Table 1, docs/model.md)."""

    E1_GPa: float = _f(294.0, 1.0, 1000.0, unit="GPa", doc="Axial Young's modulus.")
    E2_GPa: float = _f(14.0, 0.1, 1000.0, unit="GPa", doc="Transverse Young's modulus (E2 = E3).")
    G12_GPa: float = _f(28.0, 0.1, 1000.0, unit="GPa", doc="Axial shear modulus (G12 = G13).")
    G23_GPa: float = _f(5.5, 0.1, 1000.0, unit="GPa", doc="Transverse shear modulus.")
    nu12: float = _f(0.2, 0.0, 0.49, unit="1", doc="Axial Poisson ratio (nu12 = nu13).")
    nu23: float = _f(0.25, 0.0, 0.49, unit="1", doc="Transverse Poisson ratio.")
    Xt_GPa: float = _f(5.88, 0.01, 50.0, unit="GPa", doc="Axial tensile strength (brittle, maximum principal stress).")
    Xc_GPa: float = _f(3.288, 0.01, 50.0, unit="GPa", doc="Axial compressive strength.")
    compressive_yield_MPa: float = _f(3288.0, 1.0, 50000.0, unit="MPa", doc=(
        "Compressive yield stress (elastic-plastic in compression, hardening linearly to Xc at the failure strain). "
        "Reading B of Table 1: Xc (elastic to Xc, then plastic flow); reading A: 594.5 MPa."))
    compressive_failure_strain: float = _f(0.155, 0.001, 1.0, unit="1", doc="Compressive failure strain.")
    density_kg_m3: float = _f(1800.0, 100.0, 25000.0, unit="kg/m3", doc="Density (not in the paper; T800S datasheet about 1800).")


class Matrix(_Section):
    """Epoxy M21, isotropic: pressure-dependent plasticity with a crack band, or the paper's brittle law."""

    law: Literal["paraboloid", "brittle"] = Field("paraboloid", description=(
        "paraboloid: elastic-plastic with the paraboloidal yield surface (yield sigma_u in tension, "
        "compressive_yield_MPa in compression), a crack band in tension (fracture_energy_N_mm) and ductile failure at "
        "failure_plastic_strain (docs/model.md); brittle: elastic until the maximum principal stress reaches sigma_u "
        "(the paper's reading A), optionally with a crack band."))
    E_GPa: float = _f(2.96, 0.01, 1000.0, unit="GPa", doc="Young's modulus.")
    nu: float = _f(0.4, 0.0, 0.499, unit="1", doc="Poisson ratio (0.499 at most: plane strain locks at 0.5).")
    sigma_u_MPa: float = _f(74.7, 0.1, 10000.0, unit="MPa", doc="Tensile strength: the paraboloid's tensile yield, the brittle law's failure stress (maximum principal stress); 74.7 MPa the epoxy's (paper), 95 in the preset t800s-m21-2d (the 2D strip stack's equivalent, docs/model.md).")
    compressive_yield_MPa: float = _f(594.5, 0.1, 50000.0, unit="MPa", doc=(
        "paraboloid law: yield stress in uniaxial compression (reading B of the paper's Table 1); must exceed sigma_u."))
    plastic_poisson: float = _f(0.3, 0.0, 0.5, unit="1", doc="paraboloid law: plastic Poisson ratio of the non-associated flow (Melro et al. 2013).")
    failure_plastic_strain: float = _f(0.5, 0.001, 100.0, unit="1", doc=(
        "paraboloid law: equivalent plastic strain at which the matrix fails in shear or compression (our assumption)."))
    fracture_energy_N_mm: float | None = _f(
        0.277, 1e-6, 100.0, unit="N/mm",
        doc="Matrix fracture energy G_c of the crack band (Bazant & Oh 1983): a cracking element dissipates G_c per unit "
            "crack length at any element size. Required by the paraboloid law (default: the ply's mode-I toughness, "
            "docs/model.md); with the brittle law, unset = failure at sigma_u.")
    density_kg_m3: float = _f(1280.0, 100.0, 25000.0, unit="kg/m3", doc="Density (not in the paper; M21 datasheet about 1280).")


class Interface(_Section):
    """Fibre-matrix cohesive interface: bilinear, mixed mode (Camanho & Davila 2002, B-K). The defaults are the
    2D-equivalent values of the preset t800s-m21-2d (docs/model.md); the paper's own are in t800s-m21-seed."""

    normal_strength_MPa: float = _f(62.3, 0.1, 10000.0, unit="MPa", doc="Normal strength sigma_max.")
    shear_strength_MPa: float = _f(92.3, 0.1, 10000.0, unit="MPa", doc="Shear strength tau_max.")
    GIc_N_mm: float = _f(0.277, 1e-6, 100.0, unit="N/mm", doc="Mode-I fracture energy G_Ic.")
    GIIc_N_mm: float = _f(0.788, 1e-6, 100.0, unit="N/mm", doc="Mode-II fracture energy G_IIc.")
    bk_exponent: float = _f(1.45, 0.1, 10.0, unit="1", doc="Benzeggagh-Kenane exponent eta (Camanho & Davila 2002).")
    penalty_N_mm3: float = _f(1.0e6, 1.0, 1.0e12, unit="N/mm3",
                              doc="Cohesive penalty stiffness K (1e6 N/mm3 = 1e15 Pa/m); it limits the stable time step.")


class Ehm(_Section):
    """Equivalent homogeneous material outside the micro zone: stiffness and the fibre-direction
    strengths by the rule of mixtures, transverse and shear strengths of the ply (solver.fem.materials)."""

    shear_strength_MPa: float = _f(92.3, 0.1, 10000.0, unit="MPa", doc="Ply in-plane shear strength S_L of the Hashin criterion.")
    transverse_shear_strength_MPa: float = _f(75.3, 0.1, 10000.0, unit="MPa", doc=(
        "Ply transverse shear strength S_T of the Hashin criterion (Y_C / (2 tan 53 deg), docs/model.md)."))
    transverse_tensile_strength_MPa: float = _f(62.3, 0.1, 10000.0, unit="MPa", doc="Ply transverse tensile strength Y_T.")
    transverse_compressive_strength_MPa: float = _f(199.8, 0.1, 10000.0, unit="MPa", doc="Ply transverse compressive strength Y_C.")


#: material presets: the values a preset gives to the fields a scene does not set (docs/model.md)
_READING_B = {"fibre": {"compressive_yield_MPa": 3288.0},
              "matrix": {"law": "paraboloid", "compressive_yield_MPa": 594.5}}
_PAPER_INTERFACE = {"normal_strength_MPa": 167.5, "shear_strength_MPa": 25.0, "GIc_N_mm": 0.05, "GIIc_N_mm": 0.1}
#: the 3D strip's ply-consistent interface: the ply's strengths and toughnesses (the Interface defaults) on the
#: cylindrical fibre surfaces, with the penalty K = 50 E_m / r_f (Turon et al. 2007; docs/model.md)
_PLY_INTERFACE_3D = {"penalty_N_mm3": 4.0e7}
#: the 2D strip stack's matrix: a tensile yield of 95 MPa, with which its transverse cell reaches the ply's Y_T
#: (a matrix wall held along the fibres by the fibre strips and along z by plane strain yields at 0.49 sigma_u and
#: the cell flows at about 0.65 sigma_u; `fibrecut verify ply-transverse`, docs/model.md)
_MATRIX_2D = {**_READING_B["matrix"], "sigma_u_MPa": 95.0}
PRESETS: dict[str, dict] = {
    "t800s-m21-2d": {**_READING_B, "matrix": _MATRIX_2D},
    "t800s-m21-seed": {**_READING_B, "interface": _PAPER_INTERFACE},
    "t800s-m21-3d": {**_READING_B, "interface": _PLY_INTERFACE_3D},
    "t800s-m21-seed-reading-a": {
        "fibre": {"compressive_yield_MPa": 594.5},
        "matrix": {"law": "brittle", "fracture_energy_N_mm": None},
        "interface": _PAPER_INTERFACE,
        "ehm": {"shear_strength_MPa": 90.0, "transverse_shear_strength_MPa": 90.0,
                "transverse_tensile_strength_MPa": 74.7, "transverse_compressive_strength_MPa": 186.75}},
}
PRESET_DOCS = {
    "t800s-m21-2d": "reading B of the paper's Table 1 for fibre and matrix, the 2D-equivalent interface and matrix "
                    "tensile yield (95 MPa) and the EHM with ply strengths (the 2D strip stack's interfaces are "
                    "continuous planes: their strengths and toughness are the ply's; its matrix walls, held along the "
                    "fibres, take the tensile yield with which the micro zone reaches the ply's transverse strength)",
    "t800s-m21-seed": "reading B of the paper's Table 1, the paper's own interface (25 MPa, 0.05 N/mm: for its 3D "
                      "fibres in matrix)",
    "t800s-m21-3d": "reading B of the paper's Table 1, on the 3D strip's fibre surfaces the interface with which its "
                    "micro zone reaches the ply's strengths (the ply's strengths and toughnesses) and a penalty stiff "
                    "enough not to soften it (Turon et al. 2007)",
    "t800s-m21-seed-reading-a": "reading A of Table 1 (fibre compressive yield 594.5 MPa, brittle matrix deleted at "
                                "74.7 MPa), the paper's interface",
}


class Materials(_Section):
    preset: Literal["t800s-m21-2d", "t800s-m21-seed", "t800s-m21-3d", "t800s-m21-seed-reading-a"] = Field(
        "t800s-m21-2d", description="Material preset; it fills the fields a scene does not set. " +
        "; ".join(f"{k}: {v}" for k, v in PRESET_DOCS.items()) + " (docs/model.md).")
    fibre: Fibre = Field(default_factory=Fibre)
    matrix: Matrix = Field(default_factory=Matrix)
    interface: Interface = Field(default_factory=Interface)
    ehm: Ehm = Field(default_factory=Ehm)

    @model_validator(mode="before")
    @classmethod
    def _apply_preset(cls, data: Any) -> Any:
        """Fill the fields the input leaves out from the preset's values (the defaults are t800s-m21-2d's)."""
        if not isinstance(data, dict):
            return data
        name = data.get("preset", "t800s-m21-2d")
        if name not in PRESETS:
            return data  # the Literal names the allowed presets
        out = dict(data)
        for section, values in PRESETS[name].items():
            given = out.get(section)
            if given is None:
                out[section] = dict(values)
            elif isinstance(given, dict):
                out[section] = {**values, **given}
        return out


# --------------------------------------------------------------------------- tool and cut
class Tool(_Section):
    rake_angle_deg: float = _f(30.0, -45.0, 60.0, unit="deg", doc="Rake angle from the normal of the cut surface, positive leaning back.")
    clearance_angle_deg: float = _f(7.0, 0.0, 30.0, unit="deg", doc="Clearance angle (not stated in the paper; typical 6-11 deg).")
    edge_radius_um: float = _f(20.0, 0.0, 200.0, unit="um", doc="Cutting-edge radius (paper: 20 um; 0 = sharp).")
    friction: float = _f(0.3, 0.0, 2.0, unit="1", doc="Coulomb friction coefficient tool-workpiece (paper: 0.3).")


class Cut(_Section):
    depth_um: float = _f(100.0, 0.0, 1000.0, unit="um", gt=True, doc="Depth of cut a below the free surface.")
    speed_mm_s: float = _f(18.33, 0.0, 100000.0, unit="mm/s", gt=True, doc="Cutting speed (paper: 18.33 mm/s = 1100 mm/min).")
    length_um: float = _f(200.0, 0.0, 5000.0, unit="um", gt=True, doc="Length of cut travelled by the tool.")


# --------------------------------------------------------------------------- physics and numerics
class Physics(_Section):
    cohesive_interface: bool = Field(True, description="Cohesive elements at every fibre-matrix interface.")
    element_deletion: bool = Field(True, description="Failed elements are deleted (fem2d) or converted to SPH particles (hybrid2d).")
    fibre_plasticity: bool = Field(True, description="Elastic-plastic fibre in compression (paper 2.2.1).")
    fibre_failure_at: Literal["centre", "edge"] = Field(
        "edge", description="Where a fibre element's tensile criterion is checked: at its centre (the one-point integration "
                            "point) or also at its edge fibres, with the stress of its assumed-strain bending mode added.")
    hourglass_follows_material: bool = Field(False, description=(
        "2D quads: an inelastic element's hourglass (bending) stiffness follows the smallest secant ratio |S| / |C : E| "
        "its centre has had, down to half the elastic stiffness, so a fibre flowing at Xc or a softening matrix element "
        "bends little stiffer than its material (the 3D hexahedra always do, with the same floor). Off by default "
        "(docs/numerics.md)."))
    fragment_contact: bool = Field(True, description="Contact between fragments separated by failed elements.")
    ehm_failure: bool = Field(False, description=(
        "Delete EHM elements that meet their Hashin criterion. Off: the EHM stands for the elastic far field of a "
        "workpiece much larger than the cut-out; an EHM element past its criterion stays elastic and the run reports "
        "it (ehm_overloaded_elements, and a warning when it happens during the steady window)."))
    sph_damage_matrix: float = _f(0.8, 0.0, 0.99, unit="1", doc="Damage D of SPH particles from matrix: stiffness x (1 - D) (paper: 0.8 or 0.1).")
    sph_damage_fibre: float = _f(0.8, 0.0, 0.99, unit="1", doc="Damage D of SPH particles from fibre (paper: 0.8).")
    sph_particle_radius_um: float = _f(0.7, 0.05, 20.0, unit="um", doc="SPH particle radius (paper: 0.7 um).")
    sph_smoothing_factor: float = _f(1.3, 1.0, 2.5, unit="1", doc="Smoothing length h over particle spacing.")
    sph_artificial_viscosity_alpha: float = _f(1.0, 0.0, 5.0, unit="1", doc="Monaghan artificial viscosity alpha.")
    sph_artificial_viscosity_beta: float = _f(1.0, 0.0, 5.0, unit="1", doc="Monaghan artificial viscosity beta.")
    sph_artificial_stress: float = _f(0.3, 0.0, 1.0, unit="1", doc="Gray-Monaghan-Swift artificial stress epsilon (n = 4).")


class Numerics(_Section):
    element_size_um: float = _f(2.0, 0.25, 20.0, unit="um", doc="Element size along the fibre (paper: 2 um).")
    elements_across_fibre: int = _f(3, 1, 16, unit="1", doc="Elements across one fibre strip (matrix strips get at least one).")
    elements_round_fibre: int | None = _f(None, 8, 32, unit="1", doc=(
        "3D only (fem3d, hybrid3d): elements round each fibre's O-grid, a multiple of 8 (default 8)."))
    cfl: float = _f(0.5, 0.0, 10.0, unit="1", gt=True, doc="Courant factor on the stable time step (above 1 is unstable by design).")
    mass_scaling: float = _f(1.0, 1.0, 1.0e8, unit="1", doc="Density multiplier (mass scaling); the added mass is reported.")
    speed_scaling: float = _f(1.0, 1.0, 1.0e5, unit="1", doc="Tool speed multiplier (speed scaling); the kinetic/internal energy ratio is reported.")
    hourglass_coefficient: float = _f(0.1, 0.0, 0.5, unit="1", doc="Flanagan-Belytschko hourglass coefficient.")
    contact_stiffness_factor: float = _f(1.0, 0.001, 100.0, unit="1", doc=(
        "Multiplier on the automatic contact penalties: the rigid tool's 1.0 m / dt^2 per node or particle of "
        "mass m, the deformable pairs' (fragments, particle-element edges) 0.1 m_min / dt^2."))
    n_frames: int = _f(8, 0, 1000, unit="1", doc="Chip frames written to the result (0 = none).")
    frame_fields: list[Literal["positions", "material", "state", "damage", "stress"]] = Field(
        default_factory=lambda: list(FRAME_FIELDS), description="Fields stored in each frame.")
    n_force_samples: int = _f(400, 10, 100000, unit="1", doc="Samples of the force and energy histories.")
    max_steps: int = _f(20_000_000, 1, 1_000_000_000, unit="1", doc="Hard cap on time steps; a run that needs more fails with a clear reason.")
    max_wall_time_s: float = _f(3600.0, 1.0, 604800.0, unit="s", doc="Wall-time cap; a run past it fails with a clear reason.")
    chunk_steps: int = _f(2000, 1, 10_000_000, unit="1", doc="Steps per compiled chunk (progress and cancellation granularity).")
    coupling_sync_steps: int = _f(1, 1, 50, unit="1", doc=(
        "hybrid2d: engine steps per particle-element exchange. 1 (lockstep): particles and elements take "
        "the same steps and the coupling forces of one configuration act on both in the same velocity "
        "update. More: the particles take their own steps over that many engine steps against the edges "
        "where the engine left them, and the nodes take the reactions one exchange late, which makes "
        "energy (coupling_net_work_J_per_m, in the energy error): cheaper, less exact (docs/validation.md)."))


# --------------------------------------------------------------------------- the scene
class Scene(_Section):
    """One orthogonal-cutting simulation, in user-facing units."""

    name: str = Field("custom", max_length=200, description="A label for the scene.")
    fidelity: Literal["analytic", "fem2d", "hybrid2d", "fem3d", "hybrid3d"] = Field(
        "fem2d", description="analytic (mechanistic model), fem2d (classic FEM, element deletion), hybrid2d (FEM-SPH), "
                            "fem3d (the 3D strip of cylindrical fibres, classic FEM), hybrid3d (the 3D strip, FEM-SPH).")
    workpiece: Workpiece = Field(default_factory=Workpiece)
    materials: Materials = Field(default_factory=Materials)
    tool: Tool = Field(default_factory=Tool)
    cut: Cut = Field(default_factory=Cut)
    physics: Physics = Field(default_factory=Physics)
    numerics: Numerics = Field(default_factory=Numerics)

    @model_validator(mode="after")
    def _consistent(self) -> "Scene":
        def bad(field, value, why):
            raise PydanticCustomError("scene_consistency", "{why}", {"field": field, "value": value, "why": why})

        t, c, w = self.tool, self.cut, self.workpiece
        if t.edge_radius_um > 10.0 * c.depth_um:
            bad("tool.edge_radius_um", t.edge_radius_um,
                f"must be at most 10 x cut.depth_um = {10.0 * c.depth_um:g} um (the edge would only rub, not cut)")
        if t.rake_angle_deg + t.clearance_angle_deg >= 85.0:
            bad("tool.clearance_angle_deg", t.clearance_angle_deg,
                f"rake + clearance must stay below 85 deg so the tool wedge is solid (rake is {t.rake_angle_deg:g} deg)")
        if c.depth_um >= 0.9 * w.height_um:
            bad("cut.depth_um", c.depth_um, f"must be below 0.9 x workpiece.height_um = {0.9 * w.height_um:g} um")
        pitch = w.fibre_diameter_um / w.fibre_volume_fraction
        if w.fibre_offset_um >= pitch:
            bad("workpiece.fibre_offset_um", w.fibre_offset_um,
                f"must be below one strip pitch, fibre_diameter_um / fibre_volume_fraction = {pitch:g} um")
        if w.length_um is not None and w.length_um < c.length_um:
            bad("workpiece.length_um", w.length_um, f"must be at least cut.length_um = {c.length_um:g} um")
        three_d = self.fidelity in FIDELITIES_3D
        if three_d and w.far_field_damping_per_us != 0.0:
            bad("workpiece.far_field_damping_per_us", w.far_field_damping_per_us,
                f"is a field of the 2D engines (fem2d, hybrid2d); fidelity {self.fidelity} does not use it: leave it out or 0")
        for field, value in (("workpiece.strip_pitches", w.strip_pitches), ("numerics.elements_round_fibre", self.numerics.elements_round_fibre)):
            if value is not None and not three_d:
                bad(field, value, f"is a field of the 3D strip (fidelities fem3d, hybrid3d); fidelity {self.fidelity} does not use it: leave it out")
        if three_d:
            if w.fibre_angle_deg not in (0.0, 90.0):
                bad("workpiece.fibre_angle_deg", w.fibre_angle_deg, "the 3D strip is built for 0 and 90 degrees; allowed: 0, 90")
            if w.fibre_offset_um != 0.0:
                bad("workpiece.fibre_offset_um", w.fibre_offset_um, "the 3D strip starts with a whole fibre cell at the free surface; allowed: 0")
            p3 = w.fibre_diameter_um * math.sqrt(math.pi / (4.0 * w.fibre_volume_fraction))
            cells = math.ceil((w.micro_zone_depth_um + c.depth_um) / p3 - 1e-9)
            if w.fibre_angle_deg == 0.0 and cells * p3 >= w.height_um:
                bad("workpiece.micro_zone_depth_um", w.micro_zone_depth_um,
                    f"the micro zone, {cells} fibre cells of {p3:.4g} um from the surface, must stay above the bottom "
                    f"(workpiece.height_um = {w.height_um:g} um)")
            n_round = self.numerics.elements_round_fibre
            if n_round is not None and n_round % 8:
                bad("numerics.elements_round_fibre", n_round, "must be a multiple of 8 (the O-grid's quarters); allowed: 8, 16, 24, 32")
        if self.fidelity in ("fem2d", "hybrid2d", "fem3d", "hybrid3d"):
            if self.numerics.element_size_um > c.depth_um:
                bad("numerics.element_size_um", self.numerics.element_size_um,
                    f"must not exceed cut.depth_um = {c.depth_um:g} um (the cut must span at least one element)")
            if w.micro_zone_depth_um + c.depth_um > w.height_um:
                bad("workpiece.micro_zone_depth_um", w.micro_zone_depth_um,
                    f"micro zone below the cut plane plus the depth of cut must fit in workpiece.height_um = {w.height_um:g} um")
        ma = self.materials.matrix
        if ma.law == "paraboloid" and self.fidelity != "analytic":  # the analytic model does not use the law
            if ma.fracture_energy_N_mm is None:
                bad("materials.matrix.fracture_energy_N_mm", None,
                    "the paraboloid matrix law needs a fracture energy (its crack band); allowed 1e-06 <= fracture_energy_N_mm <= 100 N/mm")
            if ma.compressive_yield_MPa <= ma.sigma_u_MPa:
                bad("materials.matrix.compressive_yield_MPa", ma.compressive_yield_MPa,
                    f"must exceed the tensile yield materials.matrix.sigma_u_MPa = {ma.sigma_u_MPa:g} MPa (the paraboloid opens towards compression)")
        f = self.materials.fibre
        if f.Xc_GPa * 1e3 < f.compressive_yield_MPa:
            bad("materials.fibre.compressive_yield_MPa", f.compressive_yield_MPa,
                f"must not exceed the compressive strength Xc = {f.Xc_GPa * 1e3:g} MPa")
        if len(set(self.numerics.frame_fields)) != len(self.numerics.frame_fields):
            bad("numerics.frame_fields", self.numerics.frame_fields, "must not repeat a field")
        return self

    # ----------------------------------------------------------------- derived values
    @property
    def uses_particles(self) -> bool:
        """Only the hybrid fidelities with element deletion convert elements to SPH particles."""
        return self.fidelity in ("hybrid2d", "hybrid3d") and self.physics.element_deletion

    @property
    def uses_cohesive(self) -> bool:
        return self.fidelity in ("fem2d", "hybrid2d", "fem3d", "hybrid3d") and self.physics.cohesive_interface

    def canonical_json(self) -> str:
        """Canonical JSON (sorted keys, no blanks): the key of the result cache."""
        return json.dumps(self.model_dump(mode="json"), sort_keys=True, separators=(",", ":"))

    def si(self) -> SimpleNamespace:
        """The scene in SI units (m, rad, m/s, Pa, kg/m3, J/m2, Pa/m); the one conversion point."""
        w, m, t, c, p, n = self.workpiece, self.materials, self.tool, self.cut, self.physics, self.numerics
        fi, ma, it = m.fibre, m.matrix, m.interface
        default_len = c.length_um + c.depth_um + t.edge_radius_um + 4 * n.element_size_um
        return SimpleNamespace(
            fidelity=self.fidelity,
            fibre_angle=w.fibre_angle_deg * u.DEG,
            fibre_diameter=w.fibre_diameter_um * u.UM,
            fibre_volume_fraction=w.fibre_volume_fraction,
            height=w.height_um * u.UM,
            length=(w.length_um if w.length_um is not None else default_len) * u.UM,
            micro_zone_depth=w.micro_zone_depth_um * u.UM,
            fibre_offset=w.fibre_offset_um * u.UM,
            far_field_damping=w.far_field_damping_per_us * u.PER_US,
            strip_pitches=w.strip_pitches or 1,
            elements_round_fibre=n.elements_round_fibre or 8,
            fibre=SimpleNamespace(E1=fi.E1_GPa * u.GPA, E2=fi.E2_GPa * u.GPA, G12=fi.G12_GPa * u.GPA, G23=fi.G23_GPa * u.GPA,
                                  nu12=fi.nu12, nu23=fi.nu23, Xt=fi.Xt_GPa * u.GPA, Xc=fi.Xc_GPa * u.GPA,
                                  sigma_yc=fi.compressive_yield_MPa * u.MPA, eps_fc=fi.compressive_failure_strain,
                                  rho=fi.density_kg_m3),
            matrix=SimpleNamespace(E=ma.E_GPa * u.GPA, nu=ma.nu, sigma_u=ma.sigma_u_MPa * u.MPA, rho=ma.density_kg_m3,
                                   law=ma.law, sigma_yc=ma.compressive_yield_MPa * u.MPA, nu_p=ma.plastic_poisson,
                                   eps_f=ma.failure_plastic_strain,
                                   fracture_energy=(ma.fracture_energy_N_mm * u.N_PER_MM
                                                    if ma.fracture_energy_N_mm is not None else None)),
            interface=SimpleNamespace(sigma_n=it.normal_strength_MPa * u.MPA, tau=it.shear_strength_MPa * u.MPA,
                                      GIc=it.GIc_N_mm * u.N_PER_MM, GIIc=it.GIIc_N_mm * u.N_PER_MM,
                                      eta=it.bk_exponent, K=it.penalty_N_mm3 * u.N_PER_MM3),
            ehm=SimpleNamespace(shear_strength=m.ehm.shear_strength_MPa * u.MPA,
                                transverse_shear_strength=m.ehm.transverse_shear_strength_MPa * u.MPA,
                                yt=m.ehm.transverse_tensile_strength_MPa * u.MPA,
                                yc=m.ehm.transverse_compressive_strength_MPa * u.MPA),
            rake=t.rake_angle_deg * u.DEG,
            clearance=t.clearance_angle_deg * u.DEG,
            edge_radius=t.edge_radius_um * u.UM,
            friction=t.friction,
            depth=c.depth_um * u.UM,
            speed=c.speed_mm_s * u.MM_S,
            cut_length=c.length_um * u.UM,
            physics=p,
            sph_particle_radius=p.sph_particle_radius_um * u.UM,
            element_size=n.element_size_um * u.UM,
            numerics=n,
        )


# --------------------------------------------------------------------------- errors
@dataclass
class Problem:
    """One rejected input: where it is, the value given, and what is allowed. ``loc`` is a dotted
    scene field (``tool.rake_angle_deg``) or a path inside a document such as a study's, a tuple
    in which a dotted scene field stays one element (``("fixed", "tool.rake_angle_deg")``)."""

    loc: str | tuple[str, ...]
    value: Any
    message: str

    def __post_init__(self) -> None:
        self.loc = (self.loc,) if isinstance(self.loc, str) else tuple(self.loc)

    @property
    def field(self) -> str:
        return ".".join(self.loc)

    def __str__(self) -> str:
        return f"{self.field} = {_show(self.value)}: {self.message}"


class SceneError(ValueError):
    """Invalid input (a scene, or a study document around one); ``problems`` each name the field,
    the value and what is allowed."""

    def __init__(self, problems: list[Problem]):
        self.problems = problems
        super().__init__("; ".join(str(p) for p in problems))


def _show(value: Any) -> str:
    if isinstance(value, float) and math.isfinite(value):
        return f"{value:g}"
    if isinstance(value, (dict, list)):
        s = json.dumps(value, default=str)
        return s if len(s) < 80 else s[:77] + "..."
    return repr(value) if isinstance(value, str) else str(value)


def _field_info(path: list[str]):
    """The pydantic FieldInfo of a dotted path in the Scene model, or None."""
    model: Any = Scene
    info = None
    for part in path:
        if not (isinstance(model, type) and issubclass(model, BaseModel)) or part not in model.model_fields:
            return None
        info = model.model_fields[part]
        model = info.annotation
    return info


def allowed_range(path: str) -> str:
    """Human-readable bounds of a numeric field: '0 < x <= 1000 um'."""
    info = _field_info(path.split("."))
    if info is None:
        return ""
    lo = hi = None
    lo_op = hi_op = "<="
    for meta in info.metadata:
        for attr, op in (("gt", "<"), ("ge", "<=")):
            if getattr(meta, attr, None) is not None:
                lo, lo_op = getattr(meta, attr), op
        for attr, op in (("lt", "<"), ("le", "<=")):
            if getattr(meta, attr, None) is not None:
                hi, hi_op = getattr(meta, attr), op
    unit = (info.json_schema_extra or {}).get("unit", "") if isinstance(info.json_schema_extra, dict) else ""
    unit = "" if unit in ("", "1") else f" {unit}"
    if lo is None and hi is None:
        return ""
    left = f"{lo:g} {lo_op} " if lo is not None else ""
    right = f" {hi_op} {hi:g}" if hi is not None else ""
    return f"allowed {left}{path.split('.')[-1]}{right}{unit}"


def _known_fields(path: list[str]) -> list[str]:
    """Field names at the deepest valid prefix of a dotted path (dotted from the root)."""
    model: Any = Scene
    prefix: list[str] = []
    for part in path:
        if not (isinstance(model, type) and issubclass(model, BaseModel)) or part not in model.model_fields:
            break
        prefix.append(part)
        model = model.model_fields[part].annotation
    if isinstance(model, type) and issubclass(model, BaseModel):
        return [".".join(prefix + [name]) for name in model.model_fields]
    return []


def problems_from_validation(exc: ValidationError, prefix: str = "") -> list[Problem]:
    """Turn pydantic errors into Problems naming field, value and what is allowed."""
    out = []
    for err in exc.errors():
        ctx = err.get("ctx") or {}
        if err["type"] == "scene_consistency":
            out.append(Problem(ctx["field"], ctx["value"], ctx["why"]))
            continue
        loc = [str(x) for x in err["loc"] if not isinstance(x, int)]
        field = ".".join(([prefix] if prefix else []) + loc) or "scene"
        msg = err["msg"]
        if err["type"] == "extra_forbidden":
            known = _known_fields(loc[:-1])
            msg = "unknown field" + (f"; known fields here: {', '.join(known)}" if known else "")
        else:
            rng = allowed_range(".".join(loc))
            if rng:
                msg = f"{msg}; {rng}"
        out.append(Problem(field, err.get("input"), msg))
    return out


# --------------------------------------------------------------------------- building scenes
def parse_value(text: str) -> Any:
    """Parse a --set value: YAML scalars (15, 0.3, true, null, [a, b]); anything else stays a string."""
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError:
        return text


def apply_overrides(data: dict, overrides: dict[str, Any]) -> dict:
    """Set dotted names (``tool.rake_angle_deg``) in a nested scene dict; returns a new dict."""
    data = json.loads(json.dumps(data))
    problems = []
    for dotted, value in overrides.items():
        parts = dotted.split(".")
        if not all(parts):
            problems.append(Problem(dotted, value, "not a field name (use dotted names such as tool.rake_angle_deg)"))
            continue
        info = _field_info(parts)
        if info is None:
            known = _known_fields(parts[:-1])
            problems.append(Problem(dotted, value, "unknown field" + (f"; known fields here: {', '.join(known)}" if known else "")))
            continue
        node = data
        for part in parts[:-1]:
            if not isinstance(node.get(part), dict):
                node[part] = {}
            node = node[part]
        node[parts[-1]] = value
    if problems:
        raise SceneError(problems)
    return data


def scene_from_dict(data: Any, overrides: dict[str, Any] | None = None) -> Scene:
    """Validate a scene dict (with optional dotted overrides); raises SceneError."""
    if not isinstance(data, dict):
        raise SceneError([Problem("scene", data, "must be a mapping of sections (workpiece, materials, tool, cut, physics, numerics, fidelity)")])
    if overrides:
        data = apply_overrides(data, overrides)
    try:
        return Scene.model_validate(data)
    except ValidationError as exc:
        raise SceneError(problems_from_validation(exc)) from None


def load_scene(ref: str, overrides: dict[str, Any] | None = None) -> Scene:
    """A built-in scene name or a YAML/JSON file path, with dotted overrides.

    A file may name a built-in as ``base:`` and give only what differs from it.
    """
    from pathlib import Path

    from .catalogue import CATALOGUE, scene_dict

    if ref in CATALOGUE:
        data = scene_dict(ref)
    else:
        path = Path(ref)
        if not path.is_file():
            raise SceneError([Problem("scene", ref, f"neither a built-in scene ({', '.join(CATALOGUE)}) nor a readable file")])
        try:
            data = yaml.safe_load(path.read_text())
        except (yaml.YAMLError, UnicodeDecodeError) as exc:
            raise SceneError([Problem("scene", ref, f"not valid YAML/JSON: {str(exc).splitlines()[0]}")]) from None
        if isinstance(data, dict) and "base" in data:
            base = data.pop("base")
            if base not in CATALOGUE:
                raise SceneError([Problem("base", base, f"unknown built-in scene; allowed: {', '.join(CATALOGUE)}")])
            merged = scene_dict(base)
            _deep_update(merged, data)
            data = merged
    return scene_from_dict(data, overrides)


def _deep_update(dst: dict, src: dict) -> None:
    for k, v in src.items():
        if isinstance(v, dict) and isinstance(dst.get(k), dict):
            _deep_update(dst[k], v)
        else:
            dst[k] = v


def parse_set_options(items: list[str]) -> dict[str, Any]:
    """``["tool.rake_angle_deg=15", ...]`` to ``{"tool.rake_angle_deg": 15}``; raises SceneError."""
    out: dict[str, Any] = {}
    for item in items or []:
        if "=" not in item:
            raise SceneError([Problem("--set", item, "expected NAME=VALUE, e.g. tool.rake_angle_deg=15")])
        name, _, text = item.partition("=")
        out[name.strip()] = parse_value(text.strip())
    return out
