"""The steering-angle rate per energy (or speed) bin and the trend of its temperature.

``|steering rate|`` is exponential with temperature ``kT_theta`` (rad/s) per bin (the
one-sided law on the magnitude, sign random: PAPER_NOTES 6.4); per bin a fit, a
bootstrap KS test on a thinned test sample and a sign test; then ``kT_theta`` against
the bins' mean energy with a weighted least-squares trend (t-test of the slope, k - 2
degrees of freedom, residual scale estimated) and Spearman's rank correlation.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

from thermoswarm.analysis.fit import ExponentialFit, naive_ks
from thermoswarm.analysis.phase_tests import goodness_of_fit
from thermoswarm.analysis.phases import MIN_SAMPLES, dependence, test_sample_info
from thermoswarm.analysis.sampling import draw_test_sample

__all__ = ["TREND_ALPHA", "weighted_trend", "steering_block"]


def _spearman_p(x: np.ndarray, y: np.ndarray) -> float:
    """Two-sided p-value of Spearman's rho: exact (all orderings) for up to 9 bins."""
    rx = stats.rankdata(x)
    ry = stats.rankdata(y)

    def rho(r: np.ndarray, axis: int = -1) -> np.ndarray:
        a = rx - rx.mean()
        b = r - r.mean(axis=axis, keepdims=True)
        return (a * b).sum(axis=axis) / np.sqrt((a * a).sum() * (b * b).sum(axis=axis))

    exact = x.size <= 9
    res = stats.permutation_test(
        (ry,), rho, permutation_type="pairings", vectorized=True,
        n_resamples=np.inf if exact else 9999, alternative="two-sided",
        rng=np.random.default_rng(0),
    )  # fmt: skip
    return float(res.pvalue)


TREND_ALPHA = 0.05


def weighted_trend(xc: np.ndarray, y: np.ndarray, se: np.ndarray) -> dict[str, Any]:
    """WLS line ``y = a + b x`` (weights 1/se^2), t-test of ``b = 0``; Spearman's rho."""
    ok = np.isfinite(xc) & np.isfinite(y) & np.isfinite(se) & (se > 0)
    xc, y, se = xc[ok], y[ok], se[ok]
    k = int(xc.size)
    out: dict[str, Any] = {
        "model": "kT_theta = intercept + slope * energy_center (weighted least squares)",
        "k": k,
        "slope": None,
        "slope_se": None,
        "intercept": None,
        "t_statistic": None,
        "p_value": None,
        "spearman_rho": None,
        "spearman_p_value": None,
        "direction": None,
    }
    if k < 3:
        out["note"] = "fewer than 3 fitted bins"
        return out
    w = 1.0 / se**2
    X = np.column_stack([np.ones(k), xc])
    XtW = X.T * w
    cov_u = np.linalg.inv(XtW @ X)
    beta = cov_u @ (XtW @ y)
    resid = y - X @ beta
    s2 = float((w * resid**2).sum() / (k - 2))
    cov = cov_u * s2
    slope_se = math.sqrt(cov[1, 1]) if cov[1, 1] > 0 else float("nan")
    tstat = beta[1] / slope_se if slope_se > 0 else float("nan")
    p = float(2 * stats.t.sf(abs(tstat), k - 2)) if np.isfinite(tstat) else None
    rho = stats.spearmanr(xc, y)
    rho_p = _spearman_p(xc, y)
    out.update(
        slope=float(beta[1]),
        slope_se=slope_se,
        intercept=float(beta[0]),
        t_statistic=float(tstat),
        p_value=p,
        spearman_rho=float(rho.statistic),
        spearman_p_value=rho_p,
        # A direction is stated only when the slope test rejects at TREND_ALPHA.
        direction=(
            None
            if p is None or p >= TREND_ALPHA
            else ("decreasing" if beta[1] < 0 else "increasing")
        ),
        alpha=TREND_ALPHA,
        test="t-test of slope = 0 with k - 2 degrees of freedom, residual scale estimated",
    )
    return out


def _bin_edges(bins: int | tuple[float, ...], x: np.ndarray) -> np.ndarray:
    """Bin edges: ``bins`` quantile bins of the valid ``x`` (merged where quantiles
    coincide; one bin when all are equal), or the edges given."""
    if isinstance(bins, int):
        edges = np.quantile(x, np.linspace(0, 1, bins + 1))
        edges = np.unique(edges)
        if edges.size < 2:
            edges = np.array([x.min(), x.max() + 1e-12])
    else:
        edges = np.asarray(bins, dtype=float)
    return edges


