"""The analysis of 10 million position samples, and SciPy doing the same work on the
same samples, in one process.

Tracks (default 1,000 x 10,000 frames = 10 M position samples) are drawn from the
two-phase energy law with a steering temperature falling with speed
(:mod:`thermoswarm.analysis.synthetic`); ``run_study`` runs with its defaults (200
bootstrap replicates, test samples of at most 10,000): kinematics, one- and two-phase
fits of all energies, bootstrap KS and likelihood-ratio tests on the test sample,
eight steering bins, the trend.  Its wall time is reported as a whole.

Then each statistic that SciPy can compute is timed both ways on the *same* samples:

``one phase``
    exponential ML fit of all energies + bootstrap KS (200 replicates) of the test
    sample: ours calls ``scipy.stats.goodness_of_fit`` itself, so the ratio is about 1
    by construction (kept as a check);
``two-phase fit``
    the mixture's ML fit of all energies from the same 7 starts: our Newton ascent
    (grouped starts, exact finish) against ``scipy.optimize.minimize`` (L-BFGS-B on the
    same log-likelihood with its exact gradient, unconstrained parameters);
``LR test``
    the bootstrap likelihood-ratio test on the same test sample, 5 starts per fit:
    ours against the same procedure with SciPy's optimiser, timed for
    ``--baseline-replicates`` replicates and extrapolated to 200 (both printed).

Ratios are baseline / ours (> 1: ours faster).  Peak memory is the process's peak
resident set size (``resource.getrusage``), which includes drawing the tracks.

Usage::

    PYTHONPATH=src python benchmarks/bench_analysis.py [--n-tracks N] [--n-frames T]
        [--bootstrap B] [--baseline-replicates R] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import time

import numpy as np
from scipy import optimize, stats

from thermoswarm.analysis.fit import ExponentialFit, ExponentialMixtureFit
from thermoswarm.analysis.phase_tests import goodness_of_fit, likelihood_ratio_test
from thermoswarm.analysis.sampling import draw_test_sample
from thermoswarm.analysis.study import run_study
from thermoswarm.analysis.synthetic import synthetic_tracks
from thermoswarm.maxent import DecayingTemperature, EnergyMixture, SteeringLaw


def rss_mb() -> float:
    """Current resident set size (MB) from /proc, or NaN where there is none."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")


def peak_rss_mb() -> float:
    kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return kb / 1024.0 if sys.platform != "darwin" else kb / 2**20


def _negloglik(theta: np.ndarray, x: np.ndarray) -> tuple[float, np.ndarray]:
    """Mixture negative log-likelihood and its exact gradient in unconstrained
    parameters (logit phi, log kT1, log kT2): SciPy's optimiser at its best."""
    a, u, w = theta
    log_phi, log_1m = -np.logaddexp(0.0, -a), -np.logaddexp(0.0, a)
    l1 = log_phi - u - x * np.exp(-u)
    l2 = log_1m - w - x * np.exp(-w)
    lse = np.logaddexp(l1, l2)
    r1 = np.exp(l1 - lse)
    r2 = 1.0 - r1
    phi = np.exp(log_phi)
    grad = np.array(
        [
            (r1 - phi).sum(),
            (r1 * (x * np.exp(-u) - 1.0)).sum(),
            (r2 * (x * np.exp(-w) - 1.0)).sum(),
        ]
    )
    return -float(lse.sum()), -grad


def scipy_mixture(x: np.ndarray, starts: list[tuple[float, float, float]]) -> float:
    """Best log-likelihood of ``phi Exp(k1) + (1-phi) Exp(k2)`` by L-BFGS-B from ``starts``."""
    best = -np.inf
    for phi, k1, k2 in starts:
        th0 = np.array([np.log(phi / (1 - phi)), np.log(k1), np.log(k2)])
        res = optimize.minimize(_negloglik, th0, args=(x,), method="L-BFGS-B", jac=True)
        best = max(best, -res.fun)
    return best


