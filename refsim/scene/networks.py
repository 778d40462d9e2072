"""Spring networks (cloth, rope, hair, mass-spring solids): nodes joined by stretch edges,
bending hinges over node triples and dihedral hinges over node quads, with pinned nodes (the
`SpringNetwork` part).

Angle conventions (radians):
- hinge (a, b, c): the turning angle at b between the segments b - a and c - b, in [0, pi]
  (0: a, b, c in a straight line); energy 1/2 k (theta - theta0)^2.
- dihedral (a, b, c, d): triangles (a, b, c) and (d, c, b) share the edge b -> c; the angle
  from the normal of the first, n1 = (b - a) x (c - a), to the normal of the second,
  n2 = (c - d) x (b - d), signed about b -> c, in [-pi, pi] (0: flat); energy
  1/2 k (theta - theta0)^2.
A rest length or rest angle left as None is taken from the initial node positions.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validate import (ArrayPart, _set, float_array, index_array, nonnegative_array,
                        per_item, positive_array, read_only, zeros_or)


def _rows_norm(v: np.ndarray) -> np.ndarray:
    return np.linalg.norm(v, axis=-1)


def hinge_angles(x: np.ndarray, hinges: np.ndarray) -> np.ndarray:
    """Turning angle at the middle node of each (a, b, c) triple, in [0, pi]."""
    e1 = x[hinges[:, 1]] - x[hinges[:, 0]]
    e2 = x[hinges[:, 2]] - x[hinges[:, 1]]
    if np.any(_rows_norm(e1) == 0) or np.any(_rows_norm(e2) == 0):
        raise ValueError("network.hinges must join nodes at distinct positions")
    return np.arctan2(_rows_norm(np.cross(e1, e2)), np.sum(e1 * e2, axis=1))


def dihedral_angles(x: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Signed angle between the wing normals of each (a, b, c, d) quad, in [-pi, pi]."""
    a, b, c, d = (x[quads[:, k]] for k in range(4))
    n1, n2 = np.cross(b - a, c - a), np.cross(c - d, b - d)
    edge = c - b
    if np.any(_rows_norm(n1) == 0) or np.any(_rows_norm(n2) == 0):
        raise ValueError("network.dihedrals must have non-degenerate wing triangles")
    edge_unit = edge / _rows_norm(edge)[:, None]
    sin = np.sum(np.cross(n1, n2) * edge_unit, axis=1)
    return np.arctan2(sin, np.sum(n1 * n2, axis=1))


def _angles(name: str, value, default, count: int, low: float) -> np.ndarray:
    if value is None:
        return read_only(np.array(default, float))
    arr = per_item(name, value, count)
    if arr.size and (arr.min() < low or arr.max() > np.pi):
        raise ValueError(f"{name} must be in [{low:g}, pi], got {arr.min()}..{arr.max()}")
    return arr


def _stiffness(name: str, value, count: int) -> np.ndarray:
    """Bending stiffness per hinge (> 0): required once there is a hinge."""
    if value is None and count:
        raise ValueError(f"{name} must be given (> 0, N m) for its {count} entries")
    return per_item(name, np.zeros(0) if value is None else value, count, positive_array)


