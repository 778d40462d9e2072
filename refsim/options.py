"""Command-line values checked once, where they enter: each bad value raises ValueError naming
the option and its valid range, one message per parameter (the CLI prints that line and exits
2). Every command's numbers go through `number` or `integer`; `check_steps` holds a dt against
the run it steps."""
from __future__ import annotations

import math

MAX_STEPS = 10 ** 8
MAX_STEPS_REASON = ("a run of more steps takes minutes to hours per engine and integrator "
                    "(1 to 10 us a step) and its round-off alone, n eps of the state, passes "
                    "2e-8 of it")


def _range(low: float, high: float, low_inclusive: bool, high_inclusive: bool) -> str:
    if math.isinf(high):
        return f">= {low:g}" if low_inclusive else f"> {low:g}"
    return f"in {'[' if low_inclusive else '('}{low:g}, {high:g}{']' if high_inclusive else ')'}"


def number(name: str, value, low: float = 0.0, high: float = math.inf,
           low_inclusive: bool = False, high_inclusive: bool = True, unit: str = "") -> float:
    """`value` as a finite float in the range (by default > 0), else ValueError
    "`name` must be a finite number > 0[ unit], got ..."."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    inside = math.isfinite(x) and (x >= low if low_inclusive else x > low) and (
        x <= high if high_inclusive else x < high)
    if not inside:
        what = _range(low, high, low_inclusive, high_inclusive) + (f" {unit}" if unit else "")
        raise ValueError(f"{name} must be a finite number {what}, got {value!r}")
    return x


def integer(name: str, value, low: int = 1, example: str = "") -> int:
    """`value` as an integer >= low, written as digits or as a float such as 1e9."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    if not (math.isfinite(x) and x >= low and x == int(x)):
        hint = f" (e.g. {example})" if example else ""
        raise ValueError(f"{name} must be an integer >= {low}{hint}, got {value!r}")
    return int(x)


def check_dt(dt) -> float:
    """--dt: a finite number of seconds > 0."""
    return number("--dt", dt, unit="s")


def check_steps(dt: float, t_end: float, where: str, max_steps: int = MAX_STEPS) -> int:
    """The step count of a run of t_end at dt; ValueError naming the valid dt range when dt is
    longer than the run or the count passes max_steps (--max-steps overrides it)."""
    if dt > t_end:
        raise ValueError(f"dt = {dt:g} s is longer than the run of {where} (t_end = "
                         f"{t_end:g} s): dt must be in (0, {t_end:g}] s")
    steps = t_end / dt
    if steps > max_steps:
        raise ValueError(f"dt = {dt:g} s gives {steps:.3g} steps for {where}: dt must be in "
                         f"[{t_end / max_steps:.3g}, {t_end:g}] s, at most --max-steps "
                         f"{max_steps:g} steps ({MAX_STEPS_REASON})")
    return int(round(steps))