def quantile_starts(x: np.ndarray, n: int, rng: np.random.Generator) -> list:
    """The same starting points as ours: splits at quantiles, then random."""
    out = []
    for q in (0.5, 0.25, 0.75, 0.05, 0.95)[:n]:
        t = np.quantile(x, q)
        out.append((q, max(x[x <= t].mean(), 1e-9), max(x[x > t].mean(), 2e-9)))
    m = x.mean()
    while len(out) < n:
        out.append((rng.uniform(0.1, 0.9), m * np.exp(rng.uniform(np.log(0.05), np.log(0.8))),
                    m * np.exp(rng.uniform(np.log(1.2), np.log(5.0)))))  # fmt: skip
    return out


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-tracks", type=int, default=1000)
    ap.add_argument("--n-frames", type=int, default=10_000)
    ap.add_argument("--bootstrap", type=int, default=200)
    ap.add_argument("--baseline-replicates", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)

    t0 = time.perf_counter()
    ds, _ = synthetic_tracks(
        args.n_tracks,
        args.n_frames,
        energy=EnergyMixture(0.6, 20.0, 80.0),
        steering=SteeringLaw(DecayingTemperature(6.0, 1.0, 8.0)),
        fps=30.0,
        rng=args.seed,
    )
    t_make = time.perf_counter() - t0
    n_samples = args.n_tracks * args.n_frames
    rss_before = rss_mb()

    stages: dict[str, float] = {}
    last = [time.perf_counter(), None]

    def progress(msg: str) -> None:
        now = time.perf_counter()
        if last[1] is not None:
            stages[last[1]] = round(now - last[0], 3)
        last[0], last[1] = now, msg

    t0 = time.perf_counter()
    result = run_study(ds, n_bootstrap=args.bootstrap, seed=args.seed, progress=progress)
    wall = time.perf_counter() - t0
    progress("end")
    stages.pop("end", None)
    peak = peak_rss_mb()
    fits = result.fits

    kin = result.kinematics
    valid = kin["valid"].values & (kin["energy"].values > 0)
    energy = kin["energy"].values[valid]
    rng = np.random.default_rng(args.seed)
    test, _ = draw_test_sample(kin["energy"].values, valid, max_n=10_000, rng=rng)
    del ds, result, kin
    B = args.bootstrap

    # one phase: fit of all energies + bootstrap KS of the test sample, both ways
    t0 = time.perf_counter()
    stats.expon.fit(energy, floc=0)
    stats.goodness_of_fit(stats.expon, test, known_params={"loc": 0.0}, statistic="ks",
                          n_mc_samples=B, rng=np.random.default_rng(1))  # fmt: skip
    base_one = time.perf_counter() - t0
    t0 = time.perf_counter()
    ExponentialFit().fit(energy)
    goodness_of_fit("one_phase", test, n_bootstrap=B, random_state=1)
    ours_one = time.perf_counter() - t0

    # two-phase ML fit of all energies, same 7 starts
    t0 = time.perf_counter()
    ExponentialMixtureFit(n_starts=7, random_state=2).fit(energy)
    ours_mix = time.perf_counter() - t0
    t0 = time.perf_counter()
    scipy_mixture(energy, quantile_starts(energy, 7, np.random.default_rng(2)))
    base_mix = time.perf_counter() - t0

    # bootstrap LR test on the test sample: ours (B replicates) against the same
    # procedure with SciPy's optimiser (R replicates, extrapolated)
    t0 = time.perf_counter()
    likelihood_ratio_test(test, n_bootstrap=B, random_state=3, n_jobs=1)
    ours_lr = time.perf_counter() - t0
    g = np.random.default_rng(3)
    t0 = time.perf_counter()
    for _ in range(args.baseline_replicates + 1):  # the data and R replicates
        row = g.exponential(test.mean(), test.size)
        2.0 * (
            scipy_mixture(row, quantile_starts(row, 5, g)) + row.size * (np.log(row.mean()) + 1)
        )
    per_fit = (time.perf_counter() - t0) / (args.baseline_replicates + 1)
    base_lr = per_fit * (B + 1)
    e = fits["energy"]
    out = {
        "benchmark": "analysis",
        "n_position_samples": n_samples,
        "n_tracks": args.n_tracks,
        "n_frames": args.n_frames,
        "n_energy_samples": fits["n_samples"],
        "n_bootstrap": args.bootstrap,
        "test_size": fits["settings"]["test_size"],
        "cpu_count": os.cpu_count(),
        "make_tracks_s": round(t_make, 3),
        "wall_s": round(wall, 3),
        "stages_s": stages,
        "samples_per_s": round(n_samples / wall),
        "peak_rss_mb": round(peak, 1),
        "rss_before_analysis_mb": round(rss_before, 1),
        "same_work": {
            "one_phase_fit_and_bootstrap_ks": {
                "n_fit": int(energy.size),
                "n_test": int(test.size),
                "replicates": B,
                "ours_s": round(ours_one, 3),
                "scipy_s": round(base_one, 3),
                "ratio": round(base_one / ours_one, 2),
            },
            "two_phase_fit_all_energies": {
                "n": int(energy.size),
                "starts": 7,
                "ours_s": round(ours_mix, 3),
                "scipy_lbfgsb_s": round(base_mix, 3),
                "ratio": round(base_mix / ours_mix, 2),
            },
            "lr_test_bootstrap": {
                "n_test": int(test.size),
                "replicates": B,
                "starts": 5,
                "ours_s": round(ours_lr, 3),
                "scipy_per_fit_s": round(per_fit, 4),
                "scipy_replicates_timed": args.baseline_replicates,
                "scipy_extrapolated_s": round(base_lr, 3),
                "ratio": round(base_lr / ours_lr, 2),
            },
        },
        "result": {
            "preferred": e.get("preferred"),
            "phi": e.get("two_phase", {}).get("phi"),
            "kT1": e.get("two_phase", {}).get("kT1"),
            "kT2": e.get("two_phase", {}).get("kT2"),
            "kT_one_phase": e.get("one_phase", {}).get("kT"),
            "steering_trend_slope": fits["steering"].get("trend", {}).get("slope"),
        },
        "under_60_s": wall < 60.0,
        "under_4_gb": peak < 4096.0,
    }
    if args.json:
        print(json.dumps(out))
    else:
        print(f"whole study: {n_samples:,} position samples in {wall:.1f} s "
              f"({out['samples_per_s']:,} samples/s), peak RSS {peak:.0f} MB")  # fmt: skip
        print(f"stages (s): {stages}")
        print(f"{'same work, same samples':<44} {'ours (s)':>9} {'scipy (s)':>10} {'ratio':>7}")
        for name, r in out["same_work"].items():
            base = r.get("scipy_s", r.get("scipy_lbfgsb_s", r.get("scipy_extrapolated_s")))
            print(f"{name:<44} {r['ours_s']:>9.3f} {base:>10.3f} {r['ratio']:>7.2f}")
        print(f"result: {out['result']}")
    return out


if __name__ == "__main__":
    main()
