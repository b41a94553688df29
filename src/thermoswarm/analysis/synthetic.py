"""Trajectories drawn from known laws, for tests, benchmarks and checking an analysis.

Each step ``k`` of each track draws an energy ``E_k`` from the energy law (one or two
phases), moves at ``v_k = sqrt(2 E_k)`` (per unit mass; ``sqrt(2 E_k / m)`` with a
mass) for ``dt_k`` seconds, after turning by ``w_k`` times the spacing of the step
midpoints, where ``|w_k| ~ Exponential(kT_theta(v_k))`` with a random sign
(:class:`~thermoswarm.maxent.SteeringLaw`).  This is exactly the convention of
:func:`thermoswarm.analysis.kinematics.compute_kinematics`, so the kinematics recover
``v_k`` and ``w_k`` to rounding error, and the fits see samples of the laws.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.maxent import EnergyLaw, EnergyMixture, SteeringLaw
from thermoswarm.tracks import make_tracks

__all__ = ["synthetic_tracks"]


def synthetic_tracks(
    n_individuals: int,
    n_frames: int,
    *,
    energy: EnergyLaw | EnergyMixture,
    steering: SteeringLaw | None = None,
    fps: float = 30.0,
    time: np.ndarray | None = None,
    mass: float | None = None,
    start: np.ndarray | None = None,
    rng: np.random.Generator | int | None = None,
) -> tuple[xr.Dataset, dict[str, Any]]:
    """Tracks whose steps follow known energy and steering laws.

    Parameters
    ----------
    n_individuals, n_frames
        Number of tracks and of position samples per track (``n_frames - 1`` steps).
    energy
        Law of the step energies: per unit mass in mm^2/s^2, or in J with ``mass``.
    steering
        Law of the steering rate given the speed (mm/s); ``None``: the heading of each
        step is uniform on the circle (a gas).
    fps, time
        Regular sampling at ``fps``, or sample times in seconds (``n_frames``,
        increasing).
    mass
        kg; then ``v = sqrt(2 E / m)`` in m/s, converted to mm/s.
    start
        Start positions ``(n_individuals, 2)`` in mm (default: all at the origin).
    rng
        Generator or seed.

    Returns
    -------
    ds, truth
        The tracks, and ``{"energy", "speed", "steering_rate", "hot"}`` arrays
        ``(n_frames - 1, n_individuals)`` of the drawn step values (``steering_rate``
        is NaN at step 0; ``hot`` is whether the step came from component 2 of a
        mixture).
    """
    rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    n_steps = n_frames - 1
    if n_steps < 1 or n_individuals < 1:
        raise ValueError("need at least 2 frames and 1 individual")
    if time is None:
        t = np.arange(n_frames) / float(fps)
    else:
        t = np.asarray(time, dtype=float)
        if t.shape != (n_frames,) or np.any(np.diff(t) <= 0):
            raise ValueError("time must have n_frames increasing entries")
    dt = np.diff(t)[:, None]
    shape = (n_steps, n_individuals)
    if isinstance(energy, EnergyMixture):
        hot = rng.random(shape) >= energy.phi
        e = rng.standard_exponential(shape) * np.where(hot, energy.kT2, energy.kT1)
    else:
        hot = np.zeros(shape, dtype=bool)
        e = energy.sample(rng, shape)
    v = np.sqrt(2.0 * e) if mass is None else np.sqrt(2.0 * e / mass) * 1e3
    heading, rate = _headings(rng, steering, v, dt, shape)
    pos = np.zeros((n_frames, 2, n_individuals))
    if start is not None:
        pos[0] = np.asarray(start, dtype=float).T
    pos[1:, 0] = pos[0, 0] + np.cumsum(v * np.cos(heading) * dt, axis=0)
    pos[1:, 1] = pos[0, 1] + np.cumsum(v * np.sin(heading) * dt, axis=0)
    ds = make_tracks(pos, time=t, fps=fps if time is None else None,
                     source_software="thermoswarm.analysis.synthetic")  # fmt: skip
    truth = {"energy": e, "speed": v, "steering_rate": rate, "hot": hot}
    return ds, truth


def _headings(
    rng: np.random.Generator,
    steering: SteeringLaw | None,
    v: np.ndarray,
    dt: np.ndarray,
    shape: tuple[int, int],
) -> tuple[np.ndarray, np.ndarray]:
    """Each step's heading (rad) and steering rate (rad/s; NaN at step 0 and without a
    law) of :func:`synthetic_tracks`: uniform headings without ``steering``, else rates
    drawn given the speeds ``v`` (mm/s) and integrated over the mid-step times from a
    uniform initial heading."""
    if steering is None:
        heading = rng.uniform(-np.pi, np.pi, shape)
        rate = np.full(shape, np.nan)
    else:
        rate = steering.sample(rng, speed=v)
        rate = np.broadcast_to(rate, shape).copy()
        rate[0] = np.nan
        mid = np.empty_like(dt)
        mid[0] = 0.0
        mid[1:] = 0.5 * (dt[1:] + dt[:-1])
        h0 = rng.uniform(-np.pi, np.pi, shape[1])
        heading = h0[None, :] + np.cumsum(np.where(np.isnan(rate), 0.0, rate) * mid, axis=0)
    return heading, rate
