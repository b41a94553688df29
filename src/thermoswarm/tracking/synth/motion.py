"""Synthetic ants' motion on the paper's road: the configuration, the road geometry
and the simulation (mm, s, rad).  The model is described in
:mod:`thermoswarm.tracking.synth.clip`, which is the public API."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from thermoswarm.config import check
from thermoswarm.maxent import DecayingTemperature, EnergyMixture, SteeringLaw, wrap_angle
from thermoswarm.tracking import anatomy


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


@dataclass(frozen=True)
class _Rates:
    """The simulation's constants per step (mm, s)."""

    dt: float  # s per frame
    margin: float  # mm: the body point keeps half an ant's width from the walls
    kT: np.ndarray  # (2,) energy per unit mass of phases 1 and 2, mm^2/s^2
    p_speed: float  # probability per step of a new speed
    p_phase: float  # probability per step of a new phase draw
    gait_len: float  # mm per gait cycle

    @classmethod
    def of(cls, cfg: SynthConfig) -> _Rates:
        dt = 1.0 / cfg.fps
        return cls(
            dt=dt,
            margin=cfg.ant_width_mm / 2,
            kT=np.array([cfg.kT1, cfg.kT2]),
            p_speed=-math.expm1(-dt / cfg.speed_tau_s),
            p_phase=-math.expm1(-dt / cfg.phase_tau_s),
            gait_len=0.35 * cfg.ant_length_mm,
        )


@dataclass
class _Slots:
    """The state of the ``n`` slots (one ant per slot at a time; an ant that leaves is
    replaced by a new one in its slot)."""

    pos: np.ndarray  # (n, 2) road (s, u), mm
    goal: np.ndarray  # (n,) travel direction along the road, rad
    heading: np.ndarray  # (n,) rad
    phase: np.ndarray  # (n,) int8, 1 or 2
    v: np.ndarray  # (n,) mm/s
    head_a: np.ndarray  # (n,) head articulation, rad
    tail_a: np.ndarray  # (n,) gaster articulation, rad
    gait: np.ndarray  # (n,) rad
    ident: np.ndarray  # (n,) the individual in each slot
    n_ids: int  # individuals so far
    sizes: list[float]  # per individual
    shades: list[float]  # per individual

    @classmethod
    def start(cls, cfg: SynthConfig, road: Road, rng: np.random.Generator, r: _Rates) -> _Slots:
        n = cfg.n_ants
        pos = _place(rng, road, n, r.margin)
        goal = np.where(rng.random(n) < 0.5, 0.0, np.pi)  # travel direction along the road
        heading = goal + 0.3 * rng.standard_normal(n)
        phase = np.where(rng.random(n) < cfg.phi, 1, 2).astype(np.int8)
        v = np.sqrt(2 * r.kT[phase - 1] * rng.standard_exponential(n))
        head_a = 0.1 * rng.standard_normal(n)
        tail_a = 0.06 * rng.standard_normal(n)
        gait = rng.uniform(0, 2 * np.pi, n)
        sizes = list(1 + cfg.size_sd * rng.standard_normal(n))
        shades = list(rng.uniform(0.85, 1.15, n))
        return cls(pos, goal, heading, phase, v, head_a, tail_a, gait, np.arange(n), n,
                   sizes, shades)  # fmt: skip


class _Record:
    """What each slot was at each frame, turned into individuals at the end."""

    def __init__(self, T: int, n: int) -> None:
        self.pos = np.empty((T, n, 2))
        self.val = {k: np.empty((T, n)) for k in ("heading", "head", "tail", "gait", "v", "w")}
        self.phase = np.empty((T, n), np.int8)
        self.wall = np.zeros((T, n), bool)
        self.id = np.empty((T, n), np.int64)

    def store(self, k: int, sl: _Slots, w: np.ndarray) -> None:
        self.pos[k] = sl.pos
        self.val["heading"][k] = sl.heading
        self.val["head"][k] = sl.head_a
        self.val["tail"][k] = sl.tail_a
        self.val["gait"][k] = sl.gait
        self.val["v"][k] = sl.v
        self.val["w"][k] = w
        self.phase[k] = sl.phase
        self.id[k] = sl.ident

    def individuals(self, sl: _Slots) -> _Motion:
        """Slots -> individuals (NaN, phase 0 and not alive where one is absent)."""
        T, n = self.id.shape
        N = sl.n_ids
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
            size=np.asarray(sl.sizes),
            shade=np.asarray(sl.shades),
        )
        tt = np.repeat(np.arange(T), n)
        ii = self.id.ravel()
        out.body[tt, ii] = self.pos.reshape(-1, 2)
        out.heading[tt, ii] = self.val["heading"].ravel()
        out.head_angle[tt, ii] = self.val["head"].ravel()
        out.tail_angle[tt, ii] = self.val["tail"].ravel()
        out.gait[tt, ii] = self.val["gait"].ravel()
        out.speed[tt, ii] = self.val["v"].ravel()
        out.rate[tt, ii] = self.val["w"].ravel()
        out.phase[tt, ii] = self.phase.ravel()
        out.wall[tt, ii] = self.wall.ravel()
        out.alive[tt, ii] = True
        # The last step of an ant that leaves has no next frame: its speed and rate are
        # still the true ones of that step, kept.
        return out


