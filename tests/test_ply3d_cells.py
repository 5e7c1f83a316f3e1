"""The 3D strip's micro zone as a ply (solver/verification/ply3d_cases.py).

With the preset t800s-m21-3d (the ply's strengths and toughnesses on the fibre surfaces, Turon's penalty) a
sheared cell of the 3D strip reaches the ply's in-plane shear strength, and its shear modulus lies between
the Reuss and Voigt bounds of its constituents (Hill 1952): bounds that hold for any perfectly bonded
arrangement, which a cohesive penalty too soft for the fibre scale breaks (docs/model.md)."""

from solver.fem.materials import ehm_properties
from solver.verification import load_cases
from solver.verification.ply3d_cases import _si


def test_the_3d_cell_with_the_ply_interface_shears_like_the_ply_and_within_hills_bounds():
    res = load_cases()["ply3d-shear"][0]({"preset": "t800s-m21-3d"})
    d = res.details
    assert res.error < 0.15, d  # peak shear stress within 15 % of S_L = 92.3 MPa
    si = _si({"preset": "t800s-m21-3d"})
    f, m, vf = si.fibre, si.matrix, float(si.fibre_volume_fraction)
    g_m = m.E / (2 * (1 + m.nu))
    reuss = ehm_properties(si)["G12"]  # 1 / (Vf / G12f + (1 - Vf) / Gm)
    voigt = vf * f.G12 + (1 - vf) * g_m
    assert abs(reuss - 1 / (vf / f.G12 + (1 - vf) / g_m)) < 1e-6 * reuss
    assert reuss < d["modulus"] < voigt, (reuss, d["modulus"], voigt)
    assert abs(d["energy_error"]) < 1e-3, d
