"""The FEM-SPH hybrid: the explicit FEM engine (:mod:`solver.fem`) whose failed elements become
solid-SPH particles (:mod:`solver.sph`), the two coupled at every step.

* :mod:`solver.hybrid.coupler` - the coupled step: conversion of failed elements into their dormant
  particles, the particles' steps beside the engine's, the particle-edge reactions on the nodes, the
  energy balance of engine and particles as one body;
* :mod:`solver.hybrid.engine`  - the coupled step as the cutting scene's engine (:mod:`solver.engine`).

The particle side of the particle-edge contact (:mod:`solver.sph.coupling`) is solid SPH's: its
kernels run inside the compiled SPH step, which imports nothing of this package.
"""
