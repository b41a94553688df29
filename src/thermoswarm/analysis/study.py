"""The paper's study of trajectories: energy phases, steering temperature, regions.

:func:`analyze_tracks` takes trajectories (any source) and returns the content of
``fits.json`` (documented key by key in ``docs/analysis.md``); :func:`run_study` also
returns the kinematics and the fitted objects (for figures and the report), and
:func:`analyze_file` reads a file and writes ``fits.json``, ``report.html`` and
``kinematics.nc``.

What is computed (PAPER_NOTES section 2):

energy
    One exponential against two (:func:`thermoswarm.analysis.fit.compare_phases`) on
    all valid steps; the bootstrap tests run on a test sample thinned by the energy's
    autocorrelation time and capped at ``test_size``
    (:mod:`thermoswarm.analysis.sampling`).
groups
    The same per group of steps: by a data variable's value (``--group-by NAME``), by
    time window (``time:SECONDS``) or by region (``region``).  Across the groups, the
    paper's paired t-test of one-phase against two-phase KS distances is reported,
    labelled descriptive.
steering
    ``|steering rate|`` is exponential (the one-sided law on the magnitude, sign
    random: PAPER_NOTES 6.4) with temperature ``kT_theta`` per energy (or speed) bin;
    per bin a fit, a bootstrap KS test and a sign test; then ``kT_theta`` against the
    bins' mean energy with a weighted least-squares trend (t-test of the slope, k - 2
    degrees of freedom, residual scale estimated) and Spearman's rank correlation.
regions
    The fraction of steps in the hot phase per region: the maximum-likelihood weight
    of the ``kT2`` component with both temperatures fixed at the overall two-phase fit
    (so regions differ only in how their steps split between the same two phases).
    Its uncertainty and the test of each difference resample whole tracks
    (clusters) with replacement, which keeps the dependence of a track's steps; each
    bootstrap replicate takes one Newton step from the estimate (a one-step
    bootstrap, first-order equivalent to refitting).  The naive Wald test that treats
    steps as independent is reported beside it, labelled.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

from thermoswarm import __version__
from thermoswarm.analysis.fit import (
    ExponentialFit,
    PhaseComparison,
    compare_phases,
    goodness_of_fit,
    naive_ks,
)
from thermoswarm.analysis.kinematics import compute_kinematics, data_quality, excluded_summary
from thermoswarm.analysis.regions import OUTSIDE, Region, assign_regions, load_regions
from thermoswarm.analysis.sampling import (
    autocorrelation,
    decorrelation_lag,
    draw_test_sample,
    integrated_autocorr_time,
)
from thermoswarm.errors import ConfigError, InputError
from thermoswarm.tracks import combine_tracks

__all__ = [
    "analyze_tracks",
    "run_study",
    "analyze_file",
    "StudyResult",
    "high_T_fraction",
    "parse_group_by",
    "parse_energy_bins",
]

#: Fewer valid samples than this in a group or bin: reported, not fitted.
MIN_SAMPLES = 20
#: Fewer tracks than this: the cluster bootstrap cuts tracks into time blocks.
MIN_CLUSTERS = 20

_KINEMATICS_KEYS = (
    "keypoint",
    "smooth",
    "polyorder",
    "min_speed",
    "max_speed",
    "gap_factor",
    "max_gap",
    "stationary_speed",
    "stationary_duration",
    "drop_stationary",
    "min_confidence",
    "regular_tolerance",
    "duplicates",
    "held_positions",
    "resting_speed",
    "keep_resting",
    "implausible_factor",
    "body_length",
    "max_body_lengths_per_s",
    "keep_implausible",
    "min_track_extent",
)


# --------------------------------------------------------------------------------------
# Options


@dataclass(frozen=True)
class GroupSpec:
    """One ``--group-by`` value: ``kind`` is ``"variable"``, ``"time"`` or ``"region"``."""

    text: str
    kind: str
    name: str = ""
    window: float = 0.0


def parse_group_by(spec: str) -> GroupSpec:
    """Parse ``NAME``, ``time:SECONDS`` or ``region``."""
    text = str(spec).strip()
    if not text:
        raise ConfigError("--group-by must be a variable name, 'time:SECONDS' or 'region'")
    if text == "region":
        return GroupSpec(text, "region")
    if text.startswith("time:"):
        try:
            w = float(text[5:])
        except ValueError:
            w = float("nan")
        if not (math.isfinite(w) and w > 0):
            raise ConfigError(
                f"--group-by {text!r}: the window must be a positive number of seconds, "
                "e.g. time:60"
            )
        return GroupSpec(text, "time", window=w)
    return GroupSpec(text, "variable", name=text)


def parse_energy_bins(value: Any) -> int | tuple[float, ...]:
    """An integer (equal-count bins) or increasing edges (``"0,5,10,20"`` or a list)."""
    if isinstance(value, str):
        parts = [p for p in re.split(r"[,\s]+", value.strip()) if p]
        if len(parts) == 1:
            value = parts[0]
            try:
                value = int(value)
            except ValueError:
                raise ConfigError(
                    f"--energy-bins must be a count or comma-separated edges, got {value!r}"
                ) from None
        else:
            try:
                value = [float(p) for p in parts]
            except ValueError:
                raise ConfigError(
                    f"--energy-bins edges must be numbers, got {','.join(parts)!r}"
                ) from None
    if isinstance(value, bool):
        raise ConfigError(f"energy_bins must be a count or a list of edges, got {value!r}")
    if isinstance(value, int | np.integer):
        if value < 1:
            raise ConfigError(f"energy_bins must be at least 1, got {value}")
        return int(value)
    try:
        edges = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise ConfigError(
            f"energy_bins must be a count or a list of edges, got {value!r}"
        ) from None
    if len(edges) < 2 or not all(math.isfinite(e) for e in edges):
        raise ConfigError(f"energy_bins edges must be at least 2 finite numbers, got {edges}")
    if any(b <= a for a, b in zip(edges[:-1], edges[1:], strict=True)):
        raise ConfigError(f"energy_bins edges must increase, got {edges}")
    return edges


def _check_options(
    n_bootstrap: Any, test_size: Any, thin: Any, alpha: Any, steering_by: Any
) -> tuple[int, int | None, str | int, float]:
    if isinstance(n_bootstrap, bool) or not isinstance(n_bootstrap, int | np.integer):
        raise ConfigError(f"n_bootstrap must be an integer >= 0, got {n_bootstrap!r}")
    if n_bootstrap < 0:
        raise ConfigError(f"n_bootstrap must be an integer >= 0, got {n_bootstrap!r}")
    if test_size is not None:
        if isinstance(test_size, bool) or not isinstance(test_size, int | np.integer):
            raise ConfigError(f"test_size must be an integer >= 20 or None, got {test_size!r}")
        if test_size < MIN_SAMPLES:
            raise ConfigError(f"test_size must be an integer >= 20 or None, got {test_size!r}")
    if thin != "auto":
        if isinstance(thin, bool) or not isinstance(thin, int | np.integer) or thin < 1:
            raise ConfigError(f"thin must be 'auto' or an integer >= 1, got {thin!r}")
    try:
        alpha = float(alpha)
    except (TypeError, ValueError):
        alpha = float("nan")
    if not 0 < alpha < 1:
        raise ConfigError(f"alpha must be in (0, 1), got {alpha!r}")
    if steering_by not in ("energy", "speed"):
        raise ConfigError(f"steering_by must be 'energy' or 'speed', got {steering_by!r}")
    return int(n_bootstrap), (None if test_size is None else int(test_size)), thin, alpha


# --------------------------------------------------------------------------------------
# Results


@dataclass
class StudyResult:
    """Everything :func:`run_study` computed.

    ``fits`` is the ``fits.json`` content; ``kinematics`` the per-step dataset (with a
    ``region`` variable when regions were given); the other fields keep the fitted
    objects for figures: ``energy`` (:class:`PhaseComparison`), ``groups``
    (``{spec: {"codes": (time, individuals) int array, "labels": [...], "fits":
    {label: PhaseComparison}}}``), ``steering`` (``{"edges", "codes", "fits": [...]}``),
    ``regions`` (list of :class:`Region`).
    """

    fits: dict[str, Any]
    kinematics: xr.Dataset
    energy: PhaseComparison | None = None
    groups: dict[str, dict[str, Any]] = field(default_factory=dict)
    steering: dict[str, Any] = field(default_factory=dict)
    regions: list[Region] = field(default_factory=list)


def _dependence(values: np.ndarray, valid: np.ndarray) -> dict[str, Any]:
    """Within-track dependence of a variable: decorrelation lag and tau (in steps)."""
    rho = autocorrelation(values, valid)
    tau = integrated_autocorr_time(values, valid, rho=rho)
    return {
        "decorrelation_lag": decorrelation_lag(values, valid, rho=rho),
        "tau_int": None if not np.isfinite(tau) else float(tau),
    }


def _test_sample_info(info: dict[str, Any], dep: dict[str, Any]) -> dict[str, Any]:
    out = {k: info[k] for k in ("n", "n_available", "thinning_step", "max_n")}
    out.update(dep)
    if "note" in info:
        out["note"] = info["note"]
    return out


def _phase_block(
    energy: np.ndarray,
    mask: np.ndarray,
    *,
    dep: dict[str, Any],
    n_bootstrap: int,
    test_size: int | None,
    thin: str | int,
    alpha: float,
    seed: np.random.SeedSequence,
) -> tuple[dict[str, Any], PhaseComparison | None]:
    """compare_phases on ``energy[mask]`` with a thinned test sample."""
    rng = np.random.default_rng(seed)
    x = energy[mask]
    n_pos = int((x > 0).sum())
    if n_pos < MIN_SAMPLES:
        return {
            "n": int(x.size),
            "skipped": f"fewer than {MIN_SAMPLES} positive energies ({n_pos})",
        }, None
    positive = mask & (energy > 0)
    tx, info = draw_test_sample(
        energy, positive, max_n=test_size, thin=thin, step=dep["decorrelation_lag"], rng=rng
    )
    reuse = info["thinning_step"] == 1 and info["n"] == info["n_available"]
    if not reuse and tx.size < MIN_SAMPLES:
        tx = None
        reuse = True
        info = {**info, "n": n_pos, "thinning_step": 1, "note": "too few to thin"}
    cmp_ = compare_phases(
        x,
        test_x=None if reuse else tx,
        n_bootstrap=n_bootstrap,
        alpha=alpha,
        random_state=rng,
    )
    out = cmp_.to_dict()
    out["test_sample"] = _test_sample_info(info, dep)
    return out, cmp_


# --------------------------------------------------------------------------------------
# Groups


def _group_codes(
    spec: GroupSpec,
    ds: xr.Dataset,
    kin: xr.Dataset,
    region_codes: np.ndarray | None,
    regions: Sequence[Region],
) -> tuple[np.ndarray, list[str]]:
    """Integer code per row ``(time, individuals)`` (-1: no group) and the labels."""
    n_t, n_i = kin.sizes["time"], kin.sizes["individuals"]
    if spec.kind == "region":
        if region_codes is None:
            raise ConfigError("--group-by region needs --regions FILE")
        labels = [r.name for r in regions]
        codes = region_codes.astype(np.int64)
        if (codes[kin["valid"].values] == OUTSIDE).any():
            labels = [*labels, "outside"]
            codes = np.where(codes == OUTSIDE, len(regions), codes)
        return codes, labels
    if spec.kind == "time":
        t = kin["step_time"].values
        w = spec.window
        t0 = float(np.nanmin(t))
        with np.errstate(invalid="ignore"):
            k = np.floor((t - t0) / w)
        finite = np.isfinite(k)
        used = np.unique(k[finite]).astype(np.int64)
        codes = np.full(t.shape, -1, dtype=np.int64)
        codes[finite] = np.searchsorted(used, k[finite].astype(np.int64))
        labels = [f"{t0 + w * j:g}-{t0 + w * (j + 1):g} s" for j in used.tolist()]
        return codes, labels
    name = spec.name
    if name not in ds.data_vars or name in ("position", "confidence"):
        options = [v for v in ds.data_vars if v not in ("position", "confidence")]
        raise ConfigError(
            f"--group-by {name!r}: no such data variable (the input has "
            f"{options or 'none'}); use a variable name, 'time:SECONDS' or 'region'"
        )
    var = ds[name]
    if not set(var.dims) <= {"time", "individuals"} or var.ndim == 0:
        raise ConfigError(
            f"--group-by {name!r}: the variable has dims {var.dims}; expected (time), "
            "(individuals) or (time, individuals)"
        )
    var = var.transpose(*[d for d in ("time", "individuals") if d in var.dims])
    values = var.values
    rows = kin["input_row"].values  # (time, individuals); -1: no sample
    cols = np.broadcast_to(np.arange(n_i)[None, :], (n_t, n_i))
    safe = np.maximum(rows, 0)
    if "time" in var.dims and "individuals" in var.dims:
        values = values[safe, cols]
    elif "time" in var.dims:
        values = values[safe]
    else:
        values = np.broadcast_to(values[None, :], (n_t, n_i))
    flat = values.ravel()
    if flat.dtype.kind == "f":
        missing = ~np.isfinite(flat)
    elif flat.dtype.kind in "OUS":
        flat = flat.astype(str)
        missing = np.isin(flat, ["", "None", "nan", "NaN"])
    else:
        missing = np.zeros(flat.shape, dtype=bool)
    missing |= (rows < 0).ravel()  # rows after an individual's last sample
    keys = flat[~missing]
    uniq, inv = np.unique(keys, return_inverse=True)
    if uniq.size > 100:
        raise ConfigError(
            f"--group-by {name!r}: {uniq.size} distinct values; group-by needs a categorical "
            "variable (at most 100 values)"
        )
    codes = np.full(flat.shape, -1, dtype=np.int64)
    codes[~missing] = inv
    labels = [f"{v:g}" if isinstance(v, float | np.floating) else str(v) for v in uniq.tolist()]
    return codes.reshape(n_t, n_i), labels


def _ks_comparison(levels: dict[str, dict[str, Any]]) -> dict[str, Any]:
    fitted = {k: v for k, v in levels.items() if "one_phase" in v}
    ks1 = [v["one_phase"]["naive"]["ks"] for v in fitted.values()]
    ks2 = [v["two_phase"]["naive"]["ks"] for v in fitted.values()]
    out: dict[str, Any] = {
        "labels": list(fitted),
        "ks_one_phase": ks1,
        "ks_two_phase": ks2,
        "method": (
            "paired t-test (scipy.stats.ttest_rel) of the naive KS distances of the one- "
            "and two-phase fits across groups, as in the paper; descriptive only: the "
            "two-phase law nests the one-phase law, so its KS is smaller by construction; "
            "use each group's lr_p_value to test the number of phases"
        ),
        "t_statistic": None,
        "p_value": None,
    }
    if len(ks1) >= 2 and np.std(np.subtract(ks1, ks2)) > 0:
        res = stats.ttest_rel(ks1, ks2)
        out["t_statistic"] = float(res.statistic)
        out["p_value"] = float(res.pvalue)
    return out


# --------------------------------------------------------------------------------------
# Steering


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


def _weighted_trend(xc: np.ndarray, y: np.ndarray, se: np.ndarray) -> dict[str, Any]:
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


def _steering_block(
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
        out["trend"] = _weighted_trend(np.array([]), np.array([]), np.array([]))
        return out, keep
    if isinstance(bins, int):
        edges = np.quantile(xvar[ok], np.linspace(0, 1, bins + 1))
        edges = np.unique(edges)
        if edges.size < 2:
            edges = np.array([xvar[ok].min(), xvar[ok].max() + 1e-12])
    else:
        edges = np.asarray(bins, dtype=float)
    keep["edges"] = edges
    dep = _dependence(mag, ok)
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
            out["bins"].append(entry)
            keep["fits"].append(None)
            keep["masks"].append(m)
            continue
        fit = ExponentialFit().fit(pos)
        # one thinned draw of signed rates: magnitudes for the KS test, signs for the
        # sign test
        ts, info = draw_test_sample(
            rate,
            m & nonzero,
            max_n=test_size,
            thin=thin,
            step=dep["decorrelation_lag"],
            rng=rng,
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
            test_sample=_test_sample_info(info, dep),
        )
        out["bins"].append(entry)
        keep["fits"].append(fit)
        keep["masks"].append(m)
    centers = np.array([b["energy_center"] if b.get("kT_theta") else np.nan for b in out["bins"]])
    kts = np.array([b["kT_theta"] if b.get("kT_theta") else np.nan for b in out["bins"]])
    ses = np.array([b["kT_theta_se"] if b.get("kT_theta") else np.nan for b in out["bins"]])
    out["trend"] = _weighted_trend(centers.astype(float), kts.astype(float), ses.astype(float))
    return out, keep


# --------------------------------------------------------------------------------------
# Regions


def _score(x: np.ndarray, w: float, k1: float, k2: float) -> np.ndarray:
    """Per-sample score ``d/dw log((1-w) p1 + w p2)`` for fixed exponential components."""
    L = math.log(k1 / k2) + x * (1.0 / k1 - 1.0 / k2)  # log p2/p1
    u = np.exp(-np.abs(L))
    with np.errstate(divide="ignore", invalid="ignore"):
        pos = (1.0 - u) / ((1.0 - w) * u + w)
        neg = (u - 1.0) / ((1.0 - w) + w * u)
    return np.where(L > 0, pos, neg)


def high_T_fraction(x: np.ndarray, kT1: float, kT2: float) -> tuple[float, float]:
    """Maximum-likelihood weight ``w`` of the hot component ``Exp(kT2)`` with both
    temperatures fixed, and its standard error for independent samples.

    Maximises ``sum log((1 - w) p1(x) + w p2(x))`` over ``w`` in [0, 1] (concave).
    """
    x = np.asarray(x, dtype=np.float64)
    if x.size == 0:
        return float("nan"), float("nan")
    if _score(x, 0.0, kT1, kT2).sum() <= 0:
        w = 0.0
    elif _score(x, 1.0, kT1, kT2).sum() >= 0:
        w = 1.0
    else:
        lo, hi = 0.0, 1.0
        w = float(np.clip(0.5, lo, hi))
        for _ in range(100):
            s = _score(x, w, kT1, kT2)
            u = float(s.sum())
            info = float((s * s).sum())
            if u > 0:
                lo = w
            else:
                hi = w
            step = u / info if info > 0 else 0.0
            w_new = w + step
            if not lo < w_new < hi:
                w_new = 0.5 * (lo + hi)
            if abs(w_new - w) < 1e-12:
                w = w_new
                break
            w = w_new
    s = _score(x, w, kT1, kT2)
    info = float((s * s).sum())
    se = 1.0 / math.sqrt(info) if info > 0 else float("nan")
    return float(w), se


def _clusters(valid: np.ndarray) -> tuple[np.ndarray, int, str]:
    """Cluster id per row (tracks, or time blocks of them when there are few)."""
    n_t, n_i = valid.shape
    used = np.nonzero(valid.any(axis=0))[0]
    ind = np.broadcast_to(np.arange(n_i)[None, :], (n_t, n_i))
    if used.size >= MIN_CLUSTERS:
        return ind.copy(), n_i, "tracks"
    n_blocks = math.ceil(MIN_CLUSTERS / max(used.size, 1))
    block = np.minimum(np.arange(n_t) * n_blocks // n_t, n_blocks - 1)
    ids = ind * n_blocks + block[:, None]
    return ids, n_i * n_blocks, f"{n_blocks} contiguous time blocks of each of {used.size} tracks"


def _regions_block(
    kin: xr.Dataset,
    codes: np.ndarray,
    regions: Sequence[Region],
    two_phase: PhaseComparison | None,
    *,
    n_bootstrap: int,
    alpha: float,
    seed: np.random.SeedSequence,
    source: str | None,
) -> dict[str, Any]:
    energy = kin["energy"].values
    valid = kin["valid"].values & np.isfinite(energy) & (energy > 0)
    out: dict[str, Any] = {
        "source": source,
        "assignment": "step midpoint (x_mid, y_mid); first region in file order",
        "polygons": {r.name: r.to_dict() for r in regions},
        "n_outside": int((valid & (codes == OUTSIDE)).sum()),
        "levels": {},
        "differences": [],
    }
    levels = out["levels"]
    for k, reg in enumerate(regions):
        m = valid & (codes == k)
        x = energy[m]
        levels[reg.name] = {
            "n": int(x.size),
            "n_tracks": int(m.any(axis=0).sum()),
            "mean_energy": float(x.mean()) if x.size else None,
            "kT_one_phase": float(x.mean()) if x.size else None,
        }
    mix = None if two_phase is None else two_phase.two
    if mix is None or mix.degenerate_:
        out["high_T_fraction_note"] = (
            "no two-phase fit of all energies (too few samples, or the mixture collapsed "
            "onto one exponential): the hot-phase fraction is undefined"
        )
        return out
    k1, k2 = mix.kT1_, mix.kT2_
    out["phases"] = {"kT1": k1, "kT2": k2, "overall_high_T_fraction": 1.0 - mix.phi_}
    cl, n_cl, cl_desc = _clusters(valid)
    out["bootstrap"] = {
        "clusters": cl_desc,
        "n_bootstrap": n_bootstrap,
        "method": (
            "clusters resampled with replacement; one Newton step from the estimate per "
            "replicate (one-step bootstrap); p-value two-sided from the bootstrap "
            "standard error (normal approximation)"
        ),
    }
    names = [r.name for r in regions]
    est: dict[str, float] = {}
    sums1 = np.zeros((n_cl, len(regions)))
    sums2 = np.zeros((n_cl, len(regions)))
    for k, name in enumerate(names):
        m = valid & (codes == k)
        lev = levels[name]
        if lev["n"] < MIN_SAMPLES:
            lev.update(high_T_fraction=None, se_naive=None, se=None, ci_low=None, ci_high=None)
            lev["skipped"] = f"fewer than {MIN_SAMPLES} samples"
            continue
        w, se_naive = high_T_fraction(energy[m], k1, k2)
        est[name] = w
        s = _score(energy[m], w, k1, k2)
        sums1[:, k] = np.bincount(cl[m], weights=s, minlength=n_cl)
        sums2[:, k] = np.bincount(cl[m], weights=s * s, minlength=n_cl)
        lev.update(high_T_fraction=w, se_naive=se_naive, se=None, ci_low=None, ci_high=None)
    if n_bootstrap > 0 and est:
        rng = np.random.default_rng(seed)
        reps = np.full((n_bootstrap, len(regions)), np.nan)
        counts = rng.multinomial(n_cl, np.full(n_cl, 1.0 / n_cl), size=n_bootstrap).astype(float)
        u = counts @ sums1
        info = counts @ sums2
        for k, name in enumerate(names):
            if name not in est:
                continue
            with np.errstate(divide="ignore", invalid="ignore"):
                step = np.where(info[:, k] > 0, u[:, k] / info[:, k], np.nan)
            reps[:, k] = np.clip(est[name] + step, 0.0, 1.0)
            r = reps[:, k][np.isfinite(reps[:, k])]
            if r.size > 1:
                lev = levels[name]
                lev["se"] = float(r.std(ddof=1))
                lev["ci_low"], lev["ci_high"] = (
                    float(v) for v in np.quantile(r, [alpha / 2, 1 - alpha / 2])
                )
    else:
        reps = None
    for a in range(len(names)):
        for b in range(a + 1, len(names)):
            na, nb = names[a], names[b]
            if na not in est or nb not in est:
                continue
            diff = est[na] - est[nb]
            se_n = math.hypot(levels[na]["se_naive"], levels[nb]["se_naive"])
            entry: dict[str, Any] = {
                "a": na,
                "b": nb,
                "difference": diff,
                "se": None,
                "ci_low": None,
                "ci_high": None,
                "p_value": None,
                "se_naive": se_n,
                "p_value_naive": float(2 * stats.norm.sf(abs(diff) / se_n)) if se_n > 0 else None,
            }
            if reps is not None:
                d = reps[:, a] - reps[:, b]
                d = d[np.isfinite(d)]
                if d.size > 1:
                    se = float(d.std(ddof=1))
                    entry["se"] = se
                    entry["ci_low"], entry["ci_high"] = (
                        float(v) for v in np.quantile(d, [alpha / 2, 1 - alpha / 2])
                    )
                    entry["p_value"] = (
                        float(2 * stats.norm.sf(abs(diff) / se))
                        if se > 0
                        else (0.0 if diff != 0 else 1.0)
                    )
            out["differences"].append(entry)
    return out


# --------------------------------------------------------------------------------------
# Plausibility of the fitted temperatures


def plausibility(
    block: dict[str, Any],
    kin: xr.Dataset,
    *,
    mass: float | None,
    max_plausible_speed: float | None,
) -> dict[str, Any]:
    """Whether each fitted temperature describes motion the animal can make.

    A temperature ``kT`` (per unit mass) is the mean energy ``<v^2>/2`` of its phase,
    so its root-mean-square speed is ``sqrt(2 kT)`` (``sqrt(2 kT / m)`` with a mass).
    The bound: ``max_plausible_speed`` (mm/s) when given (the animal's top speed),
    otherwise the implausible-motion threshold of the kinematics -- a phase whose
    typical speed is one that the data's own rule calls a tracking glitch describes
    glitches, not the animal.
    """
    rule = json.loads(kin.attrs.get("implausible_rule", "{}"))
    if max_plausible_speed is not None:
        bound = float(max_plausible_speed)
        source = "max_plausible_speed (the animal's top speed, given)"
    elif rule.get("threshold_mm_s"):
        bound = float(rule["threshold_mm_s"])
        source = f"implausible-motion threshold ({rule.get('rule')} rule)"
    else:
        bound, source = None, "none (no moving steps to set a scale)"
    temps: dict[str, dict[str, Any]] = {}
    if "one_phase" in block:
        named = [("kT", block["one_phase"].get("kT"))]
        if not block["two_phase"].get("degenerate"):
            named += [
                ("kT1", block["two_phase"].get("kT1")),
                ("kT2", block["two_phase"].get("kT2")),
            ]
        for name, kt in named:
            if kt is None or not np.isfinite(kt) or kt <= 0:
                continue
            rms = math.sqrt(2.0 * kt / mass) * 1e3 if mass else math.sqrt(2.0 * kt)
            temps[name] = {
                "value": kt,
                "rms_speed_mm_s": rms,
                "plausible": None if bound is None else bool(rms <= bound),
            }
    bad = [k for k, v in temps.items() if v["plausible"] is False]
    out: dict[str, Any] = {
        "bound_mm_s": bound,
        "bound_source": source,
        "rule": "a phase is plausible when its rms speed sqrt(2 kT) is at most the bound",
        "temperatures": temps,
        "all_plausible": None if bound is None else not bad,
    }
    if bad:
        out["warning"] = (
            f"implausible temperature(s) {', '.join(bad)}: rms speed "
            + ", ".join(f"{temps[k]['rms_speed_mm_s']:.4g}" for k in bad)
            + f" mm/s above {bound:.4g} mm/s ({source}); the fit describes tracking errors "
            "or mixes animals; check the frame rate, the units, identities and --max-speed"
        )
    return out


# --------------------------------------------------------------------------------------
# The study


def run_study(
    ds: xr.Dataset,
    *,
    fps: float | None = None,
    mass: float | None = None,
    regions: Sequence[Region] | str | os.PathLike | None = None,
    group_by: Sequence[str] | str = (),
    energy_bins: int | Sequence[float] | str = 8,
    steering_by: str = "energy",
    n_bootstrap: int = 200,
    test_size: int | None = 10_000,
    thin: str | int = "auto",
    alpha: float = 0.05,
    seed: int | None = 0,
    max_plausible_speed: float | None = None,
    progress: Callable[[str], None] | None = None,
    **kinematics_options: Any,
) -> StudyResult:
    """Run the whole study on trajectories ``ds``.

    Parameters
    ----------
    ds
        Trajectories in the format of :mod:`thermoswarm.tracks` (mm).
    fps
        Frame rate for frame-numbered data.
    mass
        kg; energies in J (default: per unit mass, mm^2/s^2).
    regions
        Regions (list, or a TOML file: :mod:`thermoswarm.analysis.regions`).
    group_by
        Group specs: a data variable's name, ``time:SECONDS`` or ``region``.
    energy_bins
        Steering bins: a count (equal-count bins of ``steering_by``) or edges (in the
        energy unit, or mm/s for speed).
    steering_by
        ``"energy"`` or ``"speed"``.
    n_bootstrap
        Bootstrap replicates of every bootstrap test (0: none; p-values are ``None``
        and the preferred model is chosen by BIC).
    test_size
        Largest test sample (``None``: no cap); see
        :mod:`thermoswarm.analysis.sampling`.
    thin
        ``"auto"`` or a thinning step (1: none).
    alpha
        Level of the LR test that picks the preferred model, and of the intervals.
    seed
        Seed of every random draw (same seed, same output).
    max_plausible_speed
        The animal's top speed (mm/s) for the plausibility of the fitted temperatures
        (:func:`plausibility`); default: the implausible-motion threshold.
    progress
        Called with a short message at each stage.
    **kinematics_options
        Passed to :func:`thermoswarm.analysis.kinematics.compute_kinematics`
        (``smooth``, ``min_speed``, ``max_speed``, ``gap_factor``, ``max_gap``,
        ``duplicates``, ``resting_speed``, ``body_length``, ...).

    Raises :class:`InputError` when no step is left to fit (every step missing, a
    gap, resting or implausible): the message gives the counts.
    """
    unknown = [k for k in kinematics_options if k not in _KINEMATICS_KEYS]
    if unknown:
        raise ConfigError(
            f"unknown analysis option {unknown[0]!r}; expected one of: "
            + ", ".join(sorted(_KINEMATICS_KEYS))
        )
    n_bootstrap, test_size, thin, alpha = _check_options(
        n_bootstrap, test_size, thin, alpha, steering_by
    )
    bins = parse_energy_bins(energy_bins)
    if isinstance(group_by, str):
        group_by = [group_by]
    specs = [parse_group_by(g) for g in group_by]
    if len({s.text for s in specs}) != len(specs):
        raise ConfigError("--group-by: the same grouping is given twice")
    region_source = None
    if regions is not None and not isinstance(regions, list | tuple):
        region_source = str(regions)
        regions = load_regions(regions)
    regions = list(regions or [])
    if any(s.kind == "region" for s in specs) and not regions:
        raise ConfigError("--group-by region needs --regions FILE")
    say = progress or (lambda msg: None)
    root = np.random.SeedSequence(seed)
    s_energy, s_steer, s_regions, s_groups = root.spawn(4)

    if max_plausible_speed is not None:
        mp = float(max_plausible_speed)
        if not (math.isfinite(mp) and mp > 0):
            raise ConfigError(f"max_plausible_speed must be a positive number, got {mp!r}")
    say("kinematics")
    kin = compute_kinematics(ds, fps=fps, mass=mass, **kinematics_options)
    energy = kin["energy"].values
    valid = kin["valid"].values & np.isfinite(energy)
    if not valid.any():
        dq = data_quality(kin)
        buckets = ", ".join(
            f"{v} {k.replace('_', ' ')}" for k, v in dq["step_buckets"].items() if v
        )
        src = ds.attrs.get("source_file", "the input")
        raise InputError(
            f"{src}: no step left to fit ({dq['n_steps_total']} steps: {buckets or 'none'}); "
            "see --keep-resting, --keep-implausible, --gap-factor, --max-gap"
        )
    region_codes = None
    if regions:
        region_codes = assign_regions(regions, kin["x_mid"].values, kin["y_mid"].values)
        kin["region"] = (
            ("time", "individuals"),
            region_codes,
            {"names": ",".join(r.name for r in regions), "outside": OUTSIDE},
        )
    # Group labels before any fitting, so that a bad --group-by fails at once.
    group_codes = {spec.text: _group_codes(spec, ds, kin, region_codes, regions) for spec in specs}
    e_unit = kin.attrs["energy_unit"]
    tracks_used = int(valid.any(axis=0).sum())
    fits: dict[str, Any] = {
        "schema": "thermoswarm.analysis/1",
        "thermoswarm_version": __version__,
        "source_file": ds.attrs.get("source_file"),
        "n_tracks": tracks_used,
        "n_samples": int(valid.sum()),
        "units": {
            "energy": e_unit,
            "speed": "mm/s",
            "steering_rate": "rad/s",
            "kT_theta": "rad/s",
            "time": "s",
            "position": "mm",
        },
        "settings": {
            "fps": fps,
            "mass_kg": mass,
            "energy_bins": bins if isinstance(bins, int) else list(bins),
            "steering_by": steering_by,
            "group_by": [s.text for s in specs],
            "regions": region_source if region_source else ([r.name for r in regions] or None),
            "n_bootstrap": n_bootstrap,
            "test_size": test_size,
            "thin": thin,
            "alpha": alpha,
            "seed": seed,
            **{k: kinematics_options.get(k) for k in _KINEMATICS_KEYS},
        },
        "data_quality": data_quality(kin),
        "excluded": excluded_summary(kin),
    }
    fits["settings"]["max_plausible_speed"] = max_plausible_speed
    result = StudyResult(fits, kin, regions=regions)

    say("energy: one vs two phases")
    dep_e = _dependence(energy, valid)
    block, cmp_ = _phase_block(
        energy, valid, dep=dep_e, n_bootstrap=n_bootstrap, test_size=test_size, thin=thin,
        alpha=alpha, seed=s_energy,
    )  # fmt: skip
    block["unit"] = e_unit
    fits["energy"] = block
    fits["plausibility"] = plausibility(
        block, kin, mass=mass, max_plausible_speed=max_plausible_speed
    )
    result.energy = cmp_

    say("steering")
    steer, keep = _steering_block(
        kin, bins=bins, by=steering_by, n_bootstrap=n_bootstrap, test_size=test_size,
        thin=thin, seed=s_steer,
    )  # fmt: skip
    fits["steering"] = steer
    result.steering = keep

    fits["groups"] = {}
    for spec, gseed in zip(specs, s_groups.spawn(len(specs)), strict=True):
        say(f"groups: {spec.text}")
        codes, labels = group_codes[spec.text]
        levels: dict[str, Any] = {}
        kept: dict[str, Any] = {}
        for j, (label, lseed) in enumerate(zip(labels, gseed.spawn(len(labels)), strict=True)):
            m = valid & (codes == j)
            blk, c = _phase_block(
                energy, m, dep=dep_e, n_bootstrap=n_bootstrap, test_size=test_size,
                thin=thin, alpha=alpha, seed=lseed,
            )  # fmt: skip
            blk["n_tracks"] = int(m.any(axis=0).sum())
            levels[label] = blk
            kept[label] = c
        fits["groups"][spec.text] = {
            "kind": spec.kind,
            **({"window_s": spec.window} if spec.kind == "time" else {}),
            **({"variable": spec.name} if spec.kind == "variable" else {}),
            "levels": levels,
            "ks_comparison": _ks_comparison(levels),
        }
        result.groups[spec.text] = {"codes": codes, "labels": labels, "fits": kept}

    if regions:
        say("regions")
        fits["regions"] = _regions_block(
            kin, region_codes, regions, cmp_, n_bootstrap=n_bootstrap, alpha=alpha,
            seed=s_regions, source=region_source,
        )  # fmt: skip
    else:
        fits["regions"] = {}
    return result


def analyze_tracks(ds: xr.Dataset, **options: Any) -> dict[str, Any]:
    """The paper's statistics of trajectories ``ds``: the ``fits.json`` content.

    Options as :func:`run_study`.  Energies are in mm^2/s^2 (per unit mass) unless a
    ``mass`` (kg) is given, then in J.
    """
    return run_study(ds, **options).fits


def _write_kinematics(kin: xr.Dataset, path: Path) -> None:
    from thermoswarm.fsutil import atomic_path

    enc = {
        v: {"dtype": "float32"} for v in kin.data_vars if kin[v].dtype.kind == "f" and v != "dt"
    }
    out = kin.copy()
    for v in ("valid", "steering_valid", "stationary"):
        out[v] = out[v].astype(np.int8)
        out[v].attrs["flag"] = "1 = true"
    with atomic_path(path, suffix=".nc") as tmp:
        out.to_netcdf(tmp, engine="h5netcdf", encoding=enc)


def analyze_file(
    path: str | os.PathLike | Sequence[str | os.PathLike],
    out: str | os.PathLike,
    *,
    format: str | None = None,
    px_per_mm: float | str | None = None,
    read_options: dict[str, Any] | None = None,
    allow_pickle: bool = False,
    fps: float | None = None,
    regions: str | os.PathLike | None = None,
    report: bool = True,
    **options: Any,
) -> StudyResult:
    """Read trajectories, run the study, write ``fits.json``, ``kinematics.nc`` and
    ``report.html`` into directory ``out`` (its parent must exist; files are written
    atomically).  ``format``, ``px_per_mm``, ``allow_pickle`` and ``read_options`` go
    to :func:`thermoswarm.io.read_tracks`; the other options as :func:`run_study`.

    ``path`` may be several files (one per video or recording): each is read with the
    same options and their individuals are analysed together, named ``FILE:NAME``
    (:func:`thermoswarm.tracks.combine_tracks`)."""
    from thermoswarm.fsutil import atomic_write_json, atomic_write_text, prepare_output_dir
    from thermoswarm.io import detect_format, formats, read_tracks

    out = Path(out)
    paths = [Path(p) for p in path] if isinstance(path, list | tuple) else [Path(path)]
    if not paths:
        raise InputError("no input file given")
    read_options = dict(read_options or {})
    if options.get("duplicates") is not None and "duplicates" not in read_options:
        # one rule for the reader and the kinematics, where the reader takes it
        name = format or detect_format(paths[0])
        reader = formats().get(name)
        if reader is not None and "duplicates" in getattr(reader.load(), "OPTIONS", {}):
            read_options["duplicates"] = options["duplicates"]
    regions_list = load_regions(regions) if regions is not None else None
    prepare_output_dir(out)
    read = [
        read_tracks(
            p, format, fps=fps, px_per_mm=px_per_mm, allow_pickle=allow_pickle, **read_options
        )
        for p in paths
    ]
    if len(read) == 1:
        ds = read[0]
    else:
        stems = [p.stem for p in paths]
        prefixes = stems if len(set(stems)) == len(stems) else [str(p) for p in paths]
        ds = combine_tracks(read, prefixes, fps=fps)
    if "position" not in ds:
        raise InputError(f"{paths[0]}: the reader returned no positions")
    result = run_study(ds, fps=fps, regions=regions_list, **options)
    if regions is not None:
        result.fits["settings"]["regions"] = str(regions)
        if result.fits["regions"]:
            result.fits["regions"]["source"] = str(regions)
    result.fits["settings"]["format"] = format
    result.fits["settings"]["px_per_mm"] = px_per_mm
    _write_kinematics(result.kinematics, out / "kinematics.nc")
    atomic_write_json(out / "fits.json", result.fits)
    if report:
        from thermoswarm.analysis.figures import build_report

        atomic_write_text(out / "report.html", build_report(result))
    return result
