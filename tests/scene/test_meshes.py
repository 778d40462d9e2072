"""The finite-element mesh parts: TriangleMesh (plane, orientation, plane mode, pinned nodes,
loads) and TetMesh (orientation), each bad value refused by name in one line."""
import numpy as np
import pytest

from refsim.models.fem.meshes import box_tetrahedra, rectangle_triangles
from refsim.scene import (PLANE_MODES, STRAIN_MEASURES, Material, Plasticity, Scene, TetMesh,
                          TriangleMesh)
from refsim.scene.meshes import mesh_plane

STEEL = Material(2e11, 0.3, 7800.0)


def test_neo_hookean_is_a_strain_measure_and_plane_modes_are_stress_and_strain():
    assert STRAIN_MEASURES == ("linear", "green", "corotated", "neo_hookean")
    assert Material(1e6, 0.3, 1e3, "neo_hookean").strain == "neo_hookean"
    assert PLANE_MODES == ("stress", "strain")


def test_a_triangle_mesh_stores_pinned_nodes_sorted_and_loads_with_defaults():
    nodes, tris = rectangle_triangles(2, 1)
    mesh = TriangleMesh(nodes, tris, STEEL, pinned=[3, 0], loads=np.ones((6, 3)) * [1, 2, 0])
    assert mesh.pinned.tolist() == [0, 3] and mesh.plane == "stress"
    assert not mesh.pinned.flags.writeable and not mesh.loads.flags.writeable
    bare = TriangleMesh(nodes, tris, STEEL)
    assert bare.pinned.shape == (0,) and np.array_equal(bare.loads, np.zeros((6, 3)))
    assert mesh != bare and TriangleMesh(nodes, tris, STEEL, plane="strain") != bare


def test_an_inverted_triangle_is_named():
    nodes, tris = rectangle_triangles(2, 2)
    tris = tris.copy()
    tris[[1, 5]] = tris[[1, 5]][:, ::-1]
    with pytest.raises(ValueError, match=r"mesh\.triangles.*elements \[1, 5\] are inverted "
                                         r"\(mixed orientation, 2 of 8\)"):
        TriangleMesh(nodes, tris, STEEL)


def test_a_clockwise_mesh_in_the_xy_plane_is_all_inverted():
    nodes, tris = rectangle_triangles(1, 1)
    with pytest.raises(ValueError, match=r"all inverted, 2 of 2"):
        TriangleMesh(nodes, tris[:, ::-1], STEEL)


def test_a_tilted_plane_mesh_is_accepted_in_its_own_plane_and_a_bent_one_is_not():
    nodes, tris = rectangle_triangles(2, 2)
    tilt = np.array([[1.0, 0, 0], [0, 0.6, 0.8], [0, -0.8, 0.6]])
    tilted = nodes @ tilt.T
    basis, normal = mesh_plane(tilted, tris)
    assert np.allclose(normal, tilt[:, 2], rtol=0, atol=1e-15)  # unit vectors, round-off
    assert np.allclose(basis @ basis.T, np.eye(2), rtol=0, atol=1e-15)
    TriangleMesh(tilted, tris, STEEL)
    bent = tilted.copy()
    bent[4] += 1e-3 * normal
    with pytest.raises(ValueError, match=r"mesh\.vertices must lie in one plane.*\[4\]"):
        TriangleMesh(bent, tris, STEEL)


def test_loads_out_of_the_plane_are_refused_by_node():
    nodes, tris = rectangle_triangles(1, 1)
    loads = np.zeros((4, 3))
    loads[2] = [1.0, 0.0, 0.5]
    with pytest.raises(ValueError, match=r"mesh\.loads must lie in the mesh plane.*\[2\]"):
        TriangleMesh(nodes, tris, STEEL, loads=loads)


@pytest.mark.parametrize("kw,field", [({"plane": "membrane"}, "mesh.plane"),
                                      ({"pinned": [0, 0]}, "mesh.pinned"),
                                      ({"pinned": [7]}, "mesh.pinned"),
                                      ({"loads": np.zeros((3, 3))}, "mesh.loads")])
def test_bad_triangle_mesh_fields_are_named(kw, field):
    nodes, tris = rectangle_triangles(1, 1)
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        TriangleMesh(nodes, tris, STEEL, **kw)


def test_a_tet_mesh_is_a_mesh_part_with_fem_features():
    nodes, tets = box_tetrahedra(1, 1, 1)
    mesh = TetMesh(nodes, tets, STEEL, pinned=[0])
    assert len(mesh) == 8 and mesh.elements.shape == (6, 4) and mesh.kind == "meshes"
    plastic = TetMesh(nodes, tets, Material(2e11, 0.3, 7800.0, plasticity=Plasticity(1e8)))
    assert Scene(parts=(plastic,)).features() >= {"fem", "plasticity"}
    assert mesh == TetMesh(nodes, tets, STEEL, pinned=[0]) and hash(mesh) == hash(
        TetMesh(nodes, tets, STEEL, pinned=[0]))


def test_inverted_and_mixed_tetrahedra_are_named():
    nodes, tets = box_tetrahedra(1, 1, 1)
    mixed = tets.copy()
    mixed[[2, 4]] = mixed[[2, 4]][:, [0, 1, 3, 2]]
    with pytest.raises(ValueError, match=r"mesh\.tetrahedra.*elements \[2, 4\] are inverted "
                                         r"\(mixed orientation, 2 of 6\)"):
        TetMesh(nodes, mixed, STEEL)
    with pytest.raises(ValueError, match=r"all inverted, 6 of 6"):
        TetMesh(nodes, tets[:, [0, 1, 3, 2]], STEEL)


def test_degenerate_tetrahedra_are_named():
    nodes = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    with pytest.raises(ValueError, match=r"mesh\.tetrahedra must not be degenerate.*\[0\]"):
        TetMesh(nodes, [[0, 1, 2, 3]], STEEL)
