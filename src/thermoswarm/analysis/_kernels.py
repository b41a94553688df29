"""Numba kernels for the two-component exponential mixture.

Hand-written because no light library fits a mixture of exponentials (scikit-learn's
``GaussianMixture`` is Gaussian only; ``pomegranate`` pulls PyTorch).  Every kernel
works on energies divided by their mean (``z = x / mean(x)``), so the numbers stay
near 1 whatever the unit (mm^2/s^2 or joules).

Parameters are ``phi`` (weight of component 1), ``k1``, ``k2`` (the component means).
The Newton kernels use the unconstrained coordinates ``theta = (logit phi, log k1,
log k2)``.  With ``r`` the posterior probability of component 2 and
``d1 = (1 - phi, z/k1 - 1, 0)``, ``d2 = (-phi, 0, z/k2 - 1)`` the score vectors of the
two components' log densities, one sample contributes

    g = (1 - r) d1 + r d2
    H = (1 - r) (D1 + d1 d1^T) + r (D2 + d2 d2^T) - g g^T

with ``D1 = diag(-phi (1 - phi), -z/k1, 0)`` and ``D2 = diag(-phi (1 - phi), 0, -z/k2)``
(the second derivatives of the components' log densities).

The likelihood kernels take counts ``c`` (sample ``i`` stands for ``c[i]`` samples, as
in the grouped data of the starting-point search); pass :data:`ONCE` (empty) when each
sample counts once.  Multiplying by 1.0 is exact, so both uses share one code path.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Counts meaning "every sample once" (see the module docstring).
ONCE = np.empty(0)


@njit(inline="always")
def _count(c, i):  # pragma: no cover - compiled
    return 1.0 if c.size == 0 else c[i]


@njit(cache=True, nogil=True)
def responsibility(z, phi, k1, k2):  # pragma: no cover - compiled
    """Posterior probability of component 2 for each sample."""
    lp1 = math.log(phi) - math.log(k1)
    lp2 = math.log1p(-phi) - math.log(k2)
    i1 = 1.0 / k1
    i2 = 1.0 / k2
    out = np.empty(z.size)
    for i in range(z.size):
        d = (lp1 - z[i] * i1) - (lp2 - z[i] * i2)
        if d > 0:
            e = math.exp(-d)
            out[i] = e / (1.0 + e)
        else:
            out[i] = 1.0 / (1.0 + math.exp(d))
    return out


@njit(cache=True, nogil=True)
def ks_sorted_mixture(zs, phi, k1, k2):  # pragma: no cover - compiled
    """Kolmogorov-Smirnov distance of sorted ``zs`` from the mixture's CDF."""
    n = zs.size
    d = 0.0
    for i in range(n):
        c = 1.0 - phi * math.exp(-zs[i] / k1) - (1.0 - phi) * math.exp(-zs[i] / k2)
        dp = (i + 1.0) / n - c
        dm = c - i / n
        if dp > d:
            d = dp
        if dm > d:
            d = dm
    return d


@njit(cache=True, nogil=True)
def ks_sorted_exponential(zs, k):  # pragma: no cover - compiled
    """Kolmogorov-Smirnov distance of sorted ``zs`` from ``Exponential(mean k)``."""
    n = zs.size
    d = 0.0
    for i in range(n):
        c = -math.expm1(-zs[i] / k)
        dp = (i + 1.0) / n - c
        dm = c - i / n
        if dp > d:
            d = dp
        if dm > d:
            d = dm
    return d


# --------------------------------------------------------------------------------------


