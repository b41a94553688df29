"""Camera registration: hand-held, panning and drifting footage made still.

The classical detector subtracts a still background, so a camera that moves turns the
whole ground into "animals".  :func:`camera_path` measures how the camera moved: every
frame is registered to a reference frame (:func:`cv2.findTransformECC`, a rotation and
a shift, on a grey copy at most ``max_side`` px wide, blurred, the blobs that stand out
of their surroundings, large animals, left out of the fit: :func:`_blobs`), the
reference moving on (the current frame becomes the next
reference, the transforms chained) only when the correlation drops below
``rekey_cc`` or the frame has moved a fifth of the image away; a frame that differs
from its predecessor by under half a grey level on average is where its predecessor
was, and so is one that fails to register (too little texture: animals on a plain
floor) but differs from its predecessor by under a quarter of the picture's spread.
Letterbox bars (rows and columns black in the first frame) are left out of the fit.  A frame whose
registration fails (no convergence, correlation below ``min_cc``) against both its
reference and its predecessor is a *break*: isolated breaks are scene cuts (the
registration restarts there, that frame placed where its predecessor was); breaks in
more than ``max_break_share`` of the frames mean the camera cannot be followed, and
:class:`~thermoswarm.errors.InputError` says how it moved.

:class:`RegisteredSource` then gives the frames warped into the first frame's
coordinates on a canvas large enough for the whole path (the first frame's origin at
``offset``); what the current frame does not show (outside its field, letterbox bars) is
filled from the median of up to ``n_mosaic`` warped frames, so that it holds no edges and
no animals.  A camera whose path stays within ``still_px`` of the first frame is still:
:func:`register_source` then returns the source itself, untouched.
"""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from thermoswarm.errors import InputError
from thermoswarm.tracking.detection import FrameDetections

__all__ = [
    "CameraPath",
    "RegisteredSource",
    "camera_path",
    "register_source",
    "still_fits_better",
    "shift_detections",
    "camera_summary",
]

CameraMode = Literal["auto", "still", "moving"]


@dataclass(frozen=True)
class CameraPath:
    """How the camera moved: ``matrices`` ``(n, 2, 3)`` map each frame's px to the first
    frame's px; ``cc`` ``(n,)`` the registration's correlation (1: perfect; NaN at a
    break); ``cuts`` the frames (0-based) that start a new scene; ``size`` the frame's
    ``(width, height)`` px; ``roi`` the ``(x0, y0, x1, y1)`` px that hold the picture
    (letterbox bars left out)."""

    matrices: np.ndarray
    cc: np.ndarray
    cuts: tuple[int, ...]
    size: tuple[int, int]
    roi: tuple[int, int, int, int]
    canvas_size: tuple[int, int] = field(init=False)
    offset: tuple[float, float] = field(init=False)

    def __post_init__(self) -> None:
        w, h = self.size
        corners = np.array([[0, 0], [w, 0], [0, h], [w, h]], float)
        pts = (
            np.einsum("nij,kj->nki", self.matrices[:, :, :2], corners)
            + self.matrices[:, None, :, 2]
        )
        lo = np.floor(np.minimum(pts.reshape(-1, 2).min(0), 0.0))
        hi = np.ceil(np.maximum(pts.reshape(-1, 2).max(0), (w, h)))
        object.__setattr__(self, "offset", (float(-lo[0]), float(-lo[1])))
        object.__setattr__(self, "canvas_size", (int(hi[0] - lo[0]), int(hi[1] - lo[1])))

    @property
    def shift_px(self) -> np.ndarray:
        """``(n,)`` how far (px) each frame's centre lies from the first frame's."""
        w, h = self.size
        c = np.array([w / 2, h / 2])
        moved = self.matrices[:, :, :2] @ c + self.matrices[:, :, 2]
        return np.linalg.norm(moved - c, axis=1)

    @property
    def angle_deg(self) -> np.ndarray:
        """``(n,)`` each frame's rotation against the first frame (degrees)."""
        return np.degrees(np.arctan2(self.matrices[:, 1, 0], self.matrices[:, 0, 0]))

    def reach_px(self) -> float:
        """The largest distance (px) any frame corner moved from where it was in frame 0."""
        w, h = self.size
        corners = np.array([[0, 0, 1], [w, 0, 1], [0, h, 1], [w, h, 1]], float)
        moved = np.einsum("nij,kj->nki", self.matrices, corners)
        return float(np.max(np.linalg.norm(moved - corners[None, :, :2], axis=2)))

    def canvas_matrix(self, k: int) -> np.ndarray:
        """``(2, 3)`` frame ``k``'s px to canvas px."""
        m = self.matrices[k].copy()
        m[:, 2] += self.offset
        return m

    def table(self) -> str:
        """CSV: frame (0-based), dx, dy (px, where the frame's centre lies in the first
        frame's px, less the image centre), angle (deg), the matrix, the correlation and
        whether the frame starts a new scene."""
        rows = ["frame,dx_px,dy_px,angle_deg,a11,a12,tx,a21,a22,ty,cc,cut"]
        w, h = self.size
        c = np.array([w / 2, h / 2])
        cuts = set(self.cuts)
        for k, m in enumerate(self.matrices):
            d = m[:, :2] @ c + m[:, 2] - c
            ang = math.degrees(math.atan2(m[1, 0], m[0, 0]))
            vals = [d[0], d[1], ang, *m[0], *m[1], self.cc[k]]
            rows.append(f"{k}," + ",".join(f"{v:.4f}" for v in vals) + f",{int(k in cuts)}")
        return "\n".join(rows) + "\n"

    def describe(self) -> str:
        """The camera's motion in words (for messages and the summary)."""
        n = len(self.matrices)
        return (
            f"moved up to {self.reach_px():.0f} px and turned up to "
            f"{np.max(np.abs(self.angle_deg)):.1f} deg over {n} frames"
        )


