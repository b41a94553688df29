"""Adaptive constant-velocity Kalman filters, batched over tracks.

State ``x = (x, y, vx, vy)`` in px and px per frame, one filter per track, stacked as
arrays ``x (n, 4)`` and ``P (n, 4, 4)``.  The motion model is constant velocity with
white-noise acceleration of intensity ``q`` (px^2 per frame^3) per track:
``Q = q [[1/3, 1/2], [1/2, 1]]`` per axis for one frame.  Measurements are positions
with noise ``R = r^2 I`` (px^2).

Adaptation (the "adaptive" of the paper's adaptive Kalman filter): each track's ``q``
follows its innovations.  For a consistent filter the normalised innovation squared
``nis = v' S^-1 v`` has mean 2 (the measurement dimension).  After each update the
running mean ``m <- (1 - nis_rate) m + nis_rate nis`` is formed; a mean above 2 says
that the ant changes speed or direction more than the filter assumes, below 2 that it
moves more steadily, and ``q`` is multiplied by ``(m / 2)^(gain * nis_rate)`` and kept
within ``[q_min, q_max]`` (a small step each update, so ``q`` follows ``m`` over about
``1 / nis_rate`` updates; covariance matching on the innovations, Mehra 1972, Mohamed &
Schwarz 1999).  Ants switch between slow and fast phases, so a
fixed ``q`` is either too stiff for fast ants or too loose for slow ones.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["KalmanParams", "predict", "update", "innovation", "initial_state"]

_F = np.array([[1.0, 0, 1, 0], [0, 1, 0, 1], [0, 0, 1, 0], [0, 0, 0, 1]])
_Q1 = np.array([[1 / 3, 0, 1 / 2, 0], [0, 1 / 3, 0, 1 / 2], [1 / 2, 0, 1, 0], [0, 1 / 2, 0, 1]])
_EYE2 = np.eye(2)
_EYE4 = np.eye(4)


@dataclass(frozen=True)
class KalmanParams:
    """Noise levels of the filters (px, frames).

    ``r``: measurement noise sd (px); ``q0``: initial acceleration intensity
    (px^2/frame^3); ``q_min``/``q_max``: its bounds; ``v0``: sd of the unknown initial
    velocity (px/frame); ``nis_rate``: weight of the newest ``nis`` in its running mean;
    ``gain``: exponent of the adaptation (0 switches it off).
    """

    r: float = 1.0
    q0: float = 0.3
    q_min: float = 0.01
    q_max: float = 10.0
    v0: float = 3.0
    nis_rate: float = 0.2
    gain: float = 0.5


def initial_state(z: np.ndarray, p: KalmanParams) -> tuple[np.ndarray, np.ndarray]:
    """States and covariances ``(m, 4)``, ``(m, 4, 4)`` of new tracks at positions ``z``."""
    z = np.asarray(z, dtype=np.float64).reshape(-1, 2)
    m = z.shape[0]
    x = np.zeros((m, 4))
    x[:, :2] = z
    P = np.zeros((m, 4, 4))
    P[:, 0, 0] = P[:, 1, 1] = p.r**2
    P[:, 2, 2] = P[:, 3, 3] = p.v0**2
    return x, P


def predict(x: np.ndarray, P: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One frame ahead: ``x' = F x``, ``P' = F P F' + q Q1`` (new arrays).

    ``F`` has entries 0 and 1, so ``F x`` and ``F P F'`` are sums of two entries: the
    same numbers as the matrix products, in four array additions (the products cost
    more than the arithmetic at tens of tracks).
    """
    x = np.array(x, dtype=np.float64)
    P = np.array(P, dtype=np.float64)
    x[:, :2] += x[:, 2:]
    P[:, :2, :] += P[:, 2:, :]  # F P
    P[:, :, :2] += P[:, :, 2:]  # (F P) F'
    P += np.asarray(q, dtype=np.float64)[:, None, None] * _Q1
    return x, P


def innovation(
    x: np.ndarray, P: np.ndarray, r: float | np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Predicted positions ``(n, 2)`` and innovation covariances ``S (n, 2, 2)`` for
    measurement noise sd ``r`` (a number or one per row)."""
    r2 = np.broadcast_to(np.asarray(r, dtype=np.float64) ** 2, (x.shape[0],))
    S = P[:, :2, :2] + r2[:, None, None] * np.eye(2)
    return x[:, :2], S


def update(
    x: np.ndarray, P: np.ndarray, z: np.ndarray, r: float | np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Kalman update with positions ``z (n, 2)`` of noise sd ``r`` (px; a number or one
    per row); returns ``x, P, nis`` (Joseph form)."""
    n = x.shape[0]
    r2 = np.broadcast_to(np.asarray(r, dtype=np.float64) ** 2, (n,))[:, None, None]
    S = P[:, :2, :2] + r2 * _EYE2
    v = z - x[:, :2]
    Sinv = np.linalg.inv(S)
    # H selects (x, y): P H' is P's first two columns and K H is K followed by two
    # columns of zeros, so both are formed without a product (the same numbers).
    K = np.ascontiguousarray(P[:, :, :2]) @ Sinv  # (n, 4, 2)
    x = x + np.einsum("nij,nj->ni", K, v)
    IKH = np.broadcast_to(_EYE4, (n, 4, 4)).copy()
    IKH[:, :, :2] -= K
    P = IKH @ P @ IKH.transpose(0, 2, 1) + r2 * K @ K.transpose(0, 2, 1)
    nis = np.einsum("ni,nij,nj->n", v, Sinv, v)
    return x, P, nis


def adapt(
    q: np.ndarray, nis_mean: np.ndarray, nis: np.ndarray, p: KalmanParams
) -> tuple[np.ndarray, np.ndarray]:
    """New process-noise intensities and running mean NIS after an update:
    ``m' = (1 - nis_rate) m + nis_rate nis``, ``q' = clip(q (m' / 2)^(gain nis_rate),
    q_min, q_max)``."""
    nis_mean = (1 - p.nis_rate) * nis_mean + p.nis_rate * nis
    q = np.clip(q * (nis_mean / 2.0) ** (p.gain * p.nis_rate), p.q_min, p.q_max)
    return q, nis_mean
