"""The law: maximum-entropy distributions of energy, speed and steering.

Maximising the entropy ``-sum p ln p`` under a fixed mean energy ``<x> = E`` gives
``p(x) = exp(-x / E) / E`` with ``E = kT`` (Jaynes 1957).  The paper applies this one
law to different variables:

- energy ``E = v^2 / 2``: exponential with mean ``kT`` (:class:`EnergyLaw`);
- speed ``v = sqrt(2E / m)``: Rayleigh, the 2D Maxwell-Boltzmann law (:class:`SpeedLaw`);
- ant energy: a two-component exponential mixture (:class:`EnergyMixture`);
- steering-angle rate: signed exponential (Laplace) with temperature ``kT_theta(v)``
  (:class:`SteeringLaw`, :class:`DecayingTemperature`);
- heading: uniform, or normal around a goal direction (:class:`UniformHeading`,
  :class:`NormalHeading`).

Speeds are sampled through the energy: ``E ~ Exponential(kT)``, ``v = sqrt(2E)``
(Rayleigh; the paper's literal speed density, normalised, is
:class:`HalfNormalSpeed`).  The steering law applies to ``|rate|`` with a random sign.

Units: energies per unit mass in mm^2/s^2 (multiply by a mass for joules), speeds in
mm/s, angles in radians, rates in rad/s.  This module imports nothing of thermoswarm
and does no I/O.  Every object is a frozen dataclass with ``pdf``, ``cdf``, ``sample``
and ``mean``; sampling takes a :class:`numpy.random.Generator`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, stats

__all__ = [
    "EnergyLaw",
    "SpeedLaw",
    "HalfNormalSpeed",
    "EnergyMixture",
    "SteeringLaw",
    "DecayingTemperature",
    "UniformHeading",
    "NormalHeading",
    "speed_law",
    "kT_for_mean_speed",
    "wrap_angle",
    "jaynes",
    "maxent_density",
    "fit_temperature",
]

ArrayLike = float | np.ndarray


def _positive(name: str, value: float) -> None:
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive number, got {value!r}")


def wrap_angle(a: ArrayLike) -> ArrayLike:
    """Wrap angles (radians) into ``[-pi, pi)``."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


class _FromScipy:
    """pdf, logpdf and cdf of the frozen SciPy law ``self.dist`` (a property)."""

    def pdf(self, x: ArrayLike) -> ArrayLike:
        return self.dist.pdf(x)

    def logpdf(self, x: ArrayLike) -> ArrayLike:
        return self.dist.logpdf(x)

    def cdf(self, x: ArrayLike) -> ArrayLike:
        return self.dist.cdf(x)


@dataclass(frozen=True)
class _Speed(_FromScipy):
    """A speed law of scale ``sigma = sqrt(kT / m)``."""

    kT: float
    mass: float = 1.0

    def __post_init__(self) -> None:
        _positive("kT", self.kT)
        _positive("mass", self.mass)

    @property
    def sigma(self) -> float:
        return math.sqrt(self.kT / self.mass)


@dataclass(frozen=True)
class EnergyLaw(_FromScipy):
    """Energy ``E ~ Exponential(mean kT)``: the maximum-entropy law for a mean energy.

    ``pdf(E) = exp(-E / kT) / kT`` for ``E >= 0``.
    """

    kT: float

    def __post_init__(self) -> None:
        _positive("kT", self.kT)

    @property
    def dist(self) -> stats.rv_continuous:
        return stats.expon(scale=self.kT)

    def mean(self) -> float:
        return self.kT

    def sample(self, rng: np.random.Generator, size: int | tuple[int, ...] | None = None):
        return rng.exponential(self.kT, size)