def _picture_roi(gray: np.ndarray, dark: float = 16.0) -> tuple[int, int, int, int]:
    """``(x0, y0, x1, y1)`` of the picture inside black letterbox bars (all of it if none)."""
    rows = np.flatnonzero(gray.max(1) > dark)
    cols = np.flatnonzero(gray.max(0) > dark)
    if rows.size < gray.shape[0] // 4 or cols.size < gray.shape[1] // 4:
        return (0, 0, gray.shape[1], gray.shape[0])
    return (int(cols[0]), int(rows[0]), int(cols[-1]) + 1, int(rows[-1]) + 1)


def _small_gray(frame: np.ndarray, s: float) -> np.ndarray:
    import cv2

    g = cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY) if frame.ndim == 3 else frame
    if s != 1.0:
        g = cv2.resize(g, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
    return g.astype(np.float32)


def _blobs(g: np.ndarray) -> np.ndarray:
    """Where ``g`` (small grey copy) holds blobs that stand out of their surroundings:
    over 5 robust sd from a 21-px median, in pieces of 12 px or more (animals, not the
    floor's texture), grown by 3 px; uint8 0/1.

    Hand-written because ECC has no robust loss: its mask is the one way to keep the
    animals out.  Large animals that walk pull a camera path measured on every pixel
    along with them (SLEAP's fly clip moved by a known path: 467 px off by its last
    frame, within 2.1 px with them masked: ``benchmarks/bench_registration.py whole``)."""
    import cv2

    d = g - cv2.medianBlur(np.clip(g, 0, 255).astype(np.uint8), 21).astype(np.float32)
    out = (np.abs(d) > 5 * (1.4826 * float(np.median(np.abs(d))) + 0.5)).astype(np.uint8)
    n, lab, stats, _ = cv2.connectedComponentsWithStats(out, connectivity=8)
    big = np.zeros(n, np.uint8)
    big[1:] = stats[1:, cv2.CC_STAT_AREA] >= 12
    return cv2.dilate(big[lab], np.ones((7, 7), np.uint8))


def _ecc(
    ref: np.ndarray, img: np.ndarray, init: np.ndarray, mask: np.ndarray, blobs: Any = None
) -> tuple:
    """``(cc, W)``: W ``(3, 3)`` maps ``ref``'s px to ``img``'s; cc NaN when ECC fails.
    The blobs of both (:func:`_blobs`; ``ref``'s moved by ``init``) are left out of
    the fit unless that leaves under half of ``mask``, or a floor without texture
    (under 2 grey levels sd: small ants on a plain white floor, 1.0; the fly clip's
    floor 4.7): there the fit over blank pixels gained nothing and took 7 times as
    long.  ``blobs``: a function giving a frame's blobs (:func:`_blobs` by default;
    :func:`camera_path` keeps its reference's between frames)."""
    import cv2

    blobs = blobs or _blobs
    h, w_ = img.shape
    moved = cv2.warpAffine(
        blobs(ref), init[:2].astype(np.float32), (w_, h), flags=cv2.INTER_NEAREST
    )
    keep = (mask.astype(bool) & ~(blobs(img) | moved).astype(bool)).astype(np.uint8)
    kept = keep.astype(bool)
    fit = keep if kept.sum() >= 0.5 * mask.sum() and img[kept].std() >= 2.0 else mask
    w = init[:2].astype(np.float32).copy()
    crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 60, 1e-5)
    try:
        cc, w = cv2.findTransformECC(ref, img, w, cv2.MOTION_EUCLIDEAN, crit, fit, 5)
    except cv2.error:
        return math.nan, init
    return float(cc), np.vstack([w, [0, 0, 1]]).astype(np.float64)


