"""The paper's trained detector: a centroid U-Net, then a pose network on crops.

PAPER_NOTES section 3 (SLEAP's top-down design): a U-Net turns the frame into a
confidence map whose peaks are the ants' body points (the *anchors*); a crop centred on
each anchor goes to a pose network that predicts head, body and tail; the pose loss is
the mean squared distance of the points.  Both networks are small enough to train on
two CPU cores in minutes (:mod:`thermoswarm.tracking.train.fit`) and to run at a useful
speed on a CPU.

Centroid network (:class:`CentroidNet`)
    Input: the frame resized by ``input_scale`` (default 1/2: a 21.7 px ant of the paper's
    3.04 px/mm becomes 11 px).  A stride-2 stem and two stride-2 stages (widths
    ``centroid_channels``, the last one dilated), a decoder that adds 1x1-projected,
    upsampled features to the skips, and a head that predicts four sub-cells per cell
    (pixel shuffle): the confidence map has the *input's* resolution (2 px of the full
    frame per cell by default) while every convolution runs at 1/4 of the frame or
    coarser.  Fine cells matter: in the benchmark videos 1 % of the ants have another
    ant's body point within 4 px and 4 % within 8 px (ants cross each other), so a
    coarser map would merge them.  Trained against ``exp(-d^2 / 2 sigma^2)`` (the
    maximum over ants, so that close ants keep separate peaks) with a mean squared error
    (SLEAP's confidence maps).  Peaks: 3x3 local maxima (max-pool) above
    ``peak_threshold``, refined to sub-cell precision by the weighted centroid of the
    3x3 neighbourhood.
Pose network (:class:`PoseNet`)
    A ``crop_size`` (32 px) square of the full-resolution frame centred on the anchor,
    *not* rotation-normalised: the orientation is what the pose network estimates (a
    rotated crop would need it first, and a head-tail flip of the orientation would then
    have to be undone), cropping without resampling is exact and cheap, and training
    with rotations in all directions teaches a small network every orientation.  A
    three-level encoder-decoder returns one logit map per keypoint at the crop's full
    resolution; a spatial softmax and its expectation (soft-argmax) give sub-pixel
    coordinates, so the paper's loss (mean squared point distance) trains it directly,
    with a small penalty on the maps' variance that keeps them unimodal.  The head
    confidence (how sure the network is that head and tail are not swapped) is the mass
    of the head's map on the head side of the body point.

Scale: a model is trained at one image scale ``px_per_mm`` (stored with the weights).  A
video at another scale is resized by ``model px_per_mm / video px_per_mm`` before
detection and the points are mapped back, so a model serves any camera whose ants are
the same size in mm.

Weights file
    ``torch.save`` of ``{"format": "thermoswarm.unet", "version": 1, "config": JSON of
    ModelConfig, "info": JSON (training data and results), "state_dict": {name:
    tensor}}``, written atomically; read with ``torch.load(..., weights_only=True)``
    (strings and tensors only, no pickled code).  A plain state dict (no metadata) is
    accepted with the default :class:`ModelConfig`.  A file that is not a weights file,
    names another architecture, or holds tensors of the wrong names or shapes is one
    :class:`~thermoswarm.errors.InputError` naming the file and the first bad tensor.

This module imports PyTorch at the top: it is imported only when the ``unet`` detector
or training is used (``thermoswarm.tracking.detect.classical`` registers it lazily).  The
networks and :class:`ModelConfig` live in :mod:`thermoswarm.tracking.detect.unet_model`
and are re-exported here.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import sys
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

if "torch" not in sys.modules:
    # libgomp threads spin while they wait for work; on a machine shared with other
    # programs a spinning thread steals the core its partner needs and 2-thread
    # convolutions become 10 times slower than 1-thread ones (measured on the shared
    # 2-core development machine).  Passive waiting costs microseconds per call on an
    # idle machine.  Only a default: the user's own setting wins; it must be set
    # before the OpenMP runtime starts, i.e. before torch is imported.
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import torch  # noqa: E402
from torch import nn  # noqa: E402

from thermoswarm.config import check, from_mapping, to_dict
from thermoswarm.errors import ConfigError, InputError
from thermoswarm.fsutil import atomic_write_bytes
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.detect.unet_model import (
    CentroidNet,
    ModelConfig,
    PoseNet,
    TopDownModel,
    head_side_mass,
    soft_argmax,
)
from thermoswarm.tracking.detection import FrameDetections, load_checked

__all__ = [
    "FORMAT",
    "VERSION",
    "ModelConfig",
    "CentroidNet",
    "PoseNet",
    "TopDownModel",
    "UNetOptions",
    "UNetDetector",
    "make_detector",
    "save_model",
    "load_model",
    "soft_argmax",
    "find_peaks",
    "to_model_scale",
]

FORMAT = "thermoswarm.unet"
VERSION = 1


# ----------------------------------------------------------------------- weights


def save_model(
    model: TopDownModel, path: str | os.PathLike, info: Mapping[str, Any] | None = None
) -> Path:
    """Write the model's weights and configuration to ``path`` atomically.

    ``info`` (JSON-serialisable: training data, seed, validation results) is stored
    beside the configuration.
    """
    path = Path(path)
    obj = {
        "format": FORMAT,
        "version": VERSION,
        "config": json.dumps(to_dict(model.config)),
        "info": json.dumps(dict(info or {}), default=str),
        "state_dict": {k: v.detach().cpu().clone() for k, v in model.state_dict().items()},
    }
    buf = io.BytesIO()
    torch.save(obj, buf)
    atomic_write_bytes(path, buf.getvalue())
    return path


def _read_checkpoint(path: Path) -> tuple[ModelConfig, dict[str, torch.Tensor], dict]:
    if not path.is_file():
        raise InputError(f"{path}: model file does not exist")
    try:
        obj = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises many types for a bad file
        raise InputError(f"{path}: not a PyTorch weights file ({type(exc).__name__})") from None
    info: dict = {}
    config = ModelConfig()
    if isinstance(obj, Mapping) and "format" in obj:
        if obj.get("format") != FORMAT:
            raise InputError(f"{path}: a {obj.get('format')!r} model, expected a {FORMAT!r} model")
        version = obj.get("version")
        if not isinstance(version, int) or version > VERSION:
            raise InputError(
                f"{path}: model format version {version!r}; this thermoswarm reads "
                f"versions up to {VERSION}"
            )
        try:
            cfg_data = json.loads(obj.get("config", "{}"))
            info = json.loads(obj.get("info", "{}"))
        except (TypeError, json.JSONDecodeError):
            raise InputError(f"{path}: the model's configuration is not valid JSON") from None
        try:
            config = from_mapping(ModelConfig, cfg_data, source=f"{path}: config")
        except ConfigError as exc:
            raise InputError(str(exc)) from None
        sd = obj.get("state_dict")
    elif isinstance(obj, Mapping) and isinstance(obj.get("state_dict"), Mapping):
        sd = obj["state_dict"]
    else:
        sd = obj
    if (
        not isinstance(sd, Mapping)
        or not sd
        or not all(isinstance(k, str) and isinstance(v, torch.Tensor) for k, v in sd.items())
    ):
        raise InputError(f"{path}: expected a state dict (names -> tensors)")
    return config, dict(sd), info


def load_model(path: str | os.PathLike) -> TopDownModel:
    """Read a model written by :func:`save_model` (or a plain state dict of the default
    architecture) with ``torch.load(..., weights_only=True)``.

    The training information is in ``model.info``.  Raises :class:`InputError` (one
    line, naming the file) for a missing or unreadable file, another format, or tensors
    of the wrong names or shapes.
    """
    path = Path(path)
    config, sd, info = _read_checkpoint(path)
    model = TopDownModel(config)
    load_checked(model, sd, path, "a thermoswarm U-Net model")
    model.info = info
    model.eval()
    return model


# --------------------------------------------------------------------- inference


def to_model_scale(frame: np.ndarray, ratio: float) -> tuple[np.ndarray, tuple[float, float]]:
    """Resize ``frame`` by ``ratio`` (model px per frame px) to the model's scale.

    Returns the resized RGB ``uint8`` frame and the exact ``(x, y)`` factors used (sizes
    are rounded to whole pixels); a point ``p`` of the resized frame is
    ``(p + 0.5) / factor - 0.5`` in the original.
    """
    import cv2

    if frame.ndim == 2:
        frame = np.repeat(frame[:, :, None], 3, axis=2)
    elif frame.ndim != 3 or frame.shape[2] not in (1, 3, 4):
        raise InputError(f"frames must be (H, W) or (H, W, 3) arrays, got shape {frame.shape}")
    elif frame.shape[2] == 1:
        frame = np.repeat(frame, 3, axis=2)
    elif frame.shape[2] == 4:
        frame = frame[:, :, :3]
    if frame.dtype != np.uint8:
        raise InputError(f"frames must be uint8, got {frame.dtype}")
    H, W = frame.shape[:2]
    if abs(ratio - 1.0) < 1e-6:
        return np.ascontiguousarray(frame), (1.0, 1.0)
    w, h = max(int(round(W * ratio)), 1), max(int(round(H * ratio)), 1)
    interp = cv2.INTER_AREA if ratio < 1 else cv2.INTER_LINEAR
    return cv2.resize(frame, (w, h), interpolation=interp), (w / W, h / H)


def centroid_input(frame: np.ndarray, input_scale: float) -> tuple[np.ndarray, float, float]:
    """The centroid network's input: ``frame`` (model scale, ``uint8`` RGB) resized by
    ``input_scale`` (area interpolation) and padded (edge values) to multiples of 8.

    Returns the ``uint8`` array and the exact ``(x, y)`` resize factors.
    """
    import cv2

    H, W = frame.shape[:2]
    w, h = max(int(round(W * input_scale)), 1), max(int(round(H * input_scale)), 1)
    small = frame if (w, h) == (W, H) else cv2.resize(frame, (w, h), interpolation=cv2.INTER_AREA)
    ph, pw = (-h) % 8, (-w) % 8
    if ph or pw:
        small = cv2.copyMakeBorder(small, 0, ph, 0, pw, cv2.BORDER_REPLICATE)
    return small, w / W, h / H


def find_peaks(cmap: np.ndarray, threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """Local maxima (3x3) of a confidence map above ``threshold``.

    Returns ``(n, 2)`` sub-cell ``(x, y)`` positions (the weighted centroid of the
    positive 3x3 neighbourhood) and ``(n,)`` peak values, strongest first.
    """
    import cv2

    m = np.ascontiguousarray(cmap, dtype=np.float32)
    dil = cv2.dilate(m, np.ones((3, 3), np.uint8))
    ys, xs = np.nonzero((m >= dil) & (m > threshold))
    if ys.size == 0:
        return np.zeros((0, 2)), np.zeros(0)
    pad = np.pad(m, 1, mode="constant")
    dy, dx = np.mgrid[-1:2, -1:2]
    nb = pad[ys[:, None] + 1 + dy.ravel()[None, :], xs[:, None] + 1 + dx.ravel()[None, :]]
    w = np.clip(nb, 0, None).astype(np.float64)
    sw = np.maximum(w.sum(1), 1e-12)
    ox = (w * dx.ravel()[None, :]).sum(1) / sw
    oy = (w * dy.ravel()[None, :]).sum(1) / sw
    vals = m[ys, xs].astype(np.float64)
    order = np.argsort(-vals, kind="stable")
    xy = np.column_stack([xs + ox, ys + oy])[order]
    return xy, vals[order]


def crop_at(frame: np.ndarray, centres: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Square ``size`` crops of ``frame`` (``(H, W, 3)``) whose centre pixel is the
    rounded ``centres`` ``(n, 2)`` (x, y); outside the frame, edge pixels repeat.

    Returns crops ``(n, size, size, 3)`` and the frame position ``(n, 2)`` of each
    crop's pixel ``(0, 0)``.
    """
    H, W = frame.shape[:2]
    origin = np.round(np.asarray(centres, dtype=np.float64)).astype(np.int64) - size // 2
    r = np.arange(size)
    xs = np.clip(origin[:, 0, None] + r[None, :], 0, W - 1)
    ys = np.clip(origin[:, 1, None] + r[None, :], 0, H - 1)
    crops = frame[ys[:, :, None], xs[:, None, :]]
    return crops, origin.astype(np.float64)


