"""What a scene will cost before it is built: elements, nodes, cohesive elements, particles and
the bytes of the solver's arrays, from the scene alone (arithmetic, no mesh), and the limits a
run may not exceed.

The 3D strip (fem3d) is counted exactly by :func:`solver.fem3d.strip3d.strip_counts`. The 2D count follows the mesher's layout (solver/mesher.py): a uniform family of lines at
``element_size`` along the fibres across the whole workpiece, times the fibre-parallel lines:
``elements_across_fibre`` per fibre strip plus the matrix strips inside the micro zone's band,
and lines growing by 1.3 per step to four strip widths outside it. For 0 and 90 degrees that is
the mesh's element count; for other angles the band is a parallelogram whose clipped corners
the estimate counts too (an upper bound, within a factor of about two). A hybrid scene gets one
particle per micro-zone element. Bytes per element and per particle are the engine's (docs/
numerics.md: about 1 kB per element with its nodes, cohesive elements and contact arrays, about
0.5 kB per particle), plus what each stored frame keeps.

Limits (one machine's defaults; ``FIBRECUT_MAX_ELEMENTS``, ``FIBRECUT_MAX_PARTICLES`` and
``FIBRECUT_MAX_MEMORY_MB`` override them): 2 million elements, 2 million particles, 4096 MB of
solver arrays. :func:`check` answers the problems (field, value, message) that make a scene too
large, empty when it fits; the API answers them with a 422 and the CLI with exit code 2.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from .mesher import strip_geometry

BYTES_PER_ELEMENT = 1100
#: a hexahedron of the 3D engine with its share of nodes and cohesive elements (measured on the seed strips)
BYTES_PER_HEX = 2400
BYTES_PER_PARTICLE = 600
BYTES_PER_ELEMENT_FRAME = 45
GROWTH = 1.3  # the mesher's grading outside the micro zone


@dataclass
class Limits:
    max_elements: int = 2_000_000
    max_particles: int = 2_000_000
    max_memory_mb: float = 4096.0

    @classmethod
    def from_env(cls) -> "Limits":
        d = cls()

        def get(name, default, kind):
            try:
                v = kind(os.environ.get(name, "") or default)
                return v if v > 0 else default
            except ValueError:
                return default

        return cls(max_elements=get("FIBRECUT_MAX_ELEMENTS", d.max_elements, int),
                   max_particles=get("FIBRECUT_MAX_PARTICLES", d.max_particles, int),
                   max_memory_mb=get("FIBRECUT_MAX_MEMORY_MB", d.max_memory_mb, float))


@dataclass
class Estimate:
    elements: int
    particles: int
    cohesive: int
    memory_bytes: int

    def as_dict(self) -> dict:
        return {"elements": self.elements, "particles": self.particles, "cohesive": self.cohesive,
                "memory_mb": round(self.memory_bytes / 2**20, 1)}


def _graded_count(span: float, h0: float, hmax: float) -> int:
    """Steps of the mesher's graded lines over ``span`` (sizes h0 * 1.3^k up to hmax)."""
    if span <= 0:
        return 0
    n, pos, h = 0, 0.0, h0
    while pos < span and h < hmax:
        h = min(h * GROWTH, hmax)
        pos += h
        n += 1
    if pos < span:
        n += math.ceil((span - pos) / hmax)
    return n


def estimate(scene) -> Estimate:
    """Elements, particles, cohesive elements and bytes of the scene's solver arrays."""
    if scene.fidelity not in ("fem2d", "hybrid2d", "fem3d", "hybrid3d"):
        return Estimate(0, 0, 0, 0)
    n = scene.numerics
    if scene.fidelity in ("fem3d", "hybrid3d"):  # the 3D strip (solver.fem3d.strip3d), counted exactly
        from .fem3d.strip3d import strip_counts, strip_spec

        hexes, coh = strip_counts(strip_spec(scene.si()))
        coh = coh if scene.uses_cohesive else 0
        return Estimate(hexes, 0, coh, hexes * (BYTES_PER_HEX + int(n.n_frames) * 3 * BYTES_PER_ELEMENT_FRAME))
    g = strip_geometry(scene.si())  # the mesher's own sizes
    theta, h, d_f, d_m, nf, nm, L, H = g.theta, g.h, g.d_f, g.d_m, g.nf, g.nm, g.L, g.H
    mz_depth, x_ms = g.mz_depth, g.x_ms
    c, s = abs(math.cos(theta)), abs(math.sin(theta))
    vertical = c >= s - 1e-12
    t, cos_f = (s / c, c) if vertical else (c / s, s)
    span_u = L if vertical else H
    mz_u, mz_v = (L - x_ms, mz_depth) if vertical else (mz_depth, L - x_ms)
    span_v = H if vertical else L
    nu = max(1, math.ceil(span_u / (h * cos_f) - 1e-9))
    nu_mz = max(1, math.ceil(mz_u / (h * cos_f) - 1e-9))
    wf, wm = d_f / cos_f, d_m / cos_f
    pitch = wf + wm
    band = mz_v + mz_u * t  # the micro zone's extent across the fibre-parallel lines
    dom = span_v + span_u * t
    n_band = math.ceil(band / pitch + 2) * (nf + nm)
    h_strip = min(wf / nf, wm / nm)
    h_out = max(4.0 * h_strip, 4.0 * h * cos_f)
    n_out = _graded_count(max(0.0, dom - band), h_strip, h_out)
    elements = nu * (n_band + n_out)
    mz_elements = nu_mz * n_band
    cohesive = mz_elements * 2 // (nf + nm) if scene.uses_cohesive else 0
    particles = mz_elements if scene.uses_particles else 0
    frames = int(n.n_frames)
    memory = elements * (BYTES_PER_ELEMENT + frames * BYTES_PER_ELEMENT_FRAME) + particles * BYTES_PER_PARTICLE
    return Estimate(int(elements), int(particles), int(cohesive), int(memory))


def check(scene, limits: Limits | None = None) -> list[tuple[str, object, str]]:
    """(field, value, message) when the scene is beyond the limits; [] when it fits."""
    limits = limits or Limits.from_env()
    e = estimate(scene)
    over = []
    if e.elements > limits.max_elements:
        over.append(f"{e.elements:.3g} elements (limit {limits.max_elements:.3g}, FIBRECUT_MAX_ELEMENTS)")
    if e.particles > limits.max_particles:
        over.append(f"{e.particles:.3g} SPH particles (limit {limits.max_particles:.3g}, FIBRECUT_MAX_PARTICLES)")
    mb = e.memory_bytes / 2**20
    if mb > limits.max_memory_mb:
        over.append(f"{mb:.4g} MB of solver arrays (limit {limits.max_memory_mb:.4g} MB, FIBRECUT_MAX_MEMORY_MB)")
    if not over:
        return []
    w, num = scene.workpiece, scene.numerics
    length = f"workpiece.length_um = {w.length_um:g}" if w.length_um is not None else f"cut.length_um = {scene.cut.length_um:g}"
    drivers = (f"{length} um x workpiece.height_um = {w.height_um:g} um at numerics.element_size_um = {num.element_size_um:g} um "
               f"and numerics.elements_across_fibre = {num.elements_across_fibre}"
               + (f", numerics.n_frames = {num.n_frames}" if num.n_frames > 50 else ""))
    msg = (f"the scene is too large to run: estimated {' and '.join(over)}; it comes from {drivers}; "
           "allowed: a coarser numerics.element_size_um or a smaller workpiece")
    return [("numerics.element_size_um", num.element_size_um, msg)]
