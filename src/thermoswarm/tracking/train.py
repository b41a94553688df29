"""Training the top-down detector (:mod:`thermoswarm.tracking.unet`): data and loop.

Training data (:class:`LabeledFrames`: RGB frames and each ant's head, body and tail
in px) come from

- the synthetic generator (:func:`synthetic_data`): many short videos with their own
  seeds, frame sizes, numbers of ants (crowded up to twice the benchmark's density),
  ant sizes and imaging conditions, passed through the same video codec (x264, CRF 20)
  as the benchmark videos so that the model sees compression artefacts;
- SLEAP labels (:func:`read_slp`): a ``.slp`` file with embedded images (``.pkg.slp``)
  or with readable video files, via ``sleap-io``;
- COCO keypoint JSON (:func:`read_coco`) with its image files.

For SLEAP and COCO, the skeleton's nodes are mapped to head, body and tail by name
(``nodes=("head", "thorax", "gaster")``) or by the usual names (head; body, thorax,
mesosoma, centroid, center; tail, gaster, abdomen).  Points not labelled are NaN and do
not count in the loss.  Coordinates are used as given (pixel centres at integers, the
COCO keypoint and OpenCV convention).

Each training step draws a batch of patches for the centroid network (centred on an
ant with probability 0.8, anywhere otherwise) and a batch of crops for the pose network
(centred on an ant's body point plus a small jitter, the anchor error of the centroid
network; ants with a close neighbour are drawn more often, since crossings are where
detection fails), augments them (rotation -- by any angle half the time, by multiples of
90 degrees otherwise --, mirror, scale, brightness, contrast, colour balance, blur,
noise) and takes one AdamW step on each network (cosine learning-rate decay).  The
centroid loss is a focal binary cross-entropy against the Gaussian confidence map; the
pose loss is the paper's mean squared point distance (px^2) plus ``variance_weight``
times the variance of the soft-argmax maps.

Every ``eval_every`` steps the model is evaluated: on synthetic data, on a held-out
synthetic video (its own seed, the benchmark's density of ants, through the codec)
detected and *tracked* by the real tracker and scored with CLEAR-MOT; training stops as
soon as ``target_mota`` and ``target_idsw_rate`` are met.  On labelled data, on the
held-out fraction ``val_fraction`` of the frames (detection precision, recall, F1 and
keypoint errors).  The best model by validation (MOTA, else F1) is the one written.

Reproducibility: every draw flows from ``numpy.random.default_rng(seed)`` and
``torch.manual_seed(seed)``, with ``torch.use_deterministic_algorithms`` on; the same
seed, data, thread count and stopping rule give the same weights (a ``max_minutes``
limit stops at a time-dependent step).
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import json
import math
import os
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.config import check, to_dict
from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_json
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.unet import ModelConfig

__all__ = [
    "LabeledFrames",
    "SynthDataConfig",
    "AugmentConfig",
    "ValidationConfig",
    "TrainConfig",
    "synthetic_data",
    "read_slp",
    "read_coco",
    "read_labels",
    "ValidationSet",
    "synthetic_validation",
    "evaluate_detector",
    "train",
    "train_from_sources",
    "NODE_ALIASES",
]

#: Skeleton node names recognised as head, body and tail (lower case).
NODE_ALIASES: tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...]] = (
    ("head",),
    ("body", "thorax", "mesosoma", "centroid", "center", "centre", "trunk"),
    ("tail", "gaster", "abdomen"),
)


# ----------------------------------------------------------------------------- data


@dataclass
class LabeledFrames:
    """Frames with labelled ants.

    Attributes
    ----------
    frames
        RGB ``uint8`` ``(H, W, 3)`` images (sizes may differ).
    points
        Per frame ``(n, 3, 2)`` float px: head, body, tail of each labelled ant, NaN
        where a point is not labelled.
    px_per_mm
        Scale of the images.
    source
        Where they came from (for reports).
    """

    frames: list[np.ndarray]
    points: list[np.ndarray]
    px_per_mm: float
    source: str = ""

    def __post_init__(self) -> None:
        if len(self.frames) != len(self.points):
            raise ValueError("frames and points must have the same length")

    @property
    def n_instances(self) -> int:
        return int(sum(p.shape[0] for p in self.points))

    def __len__(self) -> int:
        return len(self.frames)

    def subset(self, idx: Sequence[int]) -> LabeledFrames:
        return LabeledFrames(
            [self.frames[i] for i in idx],
            [self.points[i] for i in idx],
            self.px_per_mm,
            self.source,
        )

    def rescaled(self, px_per_mm: float) -> LabeledFrames:
        """The frames resized to another scale (px per mm), points mapped with them."""
        from thermoswarm.tracking.unet import to_model_scale

        ratio = px_per_mm / self.px_per_mm
        if abs(ratio - 1) < 1e-6:
            return self
        frames, points = [], []
        for f, p in zip(self.frames, self.points, strict=True):
            g, (fx, fy) = to_model_scale(f, ratio)
            q = p.copy()
            q[..., 0] = (q[..., 0] + 0.5) * fx - 0.5
            q[..., 1] = (q[..., 1] + 0.5) * fy - 0.5
            frames.append(g)
            points.append(q)
        return LabeledFrames(frames, points, px_per_mm, self.source)

    @staticmethod
    def concat(parts: Sequence[LabeledFrames]) -> LabeledFrames:
        if not parts:
            raise InputError("no training data")
        scale = parts[0].px_per_mm
        out = LabeledFrames([], [], scale, " + ".join(p.source for p in parts))
        for p in parts:
            p = p.rescaled(scale)
            out.frames.extend(p.frames)
            out.points.extend(p.points)
        return out


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
class ValidationConfig:
    """The held-out synthetic video of synthetic training: ``width`` x ``height`` px,
    ``n_ants`` ants, ``n_frames`` frames (default: the benchmark's geometry and
    density, 5 s), its own ``seed``."""

    width: int = 1920
    height: int = 1080
    n_ants: int = 40
    n_frames: int = 150
    seed: int = 1_000_003

    def __post_init__(self) -> None:
        check(self.width >= 64, "width", "at least 64 px", self.width)
        check(self.height >= 64, "height", "at least 64 px", self.height)
        check(self.n_ants >= 1, "n_ants", "a positive integer", self.n_ants)
        check(self.n_frames >= 10, "n_frames", "at least 10", self.n_frames)


@dataclass(frozen=True)
class TrainConfig:
    """Training options (TOML: top-level keys and ``[model]``, ``[augment]``,
    ``[synth]``, ``[validation]`` tables).

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


