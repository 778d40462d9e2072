"""Model group `grid_fluids`: incompressible flow on a staggered (MAC) grid (the projection of
a manufactured field, Taylor-Green decay, the lid-driven cavity, particle transfers)."""
