"""What ``compression`` measures: pressure, area, ``kT_eff`` and ``Z`` with batch-means
standard errors from the sub-batch sums a run accumulates.

Private to :mod:`thermoswarm.scenarios.compression`, which re-exports :func:`measure`
and :func:`batch_means`; pure functions of arrays (batching:
``docs/scenarios_road_compression.md``).  Units: mm, s; forces in robot drag units.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from thermoswarm.errors import ConfigError

__all__ = ["batch_means", "measure"]


def batch_means(x: np.ndarray, w: np.ndarray, n_batches: int) -> np.ndarray:
    """Weighted means of ``x`` over ``n_batches`` consecutive, nearly equal batches.

    ``x`` are sub-batch means with weights ``w`` (e.g. the steps in each); a sub-batch
    is never split.
    """
    x = np.asarray(x, dtype=float)
    w = np.asarray(w, dtype=float)
    if n_batches < 1 or x.size < n_batches:
        raise ValueError(f"cannot make {n_batches} batches of {x.size} sub-batches")
    parts = np.array_split(np.arange(x.size), n_batches)
    return np.array([np.average(x[p], weights=w[p]) for p in parts])


def _mean_se(b: np.ndarray) -> tuple[float, float]:
    b = np.asarray(b, dtype=float)
    return float(b.mean()), float(b.std(ddof=1) / math.sqrt(b.size)) if b.size > 1 else math.nan


def _settled(
    used: np.ndarray,
    h: np.ndarray,
    t_end: np.ndarray,
    sub_s: float,
    d: float,
    settle: float | None,
    duration: float,
    expected_D: float,
) -> tuple[np.ndarray, float]:
    """The sub-batches kept after the settling time, and that time (s): ``settle``, or
    the shorter of a fifth of the run and three expected relaxation times (the first
    height's gap to one robot diameter over ``pi^2 expected_D``); a ConfigError when
    fewer than 2 remain."""
    # the expected relaxation time sets the default settling time
    h_guess = float(h[used][0]) - d if used.any() else 0.0
    t_relax_guess = max(h_guess, 0.0) ** 2 / (math.pi**2 * expected_D)
    settle_s = settle if settle is not None else min(duration / 5, 3 * t_relax_guess)
    keep = used & (t_end - sub_s >= settle_s - 1e-9)
    if keep.sum() < 2:
        raise ConfigError(
            f"duration {duration:g} s leaves fewer than 2 sub-batches after settle = "
            f"{settle_s:g} s; run longer"
        )
    return keep, settle_s


def _batch_estimates(
    x: dict[str, np.ndarray],
    wk: np.ndarray,
    nb: int,
    bv: np.ndarray,
    Lf: float,
    d: float,
    n: int,
    drag: float,
    tau: float,
) -> tuple[tuple[float, float], tuple[float, float], tuple[float, float]]:
    """Pressure, height and ``Z`` with their batch-means standard errors, from ``nb``
    batches of the kept sub-batches ``x`` (weights ``wk``; ``bv`` the batches' mean
    squared speeds; ``Lf`` the free width)."""
    bt = batch_means(x["f_top"], wk, nb)
    bb = batch_means(x["f_bot"], wk, nb)
    bh = batch_means(x["h"], wk, nb)
    P_b = 0.5 * (bt + bb) / Lf
    Af_b = Lf * (bh - d)
    kT_b = drag * bv * tau / 4
    Z_b = P_b * Af_b / (n * kT_b)
    return _mean_se(P_b), _mean_se(bh), _mean_se(Z_b)


def _plot_series(
    used: np.ndarray,
    t_end: np.ndarray,
    sub_s: float,
    w: np.ndarray,
    force: np.ndarray,
    h: np.ndarray,
    Lf: float,
) -> dict[str, list[float]]:
    """A short series for plots, at most ~500 points: time (s), pressure (mean wall
    ``force`` over the free width ``Lf``) and height (mm), sub-batches averaged."""
    k = max(1, math.ceil(int(used.sum()) / 500))
    idx = np.flatnonzero(used)
    groups = [idx[i : i + k] for i in range(0, idx.size, k)]
    return {
        "t": [float(t_end[g].mean() - sub_s / 2) for g in groups],
        "pressure": [float(np.average(force[g], weights=w[g]) / Lf) for g in groups],
        "height": [float(np.average(h[g], weights=w[g])) for g in groups],
    }


def measure(
    acc: dict[str, np.ndarray],
    *,
    sub_steps: int,
    dt: float,
    n: int,
    width: float,
    diameter: float,
    tau: float,
    drag: float,
    settle: float | None,
    duration: float,
    batch_relaxations: float,
    min_batches: int,
    expected_D: float,
) -> dict[str, Any]:
    """Pressure, area, ``kT_eff`` and ``Z`` with batch-means errors from the sub-batch sums
    of :meth:`Compression.observe` (batching: ``docs/scenarios_road_compression.md``)."""
    steps = acc["steps"].astype(float)
    used = steps > 0
    t_end = (np.arange(steps.size) + 1) * sub_steps * dt
    sub_s = sub_steps * dt
    w = np.where(used, steps, 0.0)
    safe = np.maximum(steps, 1)
    f_top = acc["f_top"] / safe
    f_bot = acc["f_bottom"] / safe
    h = acc["height"] / safe
    v2 = acc["v2"] / safe
    d = diameter
    keep, settle_s = _settled(used, h, t_end, sub_s, d, settle, duration, expected_D)
    x = {
        "f_top": f_top[keep],
        "f_bot": f_bot[keep],
        "h": h[keep],
        "v2": v2[keep],
    }
    wk = w[keep]
    window = float(wk.sum()) * dt
    v2m = float(np.average(x["v2"], weights=wk))
    D = v2m * tau / 4
    kT_eff = drag * D
    hm = float(np.average(x["h"], weights=wk))
    t_relax = max(hm - d, 0.0) ** 2 / (math.pi**2 * D)
    n_sub = int(keep.sum())
    want = max(1, int(window // max(batch_relaxations * t_relax, 1e-12)))
    nb = min(max(want, min_batches), n_sub)
    reliable = want >= min_batches and n_sub >= min_batches
    bv = batch_means(x["v2"], wk, nb)
    Lf = width - d
    (P, P_se), (H, H_se), (Z, Z_se) = _batch_estimates(x, wk, nb, bv, Lf, d, n, drag, tau)
    area = width * H
    series = _plot_series(used, t_end, sub_s, w, 0.5 * (f_top + f_bot), h, Lf)
    return {
        "pressure": P,
        "pressure_se": P_se,
        "pressure_top": float(np.average(x["f_top"], weights=wk)) / Lf,
        "pressure_bottom": float(np.average(x["f_bot"], weights=wk)) / Lf,
        "height": H,
        "height_se": H_se,
        "area": area,
        "area_se": width * H_se,
        "free_area": Lf * (H - d),
        "packing_fraction": n * math.pi * (d / 2) ** 2 / area,
        "density": n / area,
        "kT_eff": kT_eff,
        "kT_eff_se": drag * tau / 4 * _mean_se(bv)[1],
        "D": D,
        "Z": Z,
        "Z_se": Z_se,
        "t_relax": t_relax,
        "batch_s": window / nb,
        "n_batches": nb,
        "se_reliable": bool(reliable),
        "settle_s": float(settle_s),
        "window_s": window,
        "series": series,
    }
