"""The shared vocabulary of :mod:`thermoswarm.report.paper`: verdict words, number
formatting and the row builder (kept apart so that each experiment's comparison can
live in a module of its own)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

__all__ = ["REPRODUCED", "PARTLY", "DIFFERS", "NOT_MEASURED", "NOT_RESOLVED", "fmt"]

REPRODUCED, PARTLY, DIFFERS, NOT_MEASURED = "reproduced", "partly", "differs", "not measured"
#: A claim whose test lacks the power to decide with this run's sample (an unbounded
#: interval): more seeds (``reproduce --full``) resolve it.
NOT_RESOLVED = "not resolved at this scale"


def fmt(x: Any, nd: int = 3, unit: str = "") -> str:
    """A number for a table cell: ``nd`` significant digits, its unit, or an en dash."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "\u2013"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        text = f"{x:,}"
    elif abs(float(x)) >= 10**nd:  # 5,600 s, never 5.6e+03 s
        text = f"{float(x):,.0f}"
    else:
        text = format(float(x), f",.{nd}g")
    return f"{text} {unit}".strip()


def _get(d: Any, *keys: str, default: Any = None) -> Any:
    for k in keys:
        if not isinstance(d, Mapping) or k not in d:
            return default
        d = d[k]
    return d


def _row(claim: str, paper: str, ours: str, verdict: str, why: str) -> dict[str, str]:
    return {"claim": claim, "paper": paper, "ours": ours, "verdict": verdict, "why": why}


def _p(p: Any, n_bootstrap: Any = None) -> str:
    """``p = 0.03``, or ``p < 1/(B+1)`` at the resolution of a bootstrap of B replicates."""
    if p is None:
        return "p n/a"
    if n_bootstrap and p <= 1.02 / (n_bootstrap + 1):  # results.json rounds p
        floor = fmt(1 / (n_bootstrap + 1), 2)
        return f"p <= {floor} (the smallest p of {n_bootstrap} bootstrap replicates)"
    return f"p = {fmt(p, 2)}"