# -------------------------------------------------------------- synthetic source


def _codec_roundtrip(frames: list[np.ndarray], fps: float) -> list[np.ndarray]:
    """Encode frames with x264 (CRF 20, as the benchmark videos) and decode them."""
    from thermoswarm.tracking.synth import write_video
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
    from thermoswarm.tracking.synth import SynthConfig, generate

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


# --------------------------------------------------------------- labelled sources


def _node_indices(
    names: Sequence[str], nodes: Sequence[str] | None, where: str
) -> tuple[int, int, int]:
    low = [n.lower() for n in names]
    if nodes is not None:
        if len(nodes) != 3:
            raise InputError(f"nodes must name head, body and tail (3 names), got {list(nodes)}")
        out = []
        for want in nodes:
            if want.lower() not in low:
                raise InputError(
                    f"{where}: skeleton has no node {want!r}; its nodes are: " + ", ".join(names)
                )
            out.append(low.index(want.lower()))
        return out[0], out[1], out[2]
    out = []
    for role, aliases in zip(("head", "body", "tail"), NODE_ALIASES, strict=True):
        hit = [i for i, n in enumerate(low) if n in aliases]
        if not hit:
            raise InputError(
                f"{where}: no {role} node among {', '.join(names)} "
                f"(expected one of {', '.join(aliases)}); name them with --nodes HEAD,BODY,TAIL"
            )
        out.append(hit[0])
    return out[0], out[1], out[2]


