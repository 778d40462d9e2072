"""Model group `grid_evolution`: finite differences on regular grids, time stepped (heat and
wave modes; shared mode helpers in `_modes`)."""
