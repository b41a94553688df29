"""What the fits leave out, and why: implausible motion and resting steps.

:func:`implausible_thresholds` sets the speed (mm/s) above which a step of each
individual is implausible (identity swaps, tracker glitches); :func:`excluded_summary`
gives the counts, the rule and the worst examples that ``fits.json`` and the report
show.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import xarray as xr

__all__ = [
    "STEP_CLASSES",
    "STEP_BUCKETS",
    "CODE",
    "IMPLAUSIBLE_QUANTILE",
    "IMPLAUSIBLE_SPREAD",
    "MIN_STEPS_FOR_SCALE",
    "implausible_thresholds",
    "excluded_summary",
]

#: ``step_class`` codes, in the order the buckets are checked (``-1``: no step).
STEP_CLASSES = (
    "missing_position",
    "time_gap",
    "static_track",
    "over_max_speed",
    "implausible",
    "resting",
    "stationary_dropped",
    "used",
)
#: The data-quality key of each bucket; their values sum to ``n_steps_total``.
STEP_BUCKETS = tuple(f"n_steps_{c}" for c in STEP_CLASSES)
CODE = {c: np.int8(i) for i, c in enumerate(STEP_CLASSES)}


#: Implausible motion (no body length given): a step is implausible when its speed
#: exceeds ``implausible_factor`` times the individual's robust speed scale, the
#: ``IMPLAUSIBLE_QUANTILE`` quantile of its measured, non-resting speeds, clipped to
#: [1, ``IMPLAUSIBLE_SPREAD``] times the median of all individuals' scales.  A high
#: quantile, not the median: a mostly resting animal's median moving speed is its
#: tracker's jitter.  The clip keeps a slow individual's threshold at the group's level
#: and catches an individual whose every step is a glitch.  Its upper end is wide (10):
#: among many static objects the tracker followed (debris, jitter-only tracks) the
#: median scale is the jitter's, and a narrow clip would cut a real animal's fast steps.
IMPLAUSIBLE_QUANTILE = 0.9


IMPLAUSIBLE_SPREAD = 10.0


#: Fewer measured moving steps than this: an individual's scale is the group's.
MIN_STEPS_FOR_SCALE = 10


def implausible_thresholds(
    speed: np.ndarray,
    candidate: np.ndarray,
    *,
    factor: float,
    body_length: float | None = None,
    max_body_lengths_per_s: float = 50.0,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Speed above which a step of each individual is implausible (mm/s), and the rule.

    ``speed`` ``(steps, individuals)``; ``candidate`` marks the measured steps that
    are not resting.  With a ``body_length`` (mm) the bound is
    ``max_body_lengths_per_s * body_length`` for everyone.  Otherwise individual
    ``i``'s scale ``s_i`` is the ``IMPLAUSIBLE_QUANTILE`` quantile of its candidate
    speeds (the group's when it has fewer than ``MIN_STEPS_FOR_SCALE``), ``S`` the
    median of the scales, and the threshold ``factor * clip(s_i, S,
    IMPLAUSIBLE_SPREAD * S)``.  Under one exponential energy law the 0.9 quantile of
    the speed is ``sqrt(2 kT ln 10)``, so a speed above 5 times it has probability
    ``10**-25``; with two phases whose temperatures differ by a factor ``r`` it is at
    most about ``10**(-25 / r)`` (``6e-7`` for ``r = 4``).
    """
    n_i = speed.shape[1]
    if body_length is not None:
        bound = float(max_body_lengths_per_s * body_length)
        rule = {
            "rule": "body length",
            "body_length_mm": float(body_length),
            "max_body_lengths_per_s": float(max_body_lengths_per_s),
            "threshold_mm_s": bound,
        }
        return np.full(n_i, bound), rule
    vals = np.where(candidate, speed, np.nan)
    n = candidate.sum(axis=0)
    scale = np.full(n_i, np.nan)
    enough = n >= MIN_STEPS_FOR_SCALE
    if enough.any():
        scale[enough] = np.nanquantile(vals[:, enough], IMPLAUSIBLE_QUANTILE, axis=0)
    finite = scale[np.isfinite(scale) & (scale > 0)]
    if finite.size:
        group = float(np.median(finite))
    else:
        pooled = speed[candidate]
        group = float(np.quantile(pooled, IMPLAUSIBLE_QUANTILE)) if pooled.size else np.nan
    if not (np.isfinite(group) and group > 0):
        return np.full(n_i, np.inf), {
            "rule": "robust",
            "note": "too few moving steps to set a scale: nothing flagged",
            "threshold_mm_s": None,
        }
    s = np.where(np.isfinite(scale) & (scale > 0), scale, group)
    thr = factor * np.clip(s, group, IMPLAUSIBLE_SPREAD * group)
    rule = {
        "rule": "robust",
        "quantile": IMPLAUSIBLE_QUANTILE,
        "factor": float(factor),
        "group_scale_mm_s": group,
        "threshold_mm_s": float(factor * group),
        "threshold_max_mm_s": float(factor * IMPLAUSIBLE_SPREAD * group),
        "description": (
            f"speed above {factor:g} x the individual's {IMPLAUSIBLE_QUANTILE:g}-quantile "
            f"of its moving speeds, that scale clipped to [1, {IMPLAUSIBLE_SPREAD:g}] x the "
            "median over individuals"
        ),
    }
    return thr, rule


