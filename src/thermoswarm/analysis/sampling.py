"""Which samples the tests see: autocorrelation time, thinning and a capped subsample.

Consecutive frames of a track are not independent: a tracked ant at 30 frames/s keeps
its speed for many frames.  A KS or likelihood-ratio test that treats ``n`` correlated
samples as independent has a false-rejection rate far above its nominal level, and
its cost grows with ``n`` while its information does not.  The tests of
:mod:`thermoswarm.analysis.study` therefore run on a *test sample*:

1. the autocorrelation ``rho(k)`` of the variable is estimated within tracks
   (deviations from each track's mean, pairs of valid samples ``k`` steps apart,
   pooled over tracks, by FFT);
2. the thinning step is the *decorrelation lag*: the first lag ``k >= 1`` at which
   ``rho(k) <= 0.05``;
3. each track is thinned to every ``k``-th step from a random offset per track;
4. if more than ``max_n`` samples remain, ``max_n`` of them are drawn at random without
   replacement.

Why not the integrated autocorrelation time ``tau = 1 + 2 sum rho(k)`` (also reported)?
Samples ``tau`` steps apart can still be strongly correlated (``exp(-2)`` for an
exponential decay, 20 % for a speed held for a few frames), and on short tracks its
estimate is biased low (the per-track mean removes ``tau / T`` from every lag, summed
over the window).  The decorrelation lag asks the question directly, at one lag: in a
calibration study (``tests/analysis/test_calibration.py``) with energies held for 5
frames, thinning by ``round(tau)`` gave 14 % false rejections at the 5 % level, the
decorrelation lag 5 %.

Every test reports its ``n`` (the test sample's size); the estimates (``kT``, ``phi``)
use all samples.  Differences *between* tracks are not removed by thinning; the
region comparison therefore resamples whole tracks (:mod:`thermoswarm.analysis.study`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.fft

__all__ = [
    "autocorrelation",
    "integrated_autocorr_time",
    "decorrelation_lag",
    "draw_test_sample",
    "DECORRELATION_THRESHOLD",
]


#: ``rho(k)`` at or below this is taken as decorrelated.
DECORRELATION_THRESHOLD = 0.05


def autocorrelation(values: np.ndarray, valid: np.ndarray, *, chunk: int = 128) -> np.ndarray:
    """Within-track autocorrelation ``rho(k)``, ``k = 0 .. n_time - 1``, pooled over tracks.

    Parameters
    ----------
    values, valid
        Arrays ``(time, individuals)``; pairs of samples ``k`` steps apart count when
        both are valid.  Each track's mean is removed first.
    chunk
        Individuals per FFT batch (bounds the memory).

    Returns
    -------
    ndarray
        ``rho`` with ``rho[0] = 1``; NaN at lags with no pair (and everywhere when the
        variance is zero or there are fewer than 3 valid samples).
    """
    values = np.asarray(values, dtype=np.float64)
    valid = np.asarray(valid, dtype=bool) & np.isfinite(values)
    if values.ndim == 1:
        values, valid = values[:, None], valid[:, None]
    n_t, n_i = values.shape
    if n_t < 2 or valid.sum() < 3:
        return np.full(max(n_t, 1), np.nan)
    # Tracks sorted by their last valid row and batched: each batch's FFT is only as
    # long as its longest track, so many short tracks beside one long one (fragmented
    # identities) cost their own length, not the longest track's.
    has = valid.any(axis=0)
    last = np.where(has, n_t - np.argmax(valid[::-1], axis=0), 0)
    order = np.argsort(last, kind="stable")
    order = order[has[order]]
    num = np.zeros(n_t)
    cnt = np.zeros(n_t)
    for j0 in range(0, order.size, chunk):
        cols = order[j0 : j0 + chunk]
        length = int(last[cols].max())
        nfft = scipy.fft.next_fast_len(2 * length, real=True)
        v = values[:length, cols]
        m = valid[:length, cols]
        counts = m.sum(axis=0)
        means = np.where(counts > 0, np.where(m, v, 0.0).sum(axis=0) / np.maximum(counts, 1), 0)
        d = np.where(m, v - means, 0.0)
        fd = scipy.fft.rfft(d, n=nfft, axis=0)
        num[:length] += scipy.fft.irfft(fd * fd.conj(), n=nfft, axis=0)[:length].sum(axis=1)
        fm = scipy.fft.rfft(m.astype(np.float64), n=nfft, axis=0)
        cnt[:length] += scipy.fft.irfft(fm * fm.conj(), n=nfft, axis=0)[:length].sum(axis=1)
    cnt = np.rint(cnt)
    if cnt[0] <= 0 or num[0] <= 0:
        return np.full(n_t, np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        gamma = np.where(cnt > 0, num / cnt, np.nan)
    return gamma / gamma[0]


def integrated_autocorr_time(
    values: np.ndarray, valid: np.ndarray, *, c: float = 5.0, rho: np.ndarray | None = None
) -> float:
    """Integrated autocorrelation time ``1 + 2 sum_k rho(k)`` in steps.

    Sokal's automatic window: the sum stops at the first lag ``M >= c tau(M)``.
    Returns ``tau >= 1`` (1 for independent samples), NaN when undefined.  ``rho``:
    a precomputed :func:`autocorrelation`.
    """
    if rho is None:
        rho = autocorrelation(values, valid)
    if rho.size == 0 or not np.isfinite(rho[0]):
        return float("nan")
    tau = 1.0
    for lag in range(1, rho.size):
        if not np.isfinite(rho[lag]):
            break
        tau += 2.0 * rho[lag]
        if lag >= c * tau:
            break
    return float(max(tau, 1.0))


def decorrelation_lag(
    values: np.ndarray,
    valid: np.ndarray,
    *,
    threshold: float = DECORRELATION_THRESHOLD,
    rho: np.ndarray | None = None,
) -> int:
    """First lag ``k >= 1`` with ``rho(k) <= threshold`` (the thinning step).

    1 when undefined (too few samples); the longest lag with pairs when ``rho`` never
    falls that low.
    """
    if rho is None:
        rho = autocorrelation(values, valid)
    if rho.size < 2 or not np.isfinite(rho[0]):
        return 1
    finite = np.isfinite(rho)
    below = np.nonzero(finite[1:] & (rho[1:] <= threshold))[0]
    if below.size:
        return int(below[0] + 1)
    lags = np.nonzero(finite)[0]
    return int(max(1, lags[-1]))


def draw_test_sample(
    values: np.ndarray,
    valid: np.ndarray,
    *,
    max_n: int | None = 10_000,
    thin: str | int = "auto",
    step: int | None = None,
    rng: np.random.Generator,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Thinned, capped subsample of ``values[valid]`` for the bootstrap tests.

    Parameters
    ----------
    values, valid
        Arrays ``(time, individuals)``.
    max_n
        Largest test sample (``None``: no cap).
    thin
        ``"auto"`` (the decorrelation lag of ``values``), or a step ``k >= 1``
        (1: no thinning).
    step
        With ``"auto"``: a decorrelation lag computed beforehand (e.g. on all samples
        when ``valid`` selects a group).
    rng
        Random offsets and the capped draw.

    Returns
    -------
    sample, info
        The samples (1-D) and ``{"n", "n_available", "thinning_step", "max_n"}``.
    """
    values = np.asarray(values)
    valid = np.asarray(valid, dtype=bool) & np.isfinite(values)
    if values.ndim == 1:
        values, valid = values[:, None], valid[:, None]
    n_available = int(valid.sum())
    if thin == "auto":
        if step is None:
            step = decorrelation_lag(values, valid)
        step = max(1, int(step))
    else:
        step = int(thin)
        if step < 1:
            raise ValueError(f"thin must be 'auto' or an integer >= 1, got {thin!r}")
    if step > 1:
        offsets = rng.integers(0, step, size=values.shape[1])
        rows = np.arange(values.shape[0])[:, None]
        keep = valid & ((rows - offsets[None, :]) % step == 0)
    else:
        keep = valid
    sample = values[keep]
    if max_n is not None and sample.size > max_n:
        sample = sample[np.sort(rng.choice(sample.size, int(max_n), replace=False))]
    info = {
        "n": int(sample.size),
        "n_available": n_available,
        "thinning_step": step,
        "max_n": max_n,
    }
    return np.asarray(sample, dtype=np.float64), info
