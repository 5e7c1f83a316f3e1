"""Explicit 3D FEM engine (hexahedra with the fibre, matrix and EHM laws; the 2D plane-strain engine is solver.fem).

Use::

    from solver.fem3d import gridmesh3d, laws3d, loop, material3d
    mesh = gridmesh3d.box_mesh(nx, ny, nz, lx, ly, lz)
    C = material3d.fibre_stiffness(E1, E2, G12, nu12, nu23, direction)    # or isotropic_stiffness(E, nu)
    state = loop.build_state(mesh.X, mesh.hexes, [C], [rho])
    state.fix[...], state.vp[...], state.fext[...]                          # boundary conditions, loads
    rec = loop.advance(state, n_steps)                                      # compiled central-difference steps
    loop.energies(state)                                                    # internal, hourglass, kinetic, external
    # cohesive interfaces: a split box (gridmesh3d.split_box_mesh) and, before the first step,
    loop.add_cohesive(state, mesh.cohesive, [K, sigma_n, tau, GIc, GIIc, eta])
    # inelastic laws and deletion: material rows FIBRE=0, MATRIX=1, EHM=2 from a scene's si
    cmat, rho, props = laws3d.material_table3d(si, fibre_direction=d)
    state = loop.build_state(mesh.X, mesh.hexes, cmat, rho, mat=mat, props=props)
    rec.finding                                                             # the guard's diagnosis (guard3d)
    # the rigid tool (the 2D tool's profile extruded along z) and the strip's sides held along z:
    contact3d.add_tool(state, solver.tool.tool_array(si), mu); contact3d.strip_sides(state)
    # contact between pieces no longer joined: fc = contact3d.FragmentContact3D(state); fc.rebuild(state)

Pieces (one idea per file): :mod:`.hex8` (the element), :mod:`.material3d` (the elastic stiffnesses),
:mod:`.laws3d` (the inelastic laws and their property table), :mod:`.guard3d` (the guard's diagnosis),
:mod:`.cohesive3d` (the cohesive interface element), :mod:`.loop` (the state and the time loop),
:mod:`.gridmesh3d` (structured box meshes), :mod:`.contact3d` (rigid tool and sphere contact, fragments, symmetry planes).
"""
