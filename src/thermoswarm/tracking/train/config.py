"""The training configuration: :class:`TrainConfig` and its ``[augment]`` section.

Part of :mod:`thermoswarm.tracking.train.fit`; a module of its own so that the batch
sampler (:mod:`thermoswarm.tracking.train.augment`) and the loop both read it without
importing each other.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from thermoswarm.config import check
from thermoswarm.tracking.detect.unet import ModelConfig
from thermoswarm.tracking.train.real import RealCropConfig
from thermoswarm.tracking.train.synthetic import SynthDataConfig
from thermoswarm.tracking.train.validate import ValidationConfig

__all__ = ["AugmentConfig", "TrainConfig"]


@dataclass(frozen=True)
class AugmentConfig:
    """Augmentations: ``rotate`` (any angle half the time, multiples of 90 degrees
    otherwise), ``flip`` (mirror), ``scale`` (relative, uniform +-), ``brightness``
    (relative gain +-), ``contrast`` (relative +-), ``colour`` (per-channel gain +-),
    ``noise_sigma`` (largest Gaussian noise, grey levels), ``blur_sigma`` (largest
    Gaussian blur, px; applied to ``blur_probability`` of the samples)."""

    rotate: bool = True
    flip: bool = True
    scale: float = 0.08
    brightness: float = 0.25
    contrast: float = 0.2
    colour: float = 0.06
    noise_sigma: float = 6.0
    blur_sigma: float = 1.2
    blur_probability: float = 0.3

    def __post_init__(self) -> None:
        for name in ("scale", "brightness", "contrast", "colour"):
            v = getattr(self, name)
            check(0 <= v < 0.9, name, "in [0, 0.9)", v)
        for name in ("noise_sigma", "blur_sigma"):
            v = getattr(self, name)
            check(math.isfinite(v) and v >= 0, name, "a non-negative number", v)
        check(
            0 <= self.blur_probability <= 1, "blur_probability", "in [0, 1]", self.blur_probability
        )


@dataclass(frozen=True)
class TrainConfig:
    """Training options (TOML: top-level keys and ``[model]``, ``[augment]``,
    ``[synth]``, ``[validation]``, ``[real]`` tables; ``[real]``: the copy-paste
    composites of real ant crops, :class:`~thermoswarm.tracking.train.real.RealCropConfig`).

    ``seed``: of every random draw.  ``max_steps``: most optimisation steps (one batch
    for each network per step).  ``max_minutes``: wall-clock limit (``None``: none).
    ``eval_every``: steps between evaluations.  ``target_mota``, ``target_idsw_rate``:
    synthetic training stops when the validation video meets both, MOTA with a margin
    ``target_margin``, at ``target_evals`` consecutive evaluations (the validation clip
    is short: one lucky evaluation is not enough, and its MOTA ran 1-2 points above
    that of the longer benchmark videos).  ``lr``,
    ``weight_decay``: AdamW, learning rate decayed by a cosine to ``lr / 20`` over
    ``max_steps``.  ``centroid_batch``, ``patch_size`` (px, a multiple of 16):
    centroid patches per step and their side.  ``pose_batch``: crops per step.
    ``anchor_jitter_px``: standard deviation of the crop centre around the true body
    point (the centroid network's error); a fraction ``anchor_far_fraction`` of the
    crops is centred anywhere within ``anchor_far_px`` of it instead (a stray peak on
    a head or gaster), and every crop is labelled with the ant whose body point is
    nearest its centre, so that a stray peak yields the same pose again (removed as a
    duplicate) rather than a shifted ghost.  ``crowd_weight``: how much more often ants
    with another body point within half a body length are drawn for pose crops.
    ``variance_weight``: weight of the soft-argmax variance in the pose loss.
    ``ema_decay``: the model evaluated and saved is an exponential moving average of
    the weights with this decay per step (0: the weights themselves).
    ``val_fraction``: held-out frames of labelled data.  ``threads``: PyTorch threads
    (``None``: as set).
    """

    seed: int = 0
    max_steps: int = 4000
    max_minutes: float | None = None
    eval_every: int = 1000
    target_mota: float = 0.95
    target_idsw_rate: float = 0.01
    target_evals: int = 2
    target_margin: float = 0.01
    lr: float = 3e-3
    weight_decay: float = 1e-4
    centroid_batch: int = 8
    patch_size: int = 192
    pose_batch: int = 64
    anchor_jitter_px: float = 1.0
    anchor_far_fraction: float = 0.3
    anchor_far_px: float = 10.0
    crowd_weight: float = 3.0
    variance_weight: float = 0.05
    ema_decay: float = 0.99
    val_fraction: float = 0.1
    threads: int | None = None
    model: ModelConfig = field(default_factory=ModelConfig)
    augment: AugmentConfig = field(default_factory=AugmentConfig)
    synth: SynthDataConfig = field(default_factory=SynthDataConfig)
    validation: ValidationConfig = field(default_factory=ValidationConfig)
    real: RealCropConfig = field(default_factory=RealCropConfig)

    def __post_init__(self) -> None:
        check(self.max_steps >= 1, "max_steps", "a positive integer", self.max_steps)
        check(
            self.max_minutes is None or self.max_minutes > 0,
            "max_minutes",
            "a positive number",
            self.max_minutes,
        )
        check(self.eval_every >= 1, "eval_every", "a positive integer", self.eval_every)
        check(0 < self.target_mota <= 1, "target_mota", "in (0, 1]", self.target_mota)
        check(
            0 <= self.target_idsw_rate <= 1,
            "target_idsw_rate",
            "in [0, 1]",
            self.target_idsw_rate,
        )
        check(self.target_evals >= 1, "target_evals", "a positive integer", self.target_evals)
        check(0 <= self.target_margin < 1, "target_margin", "in [0, 1)", self.target_margin)
        check(self.lr > 0, "lr", "a positive number", self.lr)
        check(self.weight_decay >= 0, "weight_decay", "a non-negative number", self.weight_decay)
        check(
            self.centroid_batch >= 1, "centroid_batch", "a positive integer", self.centroid_batch
        )
        check(
            self.patch_size >= 32 and self.patch_size % 16 == 0,
            "patch_size",
            "a multiple of 16, at least 32 px",
            self.patch_size,
        )
        check(self.pose_batch >= 1, "pose_batch", "a positive integer", self.pose_batch)
        check(self.anchor_jitter_px >= 0, "anchor_jitter_px", ">= 0", self.anchor_jitter_px)
        check(
            0 <= self.anchor_far_fraction <= 1,
            "anchor_far_fraction",
            "in [0, 1]",
            self.anchor_far_fraction,
        )
        check(self.anchor_far_px >= 0, "anchor_far_px", ">= 0", self.anchor_far_px)
        check(self.crowd_weight >= 0, "crowd_weight", ">= 0", self.crowd_weight)
        check(self.variance_weight >= 0, "variance_weight", ">= 0", self.variance_weight)
        check(0 <= self.ema_decay < 1, "ema_decay", "in [0, 1)", self.ema_decay)
        check(0 <= self.val_fraction < 1, "val_fraction", "in [0, 1)", self.val_fraction)
        check(
            self.threads is None or self.threads >= 1,
            "threads",
            "a positive integer",
            self.threads,
        )
