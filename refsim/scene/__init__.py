"""Engine-neutral scene description: frozen, validated plain data, one module per part kind.

Every backend (the in-house engine and each adapter) reads the same `Scene`. SI units, float64;
3D scenes are z-up, 2D scenes are y-up. Validation happens when an object is built: a bad value
raises `ValueError` naming the field and its valid range, never later inside an engine. Array
parts store read-only numpy arrays, built once.

Modules: particles (Body, Particles), springs (Spring, Springs), joints (Joint, Joints), walls
(Wall, Walls, ContactModel), fluid (FluidBlock, SPH), rigid (RigidBodies), networks
(SpringNetwork), meshes (Material, Plasticity, TriangleMesh, TetMesh), grids (Grid), fluid_grid
(FluidGrid: a fluid on a MAC grid), plates (Plates: thin static slabs), queries (the collision
query batches), scene (Scene, PART_KINDS, MOVING_KINDS); _validate holds
the shared checks.
"""
from ._validate import Vec
from .fluid import FluidBlock
from .fluid_grid import FluidGrid
from .grids import BOUNDARY_KINDS, Grid
from .joints import JOINT_KINDS, Joint, Joints
from .meshes import (PLANE_MODES, STRAIN_MEASURES, Material, Plasticity, TetMesh, TriangleMesh,
                     single_mesh)
from .networks import SpringNetwork
from .particles import Body, Particles
from .plates import Plates
from .rigid import RigidBodies
from .scene import MOVING_KINDS, PART_KINDS, Scene
from .springs import Spring, Springs
from .walls import ContactModel, Wall, Walls

__all__ = ["BOUNDARY_KINDS", "Body", "ContactModel", "FluidBlock", "FluidGrid", "Grid",
           "JOINT_KINDS", "Joint", "Joints", "MOVING_KINDS", "Material", "PART_KINDS",
           "PLANE_MODES", "Particles", "Plates", "Plasticity", "RigidBodies", "STRAIN_MEASURES", "Scene",
           "Spring", "SpringNetwork", "Springs", "TetMesh", "TriangleMesh", "Vec", "Wall",
           "Walls", "single_mesh"]
