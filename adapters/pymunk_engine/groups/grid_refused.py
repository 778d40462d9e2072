"""pymunk refuses finite-difference grids (heat, wave and Poisson equations) with the reason."""
from refsim_adapters.common.grid_pde import grid_refusal

MODEL_GROUP = grid_refusal("pymunk", "it is a 2D rigid-body engine")