def _redraw(cfg: SynthConfig, sl: _Slots, u: np.ndarray, e_speed: np.ndarray, r: _Rates) -> None:
    """New phases (probability ``p_phase``) and speeds (``p_speed``, or a changed
    phase); ``u``: the step's uniforms for the phase, the new phase and the speed."""
    u_phase, u_newphase, u_speed = u
    redraw = u_phase < r.p_phase
    new_phase = np.where(u_newphase < cfg.phi, 1, 2).astype(np.int8)
    changed = redraw & (new_phase != sl.phase)
    sl.phase = np.where(redraw, new_phase, sl.phase)
    resample = (u_speed < r.p_speed) | changed
    sl.v = np.where(resample, np.sqrt(2 * r.kT[sl.phase - 1] * e_speed), sl.v)


def _turn_rate(
    cfg: SynthConfig, steer: SteeringLaw, sl: _Slots, u_sign: np.ndarray, e_steer: np.ndarray
) -> np.ndarray:
    """Turning rates (rad/s): exponential magnitudes at the steering temperature of the
    speed, towards the goal with probability ``0.5 + goal_bias * |error| / (pi / 2)``."""
    T_theta = steer.temperature(sl.v)
    err = wrap_angle(sl.goal - sl.heading)
    p_toward = 0.5 + cfg.goal_bias * np.clip(np.abs(err) / (np.pi / 2), 0, 1)
    toward = np.where(err >= 0, 1.0, -1.0)
    return np.where(u_sign < p_toward, toward, -toward) * e_steer * T_theta


def _reflect(
    road: Road,
    pos: np.ndarray,
    heading: np.ndarray,
    new: np.ndarray,
    new_heading: np.ndarray,
    margin: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Walls: reflect the step's ``new`` positions and headings (in place) across the
    lateral walls, then along (the shoulder at ``narrow_start``); a slot still outside
    (a corner) stays and turns around.  Returns the slots past an end of the road and
    the slots a wall reflected."""
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
    return ends, bad


def _walk(
    road: Road, sl: _Slots, w: np.ndarray, art: np.ndarray, r: _Rates
) -> tuple[np.ndarray, np.ndarray]:
    """One step of every slot (walls, gait, articulation); returns the slots past an
    end of the road and the slots a wall reflected."""
    step = sl.v * r.dt
    new = sl.pos + step[:, None] * np.column_stack([np.cos(sl.heading), np.sin(sl.heading)])
    new_heading = sl.heading + w * r.dt
    ends, bad = _reflect(road, sl.pos, sl.heading, new, new_heading, r.margin)
    sl.pos = new
    sl.heading = wrap_angle(new_heading)
    sl.gait = sl.gait + 2 * np.pi * step / r.gait_len
    sl.head_a = 0.9 * sl.head_a + 0.1 * 0.1 * math.sqrt(1 / 0.19) * art[0]
    sl.tail_a = 0.9 * sl.tail_a + 0.1 * 0.06 * math.sqrt(1 / 0.19) * art[1]
    return ends, bad


def _replace(
    cfg: SynthConfig,
    road: Road,
    rng: np.random.Generator,
    sl: _Slots,
    ends: np.ndarray,
    r: _Rates,
) -> None:
    """Ants that left the road at an end are replaced by new ants entering there."""
    idx = np.flatnonzero(ends)
    m = idx.size
    at_start = sl.pos[idx, 0] < 0
    s_new = np.where(at_start, 0.0, road.length)
    hw_new = road.half_width(s_new) - r.margin
    u_new = rng.uniform(-1, 1, m) * hw_new
    sl.goal[idx] = np.where(at_start, 0.0, np.pi)
    sl.heading[idx] = sl.goal[idx] + 0.3 * rng.standard_normal(m)
    sl.pos[idx] = np.column_stack([s_new, u_new])
    sl.phase[idx] = np.where(rng.random(m) < cfg.phi, 1, 2)
    sl.v[idx] = np.sqrt(2 * r.kT[sl.phase[idx] - 1] * rng.standard_exponential(m))
    sl.head_a[idx] = 0.0
    sl.tail_a[idx] = 0.0
    sl.ident[idx] = sl.n_ids + np.arange(m)
    sl.n_ids += m
    sl.sizes.extend(1 + cfg.size_sd * rng.standard_normal(m))
    sl.shades.extend(rng.uniform(0.85, 1.15, m))


def _simulate(cfg: SynthConfig, road: Road, rng: np.random.Generator) -> _Motion:
    """The ants' motion over ``n_frames`` frames (the model of
    :mod:`thermoswarm.tracking.synth.clip`)."""
    n, T = cfg.n_ants, cfg.n_frames
    r = _Rates.of(cfg)
    steer = cfg.steering_law
    sl = _Slots.start(cfg, road, rng, r)
    rec = _Record(T, n)
    for k in range(T):
        # Fixed number of draws per frame, whether used or not: reproducible streams.
        u_phase, u_newphase, u_speed, e_speed, u_sign, e_steer = rng.random((6, n))
        e_speed = -np.log1p(-e_speed)  # standard exponential from a uniform
        e_steer = -np.log1p(-e_steer)
        art = rng.standard_normal((2, n))
        if k > 0:
            _redraw(cfg, sl, (u_phase, u_newphase, u_speed), e_speed, r)
        w = _turn_rate(cfg, steer, sl, u_sign, e_steer)
        rec.store(k, sl, w)
        ends, rec.wall[k] = _walk(road, sl, w, art, r)
        if ends.any():
            _replace(cfg, road, rng, sl, ends, r)
    return rec.individuals(sl)


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
