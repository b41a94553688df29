"""Statistics that explain themselves: p-values at their resolution, trends stated only
when their test rejects, and one line on why a value departs from theory.

Every function returns text for a user (the CLI, ``report.html``, the reproduction
report); none computes a statistic.  Units are those of the caller.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = [
    "format_p_value",
    "trend_statement",
    "explain_phases",
    "explain_diffusion",
    "explain_departure",
]


def format_p_value(p: float | None, n_boot: int | None = None, *, digits: int = 2) -> str:
    """A p-value as text: ``"n/a"`` when missing, ``"< 1/(B+1)"`` at a bootstrap's floor.

    A bootstrap p-value is ``(1 + #{T* >= T}) / (B + 1)``: its smallest value
    ``1/(B+1)`` means "no replicate reached the observed statistic", so the p-value is
    only known to be below it (``"< 0.005"`` with B = 199), never "p = 0.005".
    """
    if p is None or not isinstance(p, int | float) or not math.isfinite(p):
        return "n/a"
    if n_boot:
        floor = 1.0 / (int(n_boot) + 1)
        if p <= floor * (1 + 1e-9):
            return f"< {floor:.2g}"
    return f"{p:.{digits}g}"


def trend_statement(trend: dict[str, Any], *, what: str = "kT_theta", against: str = "energy"):
    """``"kT_theta decreasing with energy (slope -0.012, p = 0.006, 8 bins)"`` when the
    slope test rejects at its level, else ``"no significant trend ..."``; the direction
    of a slope whose test does not reject is never stated."""
    if trend.get("slope") is None:
        return f"{what} against {against}: not tested ({trend.get('note', 'too few bins')})"
    p = trend.get("p_value")
    alpha = trend.get("alpha", 0.05)
    detail = f"slope {trend['slope']:.3g}, p = {format_p_value(p)}, {trend.get('k')} bins"
    if p is not None and p < alpha and trend.get("direction"):
        return f"{what} {trend['direction']} with {against} ({detail})"
    return f"{what}: no significant trend with {against} at {alpha:g} ({detail})"


def explain_phases(
    block: dict[str, Any],
    *,
    one_temperature: bool = False,
    rest_speed: float | None = None,
    mass: float | None = None,
) -> str | None:
    """One line on why two phases were preferred, or None.

    ``one_temperature``: the system was driven at a single temperature (a robot box):
    a second phase there comes from collisions, which stall robots (steps at nearly
    zero speed form a cold phase).  Otherwise, when the cold phase's rms speed
    ``sqrt(2 kT1)`` is at or below ``rest_speed`` (mm/s; e.g. the tracker's jitter),
    it is resting or jitter rather than a mode of motion; a cold phase more than five
    times slower than the hot one is said to be pausing or jitter.
    """
    if block.get("preferred") != "two_phase":
        return None
    two = block.get("two_phase", {})
    k1, k2 = two.get("kT1"), two.get("kT2")
    if one_temperature:
        return (
            "two phases preferred in a one-temperature system: collisions stall robots, "
            "and the stalled steps form a cold phase beside the driven one"
        )
    if k1 and k2 and k1 > 0:
        rms = (lambda k: math.sqrt(2 * k / mass) * 1e3) if mass else (lambda k: math.sqrt(2 * k))
        rms1, rms2 = rms(k1), rms(k2)
        if rest_speed is not None and rms1 <= rest_speed:
            return (
                f"the cold phase (rms speed {rms1:.3g} mm/s) is no faster than resting or "
                f"tracker jitter ({rest_speed:.3g} mm/s): it is a resting phase, not a "
                "mode of motion"
            )
        if rms1 < 0.2 * rms2:
            return (
                f"the cold phase (rms speed {rms1:.3g} mm/s) is far slower than the hot one "
                f"({rms2:.3g} mm/s): pausing animals, or the tracker's jitter while they "
                "stand, rather than a second way of walking"
            )
        return (
            f"two modes of motion (rms speeds {rms1:.3g} and {rms2:.3g} mm/s), or "
            "individuals that differ, mixed in the sample"
        )
    return None


def explain_departure(
    name: str,
    measured: float,
    theory: float,
    *,
    below: str,
    above: str,
    rel_tol: float = 0.1,
) -> str:
    """One line comparing a measured value with its theory, with the reason when it
    departs by more than ``rel_tol`` (``below`` / ``above``: why it would)."""
    if not (math.isfinite(measured) and math.isfinite(theory)) or theory == 0:
        return f"{name}: {measured:.4g} (theory {theory:.4g}; not comparable)"
    rel = measured / theory - 1.0
    head = f"{name} {measured:.4g} against {theory:.4g} in theory ({100 * rel:+.0f} %)"
    if abs(rel) <= rel_tol:
        return f"{head}: agrees within {100 * rel_tol:.0f} %"
    return f"{head}: {below if rel < 0 else above}"


def explain_diffusion(measured: float, theory: float, *, rel_tol: float = 0.1) -> str:
    """A diffusion coefficient against the free walker's: below theory when
    collisions and walls stop walkers; above when they persist in their heading longer
    than the theory assumes."""
    return explain_departure(
        "diffusion",
        measured,
        theory,
        below="below the free walker: collisions and walls stop walkers before they spread",
        above="above the free walker: headings persist longer than the theory assumes",
        rel_tol=rel_tol,
    )