@dataclass(frozen=True)
class UNetOptions:
    """Options of the ``unet`` detector (``--set detector.key=value``).

    ``peak_threshold``: smallest confidence-map peak taken as an ant (raw map value;
    the maps are trained towards 1 at body points).  ``duplicate_px``: two detections
    whose head, body and tail are on average closer than this (px of the model's
    scale) are one ant; the stronger is kept.
    ``device``: ``"auto"`` (CUDA when available), ``"cpu"`` or ``"cuda"``.  ``threads``:
    PyTorch CPU threads (``None``: leave ``torch.set_num_threads`` as it is).
    ``crop_batch``: crops per pose-network call.  ``max_detections``: most peaks per
    frame (the strongest are kept).
    """

    peak_threshold: float = 0.3
    duplicate_px: float = 3.5
    device: Literal["auto", "cpu", "cuda"] = "auto"
    threads: int | None = None
    crop_batch: int = 256
    max_detections: int = 2000

    def __post_init__(self) -> None:
        check(0 < self.peak_threshold < 1, "peak_threshold", "in (0, 1)", self.peak_threshold)
        check(self.duplicate_px >= 0, "duplicate_px", "a non-negative number", self.duplicate_px)
        check(
            self.threads is None or self.threads >= 1,
            "threads",
            "a positive integer",
            self.threads,
        )
        check(self.crop_batch >= 1, "crop_batch", "a positive integer", self.crop_batch)
        check(
            self.max_detections >= 1, "max_detections", "a positive integer", self.max_detections
        )