@njit(cache=True, nogil=True)
def em_steps(z, c, phi, k1, k2, n_steps, tol):  # pragma: no cover - compiled
    """Run up to ``n_steps`` EM iterations; stop when the log-likelihood gain < ``tol``.

    Returns ``(phi, k1, k2, loglik, steps)`` where ``loglik`` is that of the returned
    parameters' predecessor (the last E-step); callers that need the exact value
    call :func:`loglik`.
    """
    n = 0.0
    sz = 0.0
    for i in range(z.size):
        ci = _count(c, i)
        n += ci
        sz += ci * z[i]
    ll_old = -np.inf
    ll = -np.inf
    steps = 0
    for _ in range(n_steps):
        lp1 = math.log(phi) - math.log(k1)
        lp2 = math.log1p(-phi) - math.log(k2)
        i1 = 1.0 / k1
        i2 = 1.0 / k2
        ll = 0.0
        sr = 0.0
        srz = 0.0
        for i in range(z.size):
            ci = _count(c, i)
            a = lp1 - z[i] * i1
            b = lp2 - z[i] * i2
            if a > b:
                e = math.exp(b - a)
                ll += ci * (a + math.log1p(e))
                r = e / (1.0 + e)
            else:
                e = math.exp(a - b)
                ll += ci * (b + math.log1p(e))
                r = 1.0 / (1.0 + e)
            sr += ci * r
            srz += ci * r * z[i]
        if ll - ll_old < tol:
            break
        ll_old = ll
        steps += 1
        if sr <= 0.0 or sr >= n:
            break
        phi_new = 1.0 - sr / n
        k1_new = (sz - srz) / (n - sr)
        k2_new = srz / sr
        if not (0.0 < phi_new < 1.0 and k1_new > 0.0 and k2_new > 0.0):
            break
        phi, k1, k2 = phi_new, k1_new, k2_new
    return phi, k1, k2, ll, steps


@njit(cache=True, nogil=True)
def loglik(z, c, phi, k1, k2):  # pragma: no cover - compiled
    """Log-likelihood of the mixture at ``z`` (counts ``c``)."""
    lp1 = math.log(phi) - math.log(k1)
    lp2 = math.log1p(-phi) - math.log(k2)
    i1 = 1.0 / k1
    i2 = 1.0 / k2
    ll = 0.0
    for i in range(z.size):
        ci = _count(c, i)
        a = lp1 - z[i] * i1
        b = lp2 - z[i] * i2
        if a > b:
            ll += ci * (a + math.log1p(math.exp(b - a)))
        else:
            ll += ci * (b + math.log1p(math.exp(a - b)))
    return ll


@njit(cache=True, nogil=True)
def grad_hess(z, c, phi, k1, k2):  # pragma: no cover - compiled
    """Log-likelihood, gradient (3,) and Hessian (3, 3) in ``theta`` coordinates."""
    lp1 = math.log(phi) - math.log(k1)
    lp2 = math.log1p(-phi) - math.log(k2)
    i1 = 1.0 / k1
    i2 = 1.0 / k2
    pq = phi * (1.0 - phi)
    ll = 0.0
    g0 = g1 = g2 = 0.0
    h00 = h01 = h02 = h11 = h12 = h22 = 0.0
    d1a = 1.0 - phi
    d2a = -phi
    for i in range(z.size):
        zi = z[i]
        ci = _count(c, i)
        a = lp1 - zi * i1
        b = lp2 - zi * i2
        if a > b:
            e = math.exp(b - a)
            ll += ci * (a + math.log1p(e))
            r = e / (1.0 + e)
        else:
            e = math.exp(a - b)
            ll += ci * (b + math.log1p(e))
            r = 1.0 / (1.0 + e)
        s = 1.0 - r
        d1u = zi * i1 - 1.0
        d2w = zi * i2 - 1.0
        ga = s * d1a + r * d2a
        gu = s * d1u
        gw = r * d2w
        g0 += ci * ga
        g1 += ci * gu
        g2 += ci * gw
        h00 += ci * (-pq + s * d1a * d1a + r * d2a * d2a - ga * ga)
        h01 += ci * (s * d1a * d1u - ga * gu)
        h02 += ci * (r * d2a * d2w - ga * gw)
        h11 += ci * (s * (d1u * d1u - zi * i1) - gu * gu)
        h12 += ci * (-gu * gw)
        h22 += ci * (r * (d2w * d2w - zi * i2) - gw * gw)
    g = np.empty(3)
    g[0] = g0
    g[1] = g1
    g[2] = g2
    H = np.empty((3, 3))
    H[0, 0] = h00
    H[0, 1] = H[1, 0] = h01
    H[0, 2] = H[2, 0] = h02
    H[1, 1] = h11
    H[1, 2] = H[2, 1] = h12
    H[2, 2] = h22
    return ll, g, H