def excluded_summary(kin: xr.Dataset, n_worst: int = 5) -> dict[str, Any]:
    """What the fits leave out, and why: implausible motion and resting steps.

    ``implausible``: the rule, the count, the individuals all of whose moving steps
    were implausible, and the ``n_worst`` fastest examples (individual, time, speed);
    ``resting``: count and fraction; ``statement``: one line for the output.
    """
    attrs = kin.attrs
    cls = kin["step_class"].values
    speed = kin["speed"].values
    t = kin["step_time"].values
    names = [str(v) for v in kin["individuals"].values]
    rule = json.loads(attrs.get("implausible_rule", "{}"))
    kept = bool(attrs.get("keep_implausible", 0))
    if kept:
        thr = kin["implausible_threshold"].values
        flag = np.isfinite(speed) & (speed > thr[None, :])
    else:
        flag = cls == CODE["implausible"]
    rows, cols = np.nonzero(flag)
    order = np.argsort(-speed[rows, cols], kind="stable")[:n_worst]
    worst = [
        {
            "individual": names[int(cols[j])],
            "time_s": float(t[rows[j], cols[j]]),
            "speed_mm_s": float(speed[rows[j], cols[j]]),
            "threshold_mm_s": float(kin["implausible_threshold"].values[cols[j]]),
        }
        for j in order
    ]
    moving = np.isin(cls, [CODE["implausible"], CODE["used"], CODE["stationary_dropped"]])
    whole = [
        names[i]
        for i in range(len(names))
        if flag[:, i].any() and (flag[:, i] | ~moving[:, i]).all() and not kept
    ]
    n_impl = int(flag.sum())
    n_rest = int(attrs.get("n_steps_resting", 0) or attrs.get("n_resting_kept", 0))
    frac = float(attrs.get("resting_fraction", 0.0))
    rest_kept = bool(attrs.get("keep_resting", 0))
    parts = []
    if n_impl:
        parts.append(
            f"{n_impl} implausible step(s) {'kept' if kept else 'left out'} "
            f"({rule.get('rule', '?')} rule"
            + (f", above {rule['threshold_mm_s']:.4g} mm/s" if rule.get("threshold_mm_s") else "")
            + ")"
        )
    if n_rest:
        parts.append(
            f"{n_rest} resting step(s) (speed <= {float(attrs.get('resting_speed', 0)):g} mm/s, "
            f"{100 * frac:.1f} % of measured steps) {'kept' if rest_kept else 'left out'}"
        )
    return {
        "implausible": {
            **rule,
            "n": n_impl,
            "excluded": not kept,
            "individuals_all_implausible": whole,
            "worst": worst,
        },
        "resting": {
            "n": n_rest,
            "fraction": frac,
            "resting_speed_mm_s": float(attrs.get("resting_speed", 0.0)),
            "excluded": not rest_kept,
        },
        "statement": "; ".join(parts) if parts else "no step left out as implausible or resting",
    }
