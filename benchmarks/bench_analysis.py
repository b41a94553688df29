"""End-to-end analysis of 10 million position samples, against a SciPy baseline.

Tracks (default 1,000 x 10,000 frames = 10 M position samples) are drawn from the
two-phase energy law with a steering temperature falling with speed
(:mod:`thermoswarm.analysis.synthetic`), then ``analyze_tracks`` runs with its
defaults (200 bootstrap replicates, test samples of at most 10,000): kinematics,
one- and two-phase fits of all energies, bootstrap KS and likelihood-ratio tests,
eight steering bins with bootstrap KS tests, the trend.

Baseline, same process, same energies: ``scipy.stats.expon.fit`` plus
``scipy.stats.goodness_of_fit(expon, energies, statistic="ks")`` -- one model only,
its bootstrap replicates at the full sample size.  At 10 M samples each replicate
costs seconds, so the baseline is timed with ``--baseline-replicates`` (default 5)
and extrapolated linearly to the same 200 replicates; both numbers are printed.

Peak memory is the process's peak resident set size (``resource.getrusage``), which
includes drawing the tracks; ``rss_before_analysis_mb`` is the resident size just
before the analysis starts.

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
from scipy import stats

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

    energy = result.kinematics["energy"].values
    energy = energy[result.kinematics["valid"].values & (energy > 0)]
    del ds, result
    t0 = time.perf_counter()
    loc, scale = stats.expon.fit(energy, floc=0)
    t_fit = time.perf_counter() - t0
    t0 = time.perf_counter()
    gof = stats.goodness_of_fit(
        stats.expon,
        energy,
        known_params={"loc": 0.0},
        statistic="ks",
        n_mc_samples=args.baseline_replicates,
        rng=np.random.default_rng(args.seed),
    )
    t_gof = time.perf_counter() - t0
    per_rep = t_gof / args.baseline_replicates
    baseline_extrapolated = t_fit + per_rep * args.bootstrap
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
        "baseline": {
            "what": "scipy.stats.expon.fit + scipy.stats.goodness_of_fit(expon, ks) on all "
            "energies (one phase only)",
            "fit_s": round(t_fit, 3),
            "goodness_of_fit_s": round(t_gof, 3),
            "replicates_timed": args.baseline_replicates,
            "extrapolated_s": round(baseline_extrapolated, 3),
            "kT": float(scale),
            "ks": float(gof.statistic),
        },
        "ratio_baseline_over_ours": round(baseline_extrapolated / wall, 3),
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
        print(f"analysed {n_samples:,} position samples in {wall:.1f} s "
              f"({out['samples_per_s']:,} samples/s), peak RSS {peak:.0f} MB")  # fmt: skip
        print(f"stages (s): {stages}")
        ratio = out["ratio_baseline_over_ours"]
        print(f"baseline (one phase, scipy): fit {t_fit:.2f} s + {args.baseline_replicates} "
              f"bootstrap replicates {t_gof:.1f} s -> {baseline_extrapolated:.1f} s at "
              f"{args.bootstrap} replicates; ratio baseline/ours {ratio}")  # fmt: skip
        print(f"result: {out['result']}")
    return out


if __name__ == "__main__":
    main()
