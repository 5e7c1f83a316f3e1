"""The FEM-SPH hybrid: the explicit FEM engine (:mod:`solver.fem`) whose failed elements become
solid-SPH particles (:mod:`solver.sph`), the two coupled at every step.

* :mod:`solver.hybrid.coupler` - the coupled step: conversion of failed elements into their dormant
  particles, the particles' steps beside the engine's, the particle-edge reactions on the nodes, the
  energy balance of engine and particles as one body.

The particle side of the particle-edge contact (:mod:`solver.sph.coupling`) stays with solid SPH: its
kernels run inside the compiled SPH step, which imports nothing of this package.
"""
