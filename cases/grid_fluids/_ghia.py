"""Ghia, Ghia & Shin (1982) Re = 100 cavity centrelines, read from
`cases/data/ghia_ghia_shin_1982_re100_centrelines.csv` (its header gives the source), and the
MAC field interpolated to their points.

The file: comment lines (#), then the header `line,coordinate,velocity`; 17 rows of
`u_at_x0.5` (u on the vertical centreline x = 0.5 at height y) and 17 of `v_at_y0.5` (v on the
horizontal centreline y = 0.5 at abscissa x), velocities in units of the lid speed, the unit
square, lid at y = 1.

Interpolation (`centreline`): bilinear on each face array with the MAC ghost layers
(refsim.models.grid_fluid.mac.sample: no-slip ghosts 2 w - u half a cell beyond the last
tangential row, so the interpolant takes the wall's value w on the wall: 0, or the lid's
speed at y = 1; odd reflection of the normal component through its wall faces). Where the
centreline lies depends on n's parity: for even n, x = 0.5 is the u-face column i = n/2 and
y = 0.5 the v-face row j = n/2, so the interpolation is linear along that column (row) only;
for odd n the centreline passes through cell centres, halfway between two face columns (rows),
and the bilinear interpolant takes their mean. Either way its error is O(h^2) (h^2 u'' / 8 at
worst between two faces), of the scheme's own order in h.
"""
from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from refsim.models.grid_fluid.mac import MacGrid, sample

DATA = (Path(__file__).parent.parent / "data"
        / "ghia_ghia_shin_1982_re100_centrelines.csv")
LINES = ("u_at_x0.5", "v_at_y0.5")


def ghia() -> dict:
    """{"u_y": heights, "u": u there, "v_x": abscissae, "v": v there} (17 each, lid units),
    read by the file's header (once: read-only arrays)."""
    return dict(_read())


@functools.lru_cache(maxsize=1)
def _read() -> tuple:
    rows = [line for line in DATA.read_text().splitlines()
            if line.strip() and not line.startswith("#")]
    header = [name.strip() for name in rows[0].split(",")]
    assert header == ["line", "coordinate", "velocity"], \
        f"unexpected header in {DATA.name}: {rows[0]}"
    table = [dict(zip(header, (s.strip() for s in line.split(",")))) for line in rows[1:]]
    out = {}
    for line, (coord, value) in zip(LINES, (("u_y", "u"), ("v_x", "v"))):
        sel = [r for r in table if r["line"] == line]
        out[coord] = np.array([float(r["coordinate"]) for r in sel])
        out[value] = np.array([float(r["velocity"]) for r in sel])
    assert sum(len(out[k]) for k in ("u", "v")) == len(table), \
        f"{DATA.name}: rows outside {LINES}"
    for arr in out.values():
        arr.flags.writeable = False
    return tuple(out.items())


def reference_values() -> np.ndarray:
    """Ghia's 34 velocities: the 17 u on x = 0.5, then the 17 v on y = 0.5 (lid units)."""
    g = ghia()
    return np.concatenate([g["u"], g["v"]])


# the report's profile heights/abscissae (unit square): every 1/256, so that for even n <= 128
# each node of the bilinear interpolant along a centreline (faces at (j + 1/2) / n, the walls)
# is one of them and the drawn polyline is the interpolant itself; 257 numbers a line, inside
# the store's 400 a profile
PROFILE = np.linspace(0.0, 1.0, 257)
PROFILE.flags.writeable = False


def profiles(u, v, grid: MacGrid) -> tuple[np.ndarray, np.ndarray]:
    """(u on x = 0.5 at heights PROFILE, v on y = 0.5 at abscissae PROFILE) of the MAC field,
    scaled to the unit square as `centreline`."""
    side = grid.nx * grid.h
    half, line = np.full_like(PROFILE, 0.5), PROFILE
    return (sample(u, "u", side * np.stack([half, line], axis=-1), grid),
            sample(v, "v", side * np.stack([line, half], axis=-1), grid))


def centreline(u, v, grid: MacGrid) -> np.ndarray:
    """The MAC field (u (nx + 1, ny), v (nx, ny + 1)) at Ghia's 34 points in the same order as
    `reference_values`, scaled to the unit square (the points are x L, y L with L = nx h)."""
    g = ghia()
    side = grid.nx * grid.h
    pu = side * np.stack([np.full_like(g["u_y"], 0.5), g["u_y"]], axis=-1)
    pv = side * np.stack([g["v_x"], np.full_like(g["v_x"], 0.5)], axis=-1)
    return np.concatenate([sample(u, "u", pu, grid), sample(v, "v", pv, grid)])
