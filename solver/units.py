"""Unit conversions between the user-facing units and SI.

Users speak micrometres, degrees, mm/s, GPa/MPa and N/mm (force per unit width).
Everything inside the solver is SI (m, rad, m/s, Pa, N/m). Conversions happen only
at the edge: in :mod:`solver.scene` (inputs) and in :mod:`solver.result` (outputs).
"""

import math

UM = 1.0e-6  # micrometre -> metre
MM = 1.0e-3  # millimetre -> metre
MM_S = 1.0e-3  # mm/s -> m/s
GPA = 1.0e9  # GPa -> Pa
MPA = 1.0e6  # MPa -> Pa
N_PER_MM = 1.0e3  # N/mm (force per unit width) -> N/m
N_PER_MM3 = 1.0e9  # N/mm^3 (cohesive penalty) -> Pa/m
PER_US = 1.0e6  # 1/us (a rate, e.g. damping) -> 1/s
DEG = math.pi / 180.0  # degree -> radian


def force_to_n_per_mm(f_n_per_m: float) -> float:
    """SI force per unit width (N/m) to the user-facing N/mm."""
    return f_n_per_m / N_PER_MM


def length_to_um(x_m: float) -> float:
    """SI length (m) to the user-facing um."""
    return x_m / UM
