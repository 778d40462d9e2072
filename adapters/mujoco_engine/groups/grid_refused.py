"""mujoco refuses finite-difference grids (heat, wave and Poisson equations) with the reason."""
from refsim_adapters.common.grid_pde import grid_refusal

MODEL_GROUP = grid_refusal("mujoco", "it simulates multibody dynamics, with flex meshes for soft bodies")
