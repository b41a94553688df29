"""Synthetic ant videos with ground truth.

Ants walk on the paper's narrow wooden road (PAPER_NOTES section 3: a 40 mm wide section
and a 20 mm narrow section) under the paper's ant model, and are rendered top-down as
articulated head / mesosoma / gaster shapes with legs and antennae on a textured wooden
road, with slow lighting drift, flicker, a moving soft shadow, motion blur, optical
blur and sensor noise.  Ants touch and cross each other freely (they are not solid).

Motion (all units mm, s, rad)
-----------------------------
Each ant is in one of two phases: phase 1 ("liquid", ``kT1``) with probability ``phi``
and phase 2 ("gas", ``kT2``).  Its energy per unit mass ``E = v^2 / 2`` is drawn from
``Exponential(kT_phase)`` (:class:`thermoswarm.maxent.EnergyMixture` marginally) and its
speed is ``v = sqrt(2 E)``.  A speed draw is held for an exponential time of mean
``speed_tau_s`` and the phase is re-drawn (from ``Bernoulli(phi)``) at rate
``1 / phase_tau_s``, with a fresh speed when the phase changes; both are memoryless
renewals, so at every frame the energy is *exactly* distributed as the mixture
``phi Exp(kT1) + (1 - phi) Exp(kT2)``.  Every frame the heading turns at a rate ``w``
with ``|w| ~ Exponential(T_theta(v))`` (:class:`thermoswarm.maxent.SteeringLaw` with a
:class:`~thermoswarm.maxent.DecayingTemperature`); the sign turns towards the ant's
travel direction along the road with probability ``0.5 + goal_bias * min(1, |err| /
(pi/2))`` (``err`` = heading error), which keeps the traffic bidirectional without
changing the law of ``|w|``.  With ``p_k`` the body point in frame ``k``,
``p_{k+1} = p_k + v_k dt (cos h_k, sin h_k)`` and ``h_{k+1} = h_k + w_k dt``: the
displacement between frames ``k`` and ``k+1`` has length ``v_k dt`` and the change of
its direction is ``w_k dt``, so a tracker with perfect positions recovers ``v_k`` and
``w_k`` exactly (except at wall contacts, flagged in ``wall_contact``).

Walls reflect the heading (specular); an ant that leaves the road at an end is
replaced by a new ant (a new identity) entering at that end, so ``n_ants`` ants are on
the road at every frame.  The road runs along the frame's long axis; by default it is
as long as the frame (``road_length_mm = None``), its widths are in mm at
``px_per_mm`` (default the paper's 3.04 px/mm), and the narrow section is the last
``narrow_fraction`` of its length.

Randomness: :func:`generate` draws the motion, the appearance and one seed for the
per-frame noise from the caller's :class:`numpy.random.Generator`; frame ``k`` is
rendered with ``numpy.random.default_rng([render_seed, k])``, so frames can be rendered
in any order, and the same seed gives the same video.

Outputs
-------
:class:`SynthVideo` holds the ground truth -- ``keypoints`` ``(T, N, 3, 2)`` px [head,
body, tail] (NaN outside an ant's lifetime), the MOTChallenge GT table ``mot_gt`` and
``tracks``, the trajectory Dataset (mm in image coordinates, s) with extra variables
``speed`` (mm/s), ``steering_rate`` (rad/s), ``phase`` (1 or 2) and ``wall_contact`` --
and renders frames (RGB ``uint8``) lazily with :meth:`SynthVideo.frames`.
:func:`write_video` writes mp4 (imageio-ffmpeg) or a folder of PNG frames;
:func:`write_sequence` writes a MOTChallenge-style sequence folder.

Command line: ``python -m thermoswarm.tracking.synth OUT_DIR --seed 1 --set n_ants=40``.
"""

from __future__ import annotations

import dataclasses
import io
import math
import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from thermoswarm.config import check, dumps_toml
from thermoswarm.errors import InputError, OutputError
from thermoswarm.fsutil import (
    atomic_path,
    atomic_write_bytes,
    atomic_write_text,
    prepare_output_dir,
)
from thermoswarm.maxent import DecayingTemperature, EnergyMixture, SteeringLaw, wrap_angle
from thermoswarm.tracking import anatomy
from thermoswarm.tracks import make_tracks

__all__ = [
    "SynthConfig",
    "Road",
    "SynthVideo",
    "generate",
    "write_video",
    "write_sequence",
]


