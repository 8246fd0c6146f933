"""The meso scale: honeycomb cell walls modelled one by one (issue 20)."""

from forming.solver.options import NewtonOptions

# The walls' Jacobians (thin quadratic walls) take MUMPS's exact LU in double precision:
# the approximate ones that ``auto`` takes for large models refine slowly or not at all
# there. `meso_compression --set load=tension_x --set cells=3,3` (160,599 unknowns,
# serial): the exact LU 16.7 s, the single-precision one 16.8 s (5.3 refinements per
# solve), the compressed single-precision one 24.8 s (20 FGMRES iterations per solve);
# on 5 x 5 cells (425,187) the compressed LU needed the exact one in every solve, and in
# double precision alone it did not converge in 200 GMRES iterations (docs/performance.md,
# "MUMPS's LU in single precision").
WALL_NEWTON = NewtonOptions(linear_solver="mumps", lu_precision="double")
