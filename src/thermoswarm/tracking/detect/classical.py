"""Detection: one frame in, ant poses out.

Interface (defined in :mod:`thermoswarm.tracking.detection`, re-exported here)
--------------------------------------------------------------------------
:class:`FrameDetections`
    ``points`` ``(n, 3, 2)`` float px, [head, body, tail] x [x, y], NaN where a point is
    unknown; ``scores`` ``(n,)`` in [0, 1]; optional ``boxes`` ``(n, 4)`` MOT boxes
    (``left, top, width, height`` px; default: the body-centred box of the pose) and
    ``head_confidence`` ``(n,)`` in [0, 1], how sure the detector is that head and tail
    are not swapped (0.5: no idea; ``None``: sure).  The tracker uses it to decide
    whether motion should overrule the detector's head-tail order.  Optional
    ``hint_index`` ``(n,)``: for detectors given the tracker's predicted poses
    (``detect(frame, hints=...)``), the index of the prediction a detection was
    found from (touching ants split around their predictions), -1 for none.
:class:`Detector` (a :class:`typing.Protocol`)
    ``detect(frame) -> FrameDetections`` for one frame, ``reset()`` to forget any state
    between videos.  Frames are ``uint8`` arrays, ``(H, W, 3)`` RGB or ``(H, W)`` grey,
    given in time order.  A detector may also have ``prepare(frames)``, which the
    pipeline calls once with frames of a video before ``detect`` (spread over its first
    minute, or its first seconds: the classical detector learns its background there).
Registry (:mod:`.registry`, re-exported here)
    :func:`register_detector` adds a detector by name with a lazily imported factory
    ``factory(*, px_per_mm, model, options) -> Detector``; :func:`make_detector` builds
    one.  ``classical`` (:class:`ClassicalDetector`, the default, needs no training) is
    registered here, and ``unet`` points at ``thermoswarm.tracking.detect.unet:make_detector``,
    the trained top-down model (U-Net centroid peaks, then a pose model on crops), which
    is a separate module.  ``thermoswarm track --model PATH`` selects the first
    registered detector with ``needs_model=True`` (``unet``) unless ``--detector`` names
    one.  Model files are PyTorch state dicts read by :func:`load_state_dict` /
    :func:`load_weights` (``torch.load(..., weights_only=True)``); a missing,
    unreadable or wrong-shaped file is an :class:`~thermoswarm.errors.InputError` naming
    the file and the first mismatching tensor.

The classical detector
----------------------
Background subtraction on a downscaled image (``downsample``, default 2) of one channel
(green by default): the background is a high per-pixel quantile (``bg_quantile``) of
up to ``bg_frames`` frames given to ``prepare`` (each normalised to a common lighting),
so that an ant is background only if it covers a pixel in most of them; afterwards it
follows slow changes by a running average updated only where no ant was found
(``bg_rate``).  Lighting is normalised by the ratio of frame to background on a coarse
grid (``gain_grid`` px), median-filtered so that ants do not count, which removes
flicker, drift and moving shadows; contrast is relative, ``(expected - frame) /
expected``.  Pixels above ``threshold`` (automatic: the largest of ``min_threshold``,
``threshold_sigmas`` robust standard deviations of the noise, and ``peak_fraction`` of
the typical ant's peak contrast) form blobs (:func:`cv2.connectedComponents`).  All
blobs are then measured at once, at full resolution and vectorised over blobs
(:mod:`.blobs`): the contrast-weighted principal axis gives the orientation,
the skew of the silhouette along it the head end (the gaster is the widest part) with
a confidence, and the silhouette's two ends, less the blur widening learned in
``prepare``, place head, body and tail by the anatomy
(:mod:`~thermoswarm.tracking.anatomy`).  The tracker overrules the head-tail order
with the direction of motion.  Blobs larger than ``split_area`` single ants, or than
``hint_split_area`` when the tracker predicts two or more ants in them, are split by
k-means with segments (:mod:`.blobs`), started from the predictions when given.
The options are :class:`~.config.ClassicalConfig`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.config import from_mapping
from thermoswarm.errors import ConfigError, InputError
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.detect.blobs import (
    _Blobs,
    _weighted_median,
    blob_pixels,
    measure_singles,
    measure_splits,
    picture_background,
    split_counts,
    typical_area,
)
from thermoswarm.tracking.detect.config import ClassicalConfig
from thermoswarm.tracking.detect.join import join_split_bodies
from thermoswarm.tracking.detect.registry import (  # _DETECTORS: the registry itself
    _DETECTORS,  # noqa: F401
    DetectorEntry,
    default_model_detector,
    detectors,
    make_detector,
    register_detector,
)
from thermoswarm.tracking.detection import (
    Detector,
    FrameDetections,
    load_checked,
    load_state_dict,
    load_weights,
)

__all__ = [
    "FrameDetections",
    "Detector",
    "DetectorEntry",
    "register_detector",
    "detectors",
    "make_detector",
    "default_model_detector",
    "load_state_dict",
    "load_weights",
    "load_checked",
    "ClassicalConfig",
    "ClassicalDetector",
    "typical_area",
    "NOTHING_FOUND_HINT",
]


def _classical_factory(
    *, px_per_mm: float, model: Path | None, options: Mapping[str, Any]
) -> ClassicalDetector:
    try:
        cfg = from_mapping(ClassicalConfig, options, source="detector options")
    except ConfigError as exc:
        raise InputError(str(exc)) from None
    if "downsample" not in options:  # tiny animals: a finer working resolution
        cfg = cfg.for_animals(px_per_mm)
    return ClassicalDetector(px_per_mm, cfg)


_CHANNEL = {"red": 0, "green": 1, "blue": 2}

#: Background grey level (0-255) below which a lighting cell is too dark to measure.
_DARK_CELL = 8.0


class ClassicalDetector:
    """Background subtraction + blob moments; no training (see the module docstring).

    Call :meth:`prepare` with frames of a video (a few seconds' worth, or spread over
    it) before :meth:`detect`; otherwise the first frame given to :meth:`detect` becomes the
    background, and ants in it are missed until they move away.

    ``detect(frame, hints=...)`` accepts the tracker's predicted poses ``(m, 3, 2)``
    px: a blob that contains two or more predicted body points is split into that
    many ants, starting from the predictions (touching and crossing ants).

    Parameters
    ----------
    px_per_mm
        Image scale, px per mm.
    config
        :class:`ClassicalConfig`.
    """

    name = "classical"
    accepts_hints = True

    def __init__(self, px_per_mm: float, config: ClassicalConfig | None = None) -> None:
        if not (px_per_mm > 0 and math.isfinite(px_per_mm)):
            raise InputError(f"px_per_mm must be a positive number, got {px_per_mm!r}")
        self.px_per_mm = float(px_per_mm)
        self.config = config or ClassicalConfig()
        c = self.config
        self.prior_length_px = c.ant_length_mm * self.px_per_mm
        parts = (anatomy.HEAD, anatomy.MESOSOMA, anatomy.GASTER)
        #: Silhouette area of the anatomical model, px^2 at full resolution.
        self.model_area = math.pi * sum(p[1] * p[2] for p in parts) * self.prior_length_px**2
        f = c.downsample
        self._offsets = np.array([(dy, dx) for dy in range(f) for dx in range(f)])
        self.reset()

    # -- state
    def reset(self) -> None:
        """Forget the background and the learned sizes (a new video)."""
        self._bg: np.ndarray | None = None
        self._thr: float | None = self.config.threshold
        self._peak: float | None = None
        self._area1: float = 0.6 * self.model_area / self.config.downsample**2
        self._length: float = self.prior_length_px
        self._widen: float = 0.0
        self._bg_cells: list | None = None
        self._shape: tuple[int, int] | None = None

    @property
    def threshold(self) -> float | None:
        """The relative-contrast threshold in use."""
        return self._thr

    @property
    def single_area(self) -> float:
        """The single-ant blob area in use (px^2 at working resolution)."""
        return self._area1

    @property
    def length_px(self) -> float:
        """The expected ant body length (px, full resolution; from ``ant_length_mm``)."""
        return self._length

    @property
    def widening_px(self) -> float:
        """How much longer than the ant its silhouette looks at each end (px; learned)."""
        return self._widen

    # -- image helpers
    def _gray(self, frame: np.ndarray) -> np.ndarray:
        import cv2

        frame = np.asarray(frame)
        if frame.dtype != np.uint8:
            raise InputError(f"frames must be uint8, got {frame.dtype}")
        if frame.ndim == 2:
            gray = frame
        elif frame.ndim == 3 and frame.shape[2] in (3, 4):
            if self.config.channel == "gray":
                gray = cv2.cvtColor(np.ascontiguousarray(frame[..., :3]), cv2.COLOR_RGB2GRAY)
            else:
                gray = cv2.extractChannel(frame, _CHANNEL[self.config.channel])
        else:
            raise InputError(f"frames must be (H, W) or (H, W, 3), got shape {frame.shape}")
        if self._shape is None:
            self._shape = gray.shape
        elif gray.shape != self._shape:
            raise InputError(
                f"frame size {gray.shape[::-1]} differs from the first frame's {self._shape[::-1]}"
            )
        return gray

    def _small(self, gray: np.ndarray, dtype: type = np.float32) -> np.ndarray:
        import cv2

        f = self.config.downsample
        if f == 1:
            return gray.astype(dtype)
        h, w = gray.shape[0] // f, gray.shape[1] // f
        # Crop to a multiple of f so that small pixel (y, x) is full block [fy, fy+f).
        return cv2.resize(gray[: h * f, : w * f], (w, h), interpolation=cv2.INTER_AREA).astype(
            dtype, copy=False
        )

    def _gain(self, small: np.ndarray, bg: np.ndarray) -> np.ndarray | float:
        """Lighting of ``small`` relative to ``bg``: a field (working res.) or a number."""
        import cv2

        g = self.config.gain_grid
        h, w = small.shape
        if g and min(h, w) >= 3 * g:
            gs = (max(w // g, 1), max(h // g, 1))
            # The background's cell means change slowly: recomputed every 8th call.
            key = id(bg)
            if self._bg_cells is None or self._bg_cells[0] != key or self._bg_cells[2] >= 8:
                cells = cv2.resize(bg, gs, interpolation=cv2.INTER_AREA)
                self._bg_cells = [key, np.maximum(cells, 1.0), 0]
            self._bg_cells[2] += 1
            cells = self._bg_cells[1]
            ratio = cv2.resize(small, gs, interpolation=cv2.INTER_AREA) / cells
            # Near-black cells (dark backgrounds, black borders) carry no lighting
            # information: their ratio is 0/0-like noise, and a gain of 0 would make
            # the normalised background NaN.  They keep gain 1; all gains in [0.2, 5].
            ratio = np.where(cells >= _DARK_CELL, ratio, 1.0)
            ratio = cv2.medianBlur(np.clip(ratio, 0.2, 5.0).astype(np.float32), 3)
            return cv2.resize(ratio, (w, h), interpolation=cv2.INTER_LINEAR)
        lit = bg[::4, ::4] >= _DARK_CELL
        if not lit.any():
            return 1.0
        return float(np.clip(np.median(small[::4, ::4][lit] / bg[::4, ::4][lit]), 0.2, 5.0))

    def _contrast(self, img: np.ndarray, expected: np.ndarray) -> np.ndarray:
        # The fraction of the room left between the background and black (dark
        # animals) or white (light animals): 1 for a black ant on any ground, and for
        # light animals on a near-black ground faint texture stays small.
        if self.config.polarity == "dark":
            return (expected - img) / np.maximum(expected, 8.0)
        return (img - expected) / np.maximum(255.0 - expected, 8.0)

    def _contrast_map(
        self, small: np.ndarray, shift: bool = True
    ) -> tuple[np.ndarray, np.ndarray]:
        import cv2

        if self.config.background == "picture":
            expected = picture_background(
                small, 3 * self._length / self.config.downsample, self.config.polarity == "light"
            )
            return self._contrast(small, expected), expected
        expected = (self._bg * self._gain(small, self._bg)).astype(np.float32)
        r = self.config.shift_px if shift else 0
        if r:
            # A background edge moved by up to r px (camera jitter between photos,
            # compression) is not foreground: compare each pixel with the darkest
            # (dark animals) or lightest (light ones) background pixel within r px.
            kernel = np.ones((2 * r + 1, 2 * r + 1), np.uint8)
            op = cv2.erode if self.config.polarity == "dark" else cv2.dilate
            expected = op(expected, kernel)
        return self._contrast(small, expected), expected

    def _noise_threshold(self, smalls: list[np.ndarray]) -> float:
        """``threshold_sigmas`` robust standard deviations of the contrast of
        ``smalls`` (at least ``min_threshold``).  Measured against the background
        itself, not its shift-tolerant extreme, which widens the spread on textured
        ground without adding foreground."""
        sample = np.concatenate(
            [self._contrast_map(s, False)[0][::3, ::3].ravel() for s in smalls]
        )
        med = float(np.median(sample))
        sigma = 1.4826 * float(np.median(np.abs(sample - med)))
        return max(self.config.min_threshold, self.config.threshold_sigmas * sigma)

    # -- preparation
    def prepare(self, frames: Iterable[np.ndarray]) -> None:
        """Learn the background, the threshold and the ant size from early frames.

        ``frames`` (an iterable, consumed once) should span a few seconds of video;
        at most ``2 * bg_frames`` of them are kept, at working resolution.
        """
        self._learn(self._background(frames))

    def rebase(self, frames: Iterable[np.ndarray]) -> None:
        """Learn a new background from ``frames`` (after a scene cut), keeping the
        threshold and the sizes learned by :meth:`prepare`."""
        self._bg_cells = None
        self._background(frames)

    def _background(self, frames: Iterable[np.ndarray]) -> list[np.ndarray]:
        """Learn the background from ``frames``; return up to 8 full frames (grey)."""
        c = self.config
        smalls: list[np.ndarray] = []
        grays: list[np.ndarray] = []
        step = 1
        for n, frame in enumerate(frames):
            gray = self._gray(frame)
            if n % step:
                continue
            smalls.append(self._small(gray, np.uint8))  # 4x less memory than float
            if n % 4 == 0 and len(grays) < 8:
                grays.append(gray)
            if len(smalls) >= 2 * c.bg_frames:  # keep an even spread over all frames
                smalls = smalls[::2]
                step *= 2
        if not smalls:
            raise InputError("the classical detector needs at least one frame to prepare")
        if len(smalls) > c.bg_frames:
            idx = np.linspace(0, len(smalls) - 1, c.bg_frames).round().astype(int)
            smalls = [smalls[i] for i in idx]
        n = len(smalls)
        # Lighting reference: the median of a few frames; then every frame normalised
        # to it and the bg_quantile of each pixel over the frames (np.partition).
        ref_idx = np.linspace(0, n - 1, min(n, 9)).round().astype(int)
        ref = np.median(np.stack([smalls[i] for i in ref_idx]), axis=0).astype(np.float32)
        if n > 2:
            norm = np.empty((n, *ref.shape), np.float32)
            for i, sm in enumerate(smalls):
                sm = sm.astype(np.float32)
                np.divide(sm, self._gain(sm, ref), out=norm[i])
            q = c.bg_quantile if c.polarity == "dark" else 1 - c.bg_quantile
            kth = int(round(q * (n - 1)))
            norm.partition(kth, axis=0)  # in place: no second copy of the stack
            self._bg = norm[kth].copy()
        else:
            self._bg = ref
        return grays

    def _learn(self, grays: list[np.ndarray]) -> None:
        """Threshold, single-ant area and body length from a few full frames."""
        c = self.config
        smalls = [self._small(g) for g in grays]
        maps = [self._contrast_map(s) for s in smalls]
        noise_thr = self._noise_threshold(smalls)
        self._thr = noise_thr if c.threshold is None else c.threshold
        model = self.model_area / c.downsample**2
        if c.threshold is None:
            first = [
                self._measure(g, con, exp, self._thr, 0.2 * model, split=False)
                for g, (con, exp) in zip(grays, maps, strict=True)
            ]
            peaks = np.concatenate([b.peak for b in first])
            if peaks.size >= 3:
                # Area-weighted: many faint specks (texture, glare) do not outvote
                # a few ants (sparse ants on textured ground, e.g. photos of trays).
                w = np.concatenate([b.area for b in first])
                self._peak = _weighted_median(peaks, w)
                self._thr = max(noise_thr, c.peak_fraction * self._peak)
        found = [
            self._measure(g, con, exp, self._thr, 0.2 * model, split=False)
            for g, (con, exp) in zip(grays, maps, strict=True)
        ]
        areas = np.concatenate([b.area for b in found])
        a1 = typical_area(areas) if areas.size >= 3 else 0.6 * model
        self._area1 = float(np.clip(a1, 0.3 * model, 3.0 * model))
        spans = np.concatenate(
            [b.span[(b.area > 0.7 * self._area1) & (b.area < 1.3 * self._area1)] for b in found]
        )
        if spans.size >= 3:
            # Blur and the threshold make silhouettes look longer than the ants by a
            # fixed amount at each end; measured against the expected length.
            L0 = self.prior_length_px
            extra = 0.5 * (float(np.median(spans)) - (anatomy.FRONT - anatomy.BACK) * L0)
            self._widen = float(np.clip(extra, -0.1 * L0, 0.3 * L0))

    # -- detection
    def _measure(
        self,
        gray: np.ndarray,
        con: np.ndarray,
        expected: np.ndarray,
        thr: float,
        min_area: float,
        *,
        split: bool = True,
        hints: np.ndarray | None = None,
    ) -> _Blobs:
        """Find and measure the blobs of one frame, vectorised over blobs
        (:mod:`~thermoswarm.tracking.detect.blobs`)."""
        c = self.config
        px = blob_pixels(
            gray,
            con,
            expected,
            thr,
            min_area,
            c.downsample,
            self._offsets,
            c.peak_fraction,
            self._contrast,
        )
        if px is None:
            return _Blobs.empty()
        if split and c.join_split:  # one ant split at its waist: one detection (.join)
            span = (anatomy.FRONT - anatomy.BACK) * self._length + 2 * self._widen
            join_split_bodies(px, self._area1, self._length, span, c.downsample)
        if split:
            k, hint_at = split_counts(
                px, self._area1, c.downsample, c.split_area, c.hint_split_area, c.max_split, hints
            )
        else:
            k, hint_at = np.ones(px.n, np.int64), {}
        parts = [measure_singles(px, k, hint_at, self._length, self._widen)]
        parts += measure_splits(px, k, hint_at, hints, self._length, self._widen)
        return _Blobs.join(parts)

    def detect(self, frame: np.ndarray, hints: np.ndarray | None = None) -> FrameDetections:
        """Detect the ants in one frame.

        Parameters
        ----------
        frame
            ``(H, W, 3)`` RGB or ``(H, W)`` uint8.
        hints
            Optional predicted poses ``(m, 3, 2)`` px (from the tracker) that guide the
            splitting of touching ants.
        """
        import cv2

        gray = self._gray(frame)
        if self._bg is None:
            self.prepare([frame])
        c = self.config
        small = self._small(gray)
        con, expected = self._contrast_map(small)
        b = self._measure(gray, con, expected, self._thr, c.min_area * self._area1, hints=hints)
        if c.bg_rate > 0 and c.background == "time":
            fg = (con > 0.5 * self._thr).view(np.uint8)
            fg = cv2.dilate(fg, np.ones((5, 5), np.uint8))
            cv2.accumulateWeighted(small, self._bg, c.bg_rate, mask=1 - fg)
        if len(b.points) == 0:
            return FrameDetections.empty()
        scores = np.where(b.split, 0.6, 1.0) * np.clip(b.peak / max(self._peak or 1.0, 1e-3), 0, 1)
        return FrameDetections(
            b.points, scores, None, b.head_conf, b.hint if hints is not None else None
        )


#: The likely reasons when nothing is detected (appended to the one-line error).
NOTHING_FOUND_HINT = (
    "likely causes: the scale (--px-per-mm S expects animals about 7 S px long; "
    "leave it out to measure the size from the video), the contrast (animals must "
    "differ from the background: try --set detector.polarity=light for light "
    "animals on a dark ground, or --set detector.channel=gray), animals that do not "
    "move (the background is learned from frames spread over the clip's first minute"
    "; --set detector.background=picture with --px-per-mm finds animals that never "
    "move, by their contrast to their surroundings), or a --model not trained on such "
    "footage"
)


register_detector(
    DetectorEntry(
        "classical",
        "thermoswarm.tracking.detect.classical:_classical_factory",
        "background subtraction + blob moments (no training)",
    )
)
register_detector(
    DetectorEntry(
        "unet",
        "thermoswarm.tracking.detect.unet:make_detector",
        "trained top-down U-Net + pose model (--model PATH)",
        needs_model=True,
    )
)
