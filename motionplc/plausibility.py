"""Plausibility of values for an axis' units: warnings (never errors) for numbers that are
accepted but that no real machine has, each naming the usual unit mistake.

A linear axis is in m (m/s, m/s², m/s³), a rotary one in rad: ``v_max: 800`` on a linear axis
is almost always 800 mm/s typed as m/s, ``v_max: 360`` on a rotary one degrees typed as
radians, and a G-code feed of 1.7e7 m/s a feed word far out of range. The bounds are generous
(a fast linear motor reaches ~10 m/s and ~100 m/s²): only values beyond any machine warn.
"""

from __future__ import annotations

import math

# quantity -> (bound, unit suffix) per axis units; a value beyond the bound warns
BOUNDS: dict[str, dict[str, tuple[float, str]]] = {
    "m": {
        "position": (100.0, ""),
        "velocity": (20.0, "/s"),
        "acceleration": (500.0, "/s²"),
        "jerk": (1e6, "/s³"),
    },
    "rad": {
        "position": (1e4, ""),
        "velocity": (1000.0, "/s"),
        "acceleration": (1e5, "/s²"),
        "jerk": (1e8, "/s³"),
    },
    # a rotary axis the machine names as its spindle (``gcode: spindle:``): in rad, but a
    # spindle turns up to ~60,000 rpm (6283 rad/s)
    "spindle": {
        "position": (math.inf, ""),
        "velocity": (1e4, "/s"),
        "acceleration": (1e6, "/s²"),
        "jerk": (1e9, "/s³"),
    },
}


def _g(x: float) -> str:
    return f"{x:.4g}"


def warning(value: float, units: str, quantity: str, what: str = "") -> str | None:
    """The warning text for ``value`` of ``quantity`` (position, velocity, acceleration,
    jerk) on an axis in ``units`` (``"m"``, ``"rad"``, or ``"spindle"``: a rotary axis in rad
    that is the machine's spindle), or None when it is plausible (or
    infinite: no limit). ``what`` names the value in the text (default: the quantity)."""
    if units not in BOUNDS or not math.isfinite(value):
        return None
    bound, suffix = BOUNDS[units][quantity]
    if abs(value) <= bound:
        return None
    name = what or quantity
    if units == "spindle":
        unit = "rad" + suffix
        return (
            f"{name} {_g(value)} {unit} is implausible for a spindle (beyond ±{_g(bound)} "
            f"{unit}): rpm typed as rad/s? ({_g(value)} rpm is {_g(value * math.pi / 30)} "
            "rad/s)"
            if quantity == "velocity"
            else f"{name} {_g(value)} {unit} is implausible for a spindle (beyond "
            f"±{_g(bound)} {unit})"
        )
    unit = units + suffix
    if units == "m":
        mistake = f"mm typed as m? ({_g(value)} mm{suffix} is {_g(value / 1000)} m{suffix})"
    else:
        mistake = (
            f"degrees typed as rad? ({_g(value)} °{suffix} is {_g(math.radians(value))} "
            f"rad{suffix})"
        )
    return (
        f"{name} {_g(value)} {unit} is implausible for an axis in {units} (beyond "
        f"±{_g(bound)} {unit}): {mistake}"
    )


def feed_warning(feed: float, units: str = "m") -> str | None:
    """A G-code feed [m/s, or rad/s] beyond any machine: the F word is in program units per
    minute (G21: mm/min, G20: in/min)."""
    if units not in BOUNDS or not math.isfinite(feed):
        return None
    bound, _ = BOUNDS[units]["velocity"]
    if abs(feed) <= bound:
        return None
    mm_min = feed * 60_000.0
    return (
        f"feed {_g(feed)} {units}/s is implausible (beyond {_g(bound)} {units}/s): F is in "
        f"program units per minute (this is F{_g(mm_min)} in mm; F6000 in mm is 0.1 m/s)"
    )
