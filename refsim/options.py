"""Command-line values checked once: each bad value raises ValueError naming the option and
its valid range (the CLI prints that one line and exits 2)."""
from __future__ import annotations

import math


def positive_number(name: str, value, what: str = "a finite number > 0") -> float:
    """`value` as a float in (0, inf), else ValueError "`name` must be `what`, got ...". """
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if not (math.isfinite(number) and number > 0):
        raise ValueError(f"{name} must be {what}, got {value!r}")
    return number