@dataclass(frozen=True)
class SynthConfig:
    """Parameters of a synthetic ant video.

    Frame: ``width`` x ``height`` px, ``n_frames`` at ``fps``; ``px_per_mm`` (the paper's
    3.04).  Ants: ``n_ants`` on the road at every frame, body ``ant_length_mm`` x
    ``ant_width_mm`` (the paper's 7.14 x 2.5 mm) with a relative size spread
    ``size_sd``.  Road: ``road_wide_mm`` and ``road_narrow_mm`` wide, ``road_length_mm``
    long (``None``: the frame's long side), the last ``narrow_fraction`` narrow.
    Motion: ``phi`` (fraction in phase 1), ``kT1``, ``kT2`` (mm^2/s^2, energy per unit
    mass), steering temperature ``T_theta(v) = steer_T_min + (steer_T_max - steer_T_min)
    exp(-v / steer_v_scale)`` (rad/s, mm/s), holding times ``speed_tau_s`` and
    ``phase_tau_s`` (s), ``goal_bias`` in [0, 0.5].  Appearance: ``noise_sigma`` (grey
    levels), ``blur_sigma_px``, ``exposure`` (fraction of the frame interval, motion
    blur), ``lighting_drift`` (relative amplitude of a slow brightness oscillation),
    ``flicker`` (relative frame-to-frame sd), ``shadow_strength`` (relative darkening at
    the centre of a moving soft shadow).
    """

    width: int = 1920
    height: int = 1080
    n_ants: int = 40
    n_frames: int = 300
    fps: float = 30.0
    px_per_mm: float = 3.04
    ant_length_mm: float = anatomy.ANT_LENGTH_MM
    ant_width_mm: float = anatomy.ANT_WIDTH_MM
    size_sd: float = 0.06
    road_wide_mm: float = 40.0
    road_narrow_mm: float = 20.0
    road_length_mm: float | None = None
    narrow_fraction: float = 0.5
    phi: float = 0.4
    kT1: float = 30.0
    kT2: float = 300.0
    steer_T_max: float = 3.0
    steer_T_min: float = 0.5
    steer_v_scale: float = 10.0
    speed_tau_s: float = 0.25
    phase_tau_s: float = 2.0
    goal_bias: float = 0.3
    noise_sigma: float = 4.0
    blur_sigma_px: float = 0.6
    exposure: float = 0.5
    lighting_drift: float = 0.12
    flicker: float = 0.015
    shadow_strength: float = 0.25

    def __post_init__(self) -> None:
        check(16 <= self.width <= 8192, "width", "an integer in [16, 8192] px", self.width)
        check(16 <= self.height <= 8192, "height", "an integer in [16, 8192] px", self.height)
        check(self.n_ants >= 0, "n_ants", "a non-negative integer", self.n_ants)
        check(self.n_frames >= 1, "n_frames", "a positive integer", self.n_frames)
        for name in (
            "fps",
            "px_per_mm",
            "ant_length_mm",
            "ant_width_mm",
            "road_wide_mm",
            "road_narrow_mm",
            "kT1",
            "kT2",
            "steer_T_max",
            "steer_T_min",
            "steer_v_scale",
            "speed_tau_s",
            "phase_tau_s",
        ):
            v = getattr(self, name)
            check(math.isfinite(v) and v > 0, name, "a positive number", v)
        for name in ("noise_sigma", "blur_sigma_px", "lighting_drift", "flicker", "size_sd"):
            v = getattr(self, name)
            check(math.isfinite(v) and v >= 0, name, "a non-negative number", v)
        check(0 <= self.phi <= 1, "phi", "in [0, 1]", self.phi)
        check(0 <= self.narrow_fraction <= 1, "narrow_fraction", "in [0, 1]", self.narrow_fraction)
        check(0 <= self.goal_bias <= 0.5, "goal_bias", "in [0, 0.5]", self.goal_bias)
        check(0 <= self.exposure <= 1, "exposure", "in [0, 1]", self.exposure)
        check(0 <= self.shadow_strength < 1, "shadow_strength", "in [0, 1)", self.shadow_strength)
        check(self.size_sd < 0.3, "size_sd", "below 0.3", self.size_sd)
        check(
            self.steer_T_min <= self.steer_T_max, "steer_T_min", "<= steer_T_max", self.steer_T_min
        )
        check(
            self.road_narrow_mm <= self.road_wide_mm,
            "road_narrow_mm",
            "<= road_wide_mm",
            self.road_narrow_mm,
        )
        short_mm = min(self.width, self.height) / self.px_per_mm
        check(
            self.road_wide_mm <= short_mm,
            "road_wide_mm",
            f"at most the frame's short side ({short_mm:.1f} mm at px_per_mm)",
            self.road_wide_mm,
        )
        check(
            self.road_narrow_mm > self.ant_width_mm,
            "road_narrow_mm",
            "wider than an ant",
            self.road_narrow_mm,
        )
        if self.road_length_mm is not None:
            long_mm = max(self.width, self.height) / self.px_per_mm
            check(
                0 < self.road_length_mm <= long_mm,
                "road_length_mm",
                f"in (0, {long_mm:.1f}] mm (the frame's long side)",
                self.road_length_mm,
            )

    @property
    def energy_law(self) -> EnergyMixture:
        """The marginal energy law (per unit mass, mm^2/s^2)."""
        return EnergyMixture(self.phi, self.kT1, self.kT2)

    @property
    def steering_law(self) -> SteeringLaw:
        """``|w| ~ Exponential(T_theta(v))`` (rad/s)."""
        return SteeringLaw(
            DecayingTemperature(self.steer_T_max, self.steer_T_min, self.steer_v_scale)
        )

    @property
    def road(self) -> Road:
        return Road.for_frame(self)


@dataclass(frozen=True)
class Road:
    """The narrow straight road, in road coordinates ``s`` (along, mm) and ``u`` (across).

    ``s`` runs from 0 to ``length``; the section ``s >= narrow_start`` is
    ``narrow`` wide, the rest ``wide``; ``u = 0`` is the centre line.  ``horizontal``
    says whether ``s`` is the image's x axis; ``origin`` is the image position (mm) of
    ``s = 0, u = 0``.
    """

    length: float
    wide: float
    narrow: float
    narrow_start: float
    horizontal: bool
    origin: tuple[float, float]

    @classmethod
    def for_frame(cls, cfg: SynthConfig) -> Road:
        horizontal = cfg.width >= cfg.height
        long_mm = max(cfg.width, cfg.height) / cfg.px_per_mm
        short_mm = min(cfg.width, cfg.height) / cfg.px_per_mm
        length = cfg.road_length_mm if cfg.road_length_mm is not None else long_mm
        s0 = (long_mm - length) / 2
        u0 = short_mm / 2
        origin = (s0, u0) if horizontal else (u0, s0)
        return cls(
            length,
            cfg.road_wide_mm,
            cfg.road_narrow_mm,
            length * (1 - cfg.narrow_fraction),
            horizontal,
            origin,
        )

    def half_width(self, s: np.ndarray) -> np.ndarray:
        return np.where(np.asarray(s) >= self.narrow_start, self.narrow / 2, self.wide / 2)

    def to_image(self, su: np.ndarray) -> np.ndarray:
        """``(..., 2)`` road ``(s, u)`` mm -> image ``(x, y)`` mm."""
        su = np.asarray(su, dtype=np.float64)
        if self.horizontal:
            return np.stack([su[..., 0] + self.origin[0], su[..., 1] + self.origin[1]], -1)
        return np.stack([su[..., 1] + self.origin[0], su[..., 0] + self.origin[1]], -1)

    def vec_to_image(self, d: np.ndarray) -> np.ndarray:
        """Direction vectors ``(..., 2)`` from road to image axes."""
        d = np.asarray(d, dtype=np.float64)
        return d if self.horizontal else d[..., ::-1]