@dataclass(frozen=True)
class SpeedLaw(_Speed):
    """Speed of a robot or particle whose energy ``m v^2 / 2`` is ``Exponential(kT)``.

    ``v = sqrt(2 E / m)`` is Rayleigh with scale ``sigma = sqrt(kT / m)``: the 2D
    Maxwell-Boltzmann speed law.  ``mean = sigma sqrt(pi / 2)``, ``<v^2> = 2 kT / m``.
    """

    @property
    def dist(self) -> stats.rv_continuous:
        return stats.rayleigh(scale=self.sigma)

    def mean(self) -> float:
        return self.sigma * math.sqrt(math.pi / 2)

    def mean_square(self) -> float:
        return 2 * self.kT / self.mass

    def sample(self, rng: np.random.Generator, size: int | tuple[int, ...] | None = None):
        # Draw the energy, then v = sqrt(2E/m): the same law, and the draw that the
        # energy analysis sees.  In place: no temporaries for millions of robots.
        v = rng.standard_exponential(size)
        v *= 2.0 * self.kT / self.mass
        return np.sqrt(v, out=v) if isinstance(v, np.ndarray) else float(np.sqrt(v))


@dataclass(frozen=True)
class HalfNormalSpeed(_Speed):
    """The literal reading of the paper's formula, normalised: ``v ~ |N(0, kT / m)|``.

    Offered as an option only; its energy is *not* exponential (it is a Gamma(1/2) law).
    """

    @property
    def dist(self) -> stats.rv_continuous:
        return stats.halfnorm(scale=self.sigma)

    def mean(self) -> float:
        return self.sigma * math.sqrt(2 / math.pi)

    def mean_square(self) -> float:
        return self.kT / self.mass

    def sample(self, rng: np.random.Generator, size: int | tuple[int, ...] | None = None):
        return np.abs(rng.standard_normal(size)) * self.sigma


def speed_law(kind: str, kT: float, mass: float = 1.0) -> SpeedLaw | HalfNormalSpeed:
    """``"boltzmann"`` (Rayleigh, the default) or ``"half-normal"``."""
    if kind == "boltzmann":
        return SpeedLaw(kT, mass)
    if kind == "half-normal":
        return HalfNormalSpeed(kT, mass)
    raise ValueError(f"speed law must be 'boltzmann' or 'half-normal', got {kind!r}")


def kT_for_mean_speed(mean_speed: float, kind: str = "boltzmann", mass: float = 1.0) -> float:
    """The ``kT`` whose speed law has the given mean speed (mm/s)."""
    _positive("mean_speed", mean_speed)
    if kind == "boltzmann":
        return mass * (mean_speed / math.sqrt(math.pi / 2)) ** 2
    if kind == "half-normal":
        return mass * (mean_speed / math.sqrt(2 / math.pi)) ** 2
    raise ValueError(f"speed law must be 'boltzmann' or 'half-normal', got {kind!r}")


@dataclass(frozen=True)
class EnergyMixture:
    """Two-phase energy law ``phi Exp(kT1) + (1 - phi) Exp(kT2)``.

    Component 1 is the paper's low-temperature "liquid" phase and component 2 the
    high-temperature "gas" phase when ``kT1 < kT2``.
    """

    phi: float
    kT1: float
    kT2: float

    def __post_init__(self) -> None:
        if not (0.0 <= self.phi <= 1.0):
            raise ValueError(f"phi must be in [0, 1], got {self.phi!r}")
        _positive("kT1", self.kT1)
        _positive("kT2", self.kT2)

    def pdf(self, x: ArrayLike) -> ArrayLike:
        x = np.asarray(x, dtype=float)
        out = self.phi * np.exp(-x / self.kT1) / self.kT1
        out = out + (1 - self.phi) * np.exp(-x / self.kT2) / self.kT2
        return np.where(x >= 0, out, 0.0)

    def logpdf(self, x: ArrayLike) -> ArrayLike:
        x = np.asarray(x, dtype=float)
        with np.errstate(divide="ignore"):
            a = np.log(self.phi) - np.log(self.kT1) - x / self.kT1
            b = np.log1p(-self.phi) - np.log(self.kT2) - x / self.kT2
        return np.where(x >= 0, np.logaddexp(a, b), -np.inf)

    def cdf(self, x: ArrayLike) -> ArrayLike:
        x = np.maximum(np.asarray(x, dtype=float), 0.0)
        return 1.0 - self.phi * np.exp(-x / self.kT1) - (1 - self.phi) * np.exp(-x / self.kT2)

    def mean(self) -> float:
        return self.phi * self.kT1 + (1 - self.phi) * self.kT2

    def responsibility(self, x: ArrayLike) -> ArrayLike:
        """Posterior probability that a sample of energy ``x`` belongs to component 2."""
        x = np.asarray(x, dtype=float)
        a = np.log(self.phi) - np.log(self.kT1) - x / self.kT1 if self.phi > 0 else -np.inf
        b = np.log1p(-self.phi) - np.log(self.kT2) - x / self.kT2 if self.phi < 1 else -np.inf
        return np.exp(b - np.logaddexp(a, b))

    def sample(self, rng: np.random.Generator, size: int | tuple[int, ...] | None = None):
        which = rng.random(size) < self.phi
        e = rng.standard_exponential(size)
        return e * np.where(which, self.kT1, self.kT2)