def camera_path(
    frames: Iterator[np.ndarray],
    *,
    source: str = "video",
    max_side: int = 400,
    min_cc: float = 0.6,
    rekey_cc: float = 0.9,
    max_break_share: float = 0.05,
) -> CameraPath:
    """Measure the camera's path over ``frames`` (see the module docstring).

    Parameters
    ----------
    frames, source
        The video's frames (RGB or grey uint8), in order; its name, for messages.
    max_side
        Largest side (px) of the grey copy registered.
    min_cc, rekey_cc
        Correlation below which a registration fails, and below which the reference
        moves on to the current frame.
    max_break_share
        Largest share of frames that may fail to register (scene cuts) before the
        camera cannot be followed (:class:`InputError`, naming its motion).
    """
    mats: list[np.ndarray] = []
    ccs: list[float] = []
    breaks: list[int] = []
    ref = prev = None
    ref_mat = np.eye(3)  # the reference's small px -> first frame's small px
    W = np.eye(3)  # last estimate: reference -> current (small px)
    s = 1.0
    known: dict[int, np.ndarray] = {}  # the blobs of the frames in use, by id

    def blobs(a: np.ndarray) -> np.ndarray:
        if id(a) not in known:
            known[id(a)] = _blobs(a)
        return known[id(a)]

    for k, frame in enumerate(frames):
        # only the reference's and the predecessor's blobs are kept (their arrays are
        # alive, so their ids are not reused by the new frame)
        known = {i: b for i, b in known.items() if i in (id(ref), id(prev))}
        if k == 0:
            h, w = frame.shape[:2]
            s = min(1.0, max_side / max(h, w))
            roi, mask, g = _first(frame, s)
            ref = prev = g
            mats.append(np.eye(3))
            ccs.append(1.0)
            continue
        g = _small_gray(frame, s)
        if float(np.mean(np.abs(g - prev))) < 0.5:  # the same picture (or a blank one)
            mats.append(mats[-1].copy())
            ccs.append(1.0)
            prev = g
            continue
        cc, W2 = _ecc(ref, g, W, mask, blobs)
        far = not math.isnan(cc) and np.hypot(*W2[:2, 2]) > 0.2 * max(g.shape)
        if math.isnan(cc) or cc < rekey_cc or far:
            # The reference moves on to the previous frame (chained), then retried.
            prev_mat = mats[-1]
            cc_p, Wp = _ecc(prev, g, np.eye(3), mask, blobs)
            ref, ref_mat, W2, cc = prev, _small_mat(prev_mat, s), Wp, cc_p
        if (math.isnan(cc) or cc < min_cc) and _same_place(g, prev, mask):
            # Too little texture to register (animals on a plain floor), and hardly
            # anything changed: where its predecessor was.
            mats.append(mats[-1].copy())
            ccs.append(math.nan)
            prev = g
            continue
        if math.isnan(cc) or cc < min_cc:
            breaks.append(k)
            mats.append(mats[-1].copy())  # a cut: placed where its predecessor was
            ccs.append(math.nan)
            ref, ref_mat, W = g, _small_mat(mats[-1], s), np.eye(3)
            prev = g
            continue
        W = W2
        cur = ref_mat @ np.linalg.inv(W)  # current small px -> first frame's small px
        mats.append(_full_mat(cur, s))
        ccs.append(cc)
        prev = g
    if not mats:
        raise InputError(f"{source}: no frame could be decoded")
    path = CameraPath(np.stack([m[:2] for m in mats]), np.array(ccs), tuple(breaks), (w, h), roi)
    _check_breaks(path, source, max_break_share)
    return path


