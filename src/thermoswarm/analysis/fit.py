"""Fitting the maximum-entropy laws: one exponential, two exponentials, and tests.

Estimators follow scikit-learn: ``fit(x)`` returns ``self``; fitted values end in ``_``;
``aic()``/``bic()`` give the information criteria; ``params`` is a dict, ``nllf()`` the
negative log-likelihood and ``plot(ax)`` draws the fitted density.  The laws come from
:mod:`thermoswarm.maxent` (``law_`` is an :class:`~thermoswarm.maxent.EnergyLaw` or
:class:`~thermoswarm.maxent.EnergyMixture`), so pdf, cdf and sampling are not rewritten.

Energies ``x`` are non-negative numbers in any unit (mm^2/s^2 per unit mass, or J);
fitted temperatures ``kT`` are in the same unit.  The same code fits the magnitude of
the steering-angle rate (``kT_theta`` in rad/s).

Two-phase fit
    :class:`ExponentialMixtureFit` maximises the likelihood of
    ``phi Exp(kT1) + (1 - phi) Exp(kT2)`` (the convention of
    :class:`~thermoswarm.maxent.EnergyMixture`: ``phi`` weighs the cold "liquid"
    component; the result is sorted so that ``kT1 <= kT2``).  Starting points split
    the data at its quantiles 0.5, 0.25, 0.75, 0.05 and 0.95 (then random ones): data
    from a single exponential often have their likelihood maximum at a *small* cold
    or hot component, which only the extreme splits reach.  Each start gets a short
    EM warm-up and a Newton ascent (line search; the Hessian's eigenvalues taken in
    absolute value so that every step goes uphill; EM as the fallback when Newton
    cannot improve) on 512 groups of the sorted samples, each group stood for by its
    mean and count -- each component's log density is linear in the energy, so the
    grouped likelihood is close to the exact one and 20 times cheaper on 10,000
    samples.  The two best distinct maxima are then finished by Newton on the exact
    samples, so the result is the exact maximum likelihood estimate.  (EM alone
    converges linearly and crawls when the components overlap: thousands of passes on
    data from one exponential.)  On large data the starts run on a random subsample
    (``start_sample``); the finish always uses all samples.  Standard errors come from
    the observed information and assume independent samples.

The tests (goodness of fit, the likelihood-ratio test, :func:`compare_phases`) are in
:mod:`thermoswarm.analysis.phase_tests`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy import stats

from thermoswarm.analysis import _kernels as K
from thermoswarm.errors import InputError
from thermoswarm.maxent import EnergyLaw, EnergyMixture

__all__ = [
    "ExponentialFit",
    "ExponentialMixtureFit",
    "ks_statistic",
    "naive_ks",
]

#: A mixture whose smaller weight is below this, or whose two means differ by less than
#: this relative amount, has collapsed onto one exponential.
_DEGENERATE_WEIGHT = 1e-6
_DEGENERATE_RATIO = 1e-5
#: Starting points split the data at these quantiles (cold = below).  The extreme ones
#: reach the local maxima with a small component at either end, which the likelihood of
#: data from one exponential often has.
_START_QUANTILES = (0.5, 0.25, 0.75, 0.05, 0.95)
#: Above twice this many samples, the starts are explored on this many groups of sorted
#: samples (see ``_grouped``) before the exact finish.
_N_GROUPS = 512
#: Largest Newton step in the unconstrained coordinates (a trust radius).
_MAX_STEP = 2.0


def _as_samples(x: Any, name: str = "energies", min_n: int = 2) -> np.ndarray:
    """1-D float64 array of finite non-negative samples, or an InputError."""
    arr = np.asarray(x, dtype=np.float64).ravel()
    if arr.size < min_n:
        raise InputError(f"{name}: need at least {min_n} samples to fit, got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: {int((~np.isfinite(arr)).sum())} samples are NaN or infinite")
    if arr.min() < 0:
        raise InputError(f"{name}: must be non-negative, got a minimum of {arr.min():g}")
    if not arr.max() > 0:
        raise InputError(f"{name}: all samples are zero; no temperature can be fitted")
    return arr


def _rng(random_state: Any) -> np.random.Generator:
    if isinstance(random_state, np.random.Generator):
        return random_state
    return np.random.default_rng(random_state)


def ks_statistic(x: np.ndarray, law: EnergyLaw | EnergyMixture, *, presorted: bool = False):
    """Kolmogorov-Smirnov distance ``sup |F_n - F|`` between samples and a law.

    ``law`` is an :class:`~thermoswarm.maxent.EnergyLaw` or
    :class:`~thermoswarm.maxent.EnergyMixture`; ``x`` may be pre-sorted.
    """
    xs = np.asarray(x, dtype=np.float64).ravel()
    if not presorted:
        xs = np.sort(xs)
    if isinstance(law, EnergyMixture):
        return float(K.ks_sorted_mixture(xs, law.phi, law.kT1, law.kT2))
    return float(K.ks_sorted_exponential(xs, law.kT))


def naive_ks(x: np.ndarray, law: EnergyLaw | EnergyMixture, *, presorted: bool = False):
    """KS distance and the p-value that treats the fitted law as known in advance.

    This is the p-value of :func:`scipy.stats.kstest` (the exact Kolmogorov
    distribution :data:`scipy.stats.kstwo`).  With parameters fitted to the
    same data it is too large (the test is conservative and nearly powerless); it is
    reported because the paper reports it.  Returns ``(ks, p_value, n)``.
    """
    d = ks_statistic(x, law, presorted=presorted)
    n = int(np.size(x))
    return d, min(max(float(stats.kstwo.sf(d, n)), 0.0), 1.0), n


# --------------------------------------------------------------------------------------
# One exponential


class _FittedLaw:
    """What every fitted law shares: the fitted ``law_`` (pdf, cdf, logpdf, sample),
    likelihood, information criteria and the plot.  Subclasses set ``n_params`` and, in
    ``fit``, ``law_``, ``loglik_`` and ``n_``."""

    n_params: int
    law_: Any
    loglik_: float
    n_: int

    def pdf(self, x: Any) -> np.ndarray:
        return self.law_.pdf(x)

    def cdf(self, x: Any) -> np.ndarray:
        return self.law_.cdf(x)

    def logpdf(self, x: Any) -> np.ndarray:
        return self.law_.logpdf(x)

    def sample(self, rng: np.random.Generator, size: int | tuple[int, ...]) -> np.ndarray:
        return self.law_.sample(rng, size)

    def nllf(self, x: Any = None) -> float:
        """Negative log-likelihood of ``x`` (default: of the fitted data)."""
        if x is None:
            return -self.loglik_
        return float(-np.sum(self.logpdf(np.asarray(x, dtype=float))))

    def aic(self, x: Any = None) -> float:
        return 2.0 * self.nllf(x) + 2.0 * self.n_params

    def bic(self, x: Any = None) -> float:
        n = self.n_ if x is None else np.size(x)
        return 2.0 * self.nllf(x) + self.n_params * math.log(n)

    def density_curves(self, grid: Any, *, label_scale: float = 1.0) -> dict[str, Any]:
        """What a figure of the fit needs, on ``grid`` (the unit of the data).

        ``{"label": str, "total": pdf on grid, "components": [(weight, kT, weighted
        pdf on grid), ...]}`` -- one component for one exponential, two for a mixture
        that has not collapsed.  ``label_scale`` multiplies the temperatures in the
        label (e.g. 1e10 for J shown in 1e-10 J).
        """
        q = float(label_scale)
        grid = np.asarray(grid, dtype=np.float64)
        comps: list[tuple[float, float, np.ndarray]] = []
        if isinstance(self.law_, EnergyMixture):
            label = (
                f"2 phases: phi={self.phi_:.2f}, kT1={self.kT1_ * q:.3g}, kT2={self.kT2_ * q:.3g}"
            )
            if not getattr(self, "degenerate_", False):
                for w, k in ((self.phi_, self.kT1_), (1.0 - self.phi_, self.kT2_)):
                    comps.append((float(w), float(k), w * np.exp(-grid / k) / k))
        else:
            label = f"1 phase: kT={self.law_.kT * q:.3g}"
            comps.append((1.0, float(self.law_.kT), self.pdf(grid)))
        return {"label": label, "total": self.pdf(grid), "components": comps}

    def plot(self, ax: Any, x: Any = None, *, bins: int = 60) -> Any:
        """Draw the fitted density (and a histogram of ``x``) on log-y axes ``ax``.

        Uses only the axes' own methods (no figure module): the paper-style panels are
        in :mod:`thermoswarm.report.analysis_figures`.
        """
        hi = None
        if x is not None:
            xs = np.asarray(x, dtype=np.float64)
            xs = xs[np.isfinite(xs)]
            if xs.size:
                hi = float(np.quantile(xs, 0.999))
                dens, edges = np.histogram(xs, bins=bins, range=(0.0, hi), density=True)
                mid = 0.5 * (edges[1:] + edges[:-1])
                ax.plot(mid[dens > 0], dens[dens > 0], "o", ms=3, color="0.3", label="data")
        if hi is None or not hi > 0:
            hi = 5.0 * float(self.law_.mean())
        grid = np.linspace(0.0, hi, 400)
        curves = self.density_curves(grid)
        ax.plot(grid, curves["total"], "-", color="C3", label=curves["label"])
        if len(curves["components"]) > 1:
            for _, _, c in curves["components"]:
                ax.plot(grid, c, ":", color="C3", lw=1)
        ax.set_yscale("log")
        ax.set_ylabel("probability density")
        return ax


class ExponentialFit(_FittedLaw):
    """Maximum-likelihood fit of ``Exponential(mean kT)``: the one-phase law.

    ``kT_ = mean(x)``, ``kT_se_ = kT_ / sqrt(n)`` (independent samples).

    Attributes
    ----------
    kT_, kT_se_ : float
        Temperature (the mean, in the unit of ``x``) and its standard error.
    n_ : int
    loglik_ : float
        Maximised log-likelihood ``-n (log kT + 1)``.
    law_ : EnergyLaw
    """

    n_params = 1

    def fit(self, x: Any) -> ExponentialFit:
        """Fit to non-negative samples ``x``; returns ``self``."""
        x = _as_samples(x)
        n = x.size
        self.n_ = int(n)
        self.kT_ = float(x.mean())
        self.kT_se_ = self.kT_ / math.sqrt(n)
        self.loglik_ = -n * (math.log(self.kT_) + 1.0)
        self.law_ = EnergyLaw(self.kT_)
        return self

    @property
    def params(self) -> dict[str, float]:
        return {"kT": self.kT_}

    @property
    def se(self) -> dict[str, float]:
        return {"kT": self.kT_se_}

    def __repr__(self) -> str:
        if not hasattr(self, "kT_"):
            return "ExponentialFit()"
        return f"ExponentialFit(kT={self.kT_:.6g} +/- {self.kT_se_:.2g}, n={self.n_})"


# --------------------------------------------------------------------------------------
# Two exponentials


def _to_theta(p: tuple[float, float, float]) -> np.ndarray:
    phi, k1, k2 = p
    return np.array([math.log(phi) - math.log1p(-phi), math.log(k1), math.log(k2)])


def _from_theta(th: np.ndarray) -> tuple[float, float, float]:
    a = float(th[0])
    a = min(max(a, -700.0), 700.0)
    phi = 1.0 / (1.0 + math.exp(-a)) if a >= 0 else math.exp(a) / (1.0 + math.exp(a))
    u = min(max(float(th[1]), -50.0), 50.0)
    w = min(max(float(th[2]), -50.0), 50.0)
    return phi, math.exp(u), math.exp(w)


def _canonical(p: tuple[float, float, float]) -> tuple[float, float, float]:
    """The same mixture with the colder component first."""
    phi, k1, k2 = p
    return (phi, k1, k2) if k1 <= k2 else (1.0 - phi, k2, k1)


def _admissible(p: tuple[float, float, float]) -> bool:
    phi, k1, k2 = p
    return 1e-12 < phi < 1.0 - 1e-12 and 1e-9 < k1 < 1e9 and 1e-9 < k2 < 1e9


def _degenerate(p: tuple[float, float, float]) -> bool:
    phi, k1, k2 = p
    return min(phi, 1.0 - phi) < _DEGENERATE_WEIGHT or abs(math.log(k2 / k1)) < _DEGENERATE_RATIO


class _Samples:
    """Samples ``z`` (scaled energies), each counted ``c`` times (``None``: once)."""

    def __init__(self, z: np.ndarray, c: np.ndarray | None = None) -> None:
        self.z = z
        self.c = K.ONCE if c is None else c
        self.n = float(z.size if c is None else c.sum())

    def loglik(self, p: tuple[float, float, float]) -> float:
        return K.loglik(self.z, self.c, *p)

    def grad_hess(self, p: tuple[float, float, float]):
        return K.grad_hess(self.z, self.c, *p)

    def em(self, p: tuple[float, float, float], steps: int) -> tuple[float, float, float]:
        phi, k1, k2, _, _ = K.em_steps(self.z, self.c, *p, steps, 0.0)
        return phi, k1, k2


def _grouped(z: np.ndarray, n_groups: int) -> _Samples:
    """Sorted ``z`` in ``n_groups`` runs of equal count, each stood for by its mean.

    Within a group the log density is nearly linear in ``z`` (each component's is
    exactly linear), so the grouped likelihood is close to the exact one; it serves
    to explore the starting points cheaply, the exact data to finish.
    """
    zs = np.sort(z)
    edges = np.linspace(0, zs.size, n_groups + 1).astype(np.int64)
    counts = np.diff(edges).astype(np.float64)
    means = np.add.reduceat(zs, edges[:-1]) / counts
    return _Samples(means, counts)


def _maximise(data: _Samples, p: tuple[float, float, float], max_iter: int, tol: float):
    """Newton ascent with line search and EM fallback from ``p``.

    Returns ``(params, loglik, iterations, converged)``.
    """
    ll, g, H = data.grad_hess(p)
    # The log-likelihood is a sum of n terms: below ~1e-12 n its changes are rounding.
    tol = max(tol, 1e-12 * data.n)
    converged = False
    it = 0
    for it in range(1, max_iter + 1):  # noqa: B007 - ``it`` is returned
        if _degenerate(p):
            converged = True
            break
        w, V = np.linalg.eigh(-H)
        scale = max(float(np.abs(w).max()), 1.0)
        wabs = np.maximum(np.abs(w), 1e-10 * scale)
        step = V @ ((V.T @ g) / wabs)
        decrement = float(g @ step)
        if not np.isfinite(decrement):
            break
        if decrement < tol:
            converged = True
            break
        th = _to_theta(p)
        big = float(np.abs(step).max())
        t = 1.0 if big <= _MAX_STEP else _MAX_STEP / big
        new = None
        for _ in range(12):  # step halvings; then EM takes over
            cand = _from_theta(th + t * step)
            if _admissible(cand) and data.loglik(cand) > ll:
                new = cand
                break
            t *= 0.5
        if new is None:
            # Newton cannot go uphill (flat or curved ridge): EM always can, if anything.
            cand = data.em(p, 20)
            if not (_admissible(cand) and data.loglik(cand) > ll):
                converged = decrement < 1e3 * tol
                break
            new = cand
        p = new
        ll, g, H = data.grad_hess(p)
    return p, float(ll), it, converged


class ExponentialMixtureFit(_FittedLaw):
    """Maximum-likelihood two-phase law ``phi Exp(kT1) + (1 - phi) Exp(kT2)``, kT1 <= kT2.

    Parameters
    ----------
    n_starts
        Number of starting points: the splits of the data at its quantiles 0.5, 0.25,
        0.75, 0.05, 0.95 (component means = the means of the two parts), then random
        ones.  Each gets ``em_warmup`` EM iterations and a Newton ascent.
    max_iter
        Newton iterations per start at most.
    tol
        Convergence when the Newton decrement ``g^T |H|^-1 g`` (about twice the
        remaining log-likelihood gain) is below ``tol``.
    em_warmup
        EM iterations before Newton from each start.
    start_sample
        Above this many samples the starts run on a random subsample of this size; the
        best is then refined on all samples.
    n_polish
        Only the ``n_polish`` starts with the highest likelihood after the EM warm-up
        get the Newton ascent (``None``: all).  The bootstrap uses 1 to save time.
    random_state
        Seed or :class:`numpy.random.Generator` for the random starts and subsample.

    Attributes
    ----------
    phi_, kT1_, kT2_ : float
        Weight of the cold component and the two temperatures (unit of ``x``).
    phi_se_, kT1_se_, kT2_se_ : float
        Standard errors from the observed information (NaN when degenerate).
    cov_ : ndarray (3, 3)
        Covariance of ``(phi, kT1, kT2)``.
    loglik_ : float
    n_ : int
    n_iter_ : int
        Newton iterations of the final refinement.
    converged_ : bool
    degenerate_ : bool
        The fit collapsed onto one exponential (a weight below 1e-6 or equal means);
        then the one-phase law describes the data as well and the SEs are NaN.
    law_ : EnergyMixture
    """

    n_params = 3

    def __init__(
        self,
        n_starts: int = 7,
        *,
        max_iter: int = 100,
        tol: float = 1e-9,
        em_warmup: int = 10,
        start_sample: int = 50_000,
        n_polish: int | None = None,
        random_state: Any = None,
    ) -> None:
        self.n_starts = n_starts
        self.n_polish = n_polish
        self.max_iter = max_iter
        self.tol = tol
        self.em_warmup = em_warmup
        self.start_sample = start_sample
        self.random_state = random_state

    def _starts(self, work: np.ndarray, rng: np.random.Generator, init: Any) -> list:
        starts: list[tuple[float, float, float]] = []
        if init is not None:
            starts += [(float(p[0]), float(p[1]), float(p[2])) for p in init]
        n_target = len(starts) + max(self.n_starts, 1)
        for q in _START_QUANTILES:
            t = float(np.quantile(work, q))
            lo = work[work <= t]
            hi = work[work > t]
            if lo.size and hi.size:
                starts.append((q, max(float(lo.mean()), 1e-3), max(float(hi.mean()), 2e-3)))
        while len(starts) < n_target:
            starts.append(
                (
                    float(rng.uniform(0.1, 0.9)),
                    float(np.exp(rng.uniform(math.log(0.05), math.log(0.8)))),
                    float(np.exp(rng.uniform(math.log(1.2), math.log(5.0)))),
                )
            )
        return [p for p in starts if _admissible(p)][:n_target]

    def fit(self, x: Any, *, init: Any = None) -> ExponentialMixtureFit:
        """Fit to non-negative samples ``x``; returns ``self``.

        ``init``: optional ``(phi, kT1, kT2)`` (or several rows) tried first, in the unit
        of ``x``.
        """
        x = _as_samples(x, min_n=4)
        n = x.size
        rng = _rng(self.random_state)
        scale = float(x.mean())
        z = x / scale
        if init is not None:
            init = np.atleast_2d(np.asarray(init, dtype=float)).copy()
            init[:, 1:] /= scale
            init[:, 0] = np.clip(init[:, 0], 1e-6, 1 - 1e-6)
        work = z if n <= self.start_sample else z[rng.choice(n, self.start_sample, replace=False)]
        explore = _grouped(work, _N_GROUPS) if work.size > 2 * _N_GROUPS else _Samples(work)
        warmed = []
        for p0 in self._starts(work, rng, init):
            p = explore.em(p0, self.em_warmup)
            p = p if _admissible(p) else p0
            warmed.append((explore.loglik(p), p))
        warmed.sort(key=lambda item: -item[0])
        if self.n_polish is not None:
            warmed = warmed[: max(1, self.n_polish)]
        found = []
        for _, p in warmed:
            p, ll, it, conv = _maximise(explore, p, self.max_iter, self.tol)
            found.append((ll, p))
        # Finish the two best (distinct) maxima on the exact samples.
        found.sort(key=lambda item: -item[0])
        finals = [found[0][1]]
        first = _to_theta(_canonical(finals[0]))
        for _, p in found[1:]:
            if np.abs(_to_theta(_canonical(p)) - first).max() > 1e-3:
                finals.append(p)
                break
        exact = _Samples(z)
        best = None
        for p in finals:
            res = _maximise(exact, p, self.max_iter, self.tol)
            if best is None or res[1] > best[1]:
                best = res
        assert best is not None
        p, ll, it, conv = best
        phi, k1, k2 = _canonical(p)
        self.n_ = int(n)
        self.phi_ = float(phi)
        self.kT1_ = float(k1 * scale)
        self.kT2_ = float(k2 * scale)
        self.loglik_ = float(K.loglik(z, K.ONCE, phi, k1, k2) - n * math.log(scale))
        self.n_iter_ = int(it)
        self.converged_ = bool(conv)
        self.degenerate_ = _degenerate((phi, k1, k2))
        self.cov_ = np.full((3, 3), np.nan)
        if not self.degenerate_:
            _, _, H = K.grad_hess(z, K.ONCE, phi, k1, k2)
            try:
                cov_theta = np.linalg.inv(-H)
            except np.linalg.LinAlgError:
                cov_theta = None
            if cov_theta is not None and np.all(np.linalg.eigvalsh(-H) > 0):
                J = np.diag([phi * (1 - phi), k1 * scale, k2 * scale])
                self.cov_ = J @ cov_theta @ J
        se = np.sqrt(np.diag(self.cov_))
        self.phi_se_, self.kT1_se_, self.kT2_se_ = (float(v) for v in se)
        self.law_ = EnergyMixture(self.phi_, self.kT1_, self.kT2_)
        return self

    @property
    def params(self) -> dict[str, float]:
        return {"phi": self.phi_, "kT1": self.kT1_, "kT2": self.kT2_}

    @property
    def se(self) -> dict[str, float]:
        return {"phi": self.phi_se_, "kT1": self.kT1_se_, "kT2": self.kT2_se_}

    def predict_proba(self, x: Any) -> np.ndarray:
        """Posterior probability that each sample belongs to the hot phase (kT2)."""
        return self.law_.responsibility(x)

    def __repr__(self) -> str:
        if not hasattr(self, "phi_"):
            return f"ExponentialMixtureFit(n_starts={self.n_starts})"
        return (
            f"ExponentialMixtureFit(phi={self.phi_:.4g}, kT1={self.kT1_:.6g}, "
            f"kT2={self.kT2_:.6g}, n={self.n_})"
        )
