"""Solid SPH in 3D: the particles the 3D hybrid's failed hexahedra turn into.

The formulation of :mod:`solver.sph` (updated-Lagrangian solid SPH of Gray, Monaghan & Swift 2001)
written for three dimensions: ``kernel`` (the cubic spline, 3D normalisation), ``cells`` (the cell
list), ``particles`` (the structure-of-arrays container), ``solid`` (continuity, Jaumann stress
update, momentum with artificial viscosity and artificial stress), ``walls`` (frictionless penalty
planes), ``loop`` (the compiled kick-drift-kick chunk and its driver), ``conversion`` (failed
hexahedra of :mod:`solver.fem3d` into particles). Imports no other engine except the 3D engine's
state, read by ``conversion``.
"""
