"""Plausibility of a tuned design on its own terms: warnings, not errors.

A spec can be valid and its optimum exact and still describe something no machine does: a
feedback counter that overflows, a circle smaller than the loop can contour, a radius in
metres where millimetres were meant, or hydraulic data that contradict the ω_n and ξ given
with them. Each check here reads the spec and the tuned metrics and says what it found,
with both numbers where two disagree.
"""

from __future__ import annotations

import math
from typing import Mapping

#: ranges of machine-tool practice; outside them a value is most likely a unit slip
#: (name: (low, high, unit, what)). Feeds: 0.6 mm/min … 120 m/min; radii: 0.1 mm … 2 m.
MACHINE_RANGES = {
    "radius": (1e-4, 2.0, "m", "circle radius"),
    "feed": (1e-5, 2.0, "m/s", "feed (path velocity)"),
    "max_velocity": (1e-5, 2.0, "m/s", "maximum velocity V_m"),
    "blu": (1e-8, 1e-3, "m", "basic length unit (BLU)"),
    "time_constant": (1e-4, 10.0, "s", "drive time constant τ"),
}
#: given ω_n and ξ disagree with the ones the hydraulic data imply beyond this (relative)
HYDRAULIC_MISMATCH = 0.05


def _outside(value: float, name: str, where: str) -> str | None:
    low, high, unit, what = MACHINE_RANGES[name]
    if low <= value <= high:
        return None
    return (f"{where}: {what} {value:g} {unit} is far outside machine-tool practice "
            f"({low:g}–{high:g} {unit}); a unit slip?")


def _circles(spec) -> list[tuple[str, float, float | None]]:
    """(JSON pointer, radius [m], feed [m/s] or None) of every circle the spec names."""
    circles = []
    for section in ("objective", "constraints"):
        for i, term in enumerate(getattr(spec, section)):
            radius = getattr(term, "radius", None)
            if radius is not None:
                circles.append((f"/{section}/{i}", radius, getattr(term, "feed", None)))
    return circles


def _range_warnings(spec) -> list[str]:
    warnings = []
    for pointer, radius, feed in _circles(spec):
        warnings.append(_outside(radius, "radius", f"{pointer}/radius"))
        if feed is not None:
            warnings.append(_outside(feed, "feed", f"{pointer}/feed"))
    for name in ("max_velocity", "blu", "time_constant"):
        value = getattr(spec.plant, name, None)
        if isinstance(value, float):
            warnings.append(_outside(value, name, f"/plant/{name}"))
    return [w for w in warnings if w]


def _metric_warnings(spec, metrics: Mapping) -> list[str]:
    warnings = []
    counter = metrics.get("counter_utilisation")
    if counter is not None and counter.value is not None and counter.value > 1:
        bits = getattr(spec.plant, "counter_bits", None)
        warnings.append(
            f"the feedback counter overflows: counter_utilisation = {counter.value:.4g} > 1 "
            f"(at V_m more pulses arrive per sample than a {bits}-bit counter holds); "
            "constrain counter_utilisation max 1, or shorten the sampling period")
    min_radius = metrics.get("min_radius")
    if min_radius is not None and min_radius.value is not None:
        for pointer, radius, _ in _circles(spec):
            if min_radius.value > radius:
                warnings.append(
                    f"min_radius = {min_radius.value:.4g} m is larger than the {radius:g} m "
                    f"circle of {pointer}: at V_m that circle's radial error exceeds BLU/2")
    return warnings


#: hydraulic_rotary's given constants and what implies them (App. A2): (field, symbol, unit,
#: the params' method computing it when the field is omitted, the data that method needs)
_HYDRAULIC_IMPLIED = (
    ("hydraulic_natural_frequency", "ω_n", " rad/s", "natural_frequency",
     ("bulk_modulus", "total_volume", "inertia", "displacement")),
    ("hydraulic_damping", "ξ", "", "damping",
     ("leakage_coefficient", "viscous_damping", "bulk_modulus", "total_volume", "inertia",
      "displacement")),
)


def _hydraulic_warnings(plant) -> list[str]:
    """ω_n and ξ given together with the data that imply them (the plant's own formulas,
    App. A2), where the two differ by more than HYDRAULIC_MISMATCH."""
    if plant.type != "hydraulic_rotary":
        return []
    implied = plant.model_copy(update={field: None for field, *_ in _HYDRAULIC_IMPLIED})
    warnings = []
    for field, symbol, unit, formula, data in _HYDRAULIC_IMPLIED:
        given = getattr(plant, field)
        if given is None or any(getattr(plant, name) is None for name in data):
            continue
        value = getattr(implied, formula)()
        if abs(given - value) > HYDRAULIC_MISMATCH * given:
            warnings.append(f"/plant/{field}: given {symbol} = {given:.4g}{unit}, but "
                            f"{', '.join(data)} imply {symbol} = {value:.4g}{unit}; the given "
                            "value is used")
    return warnings


def plausibility_warnings(spec, metrics: Mapping) -> list[str]:
    """Every implausibility of ``spec`` and its tuned ``metrics`` (MetricValue by key)."""
    return _range_warnings(spec) + _metric_warnings(spec, metrics) + _hydraulic_warnings(spec.plant)