# ---------------------------------------------------------------------------- motion


@dataclass
class _Motion:
    body: np.ndarray  # (T, N, 2) road (s, u), mm
    heading: np.ndarray  # (T, N) road angle, rad
    head_angle: np.ndarray  # (T, N) head articulation, rad
    tail_angle: np.ndarray  # (T, N) gaster articulation, rad
    gait: np.ndarray  # (T, N) rad
    speed: np.ndarray  # (T, N) mm/s
    rate: np.ndarray  # (T, N) rad/s
    phase: np.ndarray  # (T, N) int8, 0 absent
    wall: np.ndarray  # (T, N) bool
    alive: np.ndarray  # (T, N) bool
    size: np.ndarray  # (N,) relative size
    shade: np.ndarray  # (N,) relative brightness


def _place(rng: np.random.Generator, road: Road, n: int, margin: float) -> np.ndarray:
    """``n`` points uniform on the road area (rejection sampling)."""
    out = np.empty((0, 2))
    while out.shape[0] < n:
        s = rng.uniform(0, road.length, 4 * n + 4)
        u = rng.uniform(-road.wide / 2, road.wide / 2, 4 * n + 4)
        ok = np.abs(u) <= road.half_width(s) - margin
        out = np.vstack([out, np.column_stack([s[ok], u[ok]])])
    return out[:n]


def _simulate(cfg: SynthConfig, road: Road, rng: np.random.Generator) -> _Motion:
    n, T = cfg.n_ants, cfg.n_frames
    dt = 1.0 / cfg.fps
    margin = cfg.ant_width_mm / 2
    steer = cfg.steering_law
    kT = np.array([cfg.kT1, cfg.kT2])
    p_speed = -math.expm1(-dt / cfg.speed_tau_s)
    p_phase = -math.expm1(-dt / cfg.phase_tau_s)
    gait_len = 0.35 * cfg.ant_length_mm

    # Slot state (one ant per slot at a time).
    pos = _place(rng, road, n, margin)
    goal = np.where(rng.random(n) < 0.5, 0.0, np.pi)  # travel direction along the road
    heading = goal + 0.3 * rng.standard_normal(n)
    phase = np.where(rng.random(n) < cfg.phi, 1, 2).astype(np.int8)
    v = np.sqrt(2 * kT[phase - 1] * rng.standard_exponential(n))
    head_a = 0.1 * rng.standard_normal(n)
    tail_a = 0.06 * rng.standard_normal(n)
    gait = rng.uniform(0, 2 * np.pi, n)
    ident = np.arange(n)
    n_ids = n
    sizes = list(1 + cfg.size_sd * rng.standard_normal(n))
    shades = list(rng.uniform(0.85, 1.15, n))

    rec_pos = np.empty((T, n, 2))
    rec = {k: np.empty((T, n)) for k in ("heading", "head", "tail", "gait", "v", "w")}
    rec_phase = np.empty((T, n), np.int8)
    rec_wall = np.zeros((T, n), bool)
    rec_id = np.empty((T, n), np.int64)
    for k in range(T):
        # Fixed number of draws per frame, whether used or not: reproducible streams.
        u_phase, u_newphase, u_speed, e_speed, u_sign, e_steer = rng.random((6, n))
        e_speed = -np.log1p(-e_speed)  # standard exponential from a uniform
        e_steer = -np.log1p(-e_steer)
        art = rng.standard_normal((2, n))
        if k > 0:
            redraw = u_phase < p_phase
            new_phase = np.where(u_newphase < cfg.phi, 1, 2).astype(np.int8)
            changed = redraw & (new_phase != phase)
            phase = np.where(redraw, new_phase, phase)
            resample = (u_speed < p_speed) | changed
            v = np.where(resample, np.sqrt(2 * kT[phase - 1] * e_speed), v)
        T_theta = steer.temperature(v)
        err = wrap_angle(goal - heading)
        p_toward = 0.5 + cfg.goal_bias * np.clip(np.abs(err) / (np.pi / 2), 0, 1)
        toward = np.where(err >= 0, 1.0, -1.0)
        w = np.where(u_sign < p_toward, toward, -toward) * e_steer * T_theta

        rec_pos[k] = pos
        rec["heading"][k] = heading
        rec["head"][k] = head_a
        rec["tail"][k] = tail_a
        rec["gait"][k] = gait
        rec["v"][k] = v
        rec["w"][k] = w
        rec_phase[k] = phase
        rec_id[k] = ident

        # Step.
        step = v * dt
        new = pos + step[:, None] * np.column_stack([np.cos(heading), np.sin(heading)])
        new_heading = heading + w * dt
        # Walls: reflect across (lateral walls), then along (the shoulder at narrow_start).
        ends = (new[:, 0] < 0) | (new[:, 0] > road.length)
        hw = road.half_width(np.clip(new[:, 0], 0, road.length)) - margin
        bad = ~ends & (np.abs(new[:, 1]) > hw)
        if bad.any():
            lim = hw[bad]
            u_ref = np.sign(new[bad, 1]) * (2 * lim - np.abs(new[bad, 1]))
            cand = new[bad].copy()
            cand[:, 1] = np.clip(u_ref, -lim, lim)
            ok_lat = np.abs(pos[bad, 1]) <= lim + 1e-9
            # Lateral wall: mirror u and the heading's u component.
            cand_h = np.where(ok_lat, -new_heading[bad], np.pi - new_heading[bad])
            # Shoulder: mirror s about the shoulder, keep u.
            s_ref = 2 * road.narrow_start - new[bad, 0]
            cand[:, 0] = np.where(ok_lat, cand[:, 0], s_ref)
            cand[:, 1] = np.where(ok_lat, cand[:, 1], new[bad, 1])
            new[bad] = cand
            new_heading[bad] = cand_h
            still = np.abs(new[bad, 1]) > road.half_width(new[bad, 0]) - margin + 1e-9
            if still.any():  # corner: stay and turn around
                idx = np.flatnonzero(bad)[still]
                new[idx] = pos[idx]
                new_heading[idx] = heading[idx] + np.pi
            rec_wall[k, bad] = True
        pos = new
        heading = wrap_angle(new_heading)
        gait = gait + 2 * np.pi * step / gait_len
        head_a = 0.9 * head_a + 0.1 * 0.1 * math.sqrt(1 / 0.19) * art[0]
        tail_a = 0.9 * tail_a + 0.1 * 0.06 * math.sqrt(1 / 0.19) * art[1]

        # Ants that left the road at an end are replaced by new ants entering there.
        if ends.any():
            idx = np.flatnonzero(ends)
            m = idx.size
            at_start = pos[idx, 0] < 0
            s_new = np.where(at_start, 0.0, road.length)
            hw_new = road.half_width(s_new) - margin
            u_new = rng.uniform(-1, 1, m) * hw_new
            goal[idx] = np.where(at_start, 0.0, np.pi)
            heading[idx] = goal[idx] + 0.3 * rng.standard_normal(m)
            pos[idx] = np.column_stack([s_new, u_new])
            phase[idx] = np.where(rng.random(m) < cfg.phi, 1, 2)
            v[idx] = np.sqrt(2 * kT[phase[idx] - 1] * rng.standard_exponential(m))
            head_a[idx] = 0.0
            tail_a[idx] = 0.0
            ident[idx] = n_ids + np.arange(m)
            n_ids += m
            sizes.extend(1 + cfg.size_sd * rng.standard_normal(m))
            shades.extend(rng.uniform(0.85, 1.15, m))

    # Slots -> individuals.
    N = n_ids
    out = _Motion(
        body=np.full((T, N, 2), np.nan),
        heading=np.full((T, N), np.nan),
        head_angle=np.full((T, N), np.nan),
        tail_angle=np.full((T, N), np.nan),
        gait=np.full((T, N), np.nan),
        speed=np.full((T, N), np.nan),
        rate=np.full((T, N), np.nan),
        phase=np.zeros((T, N), np.int8),
        wall=np.zeros((T, N), bool),
        alive=np.zeros((T, N), bool),
        size=np.asarray(sizes),
        shade=np.asarray(shades),
    )
    tt = np.repeat(np.arange(T), n)
    ii = rec_id.ravel()
    out.body[tt, ii] = rec_pos.reshape(-1, 2)
    out.heading[tt, ii] = rec["heading"].ravel()
    out.head_angle[tt, ii] = rec["head"].ravel()
    out.tail_angle[tt, ii] = rec["tail"].ravel()
    out.gait[tt, ii] = rec["gait"].ravel()
    out.speed[tt, ii] = rec["v"].ravel()
    out.rate[tt, ii] = rec["w"].ravel()
    out.phase[tt, ii] = rec_phase.ravel()
    out.wall[tt, ii] = rec_wall.ravel()
    out.alive[tt, ii] = True
    # The last step of an ant that leaves has no next frame: its speed and rate are
    # still the true ones of that step, kept.
    return out


