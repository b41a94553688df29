"""Trajectories made in code for the analysis tests: known laws, known geometry."""

from __future__ import annotations

import numpy as np

from thermoswarm.maxent import DecayingTemperature, EnergyMixture
from thermoswarm.tracks import make_tracks

#: The two-phase law of the synthetic "ants" (mm^2/s^2): 60 % cold, kT 20 and 80.
MIXTURE = EnergyMixture(phi=0.6, kT1=20.0, kT2=80.0)
#: Steering temperature falling with speed (rad/s against mm/s).
STEER_T = DecayingTemperature(T_max=6.0, T_min=1.0, v_scale=8.0)


def circle_tracks(radius=100.0, omega=0.5, fps=30.0, n=300, n_ind=1):
    """Constant-speed circles: chord speed 2 R sin(w dt / 2) / dt, turn rate w."""
    t = np.arange(n) / fps
    pos = np.zeros((n, 2, n_ind))
    for i in range(n_ind):
        pos[:, 0, i] = radius * np.cos(omega * t + i)
        pos[:, 1, i] = radius * np.sin(omega * t + i)
    return make_tracks(pos, fps=fps)


def straight_tracks(speed=10.0, fps=10.0, n=50, n_ind=1, angle=0.3):
    """Straight lines at constant speed (mm/s) and heading ``angle`` (rad)."""
    t = np.arange(n) / fps
    pos = np.zeros((n, 2, n_ind))
    for i in range(n_ind):
        pos[:, 0, i] = speed * t * np.cos(angle) + 10.0 * i
        pos[:, 1, i] = speed * t * np.sin(angle)
    return make_tracks(pos, fps=fps)
