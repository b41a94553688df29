"""What a reader is told: its options, the length unit and scale, the frame rate.

Shared by the readers (through :mod:`thermoswarm.io._common`, which re-exports every
name): each checks its ``--read-option`` values with :func:`check_options` and the
``option_*`` helpers, turns the file's lengths into mm with :func:`length_scale`, and
takes its frame rate through :func:`check_fps`, :func:`require_fps` or
:func:`resolve_fps`.  Bad input is a one-line :class:`~thermoswarm.errors.InputError`
that names the file.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.errors import InputError

#: Millimetres per unit, for files that state their own length unit.
MM_PER_UNIT: dict[str, float] = {
    "mm": 1.0,
    "millimeter": 1.0,
    "millimetre": 1.0,
    "cm": 10.0,
    "centimeter": 10.0,
    "centimetre": 10.0,
    "m": 1000.0,
    "meter": 1000.0,
    "metre": 1000.0,
    "um": 1e-3,
    "micrometer": 1e-3,
    "micrometre": 1e-3,
}
#: Names that mean "pixels".
PIXEL_UNITS = ("px", "pixel", "pixels")

#: Seconds per unit of a time column.
SECONDS_PER_UNIT: dict[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "min": 60.0, "h": 3600.0}

#: Help of the ``duplicates`` reader option (long tables).
DUPLICATES_HELP = (
    'two different rows of one individual at one time: "error" (default), "first" or '
    '"mean"; exact duplicate rows are dropped and counted either way'
)

PX_HINT = "pass --px-per-mm (the paper's scale is --px-per-mm paper = 3.04 px/mm)"
FPS_HINT = "pass --fps"


def check_options(
    path: Path, fmt: str, options: Mapping[str, Any], accepted: Mapping[str, str]
) -> None:
    """Reject options that the reader of ``fmt`` does not know, listing those it does."""
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        known = ", ".join(sorted(accepted)) or "none"
        raise InputError(
            f"{path}: unknown option(s) {', '.join(unknown)} for format {fmt!r}; "
            f"it accepts: {known}"
        )


def option_str(path: Path, name: str, value: Any, choices: Sequence[str] | None = None) -> str:
    """A string option, optionally one of ``choices``."""
    if not isinstance(value, str):
        raise InputError(f"{path}: option {name} must be a string, got {value!r}")
    if choices is not None and value not in choices:
        raise InputError(
            f"{path}: option {name} must be one of {', '.join(choices)}, got {value!r}"
        )
    return value


def option_bool(path: Path, name: str, value: Any) -> bool:
    """A boolean option (``true``/``false`` on the command line)."""
    if isinstance(value, bool | np.bool_):
        return bool(value)
    raise InputError(f"{path}: option {name} must be true or false, got {value!r}")


def option_int(path: Path, name: str, value: Any, *, minimum: int | None = None) -> int:
    """An integer option."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise InputError(f"{path}: option {name} must be an integer, got {value!r}")
    if minimum is not None and value < minimum:
        raise InputError(f"{path}: option {name} must be >= {minimum}, got {value!r}")
    return int(value)


