"""The legacy ASCII .vtk file pybullet's deformable world reads for a tetrahedral soft body
(btSoftBodyHelpers::CreateFromVtkFile, bullet3 src/BulletSoftBody/btSoftBodyHelpers.cpp), and
the orientation check every written tetrahedron passes.

What the reader takes: the line starting "POINTS n" and then one point per line, three numbers
read by `std::stringstream >> double` (pybullet's wheels are double precision; the numbers are
written with repr, so they are read back exactly); the line "CELLS m 5m" and then one cell per
line, "4 a b c d" (any other count than 4 aborts the load); "CELL_TYPES" ends the cells (the
types themselves, 10 = VTK_TETRA, are not read). Nodes keep the file's order (node i of
getMeshData is POINTS line i; measured: bit-identical positions after loading).

Orientation: pybullet computes each tetrahedron's rest matrix Dm = (x1 - x0, x2 - x0, x3 - x0)
and its volume det(Dm) / 6, signed (btSoftBody::initializeDmInverse), and weighs the element's
energy and forces by that signed volume. Swapping two nodes leaves F = Ds Dm^-1 unchanged but
makes the volume negative: the element's stiffness changes sign, and the mesh explodes where
the others do not outweigh it (measured, hanging under gravity, steps of 1 ms: a 6-tetrahedron
cube with one tetrahedron flipped reached 2e4 m after 100 steps and 2e6 m after 2000; a
120-tetrahedron bar with one flipped in its middle 3e5 m after 2000 steps, one flipped next to
its pinned face stayed bounded for those 2 s). The writer refuses any tetrahedron whose signed
volume is not positive.
"""
from __future__ import annotations

import numpy as np

VTK_TETRA = 10  # the cell type of a linear tetrahedron


def signed_volumes(vertices, tetrahedra) -> np.ndarray:
    """(x1 - x0) . ((x2 - x0) x (x3 - x0)) / 6 per tetrahedron (pybullet's det(Dm) / 6)."""
    x = np.asarray(vertices, float)
    t = np.asarray(tetrahedra)
    x0, x1, x2, x3 = (x[t[:, k]] for k in range(4))
    return np.einsum("ij,ij->i", x1 - x0, np.cross(x2 - x0, x3 - x0)) / 6.0


def orientation_reason(vertices, tetrahedra) -> str | None:
    """None when every tetrahedron has a positive signed volume, else a sentence naming them."""
    volume = signed_volumes(vertices, tetrahedra)
    bad = np.flatnonzero(~(volume > 0))
    if not len(bad):
        return None
    return (f"pybullet deformable: tetrahedra {bad[:8].tolist()} ({len(bad)} of {len(volume)}) "
            "are not positively oriented; pybullet weighs each element by its signed rest "
            "volume, and a mesh of mixed orientation explodes")


def vtk_text(vertices, tetrahedra) -> str:
    """The .vtk file's text: points in node order, cells in element order."""
    x = np.asarray(vertices, float)
    t = np.asarray(tetrahedra, dtype=np.int64)
    lines = ["# vtk DataFile Version 2.0", "refsim TetMesh", "ASCII",
             "DATASET UNSTRUCTURED_GRID", f"POINTS {len(x)} double"]
    lines += [f"{a!r} {b!r} {c!r}" for a, b, c in x.tolist()]
    lines.append(f"CELLS {len(t)} {5 * len(t)}")
    lines += [f"4 {a} {b} {c} {d}" for a, b, c, d in t.tolist()]
    lines.append(f"CELL_TYPES {len(t)}")
    lines += [str(VTK_TETRA)] * len(t)
    return "\n".join(lines) + "\n"


def write_vtk(path, vertices, tetrahedra, check=True) -> None:
    """Write the mesh to `path`; `check` (always, but for the test that shows the explosion)
    refuses a tetrahedron that is not positively oriented (ValueError)."""
    if check:
        reason = orientation_reason(vertices, tetrahedra)
        if reason:
            raise ValueError(reason)
    with open(path, "w") as fh:
        fh.write(vtk_text(vertices, tetrahedra))
