"""The analysis of 10 million position samples, and SciPy doing the same work on the
same samples, in one process.

Tracks (default 1,000 x 10,000 frames = 10 M position samples) are drawn from the
two-phase energy law with a steering temperature falling with speed
(:mod:`thermoswarm.analysis.synthetic`); ``run_study`` runs with its defaults (200
bootstrap replicates, test samples of at most 10,000): kinematics, one- and two-phase
fits of all energies, bootstrap KS and likelihood-ratio tests on the test sample,
eight steering bins, the trend.  Its wall time is reported as a whole.

Then each statistic that SciPy can compute is timed both ways on the *same* samples,
with the *same* procedure and on the *same* number of threads (one: our analysis
kernels are serial Numba, NumPy's element-wise work is serial, and the bootstrap runs
with ``n_jobs=1``; BLAS is held to one thread), and both must reach the same optimum:

``one phase``
    exponential ML fit of all energies + bootstrap KS (200 replicates) of the test
    sample: ours calls ``scipy.stats.goodness_of_fit`` itself, so the ratio is about 1
    by construction (kept as a check);
``two-phase fit``
    the mixture's ML fit of all energies from the same 7 starts, the procedure ours
    uses, with SciPy's optimiser in place of ours at each stage: the starts explored
    on the same 50,000-sample subsample grouped into the same 512 sorted groups (mean
    and count), the best finished on all samples.  Ours: EM warm-up and Newton ascent;
    SciPy: ``scipy.optimize.minimize`` (L-BFGS-B on the same log-likelihood with its
    exact gradient, unconstrained parameters).  Checked: both final log-likelihoods on
    all samples agree to ``--loglik-tol`` per sample (``same_optimum``);
``LR test``
    the bootstrap likelihood-ratio test on the same test sample, 5 starts per fit, the
    same grouped-then-exact procedure, every one of the ``--bootstrap`` replicates run
    both ways (no extrapolation); checked: the observed statistic agrees to
    ``--loglik-tol`` per sample, and the two p-values to within their Monte Carlo error.

Ratios are baseline / ours (> 1: ours faster).  Peak memory is the process's peak
resident set size (``resource.getrusage``), which includes drawing the tracks.

Usage::

    PYTHONPATH=src python benchmarks/bench_analysis.py [--n-tracks N] [--n-frames T]
        [--bootstrap B] [--loglik-tol TOL] [--json]
"""

from __future__ import annotations

import os

# Same threads for both sides: BLAS (SciPy's optimiser, NumPy's linear algebra) on one
# thread, as our serial kernels; set before NumPy loads.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import resource  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from scipy import optimize, stats  # noqa: E402

from thermoswarm.analysis.fit import ExponentialFit, ExponentialMixtureFit  # noqa: E402
from thermoswarm.analysis.phase_tests import goodness_of_fit, likelihood_ratio_test  # noqa: E402
from thermoswarm.analysis.sampling import draw_test_sample  # noqa: E402
from thermoswarm.analysis.study import run_study  # noqa: E402
from thermoswarm.analysis.synthetic import synthetic_tracks  # noqa: E402
from thermoswarm.maxent import DecayingTemperature, EnergyMixture, SteeringLaw  # noqa: E402


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


def _negloglik(
    theta: np.ndarray, x: np.ndarray, w: np.ndarray | None = None
) -> tuple[float, np.ndarray]:
    """Mixture negative log-likelihood of samples ``x`` counted ``w`` times (None: once)
    and its exact gradient in unconstrained parameters (logit phi, log kT1, log kT2):
    SciPy's optimiser at its best."""
    a, u, w_ = theta
    log_phi, log_1m = -np.logaddexp(0.0, -a), -np.logaddexp(0.0, a)
    l1 = log_phi - u - x * np.exp(-u)
    l2 = log_1m - w_ - x * np.exp(-w_)
    lse = np.logaddexp(l1, l2)
    r1 = np.exp(l1 - lse)
    r2 = 1.0 - r1
    phi = np.exp(log_phi)
    terms = (lse, r1 - phi, r1 * (x * np.exp(-u) - 1.0), r2 * (x * np.exp(-w_) - 1.0))
    if w is not None:
        terms = tuple(t * w for t in terms)
    grad = np.array([t.sum() for t in terms[1:]])
    return -float(terms[0].sum()), -grad


def _lbfgsb(th0: np.ndarray, x: np.ndarray, w: np.ndarray | None) -> tuple[float, np.ndarray]:
    res = optimize.minimize(_negloglik, th0, args=(x, w), method="L-BFGS-B", jac=True)
    return -float(res.fun), res.x


def grouped(x: np.ndarray, n_groups: int = 512) -> tuple[np.ndarray, np.ndarray]:
    """Sorted ``x`` in ``n_groups`` runs of equal count: ``(means, counts)`` (as ours)."""
    xs = np.sort(x)
    edges = np.linspace(0, xs.size, n_groups + 1).astype(np.int64)
    counts = np.diff(edges).astype(np.float64)
    return np.add.reduceat(xs, edges[:-1]) / counts, counts


def scipy_mixture(
    x: np.ndarray,
    starts: list[tuple[float, float, float]],
    explore: tuple[np.ndarray, np.ndarray | None] | None = None,
) -> float:
    """Best log-likelihood on all of ``x`` of ``phi Exp(k1) + (1-phi) Exp(k2)`` by L-BFGS-B.

    With ``explore`` (samples, counts), every start runs on it first and only the best
    is finished on ``x`` (our procedure); without, every start runs on ``x``.
    """
    th0s = [np.array([np.log(p / (1 - p)), np.log(k1), np.log(k2)]) for p, k1, k2 in starts]
    if explore is not None:
        found = [_lbfgsb(th, *explore) for th in th0s]
        th0s = [max(found, key=lambda f: f[0])[1]]
    return max(_lbfgsb(th, x, None)[0] for th in th0s)


