"""Solid SPH (updated-Lagrangian) and the FEM-to-SPH conversion of the hybrid fidelity.

One file per idea:

* :mod:`solver.sph.kernel`     - the 2D cubic-spline kernel and its gradient;
* :mod:`solver.sph.cells`      - O(N) cell-list neighbour search over the active particles;
* :mod:`solver.sph.materials`  - the particle material table (isotropic, transversely isotropic fibre);
* :mod:`solver.sph.particles`  - the particle container (structure of arrays) and lattice builders;
* :mod:`solver.sph.solid`      - the solid-SPH equations (continuity, velocity gradient, Jaumann
  hypoelastic stress with damage, Monaghan viscosity, Gray-Monaghan-Swift artificial stress, momentum);
* :mod:`solver.sph.loop`       - the compiled, chunked kick-drift-kick time loop and its driver;
* :mod:`solver.sph.conversion` - dormant particles slaved to elements and their activation on failure;
* :mod:`solver.sph.coupling`   - particles against the exposed edges of a deforming element mesh and out
  of its elements, inside the compiled step (the particle side of :mod:`solver.hybrid`).

A scene without conversion allocates no particles: nothing here is built unless asked for.
"""