# ------------------------------------------------------------------------- geometry


def _skeleton(cfg: SynthConfig, road: Road, mo: _Motion) -> dict[str, np.ndarray]:
    """Image-space geometry (px): keypoints, axis and part orientations."""
    ppm = cfg.px_per_mm
    L = cfg.ant_length_mm * mo.size[None, :]  # (1, N) mm
    ax = np.stack([np.cos(mo.heading), np.sin(mo.heading)], -1)
    ha = mo.heading + mo.head_angle
    ta = mo.heading + mo.tail_angle
    hax = np.stack([np.cos(ha), np.sin(ha)], -1)
    tax = np.stack([np.cos(ta), np.sin(ta)], -1)
    neck = mo.body + (0.22 * L)[..., None] * ax
    head = neck + ((anatomy.HEAD[0] - 0.22) * L)[..., None] * hax
    petiole = mo.body - (0.17 * L)[..., None] * ax
    tail = petiole + ((anatomy.GASTER[0] + 0.17) * L)[..., None] * tax
    to_img = road.to_image
    kp = np.stack([to_img(head), to_img(mo.body), to_img(tail)], axis=2) * ppm  # (T,N,3,2)
    return {
        "keypoints": kp,
        "axis": road.vec_to_image(ax),
        "head_axis": road.vec_to_image(hax),
        "tail_axis": road.vec_to_image(tax),
        "length_px": (L * ppm) * np.ones_like(mo.heading),
    }


# ------------------------------------------------------------------------- rendering


def _smooth_noise(
    rng: np.random.Generator,
    shape: tuple[int, int],
    sigma: tuple[float, float],
) -> np.ndarray:
    import cv2

    a = rng.standard_normal(shape).astype(np.float32)
    a = cv2.GaussianBlur(
        a, (0, 0), sigmaX=sigma[1], sigmaY=sigma[0], borderType=cv2.BORDER_REFLECT
    )
    sd = float(a.std())
    return a / sd if sd > 0 else a


