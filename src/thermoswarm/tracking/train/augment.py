"""Augmentation and batch sampling for training (affine, photometric, heat-map targets).
Part of :mod:`thermoswarm.tracking.train.fit`."""

from __future__ import annotations

import math

import numpy as np

from thermoswarm.errors import InputError
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.train.config import AugmentConfig, TrainConfig
from thermoswarm.tracking.train.data import LabeledFrames


def _affine(
    rng: np.random.Generator,
    aug: AugmentConfig,
    centre: np.ndarray,
    target: np.ndarray,
) -> np.ndarray:
    """2x3 matrix: rotation, mirror and scale about ``centre``, which lands on
    ``target`` (output px)."""
    theta = 0.0
    if aug.rotate:
        theta = rng.uniform(0, 2 * np.pi) if rng.random() < 0.5 else 0.5 * np.pi * rng.integers(4)
    s = 1.0 + aug.scale * rng.uniform(-1, 1)
    c, si = math.cos(theta) * s, math.sin(theta) * s
    A = np.array([[c, -si], [si, c]])
    if aug.flip and rng.random() < 0.5:
        A = A @ np.diag([-1.0, 1.0])
    t = target - A @ centre
    return np.column_stack([A, t])


def _apply(M: np.ndarray, pts: np.ndarray) -> np.ndarray:
    return pts @ M[:, :2].T + M[:, 2]


def _photometric(rng: np.random.Generator, aug: AugmentConfig, imgs: np.ndarray) -> np.ndarray:
    """Blur, brightness, contrast, colour and noise on a batch ``(B, H, W, 3)`` of
    ``uint8`` RGB images; returns ``uint8`` (vectorised over the batch)."""
    import cv2

    B = imgs.shape[0]
    x = imgs.astype(np.float32)
    if aug.blur_sigma > 0 and aug.blur_probability > 0:
        for b in np.flatnonzero(rng.random(B) < aug.blur_probability):
            x[b] = cv2.GaussianBlur(x[b], (0, 0), float(rng.uniform(0.3, aug.blur_sigma)))
    gain = (1 + aug.brightness * rng.uniform(-1, 1, (B, 1, 1, 1))) * (
        1 + aug.colour * rng.uniform(-1, 1, (B, 1, 1, 3))
    )
    con = 1 + aug.contrast * rng.uniform(-1, 1, (B, 1, 1, 1))
    mean = x.mean(axis=(1, 2), keepdims=True)
    x = (x - mean) * con.astype(np.float32) + mean
    x *= gain.astype(np.float32)
    if aug.noise_sigma > 0:
        sd = rng.uniform(0, aug.noise_sigma, (B, 1, 1, 1)).astype(np.float32)
        x += sd * rng.standard_normal(x.shape, dtype=np.float32)
    np.clip(x, 0, 255, out=x)
    return np.rint(x).astype(np.uint8)