def _bin_fit(
    b: int,
    edges: np.ndarray,
    m: np.ndarray,
    energy: np.ndarray,
    speed: np.ndarray,
    rate: np.ndarray,
    mag: np.ndarray,
    nonzero: np.ndarray,
    dep: dict[str, Any],
    rng: np.random.Generator,
    *,
    n_bootstrap: int,
    test_size: int | None,
    thin: str | int,
) -> tuple[dict[str, Any], ExponentialFit | None]:
    """Bin ``b`` (samples ``m``) of :func:`steering_block`: its centre, the exponential
    fit of the nonzero |rates| (rad/s), the bootstrap goodness of fit and the sign test
    on one thinned draw of signed rates; ``(entry, fit)``, fit None when the bin has
    fewer than :data:`MIN_SAMPLES` nonzero rates."""
    entry: dict[str, Any] = {
        "index": b,
        "low": float(edges[b]),
        "high": float(edges[b + 1]),
        "energy_center": float(energy[m].mean()) if m.any() else None,
        "speed_center": float(speed[m].mean()) if m.any() else None,
        "n_fit": int(m.sum()),
    }
    vals = mag[m]
    pos = vals[vals > 0]
    entry["n_zero"] = int(vals.size - pos.size)
    if pos.size < MIN_SAMPLES:
        entry.update(
            kT_theta=None, kT_theta_se=None, ks=None, p_value=None, n=int(pos.size),
            skipped=f"fewer than {MIN_SAMPLES} nonzero rates",
        )  # fmt: skip
        return entry, None
    fit = ExponentialFit().fit(pos)
    # one thinned draw of signed rates: magnitudes for the KS test, signs for the sign test
    ts, info = draw_test_sample(
        rate, m & nonzero, max_n=test_size, thin=thin, step=dep["decorrelation_lag"], rng=rng
    )
    if ts.size < MIN_SAMPLES:
        ts = rate[m & nonzero]
        info = {**info, "n": int(ts.size), "thinning_step": 1, "note": "too few to thin"}
    gof = goodness_of_fit("one_phase", np.abs(ts), n_bootstrap=n_bootstrap, random_state=rng)
    nks = naive_ks(pos, fit.law_)
    signs = rate[m][vals > 0]
    n_left = int((ts > 0).sum())
    sign_p = float(stats.binomtest(n_left, int(ts.size)).pvalue)
    entry.update(
        kT_theta=fit.kT_,
        kT_theta_se=fit.kT_se_,
        ks=gof.statistic,
        p_value=gof.p_value,
        n=gof.n,
        naive=dict(zip(("ks", "p_value", "n"), nks, strict=True)),
        fraction_positive=float((signs > 0).mean()),
        sign_p_value=sign_p,
        test_sample=test_sample_info(info, dep),
    )
    return entry, fit


def steering_block(
    kin: xr.Dataset,
    *,
    bins: int | tuple[float, ...],
    by: str,
    n_bootstrap: int,
    test_size: int | None,
    thin: str | int,
    seed: np.random.SeedSequence,
) -> tuple[dict[str, Any], dict[str, Any]]:
    rate = kin["steering_rate"].values
    ok = kin["steering_valid"].values & np.isfinite(rate)
    mag = np.abs(rate)
    xvar = kin["energy" if by == "energy" else "speed"].values
    ok &= np.isfinite(xvar)
    energy = kin["energy"].values
    speed = kin["speed"].values
    out: dict[str, Any] = {
        "by": by,
        "n": int(ok.sum()),
        "unit": "rad/s",
        "law": "|steering_rate| ~ Exponential(mean kT_theta), sign random (Laplace law)",
        "bins": [],
    }
    keep: dict[str, Any] = {"edges": None, "fits": [], "masks": []}
    if ok.sum() < MIN_SAMPLES:
        out["skipped"] = f"fewer than {MIN_SAMPLES} steering-rate samples ({int(ok.sum())})"
        out["trend"] = weighted_trend(np.array([]), np.array([]), np.array([]))
        return out, keep
    edges = _bin_edges(bins, xvar[ok])
    keep["edges"] = edges
    dep = dependence(mag, ok)
    out.update(dep)
    nonzero = ok & (mag > 0)
    codes = np.searchsorted(edges, xvar, side="right") - 1
    codes[xvar == edges[-1]] = edges.size - 2  # the last bin is closed on the right
    codes = np.where(ok & (codes >= 0) & (codes < edges.size - 1), codes, -1)
    keep["codes"] = codes
    children = seed.spawn(edges.size - 1)
    for b in range(edges.size - 1):
        m = codes == b
        rng = np.random.default_rng(children[b])
        entry, fit = _bin_fit(b, edges, m, energy, speed, rate, mag, nonzero, dep, rng,
                              n_bootstrap=n_bootstrap, test_size=test_size, thin=thin)  # fmt: skip
        out["bins"].append(entry)
        keep["fits"].append(fit)
        keep["masks"].append(m)
    centers = np.array([b["energy_center"] if b.get("kT_theta") else np.nan for b in out["bins"]])
    kts = np.array([b["kT_theta"] if b.get("kT_theta") else np.nan for b in out["bins"]])
    ses = np.array([b["kT_theta_se"] if b.get("kT_theta") else np.nan for b in out["bins"]])
    out["trend"] = weighted_trend(centers.astype(float), kts.astype(float), ses.astype(float))
    return out, keep
