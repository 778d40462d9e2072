"""Martin & Moyce (1952), the collapse of a water column (n^2 = 2): the measured surge front
and the rules every dam-break case compares with it (the SPH group's dam_break and the grid
fluids' flip_dam_break), kept here so that neither case group imports the other.

`martin_moyce()` reads the front Z = x / a against T = t sqrt(2 g / a) from
`cases/data/martin_moyce_1952_table2_front_n2eq2.csv` (its header names the source);
`clock_spread_rms(f)` is how far the measured Z(T) moves if the experiment's clock ran a
fraction f fast (their runs spread 5-10 % in T early on); `fit_time_shift` is the least-squares
time shift s (|s| <= 0.3: M&M shifted every run to T = 1.19 at Z = 1.44) and the residuals
Z_sim(T - s) - Z; `front_figure()` the report's figure of the simulated fronts over the
data (one figure for every case declaring it).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

DATA = Path(__file__).parent / "data" / "martin_moyce_1952_table2_front_n2eq2.csv"
MAX_SHIFT = 0.3  # the time shift's bound, in T units


def martin_moyce():
    """(T, Z) of the surge front from the data file."""
    rows = [line for line in DATA.read_text().splitlines() if line and not line.startswith("#")]
    assert rows[0].replace(" ", "") == "T,Z", f"unexpected header in {DATA.name}: {rows[0]}"
    table = np.array([[float(v) for v in line.split(",")] for line in rows[1:]])
    return table[:, 0], table[:, 1]


def clock_spread_rms(fraction):
    """RMS change of the measured Z(T) if the experiment's clock ran `fraction` fast: how far
    the experiment itself moves when its runs spread by that fraction in T (issue 5: the runs
    spread 5-10 % in T early on): 0.35 at 5 %, 0.66 at 10 %."""
    T, Z = martin_moyce()
    inside = T * (1 + fraction) <= T[-1]
    return float(np.sqrt(np.mean((np.interp(T[inside] * (1 + fraction), T, Z) - Z[inside]) ** 2)))


def fit_time_shift(T_sim, Z_sim):
    """Least-squares time shift s (|s| <= MAX_SHIFT) and the residuals Z_sim(T - s) - Z."""
    from scipy.optimize import minimize_scalar
    T, Z = martin_moyce()

    def residuals(s):
        inside = (T - s >= T_sim[0]) & (T - s <= T_sim[-1])
        return np.interp(T[inside] - s, T_sim, Z_sim) - Z[inside]

    best = minimize_scalar(lambda s: np.mean(residuals(s) ** 2), bounds=(-MAX_SHIFT, MAX_SHIFT),
                           method="bounded", options={"xatol": 1e-6})
    return float(best.x), residuals(best.x)


SHARED = "martin_moyce_front"  # the report draws every dam-break case's fronts in one figure


def front_figure():
    """The report's figure: the case's `front` over T (shifted by its fitted `time_shift`)
    against the measured points, shared (`SHARED`) by every case declaring it: the SPH and
    the FLIP dam breaks side by side."""
    T, Z = martin_moyce()
    return [{"kind": "trace_over_data", "title": "surge front", "shared": SHARED,
             "x": "T", "y": "front", "x_shift_column": "time_shift",
             "x_label": "T = t sqrt(2 g / a)  (+ fitted shift)", "y_label": "Z = x / a",
             "data": {"x": T.tolist(), "y": Z.tolist(),
                      "label": "Martin & Moyce (1952), Table 2"}}]