def _explore_set(x: np.ndarray, rng: np.random.Generator, start_sample: int = 50_000):
    """Our fit's exploration data: a random subsample above ``start_sample`` samples
    (drawn from ``rng`` as ours draws it), grouped above 1,024 samples."""
    work = x if x.size <= start_sample else x[rng.choice(x.size, start_sample, replace=False)]
    return work, (grouped(work) if work.size > 1024 else (work, None))


def _lr_scipy(row: np.ndarray, g: np.random.Generator) -> float:
    """The LR statistic of ``row`` by our procedure with SciPy's optimiser (5 starts)."""
    work, explore = _explore_set(row, g)
    l2 = scipy_mixture(row, quantile_starts(work, 5, g), explore)
    return max(0.0, 2.0 * (l2 + row.size * (np.log(row.mean()) + 1)))


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
    ap.add_argument(
        "--loglik-tol",
        type=float,
        default=1e-6,
        help="largest difference of the two optima's log-likelihoods per sample",
    )
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    if args.bootstrap < 1 or args.n_tracks < 1 or args.n_frames < 2:
        ap.error("--bootstrap and --n-tracks must be at least 1, --n-frames at least 2")

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

    # two-phase ML fit of all energies, same 7 starts, same procedure (explore on the
    # same grouped subsample, finish the best on all samples), same optimum checked
    t0, c0 = time.perf_counter(), time.process_time()
    mix = ExponentialMixtureFit(n_starts=7, random_state=2).fit(energy)
    ours_mix, ours_mix_cpu = time.perf_counter() - t0, time.process_time() - c0
    g = np.random.default_rng(2)
    t0, c0 = time.perf_counter(), time.process_time()
    work, explore = _explore_set(energy, g)
    ll_scipy = scipy_mixture(energy, quantile_starts(work, 7, g), explore)
    base_mix, base_mix_cpu = time.perf_counter() - t0, time.process_time() - c0
    mix_gap = abs(mix.loglik_ - ll_scipy) / energy.size

    # bootstrap LR test on the test sample: ours against the same procedure with
    # SciPy's optimiser, every replicate run both ways
    t0, c0 = time.perf_counter(), time.process_time()
    lr = likelihood_ratio_test(test, n_bootstrap=B, random_state=3, n_jobs=1)
    ours_lr, ours_lr_cpu = time.perf_counter() - t0, time.process_time() - c0
    g = np.random.default_rng(3)
    t0, c0 = time.perf_counter(), time.process_time()
    lr_scipy = _lr_scipy(test, g)
    null = [_lr_scipy(g.exponential(test.mean(), test.size), g) for _ in range(B)]
    base_lr, base_lr_cpu = time.perf_counter() - t0, time.process_time() - c0
    p_scipy = (1 + sum(v >= lr_scipy for v in null)) / (B + 1)
    lr_gap = abs(lr.statistic - lr_scipy) / test.size
    # the two p-values are Monte Carlo estimates from independent replicates
    p_mid = 0.5 * (lr.p_value + p_scipy)
    p_tol = 4.0 * math.sqrt(2.0 * max(p_mid * (1 - p_mid), 1.0 / B) / B)
    same = {
        "two_phase_fit": bool(mix_gap <= args.loglik_tol),
        "lr_statistic": bool(lr_gap <= args.loglik_tol),
        "lr_p_value": bool(abs(lr.p_value - p_scipy) <= p_tol),
    }
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
        "threads": 1,
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
                "explored_on": "the same 50,000-sample subsample in 512 sorted groups",
                "ours_s": round(ours_mix, 3),
                "scipy_lbfgsb_s": round(base_mix, 3),
                "ours_cpu_over_wall": round(ours_mix_cpu / ours_mix, 2),
                "scipy_cpu_over_wall": round(base_mix_cpu / base_mix, 2),
                "ratio": round(base_mix / ours_mix, 2),
                "loglik_ours": mix.loglik_,
                "loglik_scipy": ll_scipy,
                "loglik_gap_per_sample": mix_gap,
            },
            "lr_test_bootstrap": {
                "n_test": int(test.size),
                "replicates": B,
                "starts": 5,
                "ours_s": round(ours_lr, 3),
                "scipy_s": round(base_lr, 3),
                "ours_cpu_over_wall": round(ours_lr_cpu / ours_lr, 2),
                "scipy_cpu_over_wall": round(base_lr_cpu / base_lr, 2),
                "ratio": round(base_lr / ours_lr, 2),
                "statistic_ours": lr.statistic,
                "statistic_scipy": lr_scipy,
                "statistic_gap_per_sample": lr_gap,
                "p_ours": lr.p_value,
                "p_scipy": p_scipy,
                "p_tolerance": p_tol,
            },
        },
        "same_optimum": same,
        "loglik_tol_per_sample": args.loglik_tol,
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
            base = r.get("scipy_s", r.get("scipy_lbfgsb_s"))
            print(f"{name:<44} {r['ours_s']:>9.3f} {base:>10.3f} {r['ratio']:>7.2f}")
        print(f"same optimum (log-likelihood within {args.loglik_tol:g} per sample; "
              f"p-values within their Monte Carlo error): {same}")  # fmt: skip
        print(f"result: {out['result']}")
    if not all(same.values()):
        print(f"error: ours and SciPy reach different optima: {same}", file=sys.stderr)
        raise SystemExit(1)
    return out


if __name__ == "__main__":
    main()