@dataclass(frozen=True, eq=False)
class SpringNetwork(ArrayPart):
    """n nodes: positions (n, 3) m, masses (n,) kg > 0 (a scalar: every node), velocities
    (n, 3) m/s (zeros when omitted).
    m stretch edges (m, 2): stiffness (m,) N/m > 0, rest_length (m,) m >= 0 (None: initial
    lengths), damping (m,) N s/m >= 0 along the edge.
    hinges (k, 3) node triples: hinge_stiffness (k,) N m > 0 (required with hinges),
    hinge_rest_angle (k,) rad in [0, pi] (None: initial angles).
    dihedrals (l, 4) node quads: dihedral_stiffness (l,) N m > 0 (required with dihedrals),
    dihedral_rest_angle (l,) rad in [-pi, pi] (None: initial angles).
    pinned (p,) distinct node indices held fixed.
    Scalars are broadcast to every edge, hinge or dihedral."""

    positions: np.ndarray
    masses: np.ndarray
    edges: np.ndarray
    stiffness: np.ndarray
    rest_length: np.ndarray | None = None
    damping: np.ndarray | float = 0.0
    velocities: np.ndarray | None = None
    hinges: np.ndarray | None = None
    hinge_stiffness: np.ndarray | float | None = None
    hinge_rest_angle: np.ndarray | None = None
    dihedrals: np.ndarray | None = None
    dihedral_stiffness: np.ndarray | float | None = None
    dihedral_rest_angle: np.ndarray | None = None
    pinned: np.ndarray | None = None

    kind = "networks"
    many = True  # a scene may hold several networks

    def __post_init__(self):
        x = float_array("network.positions", self.positions, (None, 3))
        n = len(x)
        if n < 2:
            raise ValueError(f"network.positions must hold at least 2 nodes, got {n}")
        _set(self, "positions", x)
        _set(self, "masses", per_item("network.masses", self.masses, n, positive_array))
        _set(self, "velocities", zeros_or("network.velocities", self.velocities, (n, 3)))
        self._set_edges(x)
        self._set_hinges(x)
        self._set_dihedrals(x)
        pinned = index_array("network.pinned", self.pinned, None, n)
        if len(np.unique(pinned)) != len(pinned):
            raise ValueError("network.pinned must list distinct node indices")
        if np.any(self.velocities[pinned] != 0):
            raise ValueError("network.velocities of pinned nodes must be 0 (a pinned node "
                             "never moves)")
        _set(self, "pinned", pinned)

    def _set_edges(self, x: np.ndarray) -> None:
        edges = index_array("network.edges", self.edges, 2, len(x))
        m = len(edges)
        if m == 0:
            raise ValueError("network.edges must hold at least one stretch edge")
        _set(self, "edges", edges)
        _set(self, "stiffness", per_item("network.stiffness", self.stiffness, m,
                                         positive_array))
        lengths = _rows_norm(x[edges[:, 1]] - x[edges[:, 0]])
        rest = lengths if self.rest_length is None else self.rest_length
        _set(self, "rest_length", per_item("network.rest_length", rest, m, nonnegative_array))
        _set(self, "damping", per_item("network.damping", self.damping, m, nonnegative_array))

    def _set_hinges(self, x: np.ndarray) -> None:
        hinges = index_array("network.hinges", self.hinges, 3, len(x))
        k = len(hinges)
        _set(self, "hinges", hinges)
        _set(self, "hinge_stiffness", _stiffness("network.hinge_stiffness",
                                                 self.hinge_stiffness, k))
        initial = hinge_angles(x, hinges) if self.hinge_rest_angle is None else None
        _set(self, "hinge_rest_angle", _angles("network.hinge_rest_angle",
                                               self.hinge_rest_angle, initial, k, 0.0))

    def _set_dihedrals(self, x: np.ndarray) -> None:
        quads = index_array("network.dihedrals", self.dihedrals, 4, len(x))
        k = len(quads)
        _set(self, "dihedrals", quads)
        _set(self, "dihedral_stiffness", _stiffness("network.dihedral_stiffness",
                                                    self.dihedral_stiffness, k))
        initial = dihedral_angles(x, quads) if self.dihedral_rest_angle is None else None
        _set(self, "dihedral_rest_angle", _angles("network.dihedral_rest_angle",
                                                  self.dihedral_rest_angle, initial, k, -np.pi))

    def __len__(self) -> int:
        return len(self.positions)

    def edge_kinds(self) -> set[str]:
        """The edge kinds present: "stretch" always, "hinge" and "dihedral" when given."""
        present = {"stretch": True, "hinge": len(self.hinges) > 0,
                   "dihedral": len(self.dihedrals) > 0}
        return {name for name, on in present.items() if on}

    def features(self) -> set[str]:
        return {"networks"}