def _texture(cfg: SynthConfig, road: Road, rng: np.random.Generator) -> np.ndarray:
    """Background (H, W, 3) float32 RGB: wooden road on darker ground."""
    import cv2

    ppm = cfg.px_per_mm
    long_px, short_px = max(cfg.width, cfg.height), min(cfg.width, cfg.height)
    shape = (short_px, long_px)  # road along axis 1
    s_mm = (np.arange(long_px) + 0.5) / ppm - (
        road.origin[0] if road.horizontal else road.origin[1]
    )
    u_mm = (np.arange(short_px) + 0.5) / ppm - (
        road.origin[1] if road.horizontal else road.origin[0]
    )
    # Wood: growth rings across the road (lines along it), warped; fibres along it.
    small = (max(short_px // 24, 2), max(long_px // 24, 2))
    warp = (
        cv2.resize(
            rng.standard_normal(small).astype(np.float32),
            (long_px, short_px),
            interpolation=cv2.INTER_CUBIC,
        )
        * 2.5
    )
    period = rng.uniform(2.5, 4.0)  # mm between rings
    rings = np.sin(2 * np.pi * (u_mm[:, None] + warp / ppm * 3) / period).astype(np.float32)
    rings = np.sign(rings) * np.abs(rings) ** 0.5
    fibres = _smooth_noise(rng, shape, (0.7, 12.0))
    blotch = _smooth_noise(rng, shape, (25.0, 60.0))
    wood = 1 + 0.06 * rings + 0.05 * fibres + 0.05 * blotch
    ground = 1 + 0.15 * _smooth_noise(rng, shape, (2.0, 2.0)) + 0.1 * blotch
    wood_rgb = np.array([205.0, 165.0, 115.0], np.float32)
    ground_rgb = np.array([90.0, 82.0, 74.0], np.float32)
    # Road mask with anti-aliased edges and a darker rim (the edge of the plank).
    hw = road.half_width(np.clip(s_mm, 0, road.length))[None, :]
    inside_s = (s_mm >= 0) & (s_mm <= road.length)
    dist = hw - np.abs(u_mm[:, None])  # mm inside the edge
    cover = np.clip(dist * ppm + 0.5, 0, 1) * inside_s[None, :]
    rim = 1 - 0.25 * np.exp(-np.clip(dist, 0, None) * ppm / 1.5) * (dist > 0)
    img = (cover * rim * wood)[..., None] * wood_rgb + ((1 - cover) * ground)[..., None] * (
        ground_rgb
    )
    img = img.astype(np.float32)
    if not road.horizontal:
        img = np.ascontiguousarray(img.transpose(1, 0, 2))
    return img


@dataclass(frozen=True)
class _Lighting:
    drift_amp: float
    drift_period: float
    drift_phase: float
    flicker: np.ndarray  # (T,)
    shadow_start: tuple[float, float]  # px
    shadow_velocity: tuple[float, float]  # px per frame
    shadow_sigma: float  # px
    shadow_strength: float

    def gain(self, k: int, fps: float, small_shape: tuple[int, int], scale: float) -> np.ndarray:
        """Gain field at 1/scale resolution (h, w) for frame ``k``."""
        g = (
            1
            + self.drift_amp
            * math.sin(2 * math.pi * k / fps / self.drift_period + self.drift_phase)
            + self.flicker[k]
        )
        h, w = small_shape
        cx = (self.shadow_start[0] + self.shadow_velocity[0] * k) / scale
        cy = (self.shadow_start[1] + self.shadow_velocity[1] * k) / scale
        sig = self.shadow_sigma / scale
        gx = np.exp(-0.5 * ((np.arange(w) + 0.5 - cx) / sig) ** 2)
        gy = np.exp(-0.5 * ((np.arange(h) + 0.5 - cy) / sig) ** 2)
        return (g * (1 - self.shadow_strength * np.outer(gy, gx))).astype(np.float32)


def _lighting(cfg: SynthConfig, rng: np.random.Generator) -> _Lighting:
    W, H = cfg.width, cfg.height
    side = rng.integers(4)
    sig = 0.25 * min(W, H)
    # The shadow crosses the frame once over the video, entering from a random side.
    if side == 0:
        start, end = (-sig, rng.uniform(0, H)), (W + sig, rng.uniform(0, H))
    elif side == 1:
        start, end = (W + sig, rng.uniform(0, H)), (-sig, rng.uniform(0, H))
    elif side == 2:
        start, end = (rng.uniform(0, W), -sig), (rng.uniform(0, W), H + sig)
    else:
        start, end = (rng.uniform(0, W), H + sig), (rng.uniform(0, W), -sig)
    nf = max(cfg.n_frames - 1, 1)
    vel = ((end[0] - start[0]) / nf, (end[1] - start[1]) / nf)
    return _Lighting(
        drift_amp=cfg.lighting_drift,
        drift_period=float(rng.uniform(4.0, 12.0)),
        drift_phase=float(rng.uniform(0, 2 * np.pi)),
        flicker=cfg.flicker * rng.standard_normal(cfg.n_frames),
        shadow_start=(float(start[0]), float(start[1])),
        shadow_velocity=(float(vel[0]), float(vel[1])),
        shadow_sigma=float(sig),
        shadow_strength=cfg.shadow_strength,
    )


_SHIFT = 4
_NOISE_MARGIN = 64
_ONE = 1 << _SHIFT
_PART_RGB = np.array([118.0, 56.0, 34.0], np.float32)  # head and mesosoma: red-brown
_GASTER_RGB = np.array([38.0, 30.0, 28.0], np.float32)  # gaster: black


def _fx(p: np.ndarray) -> tuple[int, int]:
    return (int(round(p[0] * _ONE)), int(round(p[1] * _ONE)))


def _draw_ant(
    mA: np.ndarray,
    mB: np.ndarray,
    origin: np.ndarray,
    kp: np.ndarray,
    ax: np.ndarray,
    hax: np.ndarray,
    tax: np.ndarray,
    L: float,
    gait: float,
) -> None:
    """Draw one ant (px) into the two part masks (uint8 patches) offset by ``origin``."""
    import cv2

    head, body, tail = kp - origin
    perp = np.array([-ax[1], ax[0]])
    ang = math.degrees(math.atan2(ax[1], ax[0]))
    hang = math.degrees(math.atan2(hax[1], hax[0]))
    tang = math.degrees(math.atan2(tax[1], tax[0]))
    aa = cv2.LINE_AA

    def ell(m: np.ndarray, c: np.ndarray, a: float, b: float, deg: float) -> None:
        cv2.ellipse(
            m,
            _fx(c),
            (max(int(a * _ONE), 1), max(int(b * _ONE), 1)),
            deg,
            0,
            360,
            255,
            -1,
            aa,
            _SHIFT,
        )

    # Legs: three pairs from the mesosoma, tripod gait; two segments each.
    for j, (at, base) in enumerate(((0.10, 0.28), (0.02, 0.02), (-0.07, -0.30))):
        for side in (-1.0, 1.0):
            tri = (j + (side > 0)) % 2
            swing = 0.12 * math.sin(gait + math.pi * tri)
            root = body + at * L * ax
            knee = root + side * 0.22 * L * perp + 0.5 * (base + swing) * L * ax
            tip = root + side * 0.42 * L * perp + (base + swing) * L * ax
            cv2.line(mA, _fx(root), _fx(knee), 190, 1, aa, _SHIFT)
            cv2.line(mA, _fx(knee), _fx(tip), 160, 1, aa, _SHIFT)
    # Antennae.
    hperp = np.array([-hax[1], hax[0]])
    for side in (-1.0, 1.0):
        base = head + 0.08 * L * hax
        elbow = base + 0.16 * L * hax + side * 0.10 * L * hperp
        tip = elbow + 0.12 * L * hax + side * 0.12 * L * hperp
        cv2.line(mA, _fx(base), _fx(elbow), 170, 1, aa, _SHIFT)
        cv2.line(mA, _fx(elbow), _fx(tip), 150, 1, aa, _SHIFT)
    # Body parts.
    ell(mA, head, anatomy.HEAD[1] * L, anatomy.HEAD[2] * L, hang)
    ell(
        mA,
        body + anatomy.MESOSOMA[0] * L * ax,
        anatomy.MESOSOMA[1] * L,
        anatomy.MESOSOMA[2] * L,
        ang,
    )
    ell(mA, body - 0.17 * L * ax, 0.04 * L, 0.04 * L, ang)  # petiole
    ell(mB, tail, anatomy.GASTER[1] * L, anatomy.GASTER[2] * L, tang)


@dataclass
class SynthVideo:
    """A synthetic video: ground truth now, frames rendered on demand.

    Attributes
    ----------
    config
        The :class:`SynthConfig`.
    keypoints
        ``(T, N, 3, 2)`` float px, [head, body, tail] x [x, y]; NaN where ant ``N`` is
        not on the road.
    ids
        ``(N,)`` MOT identities (1-based) of the ants.
    mot_gt
        MOTChallenge GT rows ``(frame, id, left, top, width, height, 1, 1, visibility)``
        with body-centred boxes (:func:`~thermoswarm.tracking.anatomy.pose_boxes`).
    tracks
        The trajectory Dataset (mm, s, keypoints head/body/tail) with ``speed``
        (mm/s), ``steering_rate`` (rad/s), ``phase`` (1 or 2, 0 absent) and
        ``wall_contact``: the true values of the step from each frame to the next.
    """

    config: SynthConfig
    keypoints: np.ndarray
    ids: np.ndarray
    mot_gt: np.ndarray
    tracks: xr.Dataset
    _geom: dict[str, np.ndarray] = dataclasses.field(repr=False)
    _motion: _Motion = dataclasses.field(repr=False)
    _lighting: _Lighting = dataclasses.field(repr=False)
    _render_seed: int = dataclasses.field(repr=False)
    _texture_seed: int = dataclasses.field(repr=False)
    _background: np.ndarray | None = dataclasses.field(default=None, repr=False)
    _noise: np.ndarray | None = dataclasses.field(default=None, repr=False)

    @property
    def n_frames(self) -> int:
        return self.config.n_frames

    @property
    def box_pad_px(self) -> float:
        """Half the ant's width in px: the padding of the body-centred boxes."""
        return 0.5 * self.config.ant_width_mm * self.config.px_per_mm

    def background(self) -> np.ndarray:
        """The empty, evenly lit road (H, W, 3) float32 RGB."""
        if self._background is None:
            cfg = self.config
            self._background = _texture(cfg, cfg.road, np.random.default_rng(self._texture_seed))
        return self._background

    def _noise_bank(self) -> np.ndarray:
        # Drawing 6M normals per 1080p frame costs ~75 ms; instead each frame adds a
        # randomly offset window of a pre-drawn bank (two frames plus a margin).
        if self._noise is None:
            cfg = self.config
            rng = np.random.default_rng([self._texture_seed, 1])
            shape = (2, cfg.height + _NOISE_MARGIN, cfg.width + _NOISE_MARGIN, 3)
            bank = rng.standard_normal(shape, dtype=np.float32)
            bank *= np.float32(cfg.noise_sigma)
            self._noise = bank
        return self._noise

    def render(self, k: int) -> np.ndarray:
        """Frame ``k`` (0-based) as ``(H, W, 3)`` uint8 RGB."""
        import cv2

        cfg = self.config
        if not 0 <= k < cfg.n_frames:
            raise IndexError(f"frame {k} outside 0..{cfg.n_frames - 1}")
        rng = np.random.default_rng([self._render_seed, k])
        img = self.background().copy()
        H, W = cfg.height, cfg.width
        g = self._geom
        alive = np.flatnonzero(self._motion.alive[k])
        dt = 1.0 / cfg.fps
        ppm = cfg.px_per_mm
        for i in alive:
            kp = g["keypoints"][k, i]
            L = float(g["length_px"][k, i])
            v_px = self._motion.speed[k, i] * dt * ppm
            disp = g["axis"][k, i] * v_px * cfg.exposure
            n_sub = 1 if abs(v_px * cfg.exposure) < 0.5 else 3
            offs = np.linspace(-0.5, 0.5, n_sub) if n_sub > 1 else np.zeros(1)
            r = 0.75 * L + abs(v_px) + 3
            c = kp[1]
            x0, y0 = int(math.floor(c[0] - r)), int(math.floor(c[1] - r))
            x1, y1 = int(math.ceil(c[0] + r)), int(math.ceil(c[1] + r))
            cx0, cy0, cx1, cy1 = max(x0, 0), max(y0, 0), min(x1, W), min(y1, H)
            if cx1 <= cx0 or cy1 <= cy0:
                continue
            ph, pw = y1 - y0, x1 - x0
            aA = np.zeros((ph, pw), np.float32)
            aB = np.zeros((ph, pw), np.float32)
            origin = np.array([x0, y0], float)
            for f in offs:
                mA = np.zeros((ph, pw), np.uint8)
                mB = np.zeros((ph, pw), np.uint8)
                _draw_ant(
                    mA,
                    mB,
                    origin - f * disp,
                    kp,
                    g["axis"][k, i],
                    g["head_axis"][k, i],
                    g["tail_axis"][k, i],
                    L,
                    float(self._motion.gait[k, i]),
                )
                aA += mA
                aB += mB
            scale = 1.0 / (255.0 * n_sub)
            aA *= scale
            aB *= scale
            sl = (slice(cy0 - y0, cy1 - y0), slice(cx0 - x0, cx1 - x0))
            aA, aB = aA[sl], aB[sl]
            a = np.minimum(aA + aB, 1.0)
            tot = np.maximum(aA + aB, 1e-6)
            shade = self._motion.shade[i]
            col = (aA[..., None] * _PART_RGB + aB[..., None] * _GASTER_RGB) / tot[..., None]
            roi = img[cy0:cy1, cx0:cx1]
            roi *= 1 - a[..., None]
            roi += a[..., None] * col * shade
        # Lighting (computed at 1/8 resolution), optics, sensor noise.
        scale = 8
        small = (max(H // scale, 1), max(W // scale, 1))
        gain = self._lighting.gain(k, cfg.fps, small, H / small[0])
        gain = cv2.resize(gain, (W, H), interpolation=cv2.INTER_LINEAR)
        img *= gain[..., None]
        if cfg.blur_sigma_px > 0:
            img = cv2.GaussianBlur(img, (0, 0), cfg.blur_sigma_px)
        if cfg.noise_sigma > 0:
            b, dy, dx = rng.integers(2), rng.integers(_NOISE_MARGIN), rng.integers(_NOISE_MARGIN)
            img += self._noise_bank()[b, dy : dy + H, dx : dx + W]
        np.clip(img, 0, 255, out=img)
        return img.astype(np.uint8)

    def frames(self, start: int = 0, stop: int | None = None) -> Iterator[np.ndarray]:
        """Render frames ``start .. stop - 1`` lazily (RGB uint8)."""
        stop = self.config.n_frames if stop is None else min(stop, self.config.n_frames)
        for k in range(start, stop):
            yield self.render(k)


def _mot_gt(kp: np.ndarray, ids: np.ndarray, pad: float, W: int, H: int) -> np.ndarray:
    t_idx, i_idx = np.nonzero(np.isfinite(kp[:, :, 1, 0]))
    boxes = anatomy.pose_boxes(kp[t_idx, i_idx], pad)
    x0 = np.clip(boxes[:, 0], 0, W)
    y0 = np.clip(boxes[:, 1], 0, H)
    x1 = np.clip(boxes[:, 0] + boxes[:, 2], 0, W)
    y1 = np.clip(boxes[:, 1] + boxes[:, 3], 0, H)
    vis = np.clip((x1 - x0) * (y1 - y0) / np.maximum(boxes[:, 2] * boxes[:, 3], 1e-9), 0, 1)
    rows = np.empty((t_idx.size, 9))
    rows[:, 0] = t_idx + 1
    rows[:, 1] = ids[i_idx]
    rows[:, 2:6] = boxes
    rows[:, 6] = 1.0
    rows[:, 7] = 1.0
    rows[:, 8] = vis
    order = np.lexsort((rows[:, 1], rows[:, 0]))
    return rows[order]


def generate(
    config: SynthConfig | None = None,
    rng: np.random.Generator | int | None = None,
) -> SynthVideo:
    """Simulate ants on the road and prepare their video.

    Parameters
    ----------
    config
        :class:`SynthConfig` (default: 40 ants, 300 frames, 1920x1080 at 30 fps).
    rng
        A :class:`numpy.random.Generator` (or an integer seed).  The motion, the
        appearance and the per-frame noise all flow from it.

    Returns
    -------
    SynthVideo
        Ground truth (keypoints px, MOT GT table, trajectory Dataset in mm and s) and a
        lazy renderer of the frames.
    """
    cfg = config or SynthConfig()
    if not isinstance(rng, np.random.Generator):
        if rng is None:
            raise TypeError("generate() needs a numpy Generator or an integer seed")
        rng = np.random.default_rng(rng)
    road = cfg.road
    motion = _simulate(cfg, road, rng)
    lighting = _lighting(cfg, rng)
    texture_seed = int(rng.integers(2**63))
    render_seed = int(rng.integers(2**63))
    geom = _skeleton(cfg, road, motion)
    kp = geom["keypoints"]
    N = kp.shape[1]
    ids = np.arange(1, N + 1)
    pad = 0.5 * cfg.ant_width_mm * cfg.px_per_mm
    gt = _mot_gt(kp, ids, pad, cfg.width, cfg.height)
    pos_mm = kp.transpose(0, 3, 2, 1) / cfg.px_per_mm  # (T, 2, 3, N)
    ds = make_tracks(
        pos_mm,
        fps=cfg.fps,
        individuals=[f"ant_{i}" for i in ids],
        keypoints=list(anatomy.KEYPOINTS),
        source_software="thermoswarm.tracking.synth",
        attrs={
            "px_per_mm": cfg.px_per_mm,
            "frame_width": cfg.width,
            "frame_height": cfg.height,
            "ground_truth": 1,
        },
    )
    dims = ("time", "individuals")
    ds["speed"] = (
        dims,
        motion.speed,
        {"units": "mm/s", "long_name": "true speed of the step to the next frame"},
    )
    ds["steering_rate"] = (
        dims,
        motion.rate,
        {"units": "rad/s", "long_name": "true heading rate of that step"},
    )
    ds["phase"] = (dims, motion.phase, {"long_name": "1 liquid (kT1), 2 gas (kT2), 0 absent"})
    ds["wall_contact"] = (dims, motion.wall, {"long_name": "step reflected by a wall"})
    return SynthVideo(cfg, kp, ids, gt, ds, geom, motion, lighting, render_seed, texture_seed)


# --------------------------------------------------------------------------- writing

_MUXERS = {".mp4": "mp4", ".avi": "avi", ".mkv": "matroska", ".mov": "mov"}


def write_video(
    frames: Iterable[np.ndarray],
    path: str | os.PathLike,
    fps: float,
    *,
    quality: int = 6,
    codec: str = "libx264",
) -> Path:
    """Write RGB uint8 frames to a video file or a folder of PNG frames, atomically.

    A path ending in ``.mp4``/``.avi``/``.mkv``/``.mov`` is encoded with imageio-ffmpeg
    (``codec``, ``quality`` 0-10, 6 = x264 CRF 20, yuv420p, a key frame every second);
    any other path becomes a folder of
    ``000001.png``, ``000002.png``, ... (the MOTChallenge ``img1`` layout).
    """
    import cv2

    path = Path(path)
    if not path.absolute().parent.is_dir():
        raise OutputError(f"{path}: parent directory does not exist")
    if path.suffix.lower() in _MUXERS:
        import imageio_ffmpeg

        with atomic_path(path, suffix=path.suffix) as tmp:
            writer = None
            try:
                for frame in frames:
                    if writer is None:
                        h, w = frame.shape[:2]
                        writer = imageio_ffmpeg.write_frames(
                            str(tmp),
                            (w, h),
                            fps=fps,
                            codec=codec,
                            quality=quality,
                            pix_fmt_in="rgb24",
                            pix_fmt_out="yuv420p",
                            macro_block_size=1,
                            ffmpeg_log_level="error",
                            output_params=[
                                "-g",
                                str(max(int(round(fps)), 1)),
                                "-f",
                                _MUXERS[path.suffix.lower()],
                            ],
                        )
                        writer.send(None)
                    writer.send(np.ascontiguousarray(frame))
            finally:
                if writer is not None:
                    writer.close()
            if writer is None:
                raise InputError(f"{path}: no frames to write")
        return path
    with atomic_path(path) as tmp:
        tmp.mkdir()
        for k, frame in enumerate(frames, 1):
            bgr = cv2.cvtColor(frame, cv2.COLOR_RGB2BGR) if frame.ndim == 3 else frame
            if not cv2.imwrite(str(tmp / f"{k:06d}.png"), bgr):
                raise OutputError(f"{path}: could not write frame {k}")
    return path


def write_sequence(
    video: SynthVideo, out_dir: str | os.PathLike, *, video_format: str = "mp4"
) -> Path:
    """Write a MOTChallenge-style sequence folder.

    ``out_dir/video.mp4`` (or ``img1/`` PNG frames with ``video_format="frames"``),
    ``gt/gt.txt`` (MOT GT, body-centred boxes), ``gt/keypoints.npz`` (``keypoints``
    ``(T, N, 3, 2)`` px [head, body, tail], NaN when absent; ``ids`` ``(N,)`` the MOT
    ids; ``keypoint_names``), ``gt_tracks.nc`` (trajectory format with
    the true speeds, rates and phases), ``seqinfo.ini`` and ``synth.toml`` (the config).
    """
    from thermoswarm.io.mot import write_mot_table
    from thermoswarm.io.netcdf import write as write_nc

    if video_format not in ("mp4", "frames"):
        raise InputError(f"video_format must be 'mp4' or 'frames', got {video_format!r}")
    out = prepare_output_dir(out_dir)
    cfg = video.config
    (out / "gt").mkdir(exist_ok=True)
    write_mot_table(out / "gt" / "gt.txt", video.mot_gt)
    buf = io.BytesIO()
    np.savez_compressed(
        buf, keypoints=video.keypoints, ids=video.ids, keypoint_names=np.array(anatomy.KEYPOINTS)
    )
    atomic_write_bytes(out / "gt" / "keypoints.npz", buf.getvalue())
    write_nc(video.tracks, out / "gt_tracks.nc")
    atomic_write_text(out / "synth.toml", dumps_toml(cfg))
    target = out / ("video.mp4" if video_format == "mp4" else "img1")
    write_video(video.frames(), target, cfg.fps)
    atomic_write_text(
        out / "seqinfo.ini",
        (
            "[Sequence]\n"
            f"name={out.name}\nimDir=img1\nframeRate={cfg.fps:g}\nseqLength={cfg.n_frames}\n"
            f"imWidth={cfg.width}\nimHeight={cfg.height}\nimExt=.png\n"
        ),
    )
    return out


def _main() -> None:  # pragma: no cover - thin CLI, exercised by hand
    import click

    from thermoswarm.config import apply_overrides, from_mapping, parse_overrides, to_dict
    from thermoswarm.errors import ThermoswarmError

    @click.command()
    @click.argument("out_dir", type=click.Path(file_okay=False))
    @click.option("--seed", type=int, required=True, help="Seed of the random generator.")
    @click.option(
        "--format",
        "video_format",
        type=click.Choice(["mp4", "frames"]),
        default="mp4",
        show_default=True,
        help="Video as mp4 or PNG folder.",
    )
    @click.option(
        "--set",
        "overrides",
        multiple=True,
        metavar="KEY=VALUE",
        help="Any SynthConfig field, e.g. --set n_ants=40 --set width=1920.",
    )
    def main(out_dir: str, seed: int, video_format: str, overrides: tuple[str, ...]) -> None:
        """Write a synthetic ant video with MOTChallenge ground truth to OUT_DIR."""
        try:
            data = apply_overrides(to_dict(SynthConfig()), parse_overrides(overrides))
            cfg = from_mapping(SynthConfig, data, source="--set")
            video = generate(cfg, np.random.default_rng(seed))
            out = write_sequence(video, out_dir, video_format=video_format)
        except ThermoswarmError as exc:
            click.echo(f"error: {exc}", err=True)
            raise SystemExit(exc.exit_code) from None
        click.echo(
            f"wrote {out} ({cfg.n_ants} ants on the road at a time, {video.ids.size} "
            f"over the video as ants leave and enter; {cfg.n_frames} frames)"
        )

    main()


if __name__ == "__main__":  # pragma: no cover
    _main()