def _fuse(seq: nn.Module) -> None:
    """Fold every BatchNorm into the convolution before it (inference only)."""
    from torch.nn.utils.fusion import fuse_conv_bn_eval

    for _name, child in list(seq.named_children()):
        if (
            isinstance(child, nn.Sequential)
            and len(child) == 3
            and isinstance(child[0], nn.Conv2d)
            and isinstance(child[1], nn.BatchNorm2d)
        ):
            child[0] = fuse_conv_bn_eval(child[0], child[1])
            child[1] = nn.Identity()
        else:
            _fuse(child)


@contextlib.contextmanager
def _threads(n: int | None) -> Iterator[None]:
    if n is None:
        yield
        return
    old = torch.get_num_threads()
    torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(old)


class UNetDetector:
    """The trained top-down detector behind ``thermoswarm track --model weights.pt``.

    Parameters
    ----------
    model
        A :class:`TopDownModel` (it is copied, fused and put in inference mode).
    px_per_mm
        Scale of the video (px per mm); frames are resized to the model's scale.
    options
        :class:`UNetOptions`.
    """

    name = "unet"
    accepts_hints = False

    def __init__(
        self, model: TopDownModel, *, px_per_mm: float, options: UNetOptions | None = None
    ) -> None:
        import copy

        if not (math.isfinite(px_per_mm) and px_per_mm > 0):
            raise InputError(f"px_per_mm must be a positive number, got {px_per_mm!r}")
        self.config = options or UNetOptions()
        self.model_config = model.config
        self.px_per_mm = float(px_per_mm)
        self.ratio = self.model_config.px_per_mm / self.px_per_mm
        dev = self.config.device
        if dev == "auto":
            dev = "cuda" if torch.cuda.is_available() else "cpu"
        if dev == "cuda" and not torch.cuda.is_available():
            raise InputError("detector option device='cuda' but no CUDA device is available")
        self.device = torch.device(dev)
        m = copy.deepcopy(model).eval()
        _fuse(m)
        self.centroid = m.centroid.to(self.device, memory_format=torch.channels_last)
        self.pose = m.pose.to(self.device, memory_format=torch.channels_last)
        self.threshold = self.config.peak_threshold
        self.length_px = (
            anatomy.ANT_LENGTH_MM * self.px_per_mm
        )  # for the summary: expected ant length in px of the video

    def reset(self) -> None:
        """Nothing to forget: detection is frame by frame."""

    def _tensor(self, arr: np.ndarray) -> torch.Tensor:
        """``(B, H, W, 3)`` uint8 -> ``(B, 3, H, W)`` float 0-1, channels-last."""
        t = torch.from_numpy(np.ascontiguousarray(arr)).to(self.device)
        return (
            t.permute(0, 3, 1, 2).float().div_(255.0).contiguous(memory_format=torch.channels_last)
        )

    @torch.inference_mode()
    def confidence_map(self, frame_m: np.ndarray) -> tuple[np.ndarray, float, float]:
        """Confidence map of a model-scale frame; returns it and the resize factors."""
        cfg = self.model_config
        small, fx, fy = centroid_input(frame_m, cfg.input_scale)
        out = torch.sigmoid(self.centroid(self._tensor(small[None])))
        h = int(round(frame_m.shape[0] * fy))
        w = int(round(frame_m.shape[1] * fx))
        return out[0, 0, :h, :w].float().cpu().numpy(), fx, fy

    @torch.inference_mode()
    def poses(self, frame_m: np.ndarray, anchors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Head, body, tail ``(n, 3, 2)`` (px of the model-scale frame) and head
        confidence ``(n,)`` of the ants at ``anchors`` ``(n, 2)``."""
        C = self.model_config.crop_size
        n = anchors.shape[0]
        pts = np.empty((n, 3, 2))
        hc = np.empty(n)
        for lo in range(0, n, self.config.crop_batch):
            hi = min(lo + self.config.crop_batch, n)
            crops, origin = crop_at(frame_m, anchors[lo:hi], C)
            logits = self.pose(self._tensor(crops)).float()
            xy, _ = soft_argmax(logits)
            hc[lo:hi] = head_side_mass(logits, xy).cpu().numpy()
            pts[lo:hi] = xy.cpu().numpy().astype(np.float64) + origin[:, None, :]
        return pts, hc

    def detect(self, frame: np.ndarray) -> FrameDetections:
        """Detect the ants of one frame (``(H, W, 3)`` RGB or ``(H, W)`` uint8)."""
        with _threads(self.config.threads):
            frame_m, (rx, ry) = to_model_scale(np.asarray(frame), self.ratio)
            cmap, fx, fy = self.confidence_map(frame_m)
            cells, vals = find_peaks(cmap, self.config.peak_threshold)
            cells = cells[: self.config.max_detections]
            vals = vals[: self.config.max_detections]
            if vals.size == 0:
                return FrameDetections.empty()
            anchors = np.column_stack(
                [(cells[:, 0] + 0.5) / fx - 0.5, (cells[:, 1] + 0.5) / fy - 0.5]
            )
            pts, hc = self.poses(frame_m, anchors)
        keep = _deduplicate(pts, vals, self.config.duplicate_px)
        pts, vals, hc = pts[keep], vals[keep], hc[keep]
        pts[..., 0] = (pts[..., 0] + 0.5) / rx - 0.5
        pts[..., 1] = (pts[..., 1] + 0.5) / ry - 0.5
        scores = np.clip(vals / self.model_config.peak_reference, 0.0, 1.0)
        return FrameDetections(pts, scores, None, np.clip(hc, 0.0, 1.0))


def _deduplicate(points: np.ndarray, scores: np.ndarray, radius: float) -> np.ndarray:
    """Indices of the detections to keep: greedily, strongest first, drop any whose
    head, body and tail are on average within ``radius`` px of a kept detection's.

    Two peaks on one ant give two crops of the same ant and the same pose twice; two
    real ants, even crossing ones, differ in at least one point (measured on the
    benchmark videos: no pair of correct detections within 4 px on average).
    """
    n = points.shape[0]
    if n <= 1 or radius <= 0:
        return np.arange(n)
    from scipy.spatial import cKDTree

    # The mean over three points is below `radius` only if the body points are within
    # 3 radius: candidates by body distance, then the exact test.
    pairs = cKDTree(points[:, 1]).query_pairs(3 * radius, output_type="ndarray")
    if pairs.size == 0:
        return np.arange(n)
    d = np.linalg.norm(points[pairs[:, 0]] - points[pairs[:, 1]], axis=-1)  # (m, 3)
    with np.errstate(invalid="ignore"):
        mean = np.nanmean(np.where(np.isfinite(d), d, np.nan), axis=1)
    pairs = pairs[np.isfinite(mean) & (mean < radius)]
    if pairs.size == 0:
        return np.arange(n)
    order = np.argsort(-scores, kind="stable")
    rank = np.empty(n, np.int64)
    rank[order] = np.arange(n)
    nbrs: dict[int, list[int]] = {}
    for a, b in pairs:
        nbrs.setdefault(int(a), []).append(int(b))
        nbrs.setdefault(int(b), []).append(int(a))
    drop = np.zeros(n, bool)
    for i in order:
        if drop[i]:
            continue
        for j in nbrs.get(int(i), ()):
            if rank[j] > rank[i]:
                drop[j] = True
    return np.flatnonzero(~drop)


def make_detector(
    *, px_per_mm: float, model: Path | None, options: Mapping[str, Any]
) -> UNetDetector:
    """Registry factory of the ``unet`` detector (see
    :mod:`thermoswarm.tracking.detect.classical`)."""
    if model is None:
        raise InputError("detector 'unet' needs a trained model: pass --model PATH")
    opts = from_mapping(UNetOptions, dict(options), source="detector options")
    return UNetDetector(load_model(model), px_per_mm=px_per_mm, options=opts)
