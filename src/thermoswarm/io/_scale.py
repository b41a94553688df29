"""The image scale (px/mm) as users give it: a number in a sane range or a preset name.

Its own module so that the writers (``io.mot``) and the registry (``io``) share one
parser without importing each other.
"""

from __future__ import annotations

from thermoswarm.config import shown
from thermoswarm.errors import InputError

__all__ = ["SCALE_PRESETS", "MIN_PX_PER_MM", "MAX_PX_PER_MM", "resolve_px_per_mm"]

#: Named scale presets for ``px_per_mm``.
SCALE_PRESETS: dict[str, float] = {"paper": 3.04}

#: Range of a scale (px/mm): one pixel per kilometre to a million per millimetre.
MIN_PX_PER_MM, MAX_PX_PER_MM = 1e-6, 1e6


def resolve_px_per_mm(value: float | str | None) -> float | None:
    """``None``, a number from :data:`MIN_PX_PER_MM` to :data:`MAX_PX_PER_MM`, or a
    preset name (``"paper"`` = 3.04 px/mm); anything else is a one-line InputError."""
    if value is None:
        return None
    if isinstance(value, str):
        key = value.strip().lower()
        if key in SCALE_PRESETS:
            return SCALE_PRESETS[key]
        try:
            value = float(key)
        except ValueError:
            presets = ", ".join(SCALE_PRESETS)
            raise InputError(
                f"px_per_mm must be a positive number or a preset ({presets}), got {value!r}"
            ) from None
    try:
        value = float(value)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"px_per_mm must be a positive number, got {shown(value)}") from None
    if not MIN_PX_PER_MM <= value <= MAX_PX_PER_MM:
        raise InputError(
            f"px_per_mm must be a number from {MIN_PX_PER_MM:g} to {MAX_PX_PER_MM:g} (or a "
            f"preset: {', '.join(SCALE_PRESETS)}), got {shown(value)}"
        )
    return value