def read_slp(
    path: str | os.PathLike, *, px_per_mm: float, nodes: Sequence[str] | None = None
) -> LabeledFrames:
    """Labelled frames of a SLEAP ``.slp`` file (images embedded or in readable videos).

    User-labelled instances are used where a frame has any, else its predicted ones.
    """
    path = Path(path)
    try:
        import sleap_io as sio
    except ImportError:
        raise InputError(
            f"{path}: reading SLEAP files needs sleap-io (pip install 'thermoswarm[io]')"
        ) from None
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    try:
        labels = sio.load_slp(str(path))
    except Exception as exc:
        raise InputError(f"{path}: not a readable SLEAP file ({type(exc).__name__})") from None
    frames: list[np.ndarray] = []
    points: list[np.ndarray] = []
    cache: dict[int, tuple[int, int, int]] = {}
    for lf in labels.labeled_frames:
        insts = lf.user_instances or lf.instances
        if not insts:
            continue
        try:
            img = np.asarray(lf.image)
        except Exception as exc:
            raise InputError(
                f"{path}: image of frame {lf.frame_idx} of {lf.video.filename} cannot be "
                f"read ({type(exc).__name__}); embed the images (a .pkg.slp) or keep the "
                "video beside the labels"
            ) from None
        if img is None or img.ndim not in (2, 3):
            raise InputError(f"{path}: frame {lf.frame_idx} has no image")
        img = _rgb(img)
        pts = np.full((len(insts), 3, 2), np.nan)
        for j, inst in enumerate(insts):
            sk = inst.skeleton
            key = id(sk)
            if key not in cache:
                cache[key] = _node_indices(sk.node_names, nodes, str(path))
            xy = inst.numpy()
            pts[j] = xy[list(cache[key])]
        pts = pts[np.isfinite(pts[:, 1, 0])]
        frames.append(img)
        points.append(pts)
    if not frames:
        raise InputError(f"{path}: no labelled frames")
    return LabeledFrames(frames, points, float(px_per_mm), f"SLEAP {path.name}")


def _rgb(img: np.ndarray) -> np.ndarray:
    img = np.asarray(img)
    if img.dtype != np.uint8:
        if np.issubdtype(img.dtype, np.floating) and img.max(initial=0) <= 1.0:
            img = img * 255.0
        img = np.clip(img, 0, 255).astype(np.uint8)
    if img.ndim == 2:
        img = img[:, :, None]
    if img.shape[2] == 1:
        img = np.repeat(img, 3, axis=2)
    return np.ascontiguousarray(img[:, :, :3])