class _Sampler:
    """Draws augmented centroid patches and pose crops from labelled frames."""

    def __init__(self, data: LabeledFrames, config: TrainConfig, rng: np.random.Generator):
        from scipy.spatial import cKDTree

        self.data = data
        self.cfg = config
        self.mc = config.model
        self.rng = rng
        self.length_px = anatomy.ANT_LENGTH_MM * data.px_per_mm
        n = np.array([p.shape[0] for p in data.points], dtype=np.float64)
        if n.sum() == 0:
            raise InputError(f"{data.source}: the training frames hold no labelled ant")
        # Frames for patches: in proportion to their area (every pixel equally likely).
        area = np.array([f.shape[0] * f.shape[1] for f in data.frames], dtype=np.float64)
        self.p_frame = area / area.sum()
        # Ants for crops: crowded ones (a neighbour within half a body length) weigh more.
        inst_frame, inst_idx, weight = [], [], []
        for i, p in enumerate(data.points):
            if p.shape[0] == 0:
                continue
            b = p[:, 1]
            crowded = np.zeros(p.shape[0], bool)
            if p.shape[0] > 1:
                d, _ = cKDTree(b).query(b, k=2)
                crowded = d[:, 1] < 0.5 * self.length_px
            inst_frame.append(np.full(p.shape[0], i))
            inst_idx.append(np.arange(p.shape[0]))
            weight.append(1.0 + config.crowd_weight * crowded)
        self.inst_frame = np.concatenate(inst_frame)
        self.inst_idx = np.concatenate(inst_idx)
        w = np.concatenate(weight)
        self.p_inst = w / w.sum()
        self.n_crowded = int((w > 1).sum())

    def centroid_batch(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Inputs ``(B, h, w, 3)`` uint8 at the network's input scale and target maps
        ``(B, h, w)`` float32, plus a weight map ``(B, h, w)`` (0 within half a body
        length of the frame's ``ignore`` ants; 1 elsewhere)."""
        import cv2

        cfg, mc, rng = self.cfg, self.mc, self.rng
        P = cfg.patch_size
        s = mc.input_scale
        h = int(round(P * s))
        xs_in = (np.arange(h) + 0.5) / s - 0.5  # cell centres in patch px
        X, Y = np.meshgrid(xs_in, xs_in)
        inputs = np.empty((cfg.centroid_batch, h, h, 3), np.uint8)
        patches = np.empty((cfg.centroid_batch, P, P, 3), np.uint8)
        targets = np.zeros((cfg.centroid_batch, h, h), np.float32)
        weights = np.ones((cfg.centroid_batch, h, h), np.float32)
        two_s2 = 2 * mc.sigma_px**2
        r_ignore2 = (0.5 * self.length_px) ** 2
        for b in range(cfg.centroid_batch):
            i = int(rng.choice(len(self.data), p=self.p_frame))
            frame, pts = self.data.frames[i], self.data.points[i]
            H, W = frame.shape[:2]
            if pts.shape[0] and rng.random() < 0.8:
                j = int(rng.integers(pts.shape[0]))
                c = pts[j, 1] + rng.uniform(-0.3 * P, 0.3 * P, 2)
            else:
                c = np.array([rng.uniform(0, W), rng.uniform(0, H)])
            M = _affine(rng, cfg.augment, c, np.array([(P - 1) / 2, (P - 1) / 2]))
            patches[b] = cv2.warpAffine(
                frame, M, (P, P), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101
            )
            if pts.shape[0]:
                q = _apply(M, pts[:, 1])
                inside = (
                    (q[:, 0] > -3 * mc.sigma_px)
                    & (q[:, 0] < P + 3 * mc.sigma_px)
                    & (q[:, 1] > -3 * mc.sigma_px)
                    & (q[:, 1] < P + 3 * mc.sigma_px)
                )
                q = q[inside]
                if q.shape[0]:
                    d2 = (X[None] - q[:, 0, None, None]) ** 2 + (
                        Y[None] - q[:, 1, None, None]
                    ) ** 2
                    targets[b] = np.exp(-d2.min(0) / two_s2)
            ign = self.data.ignore_at(i)
            if ign.shape[0]:
                # An ant left unlabelled is not background: no loss within half a body
                # length of it (the target there stays 0, the weight is 0).
                q = _apply(M, ign)
                d2 = (X[None] - q[:, 0, None, None]) ** 2 + (Y[None] - q[:, 1, None, None]) ** 2
                weights[b][(d2 < r_ignore2).any(0)] = 0.0
        patches = _photometric(rng, cfg.augment, patches)
        for b in range(cfg.centroid_batch):
            inputs[b] = cv2.resize(patches[b], (h, h), interpolation=cv2.INTER_AREA)
        return inputs, targets, weights

    def pose_batch(self) -> tuple[np.ndarray, np.ndarray]:
        """Crops ``(B, C, C, 3)`` uint8 and their points ``(B, 3, 2)`` (crop px, NaN
        where unlabelled)."""
        import cv2

        cfg, mc, rng = self.cfg, self.mc, self.rng
        C = mc.crop_size
        crops = np.empty((cfg.pose_batch, C, C, 3), np.uint8)
        pts_out = np.empty((cfg.pose_batch, 3, 2))
        picks = rng.choice(self.p_inst.size, size=cfg.pose_batch, p=self.p_inst)
        for b, k in enumerate(picks):
            i, j = int(self.inst_frame[k]), int(self.inst_idx[k])
            frame, every = self.data.frames[i], self.data.points[i]
            if rng.random() < cfg.anchor_far_fraction:
                # A peak off the body (on a head or gaster): uniform in a disc.
                r = cfg.anchor_far_px * math.sqrt(rng.random())
                a = rng.uniform(0, 2 * np.pi)
                jit = np.array([r * math.cos(a), r * math.sin(a)])
            else:
                s = cfg.anchor_jitter_px
                jit = np.clip(rng.normal(0, s, 2), -3 * s, 3 * s)
            anchor = every[j, 1] + jit
            # A crop is answered with the ant whose body point is nearest its centre.
            pts = every[int(np.argmin(np.linalg.norm(every[:, 1] - anchor, axis=1)))]
            # The inference crop puts the rounded anchor at pixel C // 2: the anchor
            # lands within half a pixel of it.
            target = np.array([C // 2, C // 2]) + rng.uniform(-0.5, 0.5, 2)
            M = _affine(rng, cfg.augment, anchor, target)
            crops[b] = cv2.warpAffine(
                frame, M, (C, C), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT_101
            )
            pts_out[b] = _apply(M, pts)
        return _photometric(rng, cfg.augment, crops), pts_out


# ---------------------------------------------------------------- validation
