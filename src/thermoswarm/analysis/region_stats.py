"""The fraction of steps in the hot phase per region, with a track bootstrap.

The fraction of a region is the maximum-likelihood weight of the ``kT2`` component
with both temperatures fixed at the overall two-phase fit (so regions differ only in
how their steps split between the same two phases).  Its uncertainty and the test of
each difference resample whole tracks (clusters) with replacement, which keeps the
dependence of a track's steps; each bootstrap replicate takes one Newton step from the
estimate (a one-step bootstrap, first-order equivalent to refitting).  The naive Wald
test that treats steps as independent is reported beside it, labelled.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

from thermoswarm.analysis.phase_tests import PhaseComparison
from thermoswarm.analysis.phases import MIN_SAMPLES
from thermoswarm.analysis.regions import OUTSIDE, Region

__all__ = ["MIN_CLUSTERS", "high_T_fraction", "regions_block"]

#: Fewer tracks than this: the cluster bootstrap cuts tracks into time blocks.
MIN_CLUSTERS = 20


def _score(x: np.ndarray, w: float, k1: float, k2: float) -> np.ndarray:
    """Per-sample score ``d/dw log((1-w) p1 + w p2)`` for fixed exponential components."""
    L = math.log(k1 / k2) + x * (1.0 / k1 - 1.0 / k2)  # log p2/p1
    u = np.exp(-np.abs(L))
    # at w = 0 (or 1) a sample far in one component's tail scores p2/p1 - 1, which may
    # exceed the float range: +-inf is the right answer there
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
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


def _levels(energy: np.ndarray, valid: np.ndarray, codes: np.ndarray,
            regions: Sequence[Region]) -> dict[str, Any]:  # fmt: skip
    """Per region: step and track counts, mean energy (the one-phase temperature)."""
    levels: dict[str, Any] = {}
    for k, reg in enumerate(regions):
        m = valid & (codes == k)
        x = energy[m]
        levels[reg.name] = {
            "n": int(x.size),
            "n_tracks": int(m.any(axis=0).sum()),
            "mean_energy": float(x.mean()) if x.size else None,
            "kT_one_phase": float(x.mean()) if x.size else None,
        }
    return levels


def _fractions(
    energy: np.ndarray,
    valid: np.ndarray,
    codes: np.ndarray,
    names: list[str],
    levels: dict[str, Any],
    k1: float,
    k2: float,
    cl: np.ndarray,
    n_cl: int,
) -> tuple[dict[str, float], np.ndarray, np.ndarray]:
    """Each region's hot-phase fraction (into ``levels``) and its per-cluster score sums."""
    est: dict[str, float] = {}
    sums1 = np.zeros((n_cl, len(names)))
    sums2 = np.zeros((n_cl, len(names)))
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
    return est, sums1, sums2


def _replicates(
    est: dict[str, float],
    names: list[str],
    levels: dict[str, Any],
    sums: tuple[np.ndarray, np.ndarray],
    n_cl: int,
    *,
    n_bootstrap: int,
    alpha: float,
    seed: np.random.SeedSequence,
) -> np.ndarray | None:
    """One-step cluster-bootstrap replicates of every region's fraction (``None``
    without bootstrap); each region's standard error and interval go into ``levels``."""
    if not (n_bootstrap > 0 and est):
        return None
    sums1, sums2 = sums
    rng = np.random.default_rng(seed)
    reps = np.full((n_bootstrap, len(names)), np.nan)
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
    return reps


def _difference(
    a: int, b: int, names: list[str], est: dict[str, float], levels: dict[str, Any],
    reps: np.ndarray | None, alpha: float,
) -> dict[str, Any]:  # fmt: skip
    """The difference of two regions' fractions: estimate, naive Wald and bootstrap test."""
    na, nb = names[a], names[b]
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
                float(2 * stats.norm.sf(abs(diff) / se)) if se > 0 else (0.0 if diff != 0 else 1.0)
            )
    return entry


def regions_block(
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
    """``fits.json["regions"]``: per region the counts, mean energy and hot-phase
    fraction (with its cluster-bootstrap interval), and each pair's difference.

    Energies in the kinematics' unit; ``codes`` is each step's region index
    (:data:`OUTSIDE` for none); ``alpha`` the level of the intervals.
    """
    energy = kin["energy"].values
    valid = kin["valid"].values & np.isfinite(energy) & (energy > 0)
    out: dict[str, Any] = {
        "source": source,
        "assignment": "step midpoint (x_mid, y_mid); first region in file order",
        "polygons": {r.name: r.to_dict() for r in regions},
        "n_outside": int((valid & (codes == OUTSIDE)).sum()),
        "levels": _levels(energy, valid, codes, regions),
        "differences": [],
    }
    levels = out["levels"]
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
    est, sums1, sums2 = _fractions(energy, valid, codes, names, levels, k1, k2, cl, n_cl)
    reps = _replicates(est, names, levels, (sums1, sums2), n_cl, n_bootstrap=n_bootstrap,
                       alpha=alpha, seed=seed)  # fmt: skip
    for a in range(len(names)):
        for b in range(a + 1, len(names)):
            if names[a] in est and names[b] in est:
                out["differences"].append(_difference(a, b, names, est, levels, reps, alpha))
    return out