def _first(frame: np.ndarray, s: float) -> tuple[tuple[int, int, int, int], np.ndarray, Any]:
    """The first frame's picture ``roi`` (full px), the fit's mask and grey copy (small)."""
    h, w = frame.shape[:2]
    roi = _picture_roi(frame if frame.ndim == 2 else frame.max(2))
    g = _small_gray(frame, s)
    mask = np.zeros(g.shape, np.uint8)
    ys = slice(int(roi[1] * s) + 2, int(roi[3] * s) - 2)
    mask[ys, int(roi[0] * s) + 2 : int(roi[2] * s) - 2] = 1
    return roi, mask, g


def _check_breaks(path: CameraPath, source: str, max_break_share: float) -> None:
    """:class:`InputError` naming the camera's motion when the breaks are not isolated
    scene cuts (adjacent, or more than ``max_break_share`` of the frames)."""
    breaks, n = path.cuts, len(path.matrices)
    adjacent = any(b - 1 in breaks or b + 1 in breaks for b in breaks)
    if len(breaks) > max(1, max_break_share * n) or adjacent:
        raise InputError(
            f"{source}: the camera cannot be followed: {len(breaks)} of {n} frames do not "
            f"register to their neighbours (first at frame {breaks[0] + 1}; until then the "
            f"camera {_until(path, breaks[0])}); try a steadier or slower camera, a tripod, "
            "or cut the clip where the camera jumps"
        )


def _same_place(g: np.ndarray, prev: np.ndarray, mask: np.ndarray) -> bool:
    """Whether ``g`` differs from ``prev`` by under a quarter of the picture's spread
    (or under 4 grey levels) on average: a frame the camera has not left."""
    m = mask.astype(bool)
    change = float(np.mean(np.abs(g - prev)[m]))
    return change < max(4.0, 0.25 * float(np.std(prev[m])))


def _until(path: CameraPath, k: int) -> str:
    return CameraPath(path.matrices[:k], path.cc[:k], (), path.size, path.roi).describe()


def _small_mat(full: np.ndarray, s: float) -> np.ndarray:
    m = np.eye(3)
    m[:2] = full[:2]
    m[:2, 2] = m[:2, 2] * s
    return m


def _full_mat(small: np.ndarray, s: float) -> np.ndarray:
    m = small.copy()
    m[:2, 2] = m[:2, 2] / s
    return m