def option_positive(path: Path, name: str, value: Any) -> float:
    """A positive finite number option."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.number):
        raise InputError(f"{path}: option {name} must be a positive number, got {value!r}")
    value = float(value)
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"{path}: option {name} must be a positive number, got {value!r}")
    return value


def option_str_list(path: Path, name: str, value: Any) -> list[str]:
    """A list of strings (a single string is a list of one)."""
    if isinstance(value, str):
        return [value]
    if isinstance(value, list | tuple) and value and all(isinstance(v, str) for v in value):
        return list(value)
    raise InputError(f"{path}: option {name} must be a string or a list of strings, got {value!r}")


#: Frame rates (frames/s) a recording can have: one frame in 11.6 days to ten million
#: per second.  A rate outside makes times that are not a recording's (1e-300 frames/s
#: puts frame 1 at 1e300 s and overflows every step's speed).
FPS_RANGE = (1e-6, 1e7)


def check_fps(path: Path, fps: Any, what: str = "fps") -> float | None:
    """``None`` or a frame rate (1/s) within :data:`FPS_RANGE`.

    ``what`` names where the value came from in the error (``--fps``, a file's field).
    """
    if fps is None:
        return None
    try:
        value = float(fps)
    except (TypeError, ValueError):
        raise InputError(f"{path}: {what} must be a positive number, got {fps!r}") from None
    lo, hi = FPS_RANGE
    if not (math.isfinite(value) and lo <= value <= hi):
        raise InputError(
            f"{path}: {what} = {fps!r} is not a recording's frame rate; expected "
            f"{lo:g} to {hi:g} frames/s"
        )
    return value


def require_fps(path: Path, fps: float | None, what: str) -> float:
    """The frame rate, or an error saying that ``what`` has frame numbers only."""
    if fps is None:
        raise InputError(f"{path}: {what} has frame numbers but no times; {FPS_HINT}")
    return check_fps(path, fps, "--fps")  # type: ignore[return-value]


def require_px_per_mm(path: Path, px_per_mm: float | None, what: str) -> float:
    """The scale, or an error saying that ``what`` is in pixels."""
    if px_per_mm is None:
        raise InputError(f"{path}: {what} positions are in pixels; {PX_HINT}")
    return px_per_mm


def resolve_fps(path: Path, given: float | None, in_file: float | None, what: str) -> float | None:
    """The frame rate: ``--fps`` overrides the file's own (warning when they differ).

    A rate in the file outside :data:`FPS_RANGE` (0, negative, 1e-300, inf) is an
    error unless ``--fps`` replaces it; NaN counts as not recorded.
    """
    given = check_fps(path, given, "--fps")
    if in_file is not None and math.isnan(in_file):
        in_file = None
    if in_file is not None and given is None:
        in_file = check_fps(path, in_file, f"the frame rate stored by {what}")
    if given is not None:
        if in_file is not None and not math.isclose(given, in_file, rel_tol=1e-6):
            warnings.warn(
                f"{path}: --fps {given:g} overrides the frame rate {in_file:g} stored by {what}",
                stacklevel=3,
            )
        return given
    return in_file


def length_scale(
    path: Path,
    units: str | None,
    px_per_mm: float | None,
    what: str,
    *,
    from_file: bool = False,
) -> tuple[float, dict[str, Any]]:
    """Factor that turns the file's lengths into mm, and attrs recording the conversion.

    ``units`` is the length unit (``"px"``, ``"mm"``, ``"cm"``, ...) given by the user
    or, with ``from_file``, recorded in the file; ``None`` means unknown: then
    ``px_per_mm`` (pixels) is required.  A physical unit together with ``px_per_mm`` is
    a contradiction: an error when the user chose the unit, a warning (the scale is
    ignored) when the file records it.
    """
    if units is None:
        if px_per_mm is None:
            raise InputError(
                f"{path}: the length unit of {what} is not recorded; {PX_HINT} for pixels, "
                'or --read-option units="mm" (or "cm", "m") for physical units'
            )
        units = "px"
    key = units.strip().lower()
    if key in PIXEL_UNITS:
        scale = require_px_per_mm(path, px_per_mm, what)
        return 1.0 / scale, {"px_per_mm": scale, "source_space_unit": "px"}
    if key not in MM_PER_UNIT:
        known = ", ".join(["px", "mm", "cm", "m", "um"])
        raise InputError(f"{path}: unknown length unit {units!r}; expected one of {known}")
    if px_per_mm is not None:
        if from_file:
            warnings.warn(
                f"{path}: {what} records positions in {units}; --px-per-mm is ignored",
                stacklevel=3,
            )
        else:
            raise InputError(
                f"{path}: {what} positions are in {units}, not pixels; drop --px-per-mm "
                '(or pass --read-option units="px" if they really are pixels)'
            )
    factor = MM_PER_UNIT[key]
    return factor, {"source_space_unit": key} if factor != 1.0 else {}


def as_float_column(path: Path, values: Any, name: str) -> np.ndarray:
    """A numeric column as float64; a non-numeric entry is an error naming the column."""
    arr = np.asarray(values)
    if arr.dtype.kind in "fiu":
        return arr.astype(np.float64, copy=False)
    if arr.dtype.kind == "b":
        return arr.astype(np.float64)
    out = np.empty(arr.shape, dtype=np.float64)
    flat = arr.ravel()
    res = out.ravel()
    for i, v in enumerate(flat):
        if v is None or (isinstance(v, str) and v.strip() == ""):
            res[i] = np.nan
            continue
        try:
            res[i] = float(v)
        except (TypeError, ValueError):
            raise InputError(
                f"{path}: non-numeric value {str(v)[:40]!r} in column {name!r} (data row {i + 1})"
            ) from None
    return out


def option_duplicates(path: Path, options: Mapping[str, Any]) -> str:
    """The ``duplicates`` option (default ``"error"``)."""
    from thermoswarm.tracks import DUPLICATE_RULES

    return option_str(path, "duplicates", options.get("duplicates", "error"), DUPLICATE_RULES)
