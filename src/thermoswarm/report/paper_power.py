"""The test, the sample and the smallest detectable effect of the paper comparison's
rows (:mod:`thermoswarm.report.paper`), as one clause of each row's ``why``; the numbers
come from :mod:`thermoswarm.report.power`."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from thermoswarm.report.paper_common import fmt
from thermoswarm.report.power import mde, mde_failure_rate, power_note


def _se_diff(a: Any, b: Any) -> float | None:
    """The standard error of a difference of two independent estimates."""
    return math.hypot(a, b) if a is not None and b is not None else None


def _z_power(iso: Sequence[Mapping[str, Any]]) -> str:
    """The mean Z's test: its standard error from the points' own (independent runs),
    the departure from 1 it detects."""
    ses = [r.get("Z_se") for r in iso]
    se = math.sqrt(sum(x * x for x in ses)) / len(ses) if ses and None not in ses else None
    return power_note(
        "the mean Z against 1 with its standard error (a threshold of 10 %, not a "
        "significance test)",
        f"{fmt(len(iso))} isotherm points, one run each",
        None if se is None else f"departure of the mean Z from 1: {fmt(mde(se), 2)}",
    )


def _r2_power(k: Any) -> str:
    """An R^2 threshold's sample and what it sees: residuals over 10 % of the spread."""
    return power_note(
        "a threshold on R^2 of a least-squares line (not a significance test)",
        f"{fmt(k)} points, one run each" if k else "points n/a",
        "departure from the line: residuals above sqrt(1 - 0.99) = 10 % of the points' "
        "spread (set by the threshold, not by the sample)",
        level=False,
    )


def _arrival_power(seeds: Any) -> str:
    """The rule "every run arrives": its seeds and the failure rate they would show."""
    f = mde_failure_rate(seeds)
    return power_note(
        "a count of the runs that arrive (every run must)",
        f"{fmt(seeds)} runs (seeds)",
        None if f is None else f"failure rate {fmt(100 * f, 2)} % (a failing run is "
        "among these with probability 0.8; at a lower rate, likely none is)",
        level=False,
    )  # fmt: skip


def _mean_power(se: Any, seeds: Any, what: str) -> str:
    """A mean over seeds against its standard error (above 2 se: a motion): the mean it
    detects."""
    return power_note(
        f"the mean {what} over seeds against its standard error",
        f"{fmt(seeds)} runs (seeds)",
        None if se is None else f"mean {what} {fmt(mde(se), 2)}",
    )


def _cells_power(rs: Sequence[Mapping[str, Any]], key: str, what: str, unit: str) -> str:
    """Per cell (a mean over seeds, its t interval): the range of the means they detect."""
    ms = [mde(r.get(key), df=r["seeds"] - 1) for r in rs
          if r.get(key) is not None and (r.get("seeds") or 0) > 1]  # fmt: skip
    ms = [m for m in ms if m is not None]
    seeds = sorted({r.get("seeds") for r in rs if r.get("seeds")})
    return power_note(
        f"t interval (95 %) of each cell's mean {what} over seeds",
        f"{'-'.join(fmt(x) for x in seeds[:: max(1, len(seeds) - 1)]) or 'n/a'} seeds a "
        f"cell, {fmt(len(rs))} cells",
        f"mean {what} {fmt(min(ms), 2)}-{fmt(max(ms), 2)} {unit} (by cell)" if ms else None,
    )
