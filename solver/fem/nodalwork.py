"""The work of an element's nodal forces, booked from the forces themselves (2D elements: the
quadrilaterals of :mod:`solver.fem.quad` and the cohesive elements of :mod:`solver.fem.cohesive`).

A force buffer row f[r] holds the forces ON the element's four nodes as (x, y) pairs. Over a step
x^n - x^{n-1} = dt_prev v^{n-1/2}, so the work of f over it is dt_prev f . v^{n-1/2}, and the element's
work is booked by the trapezoidal rule, (1/2) dt_prev (f^{n-1} + f^n) . v^{n-1/2}: the rule the central
difference's kinetic energy obeys (the energy check of the explicit step, Belytschko, Liu & Moran 2014,
box 6.1), so the balance closes exactly. An element that stops acting at x^n (deleted, failed,
or tied to a deleted element) has had the trapezoid booked with f^n, which never acts: its
:func:`withdraw_forces` takes back (1/2) dt_prev f^n . v^{n-1/2} and zeroes the row.

Both are inlined into their callers (``inline="always"``, at numba's IR level), so their arithmetic
is compiled with the caller's floating-point flags in the caller's operation order. Used by the
cohesive element (:func:`solver.fem.cohesive.cohesive_update`: the work of its forces, and the
correction when a tied element is deleted). The element loop of :mod:`solver.fem.loop` keeps its own
copy of the correction written out: this call in its place (in either of two statement orders) was
measured to move the round-off of the 2D cutting runs already before any element failed, i.e.
elsewhere in that fast-math chunk, whereas the calls inside the cohesive element keep the runs bit
for bit.
"""

from __future__ import annotations

import numba


@numba.njit(cache=True, inline="always")
def nodal_power(f, r, nodes, vx, vy):
    """sum over the four nodes nd = nodes[r, k] of f[r, 2k] vx[nd] + f[r, 2k + 1] vy[nd] (the power of the
    row's forces at the nodes' velocities), accumulated in node order."""
    p = 0.0
    for k in range(4):
        nd = nodes[r, k]
        p += f[r, 2 * k] * vx[nd] + f[r, 2 * k + 1] * vy[nd]
    return p


@numba.njit(cache=True, inline="always")
def withdraw_forces(f, r, nodes, vx, vy, dtprev):
    """The work to take back from an element whose forces f^n = f[r] never act (module docstring),
    (1/2) dt_prev f^n . v^{n-1/2}; zeroes f[r] (eight entries)."""
    corr = 0.5 * dtprev * nodal_power(f, r, nodes, vx, vy)
    for k in range(8):
        f[r, k] = 0.0
    return corr
