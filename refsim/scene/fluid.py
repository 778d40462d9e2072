"""The SPH fluid block: a 2D block of liquid in a rectangular tank (weakly compressible SPH)."""
from __future__ import annotations

from dataclasses import dataclass

from ._validate import _nonnegative, _positive, _set


@dataclass(frozen=True)
class FluidBlock:
    """A 2D block of liquid [x0, x1] x [y0, y1] (m) sampled at `spacing`, at rest and in
    hydrostatic balance at t = 0, inside a rectangular `tank` [0, tank_width] x [0,
    tank_height] with solid walls. Weakly compressible: sound speed c0; Monaghan's artificial
    viscosity alpha; smoothing length h = smoothing * spacing. `no_slip`: the artificial
    viscosity also acts between fluid and wall particles (a numerical no-slip wall whose
    effective viscosity alpha c0 h / 8 shrinks with the resolution); otherwise the walls act
    through pressure only (free-slip). `delta`: the delta-SPH density diffusion coefficient
    (Molteni & Colagrossi 2009; 0 = none). `tension`: the pressure follows the equation of
    state below rho0 too (negative pressure holds the fluid together); otherwise it is
    clamped at 0 there."""

    lower: tuple[float, float]
    upper: tuple[float, float]
    spacing: float
    tank_width: float
    tank_height: float
    density: float = 1000.0
    sound_speed: float = 20.0
    viscosity_alpha: float = 0.02
    smoothing: float = 1.3
    no_slip: bool = False
    delta: float = 0.0
    tension: bool = False

    kind = "fluid"

    def __post_init__(self):
        _set(self, "no_slip", bool(self.no_slip))
        _set(self, "tension", bool(self.tension))
        _set(self, "delta", _nonnegative("fluid.delta", self.delta))
        for name in ("spacing", "tank_width", "tank_height", "density", "sound_speed",
                     "smoothing"):
            _set(self, name, _positive(f"fluid.{name}", getattr(self, name)))
        _set(self, "viscosity_alpha", _nonnegative("fluid.viscosity_alpha",
                                                   self.viscosity_alpha))
        lo, hi = tuple(map(float, self.lower)), tuple(map(float, self.upper))
        if len(lo) != 2 or len(hi) != 2 or not all(a < b for a, b in zip(lo, hi)):
            raise ValueError(f"fluid block must have lower < upper in 2D, got {lo}, {hi}")
        if lo[0] < 0 or lo[1] < 0 or hi[0] > self.tank_width or hi[1] > self.tank_height:
            raise ValueError("fluid block must lie inside the tank")
        _set(self, "lower", lo)
        _set(self, "upper", hi)

    @property
    def lattice_shape(self) -> tuple[int, int]:
        """Fluid particles per axis of the square lattice at `spacing` filling the block:
        round(extent / spacing) each (the particle count engines report in "x", "v")."""
        return tuple(int(round((b - a) / self.spacing)) for a, b in zip(self.lower, self.upper))

    @property
    def particle_count(self) -> int:
        nx, ny = self.lattice_shape
        return nx * ny

    def features(self) -> set[str]:
        return {"fluid", "walls"}
