"""The power of each verdict: the smallest effect its test can detect at its sample.

Every verdict of :mod:`thermoswarm.report.paper` is a test on a sample (seeds, steps,
bootstrap replicates).  A verdict that says nothing about how large an effect the test
could have seen reads as evidence of absence; these helpers turn the row's own numbers
(a standard error, a sample size, a replicate count) into the *minimum detectable
effect* (MDE): the true effect that a two-sided test at level ``alpha`` detects with
probability ``power``.  The defaults are the conventional 5 % and 80 %, so for a
difference estimated with standard error ``SE`` the MDE is
``(z_0.975 + z_0.8) SE = 2.80 SE``.
"""

from __future__ import annotations

import math
from statistics import NormalDist

__all__ = [
    "ALPHA",
    "POWER",
    "mde",
    "mde_failure_rate",
    "mde_ks",
    "mde_spearman",
    "p_floor",
    "power_note",
    "rank_p_floor",
]

#: The level and the power every row's smallest detectable effect is stated at.
ALPHA, POWER = 0.05, 0.8


def _finite(x: object) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)


def mde(se: float | None, *, alpha: float = ALPHA, power: float = POWER,
        df: float | None = None) -> float | None:  # fmt: skip
    """The minimum detectable effect of a two-sided test of an estimate with standard
    error ``se``: ``(q_{1-alpha/2} + q_power) * se``, same unit as ``se``.

    Parameters
    ----------
    se
        Standard error of the estimated effect (a difference, a mean, a slope), in the
        effect's unit; ``None`` or non-finite gives ``None``.
    alpha, power
        Two-sided level and the power (0.05 and 0.8: the factor is 2.80).
    df
        Degrees of freedom of a t-test (Student quantiles, larger factor for few
        degrees); ``None``: normal quantiles.

    Returns
    -------
    float or None
        The smallest true effect detected with probability ``power``.
    """
    if not _finite(se) or se < 0:  # type: ignore[operator]
        return None
    if df is None:
        z = NormalDist()
        factor = z.inv_cdf(1 - alpha / 2) + z.inv_cdf(power)
    else:
        if not _finite(df) or df < 1:
            return None
        from scipy import stats

        factor = float(stats.t.ppf(1 - alpha / 2, df) + stats.t.ppf(power, df))
    return factor * float(se)  # type: ignore[arg-type]


def p_floor(n_bootstrap: int | None) -> float | None:
    """The smallest p-value a bootstrap of ``n_bootstrap`` replicates can give,
    ``1 / (n_bootstrap + 1)`` (dimensionless); ``None`` without a bootstrap."""
    return 1 / (n_bootstrap + 1) if n_bootstrap else None


def rank_p_floor(group_sizes: list[int] | None) -> float | None:
    """The smallest two-sided p-value that an exact rank test of a trend (Spearman's, or
    any test that only sees the ranks) can give for runs at ``len(group_sizes)`` values of
    x, ``group_sizes[i]`` runs at the i-th (ties in x), the responses all distinct:
    ``2 prod(m_i!) / n!`` (dimensionless), the share of the ``n!`` equally likely
    orderings that are perfectly increasing or perfectly decreasing.  At or above the
    level, no rank test can reject: 4 runs at 4 sizes give 2/24 = 0.083; ``None`` below
    two values of x."""
    sizes = [int(m) for m in group_sizes or [] if m]
    if len(sizes) < 2:
        return None
    n, same = sum(sizes), math.prod(math.factorial(m) for m in sizes)
    return min(1.0, 2 * same / math.factorial(n))


def mde_failure_rate(n_runs: int | None, *, power: float = POWER) -> float | None:
    """The smallest failure rate that ``n_runs`` independent runs show (at least one
    failure) with probability ``power``: ``1 - (1 - power)^(1/n_runs)`` (a fraction).
    A rule "every run succeeds" cannot see a failure rate below it."""
    if not n_runs or n_runs < 1:
        return None
    return 1 - (1 - power) ** (1 / n_runs)


def mde_spearman(n: int | None, *, alpha: float = ALPHA, power: float = POWER) -> float | None:
    """The smallest Spearman rank correlation that ``n`` pairs detect: Fisher's z with
    the rank correlation's variance ``1.06 / (n - 3)`` (Fieller, Hartley and Pearson
    1957), ``tanh(mde(sqrt(1.06 / (n - 3))))``; ``None`` below 4 pairs."""
    if not n or n < 4:
        return None
    return math.tanh(mde(math.sqrt(1.06 / (n - 3)), alpha=alpha, power=power))  # type: ignore[arg-type]


def mde_ks(n: int | None, *, alpha: float = ALPHA, power: float = POWER) -> float | None:
    """The Kolmogorov-Smirnov distance (largest gap between the data's and the model's
    cumulative distributions) that a one-sample test on ``n`` independent values detects
    with at least probability ``power`` whatever the departure's shape: the asymptotic
    critical value ``sqrt(-ln(alpha/2)/2)/sqrt(n)`` plus ``q_power`` times the largest
    standard deviation of the empirical CDF where the gap is, ``0.5/sqrt(n)``
    (dimensionless).  An upper bound: a broad departure is detected at smaller gaps."""
    if not n or n < 1:
        return None
    c = math.sqrt(-math.log(alpha / 2) / 2)
    return (c + NormalDist().inv_cdf(power) * 0.5) / math.sqrt(n)


def power_note(test: str, sample: str, detectable: str | None, *, level: bool = True) -> str:
    """One plain clause for a row's ``why``: ``test: ...; sample: ...; smallest
    detectable effect (two-sided 5 % level, 80 % power): ...``; without a
    ``detectable`` effect, says that none can be computed from this sample;
    ``level=False`` for a rule that is no significance test (one run, a threshold)."""
    if detectable is None:
        detectable, level = "none computable from this sample", False
    at = f" (two-sided {100 * ALPHA:g} % level, {100 * POWER:g} % power)" if level else ""
    return f"test: {test}; sample: {sample}; smallest detectable effect{at}: {detectable}"