@dataclass(frozen=True)
class DecayingTemperature:
    """A steering temperature falling with speed: ``T(v) = T_min + (T_max - T_min) e^{-v/v_s}``.

    Units: rad/s for the temperatures (the mean ``|rate|``), mm/s for ``v_scale``.
    """

    T_max: float
    T_min: float
    v_scale: float

    def __post_init__(self) -> None:
        _positive("T_max", self.T_max)
        _positive("T_min", self.T_min)
        _positive("v_scale", self.v_scale)
        if self.T_min > self.T_max:
            raise ValueError(f"T_min ({self.T_min}) must not exceed T_max ({self.T_max})")

    def __call__(self, v: ArrayLike) -> ArrayLike:
        return self.T_min + (self.T_max - self.T_min) * np.exp(-np.asarray(v) / self.v_scale)


@dataclass(frozen=True)
class SteeringLaw:
    """Steering-angle rate ``w`` with ``|w| ~ Exponential(kT_theta(v))`` and a random sign.

    The paper's one-sided density applied to the magnitude (PAPER_NOTES section 6.4):
    ``pdf(w | v) = exp(-|w| / T) / (2 T)`` with ``T = kT_theta(v)`` (a Laplace law).
    ``kT_theta`` is a number or a callable of speed (e.g. :class:`DecayingTemperature`).
    """

    kT_theta: float | Callable[[ArrayLike], ArrayLike] = field(default=1.0)

    def temperature(self, speed: ArrayLike = 0.0) -> ArrayLike:
        T = self.kT_theta(speed) if callable(self.kT_theta) else self.kT_theta
        T = np.asarray(T, dtype=float)
        if np.any(~np.isfinite(T) | (T <= 0)):
            raise ValueError("kT_theta must be positive")
        return T

    def pdf(self, rate: ArrayLike, speed: ArrayLike = 0.0) -> ArrayLike:
        T = self.temperature(speed)
        return np.exp(-np.abs(rate) / T) / (2 * T)

    def cdf(self, rate: ArrayLike, speed: ArrayLike = 0.0) -> ArrayLike:
        return stats.laplace.cdf(rate, scale=self.temperature(speed))

    def mean(self, speed: ArrayLike = 0.0) -> ArrayLike:
        """Mean of the signed rate: 0.  See :meth:`mean_abs` for the temperature."""
        return np.zeros_like(np.asarray(self.temperature(speed)))

    def mean_abs(self, speed: ArrayLike = 0.0) -> ArrayLike:
        return self.temperature(speed)

    def sample(
        self,
        rng: np.random.Generator,
        speed: ArrayLike = 0.0,
        size: int | tuple[int, ...] | None = None,
    ):
        T = self.temperature(speed)
        if size is None:
            size = np.shape(T) if np.ndim(T) else None
        mag = rng.standard_exponential(size) * T
        sign = np.where(rng.random(size) < 0.5, -1.0, 1.0)
        return sign * mag


@dataclass(frozen=True)
class UniformHeading(_FromScipy):
    """Heading uniform on ``[low, high)`` radians (default the whole circle)."""

    low: float = -math.pi
    high: float = math.pi

    def __post_init__(self) -> None:
        if not self.high > self.low:
            raise ValueError(f"high ({self.high}) must exceed low ({self.low})")

    @property
    def dist(self) -> stats.rv_continuous:
        return stats.uniform(loc=self.low, scale=self.high - self.low)

    def mean(self) -> float:
        return 0.5 * (self.low + self.high)

    def sample(self, rng: np.random.Generator, size: int | tuple[int, ...] | None = None):
        return rng.uniform(self.low, self.high, size)


