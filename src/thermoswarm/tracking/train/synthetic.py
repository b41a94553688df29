"""Synthetic training frames for the U-Net + pose model: many short videos of the
generator (:mod:`thermoswarm.tracking.synth`), each with its own seed, size, density of
ants, ant size and imaging, through the benchmark's video codec.  Part of
:mod:`thermoswarm.tracking.train.fit`."""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.config import check
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.train.data import LabeledFrames

__all__ = ["SynthDataConfig", "synthetic_data"]


@dataclass(frozen=True)
class SynthDataConfig:
    """Synthetic training data: ``n_videos`` videos, ``frames_per_video`` frames each
    (``frame_step`` frames apart), of ``width`` x ``height`` px (the road along the
    long side; each size varies by up to ``size_jitter`` of itself), with a density of
    ants drawn uniformly between ``density_min`` and ``density_max`` ants per 100 mm of
    road (the benchmark: 40 ants on 632 mm, 6.3), ant lengths drawn within
    ``length_jitter`` of the paper's 7.14 mm, and, if ``vary_imaging``, noise, blur,
    lighting and shadows varied around the generator's defaults.  ``codec``: pass the
    frames through x264 (CRF 20) like the benchmark videos."""

    n_videos: int = 40
    frames_per_video: int = 12
    frame_step: int = 5
    width: int = 640
    height: int = 224
    size_jitter: float = 0.25
    density_min: float = 4.0
    density_max: float = 13.0
    length_jitter: float = 0.1
    vary_imaging: bool = True
    codec: bool = True

    def __post_init__(self) -> None:
        check(self.n_videos >= 1, "n_videos", "a positive integer", self.n_videos)
        check(
            self.frames_per_video >= 1,
            "frames_per_video",
            "a positive integer",
            self.frames_per_video,
        )
        check(self.frame_step >= 1, "frame_step", "a positive integer", self.frame_step)
        check(self.width >= 64, "width", "at least 64 px", self.width)
        check(self.height >= 64, "height", "at least 64 px", self.height)
        check(0 <= self.size_jitter < 1, "size_jitter", "in [0, 1)", self.size_jitter)
        check(
            0 < self.density_min <= self.density_max,
            "density_min",
            "positive and <= density_max",
            self.density_min,
        )
        check(0 <= self.length_jitter < 0.5, "length_jitter", "in [0, 0.5)", self.length_jitter)


def _codec_roundtrip(frames: list[np.ndarray], fps: float) -> list[np.ndarray]:
    """Encode frames with x264 (CRF 20, as the benchmark videos) and decode them."""
    from thermoswarm.tracking.synth.clip import write_video
    from thermoswarm.tracking.video import open_video

    with tempfile.TemporaryDirectory(prefix="thermoswarm-train-") as tmp:
        path = Path(tmp) / "v.mp4"
        write_video(frames, path, fps)
        out = list(open_video(path).frames())
    if len(out) != len(frames):
        raise RuntimeError(f"codec round trip returned {len(out)} of {len(frames)} frames")
    return out


def synthetic_data(
    config: SynthDataConfig,
    rng: np.random.Generator,
    *,
    px_per_mm: float = 3.04,
    progress: Callable[[int, int], None] | None = None,
) -> LabeledFrames:
    """Render labelled frames from many synthetic videos (see :class:`SynthDataConfig`)."""
    from thermoswarm.tracking.synth.clip import SynthConfig, generate

    frames: list[np.ndarray] = []
    points: list[np.ndarray] = []
    c = config
    for v in range(c.n_videos):
        w = int(round(c.width * (1 + c.size_jitter * rng.uniform(-1, 1))))
        h = int(round(c.height * (1 + c.size_jitter * rng.uniform(-1, 1))))
        w, h = max(w, h), min(w, h)
        h = max(h, int(math.ceil(44 * px_per_mm)))  # the 40 mm road must fit
        w, h = w + w % 2, h + h % 2  # even sizes for the codec's 4:2:0 chroma
        road_mm = w / px_per_mm
        density = rng.uniform(c.density_min, c.density_max)
        n_ants = max(1, int(round(density * road_mm / 100)))
        kw: dict[str, Any] = dict(
            width=w,
            height=h,
            n_ants=n_ants,
            n_frames=c.frames_per_video * c.frame_step,
            px_per_mm=px_per_mm,
            ant_length_mm=anatomy.ANT_LENGTH_MM * (1 + c.length_jitter * rng.uniform(-1, 1)),
        )
        if c.vary_imaging:
            kw.update(
                noise_sigma=float(rng.uniform(2.0, 7.0)),
                blur_sigma_px=float(rng.uniform(0.3, 1.0)),
                lighting_drift=float(rng.uniform(0.0, 0.2)),
                flicker=float(rng.uniform(0.0, 0.03)),
                shadow_strength=float(rng.uniform(0.0, 0.4)),
                exposure=float(rng.uniform(0.2, 0.8)),
            )
        video = generate(SynthConfig(**kw), rng)
        ks = np.arange(c.frames_per_video) * c.frame_step + int(rng.integers(c.frame_step))
        imgs = [video.render(int(k)) for k in ks]
        if c.codec:
            imgs = _codec_roundtrip(imgs, video.config.fps)
        for k, img in zip(ks, imgs, strict=True):
            kp = video.keypoints[k]
            frames.append(img)
            points.append(kp[np.isfinite(kp[:, 1, 0])].copy())
        if progress is not None:
            progress(v + 1, c.n_videos)
    return LabeledFrames(frames, points, px_per_mm, f"synthetic ({c.n_videos} videos)")
