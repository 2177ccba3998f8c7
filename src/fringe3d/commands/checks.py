"""Checks of command-line values that typer's types do not make (finite, in range)."""
from __future__ import annotations

import math


def check_number(value: float | None, option: str, minimum: float | None = None, maximum: float | None = None,
                 positive: bool = False) -> None:
    """Refuse NaN/inf and out-of-range values of ``option`` (None passes: the option was not given)."""
    if value is None:
        return
    if not math.isfinite(value):
        raise ValueError(f"{option} must be a finite number, got {value}")
    if positive and not value > 0:
        raise ValueError(f"{option} must be positive, got {value:g}")
    if minimum is not None and value < minimum:
        raise ValueError(f"{option} must be at least {minimum:g}, got {value:g}")
    if maximum is not None and value > maximum:
        raise ValueError(f"{option} must be at most {maximum:g}, got {value:g}")


#: Camera bit depths fringe3d reads (10-14 stored in 16-bit files).
BIT_DEPTHS = (8, 10, 12, 14, 16)


def check_choice(value, option: str, choices) -> None:
    """Refuse a value of ``option`` outside ``choices`` (None passes: the option was not given)."""
    if value is not None and value not in choices:
        raise ValueError(f"{option} must be one of {', '.join(map(str, choices))}, got {value!r}")


def parse_stage_sigma(text: str, option: str) -> tuple[float, float]:
    """``"2,0.2"`` as a stage's 1-sigma ``(rotation mrad, translation mm)``, both finite and >= 0;
    ``ValueError`` naming ``option`` otherwise."""
    try:
        values = [float(x) for x in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 2 or not all(math.isfinite(v) and v >= 0 for v in values):
        raise ValueError(f"{option}: expected ROT_MRAD,TRANS_MM (two numbers >= 0, e.g. 2,0.2), got {text!r}")
    return values[0], values[1]


def parse_exposures(text: str | None, option: str) -> list[float] | None:
    """``"0.001,0.004"`` as exposure times (s), each a finite number > 0, no repeats; ``None`` stays
    ``None``. ``ValueError`` naming ``option`` otherwise."""
    if text is None:
        return None
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ValueError(f"{option}: expected comma-separated exposure times in seconds, got {text!r}") from None
    if not values or not all(math.isfinite(v) and v > 0 for v in values):
        raise ValueError(f"{option}: expected positive exposure times in seconds, got {text!r}")
    if len(set(values)) != len(values):
        raise ValueError(f"{option}: repeated exposure time in {text!r}")
    return values
