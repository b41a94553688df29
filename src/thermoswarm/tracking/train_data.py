"""Labelled frames for training the U-Net + pose model: SLEAP ``.slp`` and COCO keypoint
readers and synthetic training data.  Part of :mod:`thermoswarm.tracking.train`."""

from __future__ import annotations

import json
import math
import os
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.config import check
from thermoswarm.errors import InputError
from thermoswarm.tracking import anatomy

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
