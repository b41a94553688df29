"""Tests of the maximum-entropy laws: goodness of fit, one phase against two.

:func:`goodness_of_fit` gives the KS distance between the data and the law fitted to
them, with a parametric-bootstrap p-value that is valid for fitted parameters (each
bootstrap sample is drawn from the fitted law and refitted;
:func:`scipy.stats.goodness_of_fit` for one exponential,
:func:`scipy.stats.monte_carlo_test` for the mixture).  The p-value is
``(1 + #{T* >= T}) / (B + 1)``.  :func:`~thermoswarm.analysis.fit.naive_ks` gives the
p-value that treats the fitted parameters as known (what the paper reports; too large,
since a fitted law is closer to its data than the truth is).
:func:`likelihood_ratio_test` compares one phase with two by the parametric bootstrap
of the likelihood ratio under the fitted single exponential (McLachlan 1987): the usual
chi-square reference is wrong here because the null hypothesis lies on the boundary of
the mixture's parameter space.

One procedure.  A bootstrap p-value is valid only when the observed statistic and every
replicate come from the same procedure.  The statistic is therefore one function of a
sample and a generator -- the same number of mixture starts, no start at the
parameters that generated the replicate -- applied to the data (with a generator drawn
like the replicates') and to each replicate (:func:`_same_procedure`).  The fits that
give the reported estimates (more starts, all samples) are separate and do not enter
any test.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

from thermoswarm.analysis.fit import (
    ExponentialFit,
    ExponentialMixtureFit,
    _as_samples,
    _rng,
    ks_statistic,
    naive_ks,
)
from thermoswarm.maxent import EnergyLaw

__all__ = [
    "TestResult",
    "PhaseComparison",
    "goodness_of_fit",
    "likelihood_ratio_test",
    "compare_phases",
    "ks_statistic",
    "naive_ks",
]


@dataclass(frozen=True)
class TestResult:
    """A test statistic, its sample size and its p-value.

    ``p_value`` is ``None`` when no bootstrap was run (``n_bootstrap = 0``).
    """

    statistic: float
    p_value: float | None
    n: int
    n_bootstrap: int
    method: str
    null_distribution: np.ndarray | None = field(default=None, repr=False, compare=False)

    __test__ = False  # not a pytest class

    def to_dict(self) -> dict[str, Any]:
        return {
            "statistic": self.statistic,
            "p_value": self.p_value,
            "n": self.n,
            "n_bootstrap": self.n_bootstrap,
            "method": self.method,
        }


def _n_jobs(n_jobs: int | None) -> int:
    if n_jobs is None:
        return max(1, min(4, os.cpu_count() or 1))
    return max(1, int(n_jobs))


def _map_rows(func: Any, data: np.ndarray, rng: np.random.Generator, n_jobs: int) -> np.ndarray:
    """``func(row, generator)`` for each row of ``data`` (2-D), in threads.

    The kernels release the GIL, so threads run the fits in parallel.  Each row gets
    its own generator seeded from ``rng`` beforehand, so the result does not depend on
    the threads' timing.
    """
    seeds = rng.integers(0, 2**63 - 1, size=data.shape[0])
    rows = [(data[i], np.random.default_rng(int(seeds[i]))) for i in range(data.shape[0])]
    if n_jobs <= 1 or len(rows) < 2:
        return np.array([func(r, g) for r, g in rows], dtype=float)
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(max_workers=n_jobs) as pool:
        return np.array(list(pool.map(lambda rg: func(*rg), rows)), dtype=float)


def _mixture_fitter(
    rng: np.random.Generator, n_starts: int, n_polish: int | None = None
) -> ExponentialMixtureFit:
    return ExponentialMixtureFit(n_starts=n_starts, n_polish=n_polish, random_state=rng)


def goodness_of_fit(
    model: str,
    x: Any,
    *,
    n_bootstrap: int = 200,
    random_state: Any = None,
    n_starts: int = 5,
    n_jobs: int | None = None,
) -> TestResult:
    """KS goodness of fit of the one- or two-phase law fitted to ``x``.

    Parameters
    ----------
    model
        ``"one_phase"`` (exponential) or ``"two_phase"`` (mixture).
    x
        Non-negative samples (all are used; the statistic's ``n`` is ``len(x)``).
    n_bootstrap
        Parametric-bootstrap samples (0: statistic only, ``p_value = None``).
    random_state
        Seed or Generator.
    n_starts
        Starts of the mixture fit, for the data and for every replicate alike.
    n_jobs
        Threads for the bootstrap fits (default: up to 4 CPUs).  Results do not depend
        on it.

    Returns
    -------
    TestResult
        ``statistic`` is the KS distance between ``x`` and the law fitted to ``x``.
    """
    x = _as_samples(x, min_n=4 if model == "two_phase" else 2)
    rng = _rng(random_state)
    jobs = _n_jobs(n_jobs)
    n = x.size
    if model == "one_phase":
        law = EnergyLaw(float(x.mean()))
        d = ks_statistic(x, law)
        if n_bootstrap <= 0:
            return TestResult(d, None, n, 0, "KS, exponential fitted by ML")
        res = stats.goodness_of_fit(
            stats.expon, x, known_params={"loc": 0.0}, statistic="ks",
            n_mc_samples=int(n_bootstrap), rng=rng,
        )  # fmt: skip
        return TestResult(
            float(res.statistic), float(res.pvalue), n, int(n_bootstrap),
            "KS, exponential fitted by ML; parametric bootstrap (scipy.stats.goodness_of_fit)",
            np.asarray(res.null_distribution),
        )  # fmt: skip
    if model != "two_phase":
        raise ValueError(f"model must be 'one_phase' or 'two_phase', got {model!r}")

    def fit_two(row: np.ndarray, g: np.random.Generator) -> ExponentialMixtureFit:
        return _mixture_fitter(g, n_starts).fit(row)

    def one_replicate(row: np.ndarray, g: np.random.Generator) -> float:
        return ks_statistic(row, fit_two(row, g).law_)

    fitted = fit_two(x, _child(rng))
    d = ks_statistic(x, fitted.law_)
    if n_bootstrap <= 0:
        return TestResult(d, None, n, 0, "KS, two-exponential mixture fitted by ML")

    def rvs(size: tuple[int, ...]) -> np.ndarray:
        return fitted.law_.sample(rng, size)

    return _parametric_bootstrap(
        x, d, rvs, one_replicate, n_bootstrap, rng, jobs,
        "KS, two-exponential mixture fitted by ML; parametric bootstrap "
        "(scipy.stats.monte_carlo_test); the same fit for the data and each replicate",
    )  # fmt: skip


def _child(rng: np.random.Generator) -> np.random.Generator:
    """A generator drawn from ``rng`` the way :func:`_map_rows` draws each replicate's."""
    return np.random.default_rng(int(rng.integers(0, 2**63 - 1)))


def _parametric_bootstrap(
    x: np.ndarray,
    observed: float,
    rvs: Any,
    one_replicate: Any,
    n_bootstrap: int,
    rng: np.random.Generator,
    jobs: int,
    method: str,
) -> TestResult:
    """``scipy.stats.monte_carlo_test`` of ``observed`` (large is extreme) against
    ``one_replicate(row, generator)`` on data drawn by ``rvs``, rows spread over
    ``jobs`` workers with generators spawned from ``rng``."""

    def statistic(data: np.ndarray, axis: int = -1) -> np.ndarray | float:
        data = np.moveaxis(np.asarray(data), axis, -1)
        if data.ndim == 1:
            return observed  # computed by the caller with the same procedure
        flat = data.reshape(-1, data.shape[-1])
        return _map_rows(one_replicate, flat, rng, jobs).reshape(data.shape[:-1])

    res = stats.monte_carlo_test(
        x, rvs, statistic, vectorized=True, n_resamples=int(n_bootstrap),
        alternative="greater", batch=min(int(n_bootstrap), 50),
    )  # fmt: skip
    return TestResult(
        observed, float(res.pvalue), x.size, int(n_bootstrap), method,
        np.asarray(res.null_distribution),
    )  # fmt: skip


def likelihood_ratio_test(
    x: Any,
    *,
    n_bootstrap: int = 200,
    random_state: Any = None,
    n_starts: int = 5,
    n_jobs: int | None = None,
) -> TestResult:
    """Bootstrap likelihood-ratio test of one phase (H0) against two phases.

    ``statistic = 2 (loglik_two - loglik_one) >= 0``; its null distribution is
    simulated by drawing ``len(x)`` samples from the fitted exponential and fitting
    both models to each (the chi-square reference does not hold on the boundary).
    The statistic of ``x`` comes from the very fits the replicates get (``n_starts``
    mixture starts each).  ``n_jobs`` as in :func:`goodness_of_fit`.
    """
    x = _as_samples(x, min_n=4)
    rng = _rng(random_state)
    jobs = _n_jobs(n_jobs)
    n = x.size

    def statistic(row: np.ndarray, g: np.random.Generator) -> float:
        l1 = ExponentialFit().fit(row).loglik_
        l2 = _mixture_fitter(g, n_starts).fit(row).loglik_
        return max(0.0, 2.0 * (l2 - l1))

    lr = statistic(x, _child(rng))
    if n_bootstrap <= 0:
        return TestResult(lr, None, n, 0, "likelihood ratio, two vs one exponential")
    kT = float(x.mean())

    def rvs(size: tuple[int, ...]) -> np.ndarray:
        return rng.exponential(kT, size)

    return _parametric_bootstrap(
        x, lr, rvs, statistic, n_bootstrap, rng, jobs,
        "likelihood ratio, two vs one exponential; parametric bootstrap under the fitted "
        "exponential (scipy.stats.monte_carlo_test); the same fits for the data and each "
        "replicate",
    )  # fmt: skip


@dataclass
class PhaseComparison:
    """One phase against two on the same energies: fits, goodness of fit, LR and BIC.

    ``one`` and ``two`` are fitted to all samples; the tests (``gof_one``, ``gof_two``,
    ``lr``) run on the test sample (all samples, or a thinned subsample: see
    :mod:`thermoswarm.analysis.sampling`), whose size is each test's ``n``; the naive KS
    values (``naive_one``, ``naive_two``: ``(ks, p, n)``) use all samples.
    """

    one: ExponentialFit
    two: ExponentialMixtureFit
    gof_one: TestResult
    gof_two: TestResult
    lr: TestResult
    naive_one: tuple[float, float, int]
    naive_two: tuple[float, float, int]
    alpha: float
    zero_count: int = 0
    mean: float = float("nan")

    @property
    def preferred(self) -> str:
        """``"two_phase"`` when the LR test rejects one phase at ``alpha`` (BIC without
        a bootstrap), and the mixture has not collapsed; else ``"one_phase"``."""
        if self.two.degenerate_:
            return "one_phase"
        if self.lr.p_value is not None:
            return "two_phase" if self.lr.p_value < self.alpha else "one_phase"
        return self.bic_preferred

    @property
    def bic_preferred(self) -> str:
        return "two_phase" if self.two.bic() < self.one.bic() else "one_phase"

    def to_dict(self) -> dict[str, Any]:
        one, two = self.one, self.two
        d_one = {
            "kT": one.kT_,
            "kT_se": one.kT_se_,
            "n_fit": one.n_,
            "loglik": one.loglik_,
            "aic": one.aic(),
            "bic": one.bic(),
            "ks": self.gof_one.statistic,
            "p_value": self.gof_one.p_value,
            "n": self.gof_one.n,
            "naive": dict(zip(("ks", "p_value", "n"), self.naive_one, strict=True)),
        }
        d_two = {
            "phi": two.phi_,
            "phi_se": two.phi_se_,
            "kT1": two.kT1_,
            "kT1_se": two.kT1_se_,
            "kT2": two.kT2_,
            "kT2_se": two.kT2_se_,
            "high_T_fraction": 1.0 - two.phi_,
            "n_fit": two.n_,
            "loglik": two.loglik_,
            "aic": two.aic(),
            "bic": two.bic(),
            "converged": two.converged_,
            "degenerate": two.degenerate_,
            "ks": self.gof_two.statistic,
            "p_value": self.gof_two.p_value,
            "n": self.gof_two.n,
            "naive": dict(zip(("ks", "p_value", "n"), self.naive_two, strict=True)),
        }
        return {
            "n": one.n_,
            "n_zero": self.zero_count,
            "mean": self.mean,
            "one_phase": d_one,
            "two_phase": d_two,
            "preferred": self.preferred,
            "preferred_by": (
                "one_phase: the mixture collapsed onto one exponential"
                if two.degenerate_
                else f"bootstrap likelihood-ratio test at alpha={self.alpha}"
                if self.lr.p_value is not None
                else "BIC (no bootstrap)"
            ),
            "lr_statistic": self.lr.statistic,
            "lr_p_value": self.lr.p_value,
            "lr_n": self.lr.n,
            "bic_preferred": self.bic_preferred,
            "delta_bic": two.bic() - one.bic(),
            "n_bootstrap": self.lr.n_bootstrap,
            **(
                {
                    "note": f"with {self.lr.n_bootstrap} bootstrap replicates the smallest "
                    f"p-value is {1 / (self.lr.n_bootstrap + 1):.3g}: no test can reject "
                    f"at alpha={self.alpha}"
                }
                if 0 < self.lr.n_bootstrap and 1 / (self.lr.n_bootstrap + 1) >= self.alpha
                else {}
            ),
        }


def compare_phases(
    x: Any,
    *,
    test_x: Any = None,
    n_bootstrap: int = 200,
    alpha: float = 0.05,
    random_state: Any = None,
    n_starts: int = 7,
    n_starts_bootstrap: int = 5,
    n_jobs: int | None = None,
) -> PhaseComparison:
    """Fit one and two phases to energies ``x`` and test them.

    Exact zeros are set aside (a point mass at zero, e.g. a tracker repeating a
    position, is not part of a continuous law; it would make the mixture's likelihood
    unbounded) and counted in ``zero_count``.  ``test_x`` (default ``x``) is the sample
    on which the bootstrap tests run; see :class:`PhaseComparison`.  ``n_jobs``: threads
    of the bootstrap fits (the results do not depend on it).
    """
    x = np.asarray(x, dtype=np.float64).ravel()
    positive = x[x > 0]
    zero_count = int(x.size - positive.size)
    x = _as_samples(positive, min_n=4)
    rng = _rng(random_state)
    one = ExponentialFit().fit(x)
    two = ExponentialMixtureFit(n_starts=n_starts, random_state=rng).fit(x)
    xs = np.sort(x)
    naive_one = naive_ks(xs, one.law_, presorted=True)
    naive_two = naive_ks(xs, two.law_, presorted=True)
    del xs
    if test_x is None:
        tx = x
    else:
        tx = np.asarray(test_x, dtype=np.float64).ravel()
        tx = _as_samples(tx[tx > 0], name="test sample", min_n=4)
    gof_one = goodness_of_fit("one_phase", tx, n_bootstrap=n_bootstrap, random_state=rng)
    gof_two = goodness_of_fit(
        "two_phase", tx, n_bootstrap=n_bootstrap, random_state=rng,
        n_starts=n_starts_bootstrap, n_jobs=n_jobs,
    )  # fmt: skip
    lr = likelihood_ratio_test(
        tx, n_bootstrap=n_bootstrap, random_state=rng, n_starts=n_starts_bootstrap,
        n_jobs=n_jobs,
    )  # fmt: skip
    return PhaseComparison(
        one, two, gof_one, gof_two, lr, naive_one, naive_two, alpha, zero_count, float(x.mean())
    )