def read_coco(
    path: str | os.PathLike,
    *,
    px_per_mm: float,
    image_root: str | os.PathLike | None = None,
    nodes: Sequence[str] | None = None,
) -> LabeledFrames:
    """Labelled frames of a COCO keypoint JSON file and its images.

    ``image_root`` (default: the JSON file's folder) is where ``file_name`` paths
    start.  Keypoints with visibility 0 are not labelled (NaN); 1 and 2 count.  Only
    categories that define ``keypoints`` are used.
    """
    import cv2

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    try:
        doc = json.loads(path.read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: not a JSON file ({exc})") from None
    if not isinstance(doc, dict) or not all(
        isinstance(doc.get(k), list) for k in ("images", "annotations", "categories")
    ):
        raise InputError(f"{path}: not COCO keypoints (needs images, annotations, categories)")
    root = Path(image_root) if image_root is not None else path.parent
    cats: dict[int, tuple[int, int, int]] = {}
    for cat in doc["categories"]:
        try:
            names = cat.get("keypoints")
            if names:
                cats[int(cat["id"])] = _node_indices([str(n) for n in names], nodes, str(path))
        except (KeyError, TypeError, ValueError):
            raise InputError(f"{path}: malformed category {cat!r:.80}") from None
    if not cats:
        raise InputError(f"{path}: no category defines keypoints")
    by_image: dict[int, list[np.ndarray]] = {}
    for i, ann in enumerate(doc["annotations"]):
        try:
            cid = int(ann["category_id"])
            if cid not in cats:
                continue
            kp = np.asarray(ann["keypoints"], dtype=np.float64).reshape(-1, 3)
            img_id = int(ann["image_id"])
        except (KeyError, TypeError, ValueError):
            raise InputError(f"{path}: annotation {i} is malformed") from None
        idx = list(cats[cid])
        if max(idx) >= kp.shape[0]:
            raise InputError(f"{path}: annotation {i} has {kp.shape[0]} keypoints, too few")
        sel = kp[idx]
        xy = np.where(sel[:, 2:3] > 0, sel[:, :2], np.nan)
        by_image.setdefault(img_id, []).append(xy)
    frames: list[np.ndarray] = []
    points: list[np.ndarray] = []
    for im in doc["images"]:
        try:
            img_id, name = int(im["id"]), str(im["file_name"])
        except (KeyError, TypeError, ValueError):
            raise InputError(f"{path}: malformed image entry {im!r:.80}") from None
        if img_id not in by_image:
            continue
        file = root / name
        bgr = cv2.imread(str(file), cv2.IMREAD_COLOR) if file.is_file() else None
        if bgr is None:
            raise InputError(f"{path}: image {file} is missing or unreadable")
        pts = np.stack(by_image[img_id])
        frames.append(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
        points.append(pts[np.isfinite(pts[:, 1, 0])])
    if not frames:
        raise InputError(f"{path}: no image has keypoint annotations")
    return LabeledFrames(frames, points, float(px_per_mm), f"COCO {path.name}")


def read_labels(
    path: str | os.PathLike,
    *,
    px_per_mm: float,
    nodes: Sequence[str] | None = None,
    image_root: str | os.PathLike | None = None,
) -> LabeledFrames:
    """:func:`read_slp` for ``.slp`` files, :func:`read_coco` for ``.json`` files."""
    p = Path(path)
    if p.suffix.lower() == ".slp":
        return read_slp(p, px_per_mm=px_per_mm, nodes=nodes)
    if p.suffix.lower() == ".json":
        return read_coco(p, px_per_mm=px_per_mm, image_root=image_root, nodes=nodes)
    raise InputError(f"{p}: unknown label format (expected .slp or COCO .json)")


# ---------------------------------------------------------------- augmentation


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
        ``(B, h, w)`` float32, plus a weight map ``(B, h, w)`` (0 where unlabelled
        ants may be: none for complete labels)."""
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
        two_s2 = 2 * mc.sigma_px**2
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
        patches = _photometric(rng, cfg.augment, patches)
        for b in range(cfg.centroid_batch):
            inputs[b] = cv2.resize(patches[b], (h, h), interpolation=cv2.INTER_AREA)
        return inputs, targets, np.ones_like(targets)

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


@dataclass
class ValidationSet:
    """Frames and truth for evaluation: a synthetic video (``mot_gt``: MOT ground
    truth, ``fps``) or labelled frames (``mot_gt`` None).

    ``frames`` is a list of RGB frames or the path of a video file, decoded at each
    evaluation (a long 1080p validation video would not fit in memory).
    """

    frames: list[np.ndarray] | Path
    points: list[np.ndarray]
    px_per_mm: float
    fps: float | None = None
    mot_gt: np.ndarray | None = None
    description: str = ""
    _keep: Any = field(default=None, repr=False)  # the temporary folder of the video

    def iter_frames(self) -> Iterator[np.ndarray]:
        if isinstance(self.frames, Path):
            from thermoswarm.tracking.video import open_video

            yield from open_video(self.frames).frames(len(self.points), prefetch=4)
        else:
            yield from self.frames


def synthetic_validation(
    config: ValidationConfig, *, px_per_mm: float = 3.04, codec: bool = True
) -> ValidationSet:
    """A held-out synthetic video with its ground truth.

    With ``codec`` the video is encoded like the benchmark videos (x264, CRF 20) into a
    temporary file, which lives as long as the returned object; otherwise the frames
    are kept in memory.
    """
    from thermoswarm.tracking.synth import SynthConfig, generate, write_video

    cfg = SynthConfig(
        width=config.width,
        height=config.height,
        n_ants=config.n_ants,
        n_frames=config.n_frames,
        px_per_mm=px_per_mm,
    )
    video = generate(cfg, np.random.default_rng(config.seed))
    keep = None
    if codec:
        keep = tempfile.TemporaryDirectory(prefix="thermoswarm-val-")
        frames: list[np.ndarray] | Path = Path(keep.name) / "validation.mp4"
        write_video(video.frames(), frames, cfg.fps)
    else:
        frames = list(video.frames())
    kp = video.keypoints
    points = [kp[k][np.isfinite(kp[k, :, 1, 0])] for k in range(cfg.n_frames)]
    return ValidationSet(
        frames,
        points,
        px_per_mm,
        cfg.fps,
        video.mot_gt,
        f"synthetic {config.width}x{config.height}, {config.n_ants} ants, "
        f"{config.n_frames} frames, seed {config.seed}",
        keep,
    )


def detection_metrics(
    detections: Sequence[Any], truth: Sequence[np.ndarray], radius_px: float
) -> dict[str, float]:
    """Per-frame matching of detected and true body points (Hungarian, within
    ``radius_px``): precision, recall, F1 and keypoint errors (px) of the matches."""
    from scipy.optimize import linear_sum_assignment

    tp = fp = fn = 0
    errs: list[np.ndarray] = []
    flips = []
    for det, gt in zip(detections, truth, strict=True):
        P = det.points
        if gt.shape[0] == 0 or P.shape[0] == 0:
            fp += P.shape[0]
            fn += gt.shape[0]
            continue
        D = np.linalg.norm(gt[:, None, 1] - P[None, :, 1], axis=-1)
        D = np.where(np.isfinite(D), D, np.inf)
        # Pairs beyond the radius cost more than any possible set of matches within it.
        r, c = linear_sum_assignment(np.where(D <= radius_px, D, 1e6))
        ok = D[r, c] <= radius_px
        r, c = r[ok], c[ok]
        tp += r.size
        fp += P.shape[0] - r.size
        fn += gt.shape[0] - r.size
        e = np.linalg.norm(gt[r] - P[c], axis=-1)  # (m, 3)
        errs.append(e)
        ax_g = gt[r, 0] - gt[r, 2]
        ax_p = P[c, 0] - P[c, 2]
        good = np.all(np.isfinite(ax_g), 1) & np.all(np.isfinite(ax_p), 1)
        flips.append(((ax_g * ax_p).sum(-1) < 0)[good])
    e = np.concatenate(errs) if errs else np.zeros((0, 3))
    out = {
        "tp": int(tp),
        "fp": int(fp),
        "fn": int(fn),
        "precision": tp / max(tp + fp, 1),
        "recall": tp / max(tp + fn, 1),
    }
    out["f1"] = 2 * tp / max(2 * tp + fp + fn, 1)
    for k, name in enumerate(anatomy.KEYPOINTS):
        ek = e[:, k][np.isfinite(e[:, k])]
        out[f"{name}_error_median_px"] = float(np.median(ek)) if ek.size else float("nan")
        out[f"{name}_error_p90_px"] = float(np.quantile(ek, 0.9)) if ek.size else float("nan")
    fl = np.concatenate(flips) if flips else np.zeros(0, bool)
    out["head_tail_swapped"] = float(fl.mean()) if fl.size else float("nan")
    return out


def evaluate_detector(detector: Any, val: ValidationSet) -> dict[str, Any]:
    """Detect every validation frame; detection metrics, and for a video also the
    tracker's CLEAR-MOT scores (``mota``, ``idf1``, ``idsw_rate``, ...) against the
    ground truth."""
    t0 = time.perf_counter()
    dets = []
    t_det = 0.0
    size = (0, 0)
    for f in val.iter_frames():
        t1 = time.perf_counter()
        dets.append(detector.detect(f))
        t_det += time.perf_counter() - t1
        size = f.shape[:2]
    if len(dets) != len(val.points):
        raise InputError(f"validation: {len(dets)} frames for {len(val.points)} labelled ones")
    radius = 0.5 * anatomy.ANT_LENGTH_MM * val.px_per_mm
    out: dict[str, Any] = detection_metrics(dets, val.points, radius)
    out["detect_seconds_per_frame"] = t_det / max(len(dets), 1)
    out["eval_seconds"] = time.perf_counter() - t0
    if val.mot_gt is not None:
        from thermoswarm.tracking.evaluate import evaluate_tables
        from thermoswarm.tracking.tracker import track_detections

        H, W = size
        res = track_detections(dets, px_per_mm=val.px_per_mm, fps=val.fps, frame_size=(W, H))
        m = evaluate_tables(val.mot_gt, res.mot_table())
        for k in ("mota", "idf1", "idsw", "idsw_rate", "fp", "fn", "n_gt", "motp"):
            out[f"track_{k}" if k in ("fp", "fn") else k] = m[k]
    return out


# ------------------------------------------------------------------- training


@contextlib.contextmanager
def _torch_state(seed: int, threads: int | None) -> Iterator[None]:
    import torch

    old_threads = torch.get_num_threads()
    old_det = torch.are_deterministic_algorithms_enabled()
    old_warn = torch.is_deterministic_algorithms_warn_only_enabled()
    torch.manual_seed(seed)
    torch.use_deterministic_algorithms(True, warn_only=True)
    if threads is not None:
        torch.set_num_threads(threads)
    try:
        yield
    finally:
        torch.set_num_threads(old_threads)
        torch.use_deterministic_algorithms(old_det, warn_only=old_warn)


def _centroid_loss(logits: Any, target: Any, weight: Any) -> Any:
    """Quality focal loss (Li et al. 2020, generalised focal loss): binary cross-entropy
    against the soft Gaussian targets, scaled by ``|sigmoid(logit) - target|^2`` so that
    the many easy background cells do not swamp the few ant cells; normalised by the
    targets' total mass (about one per ant and cell area of its peak)."""
    import torch.nn.functional as F

    p = logits.sigmoid()
    bce = F.binary_cross_entropy_with_logits(logits, target, reduction="none")
    loss = (bce * (p - target).abs().pow(2) * weight).sum()
    return loss / target.sum().clamp(min=1.0)


def calibrate_peaks(
    model: Any, data: LabeledFrames, *, rng: np.random.Generator, n_frames: int = 24
) -> float:
    """Median confidence-map peak (raw value) of the labelled ants found in up to
    ``n_frames`` frames of ``data`` (a peak within a quarter body length of a labelled
    body point); 1 when none is found."""
    from thermoswarm.tracking.unet import UNetDetector, find_peaks, to_model_scale

    det = UNetDetector(model, px_per_mm=data.px_per_mm, options=None)
    idx = rng.choice(len(data), size=min(n_frames, len(data)), replace=False)
    radius = 0.25 * anatomy.ANT_LENGTH_MM * data.px_per_mm
    vals = []
    for i in sorted(idx):
        frame, (rx, ry) = to_model_scale(data.frames[i], det.ratio)
        cmap, fx, fy = det.confidence_map(frame)
        cells, v = find_peaks(cmap, 0.05)
        body = data.points[i][:, 1]
        if not len(v) or not len(body):
            continue
        xy = np.column_stack([(cells[:, 0] + 0.5) / fx - 0.5, (cells[:, 1] + 0.5) / fy - 0.5])
        xy = np.column_stack([(xy[:, 0] + 0.5) / rx - 0.5, (xy[:, 1] + 0.5) / ry - 0.5])
        d = np.linalg.norm(body[:, None] - xy[None], axis=-1)
        best = d.argmin(1)
        ok = d[np.arange(len(body)), best] <= radius
        vals.extend(v[best[ok]])
    if not vals:
        return 1.0
    return float(np.clip(np.median(vals), 1e-3, 1.0))


def _ema_update(ema: Any, model: Any, decay: float, step: int) -> None:
    """Exponential moving average of the weights (and BatchNorm statistics), with the
    usual warm-up ``min(decay, (1 + step) / (10 + step))``; ``decay = 0`` copies."""
    import torch

    d = min(decay, (1 + step) / (10 + step))
    with torch.no_grad():
        for e, m in zip(ema.state_dict().values(), model.state_dict().values(), strict=True):
            if e.dtype.is_floating_point:
                e.mul_(d).add_(m, alpha=1 - d)
            else:
                e.copy_(m)


def _score(metrics: dict[str, Any]) -> tuple[float, float]:
    """Order of validation results: MOTA (video) or F1, then lower body error."""
    main = metrics.get("mota", metrics.get("f1", 0.0))
    err = metrics.get("body_error_median_px", float("inf"))
    return float(main), -float(err if math.isfinite(err) else 1e9)


def train(
    data: LabeledFrames,
    out: str | os.PathLike,
    config: TrainConfig | None = None,
    *,
    validation: ValidationSet | None = None,
    init: str | os.PathLike | None = None,
    progress: bool = False,
    log: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Train a top-down model on ``data``; write its weights to ``out``.

    Parameters
    ----------
    data
        Training frames (:func:`synthetic_data`, :func:`read_slp`, :func:`read_coco`).
    out
        Weights file to write (atomically; the report goes to the same name with
        ``.json``).
    config
        :class:`TrainConfig`; its ``model.px_per_mm`` is replaced by the data's scale.
    validation
        Held-out data (:func:`synthetic_validation`); default: ``val_fraction`` of the
        frames of ``data``.
    init
        Start from the weights of this model file (fine-tuning); its architecture is
        used.
    progress
        Show a progress bar.
    log
        Called with a one-line message after each evaluation.

    Returns
    -------
    dict
        The report (also written as JSON, keys in ``docs/tracking_unet.md``).
    """
    import torch

    from thermoswarm.tracking.unet import (
        TopDownModel,
        UNetDetector,
        load_model,
        save_model,
        soft_argmax,
    )

    cfg = config or TrainConfig()
    out = Path(out)
    if not out.absolute().parent.is_dir():
        raise InputError(f"{out}: parent directory does not exist")
    if len(data) == 0:
        raise InputError("no training frames")
    rng = np.random.default_rng(cfg.seed)
    t_start = time.perf_counter()
    c_start = time.process_time()
    with _torch_state(cfg.seed, cfg.threads):
        if init is not None:
            model = load_model(init)
            mcfg = model.config
        else:
            mcfg = dataclasses.replace(cfg.model, px_per_mm=float(data.px_per_mm))
            model = TopDownModel(mcfg)
        data = data.rescaled(mcfg.px_per_mm)
        cfg = dataclasses.replace(cfg, model=mcfg)
        if validation is None:
            n_val = int(round(cfg.val_fraction * len(data)))
            if n_val >= 1 and len(data) - n_val >= 1:
                perm = rng.permutation(len(data))
                val_data = data.subset(sorted(perm[:n_val]))
                data = data.subset(sorted(perm[n_val:]))
                validation = ValidationSet(
                    val_data.frames,
                    val_data.points,
                    data.px_per_mm,
                    description=f"{n_val} held-out frames of {data.source}",
                )
        sampler = _Sampler(data, cfg, rng)
        model.train()
        ema = copy.deepcopy(model).eval()
        for p in ema.parameters():
            p.requires_grad_(False)
        params_c = list(model.centroid.parameters())
        params_p = list(model.pose.parameters())
        opt = torch.optim.AdamW(
            [{"params": params_c}, {"params": params_p}],
            lr=cfg.lr,
            weight_decay=cfg.weight_decay,
        )
        sched = torch.optim.lr_scheduler.CosineAnnealingLR(
            opt, T_max=cfg.max_steps, eta_min=cfg.lr / 20
        )
        history: list[dict[str, Any]] = []
        best: dict[str, Any] | None = None
        best_state: dict[str, torch.Tensor] | None = None
        stopped = "max_steps"
        n_met = 0
        run_c = run_p = None
        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=cfg.max_steps, unit="step", desc="train", disable=None)
        t_train = time.perf_counter()
        step = 0
        for step in range(1, cfg.max_steps + 1):
            xb, yb, wb = sampler.centroid_batch()
            x = torch.from_numpy(xb).permute(0, 3, 1, 2).float().div_(255.0)
            y = torch.from_numpy(yb)[:, None]
            loss_c = _centroid_loss(model.centroid(x), y, torch.from_numpy(wb)[:, None])
            cb, pb = sampler.pose_batch()
            xc = torch.from_numpy(cb).permute(0, 3, 1, 2).float().div_(255.0)
            target = torch.from_numpy(pb).float()
            xy, var = soft_argmax(model.pose(xc))
            valid = torch.isfinite(target).all(-1)
            d2 = ((xy - torch.nan_to_num(target)) ** 2).sum(-1)
            nvalid = valid.sum().clamp(min=1)
            loss_p = (d2 * valid).sum() / nvalid + cfg.variance_weight * (
                var * valid
            ).sum() / nvalid
            opt.zero_grad(set_to_none=True)
            (loss_c + loss_p).backward()
            opt.step()
            sched.step()
            _ema_update(ema, model, cfg.ema_decay, step)
            lc, lp = loss_c.item(), loss_p.item()
            run_c = lc if run_c is None else 0.95 * run_c + 0.05 * lc
            run_p = lp if run_p is None else 0.95 * run_p + 0.05 * lp
            if bar is not None:
                bar.update(1)
                bar.set_postfix(centroid=f"{run_c:.4f}", pose=f"{run_p:.2f}")
            last = step == cfg.max_steps
            over_time = (
                cfg.max_minutes is not None
                and time.perf_counter() - t_train > 60 * cfg.max_minutes
            )
            if step % cfg.eval_every and not last and not over_time:
                continue
            entry: dict[str, Any] = {
                "step": step,
                "seconds": time.perf_counter() - t_start,
                "cpu_seconds": time.process_time() - c_start,
                "loss_centroid": run_c,
                "loss_pose": run_p,
                "lr": float(sched.get_last_lr()[0]),
            }
            ema.config = dataclasses.replace(
                ema.config, peak_reference=calibrate_peaks(ema, data, rng=np.random.default_rng(0))
            )
            if validation is not None:
                det = UNetDetector(ema, px_per_mm=validation.px_per_mm)
                entry.update(evaluate_detector(det, validation))
                entry["seconds_with_eval"] = time.perf_counter() - t_start
                entry["cpu_seconds_with_eval"] = time.process_time() - c_start
            history.append(entry)
            if log is not None:
                log(_log_line(entry))
            entry["peak_reference"] = ema.config.peak_reference
            if best is None or (validation is not None and _score(entry) > _score(best)):
                best = entry
                best_state = copy.deepcopy(ema.state_dict())
            if validation is None:
                best, best_state = entry, copy.deepcopy(ema.state_dict())
            met = (
                validation is not None
                and validation.mot_gt is not None
                and entry.get("mota", 0) >= cfg.target_mota + cfg.target_margin
                and entry.get("idsw_rate", 1) <= cfg.target_idsw_rate
            )
            n_met = n_met + 1 if met else 0
            if n_met >= cfg.target_evals:
                stopped = "target"
                best, best_state = entry, copy.deepcopy(ema.state_dict())
                break
            if over_time:
                stopped = "max_minutes"
                break
        if bar is not None:
            bar.close()
        assert best_state is not None
        model.load_state_dict(best_state)
        model.config = dataclasses.replace(model.config, peak_reference=best["peak_reference"])
        elapsed = time.perf_counter() - t_start
        report: dict[str, Any] = {
            "model": str(out),
            "stopped": stopped,
            "target_reached": stopped == "target",
            "steps": step,
            "seconds": elapsed,
            "cpu_seconds": time.process_time() - c_start,
            "train_seconds": time.perf_counter() - t_train,
            "best": best,
            "history": history,
            "data": {
                "source": data.source,
                "n_frames": len(data),
                "n_instances": data.n_instances,
                "n_crowded_instances": sampler.n_crowded,
                "px_per_mm": data.px_per_mm,
            },
            "validation": None if validation is None else validation.description,
            "torch_threads": torch.get_num_threads(),
            "torch_version": torch.__version__,
            "init": None if init is None else str(init),
            "config": to_dict(cfg),
        }
        model.eval()
        save_model(
            model,
            out,
            info={
                k: report[k]
                for k in ("stopped", "target_reached", "steps", "seconds", "best", "data")
            }
            | {"seed": cfg.seed},
        )
        atomic_write_json(out.with_suffix(".json"), report)
    return report


def _log_line(e: dict[str, Any]) -> str:
    parts = [
        f"step {e['step']}",
        f"{e.get('seconds_with_eval', e['seconds']):.0f} s",
        f"loss {e['loss_centroid']:.4f}/{e['loss_pose']:.2f}",
    ]
    if "f1" in e:
        parts.append(f"F1 {e['f1']:.3f}")
        parts.append(f"body {e['body_error_median_px']:.2f} px")
    if "mota" in e:
        parts.append(f"MOTA {e['mota']:.4f}")
        parts.append(f"IDSW {100 * e['idsw_rate']:.2f} %")
    return ", ".join(parts)


def train_from_sources(
    out: str | os.PathLike,
    *,
    synthetic: bool = False,
    labels: Sequence[str | os.PathLike] = (),
    px_per_mm: float | None = None,
    nodes: Sequence[str] | None = None,
    image_root: str | os.PathLike | None = None,
    init: str | os.PathLike | None = None,
    config: TrainConfig | None = None,
    progress: bool = False,
    log: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """What ``thermoswarm track train`` runs: gather the data, then :func:`train`.

    Parameters
    ----------
    out
        Weights file to write.
    synthetic
        Render training data with the generator (``config.synth``) and validate on a
        held-out synthetic video (``config.validation``), tracked and scored.
    labels
        SLEAP ``.slp`` or COCO ``.json`` files (:func:`read_labels`).
    px_per_mm
        Scale of the labelled images (required with ``labels``); the synthetic data are
        rendered at it too (default: ``config.model.px_per_mm``).
    nodes, image_root
        See :func:`read_labels`.
    init
        Fine-tune this model instead of starting from random weights.
    config
        :class:`TrainConfig`.  The synthetic data are drawn from
        ``numpy.random.default_rng([config.seed, 1])``.
    """
    cfg = config or TrainConfig()
    out = Path(out)
    if not out.absolute().parent.is_dir():
        raise InputError(f"{out}: parent directory does not exist")
    if not synthetic and not labels:
        raise InputError("no training data: synthetic=False and no label files")
    if labels and px_per_mm is None:
        raise InputError("labelled images need their scale: px_per_mm")
    if px_per_mm is not None and not (math.isfinite(px_per_mm) and px_per_mm > 0):
        raise InputError(f"px_per_mm must be a positive number, got {px_per_mm!r}")
    if init is not None:
        from thermoswarm.tracking.unet import load_model

        scale = load_model(init).config.px_per_mm
    else:
        scale = px_per_mm if px_per_mm is not None else cfg.model.px_per_mm
    parts = [
        read_labels(p, px_per_mm=float(px_per_mm), nodes=nodes, image_root=image_root)
        for p in labels
    ]
    validation = None
    if synthetic:
        if log is not None:
            log(f"rendering {cfg.synth.n_videos} synthetic training videos ...")
        gen_scale = px_per_mm if px_per_mm is not None else scale
        parts.append(
            synthetic_data(cfg.synth, np.random.default_rng([cfg.seed, 1]), px_per_mm=gen_scale)
        )
        validation = synthetic_validation(cfg.validation, px_per_mm=gen_scale)
    data = LabeledFrames.concat([p.rescaled(scale) for p in parts])
    return train(data, out, cfg, validation=validation, init=init, progress=progress, log=log)
