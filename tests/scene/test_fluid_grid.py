"""The FluidGrid part (MAC grid fluid): validation naming the field and its range, read-only
arrays, features, and its observables in the contract table."""
import numpy as np
import pytest

from refsim.observation import check_observation, expected
from refsim.scene import FluidGrid, Scene
from refsim.scene.fluid_grid import AIR, FLUID, SOLID


def _grid(nx=4, ny=3, **kw):
    return FluidGrid(nx=nx, ny=ny, h=0.25, u=np.zeros((nx + 1, ny)), v=np.zeros((nx, ny + 1)),
                     **kw)


def test_fields_are_stored_read_only_and_defaults_hold():
    g = _grid(nu=0.01, lid=1.0)
    assert g.sides == ("wall", "wall") and g.shape == (4, 3)
    assert g.density == 1.0 and g.rtol == 1e-10 and g.viscosity_scheme == "implicit"
    for arr in (g.u, g.v):
        assert not arr.flags.writeable and arr.dtype == np.float64
    assert g.features() == {"fluid_grid", "viscosity"}
    assert _grid().features() == {"fluid_grid"}


def test_marks_bring_their_features():
    marks = np.full((4, 3), FLUID)
    marks[:, 2] = AIR
    marks[0, 0] = SOLID
    g = _grid(marks=marks)
    assert g.features() == {"fluid_grid", "free_surface", "solid_cells"}
    assert g.marks.dtype == np.int8 and not g.marks.flags.writeable


@pytest.mark.parametrize("kw,message", [
    ({"nx": 1}, "fluid_grid.nx must be an integer >= 2, got 1"),
    ({"h": 0.0}, "fluid_grid.h must be a finite number > 0"),
    ({"nu": -1.0}, "fluid_grid.nu must be a finite number >= 0"),
    ({"density": 0.0}, "fluid_grid.density must be a finite number > 0"),
    ({"sides": "open"}, "fluid_grid.sides[0] must be one of ['wall', 'periodic']"),
    ({"sides": ("wall",)}, "fluid_grid.sides must be one kind or one per axis"),
    ({"lid": 1.0, "sides": ("wall", "periodic")}, "fluid_grid.lid must be 0 unless"),
    ({"rtol": 1.0}, "fluid_grid.rtol must be in (0, 1)"),
    ({"viscosity_scheme": "crank"}, "fluid_grid.viscosity_scheme must be one of"),
    ({"gravity": 1}, "fluid_grid.gravity must be True or False"),
    ({"marks": np.full((4, 3), 7)}, "fluid_grid.marks must be an array of shape (4, 3)"),
])
def test_bad_values_name_the_field_and_range(kw, message):
    base = {"nx": 4, "ny": 3, "h": 0.25}
    base.update(kw)
    nx, ny = base["nx"], base["ny"]
    with pytest.raises(ValueError) as err:
        FluidGrid(u=np.zeros((max(nx, 2) + 1, ny)), v=np.zeros((max(nx, 2), ny + 1)), **base)
    assert message in str(err.value)


def test_face_arrays_are_checked_for_shape_walls_and_periodic_copies():
    with pytest.raises(ValueError, match=r"fluid_grid.u must have shape \(5, 3\)"):
        FluidGrid(4, 3, 0.25, np.zeros((4, 3)), np.zeros((4, 4)))
    u = np.zeros((5, 3))
    u[0, 1] = 1.0
    with pytest.raises(ValueError, match="fluid_grid.u must be 0 on the wall faces of axis 0"):
        FluidGrid(4, 3, 0.25, u, np.zeros((4, 4)))
    with pytest.raises(ValueError, match="last faces equal to its first along the periodic"):
        FluidGrid(4, 3, 0.25, u, np.zeros((4, 4)), sides="periodic")
    u[4, 1] = 1.0
    v = np.zeros((4, 4))
    v[1, 0] = v[1, 3] = 2.0
    g = FluidGrid(4, 3, 0.25, u, v, sides="periodic")
    assert g.u[4, 1] == g.u[0, 1] == 1.0


def test_observables_of_the_part_in_the_contract():
    scene = Scene(parts=(_grid(),), dim=2)
    assert scene.part_kinds() == {"fluid_grids"}
    required = {n: s for n, (s, req) in expected(scene).items() if req}
    assert required == {"t": (), "grid.u": (5, 3), "grid.v": (4, 4), "grid.p": (4, 3)}
    obs = {"t": 0.0, "grid.u": np.zeros((5, 3)), "grid.v": np.zeros((4, 4)),
           "grid.p": np.zeros((4, 3))}
    assert check_observation(obs, scene) == []
    obs["grid.p"] = np.zeros((5, 3))
    assert check_observation(obs, scene) == ["'grid.p' has shape (5, 3), expected (4, 3)"]