@dataclass(frozen=True)
class NormalHeading:
    """Heading ``N(mean, sigma)`` wrapped onto the circle ``[-pi, pi)``.

    The narrow-road law (PAPER_NOTES section 6.2): mean 0 for one group, pi for the
    other; ``sigma`` in radians is a parameter the paper does not give.
    """

    mean_angle: float = 0.0
    sigma: float = math.pi / 4

    def __post_init__(self) -> None:
        _positive("sigma", self.sigma)

    def pdf(self, a: ArrayLike) -> ArrayLike:
        """Wrapped-normal density (sum over enough images of the circle)."""
        a = wrap_angle(np.asarray(a, dtype=float) - self.mean_angle)
        k = np.arange(
            -(int(3 * self.sigma / (2 * np.pi)) + 2), int(3 * self.sigma / (2 * np.pi)) + 3
        )
        terms = stats.norm.pdf(a[..., None] + 2 * np.pi * k, scale=self.sigma)
        return terms.sum(axis=-1)

    def cdf(self, a: ArrayLike) -> ArrayLike:
        """CDF on ``[-pi, pi)`` measured from ``-pi`` (numerical integral of the pdf)."""
        a = np.asarray(a, dtype=float)
        grid = np.linspace(-np.pi, np.pi, 4097)
        dens = self.pdf(grid)
        c = np.concatenate([[0.0], np.cumsum((dens[1:] + dens[:-1]) / 2 * np.diff(grid))])
        return np.interp(wrap_angle(a), grid, c / c[-1])

    def mean(self) -> float:
        return float(wrap_angle(self.mean_angle))

    def sample(self, rng: np.random.Generator, size: int | tuple[int, ...] | None = None):
        return wrap_angle(self.mean_angle + self.sigma * rng.standard_normal(size))


def jaynes(energies: np.ndarray, mean_energy: float) -> tuple[np.ndarray, float]:
    """Solve Jaynes' problem on discrete states: maximise entropy subject to ``<e> = E``.

    Returns the Boltzmann probabilities ``p_i = exp(-beta e_i) / Z`` and ``beta = 1/kT``
    (``beta`` may be negative when ``E`` exceeds the mean of the states).

    Raises ``ValueError`` when ``E`` is outside ``(min e, max e)``.
    """
    e = np.asarray(energies, dtype=float).ravel()
    if e.size < 2 or not np.all(np.isfinite(e)):
        raise ValueError("need at least two finite state energies")
    lo, hi = e.min(), e.max()
    if not (lo < mean_energy < hi):
        raise ValueError(f"mean_energy must lie strictly between {lo} and {hi}")
    scale = max(hi - lo, 1e-300)
    x = (e - lo) / scale
    target = (mean_energy - lo) / scale

    def mean_at(b: float) -> float:
        w = np.exp(-b * (x - (x.min() if b > 0 else x.max())))
        return float((w * x).sum() / w.sum()) - target

    b_lo, b_hi = -1.0, 1.0
    while mean_at(b_lo) < 0:
        b_lo *= 2
    while mean_at(b_hi) > 0:
        b_hi *= 2
    b = optimize.brentq(mean_at, b_lo, b_hi, xtol=1e-14, rtol=1e-14)
    w = np.exp(-b * (x - (x.min() if b > 0 else x.max())))
    return w / w.sum(), b / scale


def maxent_density(mean_energy: float) -> EnergyLaw:
    """The continuous closed form on ``[0, inf)``: mean ``E`` gives ``Exponential(E)``."""
    return EnergyLaw(kT=float(mean_energy))


def fit_temperature(samples: np.ndarray) -> tuple[float, float]:
    """Maximum-likelihood ``kT`` of exponential samples and its standard error.

    ``kT_hat = mean(x)``; ``se = kT_hat / sqrt(n)``.  NaNs are ignored; negative values
    are an error (energies are non-negative).
    """
    x = np.asarray(samples, dtype=float).ravel()
    x = x[np.isfinite(x)]
    if x.size == 0:
        raise ValueError("no finite samples")
    if np.any(x < 0):
        raise ValueError("energies must be non-negative")
    kT = float(x.mean())
    return kT, kT / math.sqrt(x.size)
