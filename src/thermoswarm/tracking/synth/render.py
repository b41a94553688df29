"""Rendering of the synthetic ants: wood texture, lighting, the articulated ant shape,
and :class:`SynthVideo`, the ground truth with a lazy frame renderer.  Part of
:mod:`thermoswarm.tracking.synth.clip`, which is the public API."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import xarray as xr

from thermoswarm.tracking import anatomy
from thermoswarm.tracking.synth.motion import Road, SynthConfig, _Motion


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
