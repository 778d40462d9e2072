"""Model group `grid_poisson`: finite-difference Poisson solves on regular grids (a manufactured
solution)."""