class RegisteredSource:
    """A video source whose frames come warped into the first frame's coordinates, on
    the canvas of ``path`` (see the module docstring).  ``size`` is the canvas's."""

    def __init__(self, src: Any, path: CameraPath, n_mosaic: int = 15) -> None:
        self._src = src
        self.camera = path
        self.path: Path = src.path
        self.fps = src.fps
        self.n_frames = src.n_frames
        self.size = path.canvas_size
        self._mosaic = self._median_mosaic(n_mosaic)

    @property
    def files(self) -> list[Path] | None:
        """The source's image files (None for a video file)."""
        return self._src.files

    def _warp(self, frame: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        import cv2

        m = self.camera.canvas_matrix(k)
        x0, y0, x1, y1 = self.camera.roi
        roi = np.zeros(frame.shape[:2], np.uint8)
        roi[y0:y1, x0:x1] = 1
        img = cv2.warpAffine(frame, m, self.size, flags=cv2.INTER_LINEAR)
        valid = cv2.warpAffine(roi, m, self.size, flags=cv2.INTER_NEAREST)
        valid = cv2.erode(valid, np.ones((5, 5), np.uint8))
        return img, valid.astype(bool)

    def _median_mosaic(self, n: int) -> np.ndarray:
        total = len(self.camera.matrices)
        pick = set(np.linspace(0, total - 1, min(n, total)).round().astype(int).tolist())
        stack = []
        for k, frame in enumerate(self._src.frames(total)):
            if k in pick:
                img, valid = self._warp(frame, k)
                img = img.astype(np.float32)
                img[~valid] = np.nan
                stack.append(img)
        with warnings.catch_warnings():  # canvas px no frame shows: NaN, then 0
            warnings.simplefilter("ignore", RuntimeWarning)
            mosaic = np.nanmedian(np.stack(stack), axis=0) if len(stack) > 1 else stack[0]
        return np.nan_to_num(mosaic, nan=0.0).astype(np.uint8)

    def frames(
        self, stop: int | None = None, *, step: int = 1, prefetch: int = 0, start: int = 0
    ) -> Iterator[np.ndarray]:
        """Warped frames ``start, start + step, ...`` below ``stop`` (as the source's
        ``frames``)."""
        total = len(self.camera.matrices)
        stop = total if stop is None else min(stop, total)
        frames = self._src.frames(stop, step=step, prefetch=prefetch, start=start)
        for i, frame in enumerate(frames):
            img, valid = self._warp(frame, start + i * step)
            yield np.where(valid[..., None] if img.ndim == 3 else valid, img, self._mosaic)


#: The last camera path measured in this process, by file (its real path, mtime and
#: size) and frame count: ``track --detector self-trained`` registers one clip three
#: times (its classical pass, its label frames, its U-Net pass), and a path takes about
#: 2.7 s per 150 frames of 800 x 800 px on 2 cores.  One entry: one clip at a time.
_LAST_PATH: dict[tuple[Any, ...], CameraPath] = {}


def _measured_path(src: Any, max_frames: int | None) -> CameraPath:
    """:func:`camera_path` of ``src``'s frames (below ``max_frames``), measured once
    per video file and frame count in a process."""
    key: tuple[Any, ...] | None = None
    # Video files only: a list of images (or a folder of them) is named by a folder, or
    # by a made-up name, whose mtime does not follow its frames.
    if getattr(src, "files", None) is None and os.path.isfile(getattr(src, "path", "")):
        st = os.stat(src.path)
        key = (os.path.realpath(src.path), st.st_mtime_ns, st.st_size, max_frames)
    if key is not None and key in _LAST_PATH:
        return _LAST_PATH[key]
    path = camera_path(src.frames(max_frames, prefetch=4), source=str(src.path))
    if key is not None:
        _LAST_PATH.clear()
        _LAST_PATH[key] = path
    return path


def register_source(
    src: Any, mode: CameraMode = "auto", *, max_frames: int | None = None, still_px: float = 3.0
) -> tuple[Any, CameraPath | None]:
    """``(source, path)``: a :class:`RegisteredSource` and its :class:`CameraPath` for a
    moving camera; ``src`` itself for a still one (with its path, for the scene cuts,
    or ``None`` when nothing was measured).

    ``mode``: ``"still"`` trusts the camera not to move (nothing measured);
    ``"moving"`` registers whatever the path; ``"auto"`` registers when the measured
    path leaves ``still_px`` of the first frame.
    """
    if mode not in ("auto", "still", "moving"):
        raise InputError(f"camera must be one of auto, still, moving; got {mode!r}")
    if mode == "still":
        return src, None
    path = _measured_path(src, max_frames)
    if mode == "auto" and path.reach_px() <= still_px:
        return src, path  # a still camera: the frames as they are (the path for its cuts)
    # Before the size check: on a plain floor a path "measured" from animals that creep
    # in step can reach hundreds of px (two drawn ants on white: 611 px, 131 deg).
    if mode == "auto" and still_fits_better(src, path):
        return src, path  # the animals, not the camera, moved (a plain floor)
    canvas = path.canvas_size[0] * path.canvas_size[1]
    if canvas > 6 * path.size[0] * path.size[1]:
        raise InputError(
            f"{src.path}: the camera {path.describe()}: the scene it covers is "
            f"{canvas / (path.size[0] * path.size[1]):.1f} times the frame; track "
            "shorter pieces of the clip (--max-frames) or use a steadier camera"
        )
    return RegisteredSource(src, path), path


def still_fits_better(src: Any, path: CameraPath, n: int = 9) -> bool:
    """Whether a still background explains ``n`` frames spread over the clip at least
    as well as the registered one: on a plain floor the only texture is the animals,
    and a path measured from them is the animals' motion, not the camera's (66 ants
    walking on white: "moved up to 37 px"; tracks then land in the wrong place).

    Each way, the frames' grey copies (largest side at most 400 px) against their median (the
    registered ones warped by ``path``, on the pixels they show); a pixel is
    unexplained when it is off by over 5 robust sds of the still residual (at least 10
    grey levels).  The camera moved when registration leaves under 0.9 of the still
    model's unexplained share and at least 0.2 % of the picture fewer.  Measured: 66
    drawn ants walking on white, still 1.1 % unexplained, registered 1.4 % (still);
    SLEAP's fly clip moved 166 px, 4.7 % and 0.02 %; its walking frames moved 190 px
    with a path 34 px off, 4.8 % and 3.2 % (registered, both).
    """
    import cv2

    total = len(path.matrices)
    picks = np.unique(np.linspace(0, total - 1, min(n, total)).round().astype(int))
    w, h = path.size
    s = min(1.0, 400 / max(w, h))
    size = (max(1, int(round(w * s))), max(1, int(round(h * s))))
    scale = np.diag([s, s, 1.0])
    raw, warped, valid = [], [], []
    for k in picks:
        frame = next(src.frames(k + 1, start=int(k)), None)
        if frame is None:
            return False
        g = cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY) if frame.ndim == 3 else frame
        g = cv2.resize(g, size, interpolation=cv2.INTER_AREA).astype(np.float32)
        m = (scale @ np.vstack([path.matrices[k], [0, 0, 1]]) @ np.linalg.inv(scale))[:2]
        raw.append(g)
        warped.append(cv2.warpAffine(g, m, size, flags=cv2.INTER_LINEAR))
        seen = cv2.warpAffine(np.ones_like(g), m, size, flags=cv2.INTER_NEAREST)
        valid.append(cv2.erode(seen, np.ones((5, 5), np.uint8)) > 0.5)
    raw_res = np.abs(np.stack(raw) - np.median(np.stack(raw), axis=0))
    stack = np.where(np.stack(valid), np.stack(warped), np.nan)
    with warnings.catch_warnings():  # px no picked frame shows: NaN
        warnings.simplefilter("ignore", RuntimeWarning)
        reg_res = np.abs(stack - np.nanmedian(stack, axis=0))
    med = float(np.median(raw_res))
    t = max(10.0, med + 5 * 1.4826 * float(np.median(np.abs(raw_res - med))))
    still = float(np.mean(raw_res > t))
    seen = np.isfinite(reg_res)
    moved = float(np.mean(reg_res[seen] > t)) if seen.any() else 1.0
    return not (moved < 0.9 * still and still - moved > 0.002)


