"""Which samples the tests see: autocorrelation time, thinning and a capped subsample.

Consecutive frames of a track are not independent: a tracked ant at 30 frames/s keeps
its speed for many frames.  A KS or likelihood-ratio test that treats ``n`` correlated
samples as independent has a false-rejection rate far above its nominal level, and
its cost grows with ``n`` while its information does not.  The tests of
:mod:`thermoswarm.analysis.study` therefore run on a *test sample*:

1. the integrated autocorrelation time ``tau`` (in steps) of the variable is estimated
   within tracks (deviations from each track's mean, pooled over tracks, Sokal's
   automatic window with ``c = 5``);
2. each track is thinned to every ``k``-th step, ``k = max(1, round(tau))``, from a
   random offset per track;
3. if more than ``max_n`` samples remain, ``max_n`` of them are drawn at random without
   replacement.

Every test reports its ``n`` (the test sample's size); the estimates (``kT``, ``phi``)
use all samples.  Independence of the thinned samples is approximate (samples ``k``
steps apart still correlate by about ``exp(-1)`` for an exponential decay), and
differences *between* tracks are not removed by thinning; the region comparison
therefore resamples whole tracks (:mod:`thermoswarm.analysis.study`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.fft

__all__ = ["integrated_autocorr_time", "draw_test_sample"]


def integrated_autocorr_time(
    values: np.ndarray, valid: np.ndarray, *, c: float = 5.0, chunk: int = 128
) -> float:
    """Integrated autocorrelation time ``1 + 2 sum_k rho(k)`` in steps, pooled over tracks.

    Parameters
    ----------
    values, valid
        Arrays ``(time, individuals)``; only ``valid`` entries count.  Pairs of samples
        ``k`` steps apart are used when both are valid.
    c
        Sokal's window constant: the sum stops at the first lag ``M >= c tau(M)``.
    chunk
        Individuals per FFT batch (bounds the memory).

    Returns
    -------
    float
        ``tau >= 1`` (1 for independent samples); ``nan`` when fewer than 3 valid pairs.
    """
    values = np.asarray(values, dtype=np.float64)
    valid = np.asarray(valid, dtype=bool) & np.isfinite(values)
    if values.ndim == 1:
        values, valid = values[:, None], valid[:, None]
    n_t, n_i = values.shape
    if n_t < 3 or valid.sum() < 3:
        return float("nan")
    nfft = scipy.fft.next_fast_len(2 * n_t, real=True)
    num = np.zeros(n_t)
    cnt = np.zeros(n_t)
    for i0 in range(0, n_i, chunk):
        v = values[:, i0 : i0 + chunk]
        m = valid[:, i0 : i0 + chunk]
        counts = m.sum(axis=0)
        means = np.where(counts > 0, np.where(m, v, 0.0).sum(axis=0) / np.maximum(counts, 1), 0)
        d = np.where(m, v - means, 0.0)
        fd = scipy.fft.rfft(d, n=nfft, axis=0)
        num += scipy.fft.irfft(fd * fd.conj(), n=nfft, axis=0)[:n_t].sum(axis=1)
        fm = scipy.fft.rfft(m.astype(np.float64), n=nfft, axis=0)
        cnt += scipy.fft.irfft(fm * fm.conj(), n=nfft, axis=0)[:n_t].sum(axis=1)
    cnt = np.rint(cnt)
    ok = cnt > 0
    if not ok[0] or num[0] <= 0:
        return float("nan")
    gamma = np.where(ok, num / np.maximum(cnt, 1), 0.0)
    rho = gamma / gamma[0]
    tau = 1.0
    for lag in range(1, n_t):
        if not ok[lag]:
            break
        tau += 2.0 * rho[lag]
        if lag >= c * tau:
            break
    return float(max(tau, 1.0))


def draw_test_sample(
    values: np.ndarray,
    valid: np.ndarray,
    *,
    max_n: int | None = 10_000,
    thin: str | int = "auto",
    tau: float | None = None,
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
        ``"auto"`` (step ``round(tau)``), or a step ``k >= 1`` (1: no thinning).
    tau
        Integrated autocorrelation time to use with ``"auto"`` (estimated from
        ``values`` when omitted).
    rng
        Random offsets and the capped draw.

    Returns
    -------
    sample, info
        The samples (1-D) and ``{"n", "n_available", "tau_int", "thinning_step",
        "max_n"}``.
    """
    values = np.asarray(values)
    valid = np.asarray(valid, dtype=bool) & np.isfinite(values)
    if values.ndim == 1:
        values, valid = values[:, None], valid[:, None]
    n_available = int(valid.sum())
    if thin == "auto":
        if tau is None:
            tau = integrated_autocorr_time(values, valid)
        step = 1 if not np.isfinite(tau) else max(1, int(round(tau)))
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
        "tau_int": None if tau is None or not np.isfinite(tau) else float(tau),
        "thinning_step": step,
        "max_n": max_n,
    }
    return np.asarray(sample, dtype=np.float64), info
