"""Grid fluids (issue 27, slides 001/000): incompressible Navier-Stokes on a staggered (MAC)
grid, vectorised numpy and scipy.sparse (no Python loop over cells or particles).

MAC conventions, fixed for every module of the group (and the engines' grid-fluid groups):
- a 2D grid of nx x ny square cells of side h on [0, nx h] x [0, ny h]; arrays indexed [i, j]
  with i along x and j along y ('ij'), float64;
- cell quantities (the pressure p, a level set, marks) p[i, j] at ((i + 1/2) h, (j + 1/2) h),
  shape (nx, ny); u[i, j] (x-velocity) on the vertical faces at (i h, (j + 1/2) h), shape
  (nx + 1, ny); v[i, j] on the horizontal faces at ((i + 1/2) h, j h), shape (nx, ny + 1);
- sides per axis: "wall" (no through-flow: u = 0 on the x-walls' faces, v = 0 on the
  y-walls'; no slip: the tangential ghost 2 w - u with w the wall's velocity, 0 or the
  cavity's lid, in the viscous term and the advection's interpolation) or "periodic" (the
  last face equals the first, u[nx] == u[0], kept so after every step);
- free surface: cells marked FLUID / AIR / SOLID (refsim.scene.fluid_grid, int8 (nx, ny)),
  p = 0 in air, faces touching a solid held at 0;
- discrete divergence D u = (u[i+1, j] - u[i, j] + v[i, j+1] - v[i, j]) / h per cell;
  gradient G p on the interior (and periodic seam) faces, (p[i] - p[i-1]) / h; the projection
  solves (D G) p = D u* / dt with walls as homogeneous Neumann (their face velocity fixed) and
  subtracts dt G p: the projected field has D u = 0 to the solver's tolerance. p is kinematic
  (p / rho, m^2/s^2).
- observables: grid.u, grid.v (face arrays, m/s), grid.p (cells, m^2/s^2); particle methods
  add the particles' x, v (n, 3), z = 0.

Modules: mac (MacGrid; divergence, gradient, face <-> cell averages, ghost layers, bilinear
sampling, velocity_at), advection (semi-Lagrangian: backtraces euler / rk2 / rk3 (Ralston),
interpolants linear / cubic (Catmull-Rom) / cubic_clamped), projection (PressureSystem: G,
A = G^T G, direct / cg / pyamg solves to a relative residual), viscosity (explicit and
implicit, no-slip walls, the lid), solver (FluidSolver: one step; scheme names
"sl_<interpolant>:<backtrace>", their orders in refsim.integrators.semi_lagrangian),
projection_mg (the cell-centred multigrid preconditioner of the projection's MGPCG), transfer
and transfer_theory (particle <-> grid: PIC, FLIP, the blend and APIC in the MAC form; the
momenta, energies and loss identities they are tested against), particle_fluid (the
particle-fluid step: P2G, marks, forces, projection with p = 0 in air, G2P, particle
advection), prescribed_flow and level_set (analytic flows, LeVeque's vortex and Zalesak's
rotation; a level set advected through them with exact signed distances and the area rule).
"""