def shift_detections(d: FrameDetections, offset: tuple[float, float]) -> FrameDetections:
    """``d`` moved by ``-offset`` px: from a registered canvas to the first frame's px."""
    if not len(d) or offset == (0.0, 0.0):
        return d
    off = np.asarray(offset, float)
    boxes = None if d.boxes is None else d.boxes - np.array([*off, 0.0, 0.0])
    return dataclasses.replace(d, points=d.points - off, boxes=boxes)


def camera_summary(
    path: CameraPath | None, registered: bool, more_cuts: list[int] | tuple = ()
) -> dict[str, Any]:
    """The camera's record for ``summary.json``: whether the frames were registered,
    the motion, the scene cuts (1-based frames: the path's and ``more_cuts``, 0-based
    frames found otherwise) and the frame the outputs are in."""
    cuts = sorted({*(k + 1 for k in (path.cuts if path else ())), *(k + 1 for k in more_cuts)})
    if path is None:
        out = {"registered": False, "measured": False, "outputs": []}
        return {**out, "scene_cuts": cuts} if cuts else out
    return {
        "registered": registered,
        "measured": True,
        "motion": path.describe(),
        "reach_px": path.reach_px(),
        "max_angle_deg": float(np.max(np.abs(path.angle_deg))),
        "scene_cuts": cuts,
        "coordinates": "first frame's px" if registered else "image px",
        "canvas_size": list(path.canvas_size) if registered else None,
        "outputs": ["camera_path.csv"] if registered else [],
    }
