"""Each individual's samples before the steps: sorted, duplicates resolved, gaps
bridged, positions smoothed.

Arrays are ``(rows, individuals)``: column ``i`` holds individual ``i``'s samples in
time order from row 0 (times ``T`` in s, NaN after its last sample; positions ``X``,
``Y`` in mm, NaN where missing).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.signal import savgol_filter

from thermoswarm.errors import ConfigError
from thermoswarm.tracks import resolve_duplicates

__all__ = ["runs", "clean_columns", "interpolate_gaps", "smooth_positions"]


def runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Runs of True along axis 0 of ``mask (rows, individuals)``.

    Returns ``(individual, start, stop)`` arrays (``stop`` exclusive), ordered by
    individual then row.
    """
    n_t, n_i = mask.shape
    padded = np.zeros((n_i, n_t + 2), dtype=np.int8)
    padded[:, 1:-1] = mask.T
    d = np.diff(padded, axis=1)
    si, st = np.nonzero(d == 1)
    _, en = np.nonzero(d == -1)
    return si, st, en


def clean_columns(
    T: np.ndarray, X: np.ndarray, Y: np.ndarray, rule: str, names: list[str], src: str,
    counts: dict[str, Any], padded: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """Per individual: drop samples without a time, sort, resolve equal times.

    Returns padded ``(T, X, Y, input_row)``: column ``i`` holds individual ``i``'s
    samples in time order from row 0, NaN (``-1`` for rows) after its last.  With
    ``padded`` (per-individual clocks) a NaN time after an individual's last sample
    is padding, not a missing timestamp.
    """
    n_t, n_i = T.shape
    finite = np.isfinite(T)
    rows_all = np.broadcast_to(np.arange(n_t)[:, None], (n_t, n_i))
    with np.errstate(invalid="ignore"):
        d = np.diff(T, axis=0)
    both = finite[1:] & finite[:-1]
    # clean: every column's times finite up to its last sample, strictly increasing
    prefix = np.all(finite[1:] <= finite[:-1], axis=0)  # no sample after a missing time
    increasing = not np.any(both & ~(d > 0))
    if prefix.all() and increasing:
        # already clean: returned as given (a shared axis stays a read-only broadcast)
        return T, X, Y, np.where(finite, rows_all, -1)
    # Padding after an individual's last sample is not a missing timestamp
    last = np.where(finite.any(axis=0), n_t - 1 - np.argmax(finite[::-1], axis=0), -1)
    if not padded:
        last[:] = n_t - 1
    counts["n_missing_timestamps"] = int((~finite & (rows_all <= last[None, :])).sum())
    cols = []
    for i in range(n_i):
        keep = np.flatnonzero(finite[:, i])
        t = T[keep, i]
        counts["n_decreasing_timestamps"] += int((np.diff(t) < 0).sum())
        idx, vals, n_exact, n_conflict = resolve_duplicates(
            t,
            np.column_stack([X[keep, i], Y[keep, i]]),
            rule,
            describe=lambda _g, when, i=i: f"{src}: individual {names[i]!r} at time {when:.10g} s",
        )
        counts["n_duplicate_rows"] += n_exact
        counts["n_conflicting_duplicates"] += n_conflict
        cols.append((t[idx], vals[:, 0], vals[:, 1], keep[idx]))
    m = max((c[0].size for c in cols), default=0)
    T2 = np.full((m, n_i), np.nan)
    X2 = np.full((m, n_i), np.nan)
    Y2 = np.full((m, n_i), np.nan)
    R2 = np.full((m, n_i), -1, dtype=np.int64)
    for i, (t, x, y, r) in enumerate(cols):
        T2[: t.size, i], X2[: t.size, i], Y2[: t.size, i], R2[: t.size, i] = t, x, y, r
    return T2, X2, Y2, R2


def interpolate_gaps(T, X, Y, sample, max_gap, counts):
    """Fill missing positions inside tracks whose gap lasts at most ``max_gap`` s."""
    present = np.isfinite(X) & np.isfinite(Y)
    n_t = T.shape[0]
    idx = np.arange(n_t)[:, None]
    prev = np.maximum.accumulate(np.where(present, idx, -1), axis=0)
    nxt = np.minimum.accumulate(np.where(present, idx, n_t)[::-1], axis=0)[::-1]
    inside = sample & ~present & (prev >= 0) & (nxt < n_t)
    pc = np.clip(prev, 0, n_t - 1)
    nc = np.clip(nxt, 0, n_t - 1)
    cols = np.broadcast_to(np.arange(X.shape[1]), X.shape)
    tp, tn = T[pc, cols], T[nc, cols]
    with np.errstate(invalid="ignore"):
        fill = inside & (tn - tp <= max_gap)
    if fill.any():
        with np.errstate(invalid="ignore", divide="ignore"):
            w = np.where(fill, (T - tp) / np.where(fill, tn - tp, 1.0), 0.0)
        X = np.where(fill, X[pc, cols] + w * (X[nc, cols] - X[pc, cols]), X)
        Y = np.where(fill, Y[pc, cols] + w * (Y[nc, cols] - Y[pc, cols]), Y)
    counts["n_interpolated_positions"] = int(fill.sum())
    return X, Y


def _savgol(v: np.ndarray, window: int, polyorder: int) -> np.ndarray:
    return savgol_filter(v, window, polyorder, axis=0, mode="interp")


def smooth_positions(T, X, Y, link, med, smooth, polyorder, irregular, counts):
    """Savitzky-Golay smoothing of positions, segment by segment (``link``: the step
    from row k to k+1 joins one segment)."""
    windows = []
    for m in med:
        if not np.isfinite(m):
            windows.append(0)
            continue
        w = int(round(smooth / m))
        windows.append(w + 1 if w % 2 == 0 else w)
    ok_w = [w for w in windows if w > 0]
    if ok_w and min(ok_w) <= polyorder:
        m = float(med[int(np.argmin([w if w > 0 else 10**9 for w in windows]))])
        raise ConfigError(
            f"smoothing window {smooth:g} s is {min(ok_w)} samples at the median step "
            f"{m:g} s; it must exceed polyorder {polyorder}"
        )
    counts["smooth_window_samples"] = int(max(ok_w, default=0))
    present = np.isfinite(X) & np.isfinite(Y)
    starts = np.ones_like(present)
    starts[1:] = ~link
    si, st, en = runs(present)
    segments = []
    for i, s, e in zip(si.tolist(), st.tolist(), en.tolist(), strict=True):
        cuts = np.nonzero(starts[s + 1 : e, i])[0] + s + 1
        bounds = [s, *cuts.tolist(), e]
        segments.extend((i, a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True))
    counts["n_segments"] = len(segments)
    Xs, Ys = X.copy(), Y.copy()
    n_sm = n_rs = n_un = 0
    for i, a, b in segments:
        window = windows[i]
        length = b - a
        w = window if length >= window else (length if length % 2 else length - 1)
        if w <= polyorder:
            n_un += 1
            continue
        if irregular[a : b - 1, i].any():
            tt = T[a:b, i]
            n_grid = int(round((tt[-1] - tt[0]) / med[i])) + 1
            grid = np.linspace(tt[0], tt[-1], n_grid)  # about the median step, ends kept
            w = window if n_grid >= window else (n_grid if n_grid % 2 else n_grid - 1)
            if w <= polyorder:
                n_un += 1
                continue
            gx = _savgol(np.interp(grid, tt, X[a:b, i]), w, polyorder)
            gy = _savgol(np.interp(grid, tt, Y[a:b, i]), w, polyorder)
            Xs[a:b, i] = np.interp(tt, grid, gx)
            Ys[a:b, i] = np.interp(tt, grid, gy)
            n_rs += 1
        else:
            Xs[a:b, i] = _savgol(X[a:b, i], w, polyorder)
            Ys[a:b, i] = _savgol(Y[a:b, i], w, polyorder)
        n_sm += 1
    counts.update(n_segments_smoothed=n_sm, n_segments_resampled=n_rs, n_segments_unsmoothed=n_un)
    return Xs, Ys
