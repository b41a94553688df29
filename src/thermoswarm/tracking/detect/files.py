"""Detections of other detectors, read from files: MOTChallenge, YOLO txt, COCO JSON.

Every reader returns a :class:`DetectionTable`: frame numbers exactly as the file
gives them, boxes ``left, top, width, height`` in px and scores in [0, 1].

``mot``
    One text file of MOTChallenge rows ``frame, id, left, top, width, height, conf,
    ...`` (the id is ignored; a negative ``conf``, as in files without scores, counts
    as 1).  Frames may start at 0 or 1.
``yolo``
    A folder of per-frame text files (what YOLO detectors write with ``save_txt``),
    each line ``class cx cy w h [conf]`` normalised by the image size, which must be
    given (``image_size``).  The frame number is the last integer in the file name
    (``clip_000123.txt`` -> 123).  Frames without a file have no detections.
``coco``
    A JSON file: either COCO's results format (a list of ``{"image_id", "bbox",
    "score"}``, the frame number being ``image_id``) or a dataset with ``images`` and
    ``annotations`` (frame number: the image's ``frame_id``, else the last integer of
    its ``file_name``, else its ``id``; ``score`` 1 when absent).  ``bbox`` is
    ``[x, y, width, height]`` in px.  When the annotations' category names keypoints
    ``head``, ``body`` and ``tail``, annotations with ``keypoints`` (``[x, y, v]`` each,
    ``v = 0``: unknown) give the detections' poses, and ``head_confidence`` (ours)
    how sure the detector was of the head-tail order.  What ``thermoswarm detect``
    writes (:func:`coco_dataset`) also records the objects' length ``length_px`` and
    that its boxes are the poses' own (``info.thermoswarm``), so that tracking the file
    gives the same tracks as tracking the video with the same detections.

Writing: :func:`coco_dataset` builds a COCO keypoints dataset from per-frame
detections (``images``, ``annotations`` with ``bbox``, ``score``, ``keypoints``,
``categories`` with the keypoint names and skeleton); :func:`mot_rows` the
MOTChallenge detection rows of a video.

Frame numbering is kept: the tracker runs from frame 0 when the file has a frame 0,
else from frame 1 (or from ``first_frame``), frames without detections are empty,
and the tracks are written with the same numbers.  Negative frame numbers, a frame
range over :data:`MAX_FRAMES`, boxes of negative or zero size and non-finite values
are refused with a one-line :class:`~thermoswarm.errors.InputError`.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from thermoswarm.config import shown
from thermoswarm.errors import InputError
from thermoswarm.tracking.detection import FrameDetections

__all__ = [
    "DetectionTable",
    "FORMATS",
    "MAX_FRAMES",
    "read_detections",
    "parse_image_size",
    "coco_dataset",
    "mot_rows",
    "KEYPOINT_NAMES",
]

#: Keypoint names (COCO ``categories[].keypoints``) and skeleton (1-based pairs).
KEYPOINT_NAMES = ("head", "body", "tail")
SKELETON = [[1, 2], [2, 3]]

#: Formats :func:`read_detections` reads.
FORMATS = ("mot", "yolo", "coco")

#: The longest frame range accepted (1 million frames: 9.3 hours at 30 fps). The tracker
#: walks every frame of the range: a sparse file spanning 1,000,000 frames takes 24 s and
#: 1.5 GB (issue 36's fuzz: 10 million took minutes and many GB).
MAX_FRAMES = 1_000_000
#: The largest frame number (exact in a float64).
MAX_FRAME_NUMBER = 2**53
#: The largest box coordinate or size, and image side (px).
MAX_PX = 1e7

_INT = re.compile(r"(\d+)")


@dataclass(frozen=True)
class DetectionTable:
    """Detections of a whole video, one row per box.

    ``frames`` (n,) int frame numbers as in the file; ``boxes`` (n, 4) ``left, top,
    width, height`` px; ``scores`` (n,) in [0, 1]; ``image_size`` ``(width, height)``
    px if the file or the caller knows it; ``fmt`` the format read.  Optional
    (COCO keypoints): ``points`` (n, 3, 2) head, body, tail px (NaN: unknown),
    ``head_confidence`` (n,), ``object_length_px`` the objects' length recorded in
    the file, and ``pose_boxes`` (the boxes are the poses' own, padded: the tracker
    may recompute them from its corrected poses).
    """

    frames: np.ndarray
    boxes: np.ndarray
    scores: np.ndarray
    source: str
    fmt: str
    image_size: tuple[int, int] | None = None
    points: np.ndarray | None = None
    head_confidence: np.ndarray | None = None
    object_length_px: float | None = None
    pose_boxes: bool = False

    def __len__(self) -> int:
        return int(self.frames.size)

    def first_frame(self, first_frame: int | None = None) -> int:
        """The number of the tracker's first frame: ``first_frame`` if given (0 or 1),
        else the file's first frame number (0 when empty).  A file numbered from
        10,000,000 is tracked from there, not from frame 0."""
        if first_frame is not None:
            if isinstance(first_frame, bool) or first_frame not in (0, 1):
                raise InputError(f"first_frame must be 0 or 1, got {first_frame!r}")
            if len(self) and int(self.frames.min()) < first_frame:
                raise InputError(
                    f"{self.source}: frame {int(self.frames.min())} comes before the "
                    f"first frame {first_frame}"
                )
            if len(self) and int(self.frames.max()) - first_frame + 1 > MAX_FRAMES:
                raise InputError(
                    f"{self.source}: frames {first_frame} to {int(self.frames.max())} are "
                    f"more than the {MAX_FRAMES:,} accepted; leave out --first-frame to "
                    f"start at the file's first frame {int(self.frames.min())}"
                )
            return first_frame
        return int(self.frames.min()) if len(self) else 0

    def per_frame(self, first_frame: int | None = None) -> tuple[int, list[FrameDetections]]:
        """``(first, dets)``: detections of frames ``first, first + 1, ...`` up to the
        last frame with a detection (box centres as body points, head and tail
        unknown)."""
        first = self.first_frame(first_frame)
        if len(self) == 0:
            return first, []
        n = int(self.frames.max()) - first + 1
        order = np.argsort(self.frames, kind="stable")
        bounds = np.searchsorted(self.frames[order], np.arange(first, first + n + 1))
        out = []
        hc = self.head_confidence
        for f in range(n):
            rows = order[bounds[f] : bounds[f + 1]]
            b = self.boxes[rows]
            if self.points is not None:
                pts = self.points[rows]
            else:
                pts = np.full((rows.size, 3, 2), np.nan)
                pts[:, 1] = b[:, :2] + b[:, 2:] / 2
            full = self.pose_boxes and bool(np.all(np.isfinite(pts)))
            out.append(
                FrameDetections(
                    pts,
                    self.scores[rows],
                    boxes=None if full else b,
                    head_confidence=None if hc is None else hc[rows],
                )
            )
        return first, out

    def length_px(self) -> float | None:
        """The objects' size (px): the length the file records, else the median
        longer side of the boxes; None if empty."""
        if self.object_length_px is not None:
            return self.object_length_px
        if len(self) == 0:
            return None
        return float(np.median(np.max(self.boxes[:, 2:], axis=1)))


def _check_table(source: str, frames: np.ndarray, boxes: np.ndarray, where: list[str]) -> None:
    """One-line errors for bad rows; ``where[i]`` names row ``i`` (file:line)."""
    bad = ~np.all(np.isfinite(boxes), axis=1)
    if bad.any():
        raise InputError(f"{where[int(np.argmax(bad))]}: non-finite box value")
    bad = np.any(np.abs(boxes) > MAX_PX, axis=1)
    if bad.any():
        raise InputError(
            f"{where[int(np.argmax(bad))]}: a box value beyond {MAX_PX:g} px "
            f"({', '.join(f'{v:g}' for v in boxes[int(np.argmax(bad))])})"
        )
    bad = (boxes[:, 2] <= 0) | (boxes[:, 3] <= 0)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(
            f"{where[i]}: box width and height must be positive, got "
            f"{boxes[i, 2]:g} x {boxes[i, 3]:g}"
        )
    if frames.size:
        if frames.min() < 0:
            i = int(np.argmin(frames))
            raise InputError(f"{where[i]}: negative frame number {int(frames[i])}")
        span = int(frames.max()) - int(frames.min()) + 1
        if span > MAX_FRAMES:
            raise InputError(
                f"{source}: frames {int(frames.min())} to {int(frames.max())} span "
                f"{span:,} frames, more than the {MAX_FRAMES:,} accepted"
            )


def _read_mot(path: Path) -> DetectionTable:
    from thermoswarm.io.mot import read_mot_table

    table = read_mot_table(path, min_frame=0)
    frames = table[:, 0].astype(np.int64)
    boxes = table[:, 2:6].copy()
    where = [f"{path}: row {i + 1}" for i in range(len(table))]
    _check_table(str(path), frames, boxes, where)
    scores = np.clip(np.where(table[:, 6] < 0, 1.0, table[:, 6]), 0.0, 1.0)
    return DetectionTable(frames, boxes, scores, str(path), "mot")


def _frame_number(name: str, source: str) -> int:
    nums = _INT.findall(Path(name).stem)
    if not nums:
        raise InputError(f"{source}: no frame number in the file name {name!r}")
    if len(nums[-1]) > 16 or int(nums[-1]) > MAX_FRAME_NUMBER:
        raise InputError(
            f"{source}: frame number {nums[-1][:20]} in {name[:80]!r} is above {MAX_FRAME_NUMBER}"
        )
    return int(nums[-1])


def _read_yolo(path: Path, image_size: tuple[int, int] | None) -> DetectionTable:
    if image_size is None:
        raise InputError(
            f"{path}: YOLO boxes are normalised by the image size; pass --image-size "
            "WIDTHxHEIGHT (or a frame or the video to read it from)"
        )
    W, H = image_size
    # a folder named like frame_9.txt is not a frame's file
    files = sorted(p for p in path.iterdir() if p.suffix.lower() == ".txt" and p.is_file())
    if not files:
        raise InputError(f"{path}: no .txt files (YOLO detections: one file per frame)")
    frames, rows, where = [], [], []
    seen: dict[int, str] = {}
    for f in files:
        k = _frame_number(f.name, str(path))
        if k in seen:
            raise InputError(f"{path}: files {seen[k]!r} and {f.name!r} are both frame {k}")
        seen[k] = f.name
        try:
            text = f.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            raise InputError(f"{f}: not a YOLO text file") from None
        except OSError as exc:
            raise InputError(f"{f}: cannot be read ({exc.strerror or exc})") from None
        for lineno, line in enumerate(text.splitlines(), 1):
            parts = line.split()
            if not parts:
                continue
            if len(parts) not in (5, 6):
                raise InputError(
                    f"{f}:{lineno}: expected 'class cx cy w h [conf]', got {len(parts)} values"
                )
            try:
                v = [float(x) for x in parts]
            except ValueError:
                raise InputError(f"{f}:{lineno}: non-numeric value in {line[:60]!r}") from None
            if not all(math.isfinite(x) for x in v):
                raise InputError(f"{f}:{lineno}: non-finite value")
            cx, cy, w, h = v[1:5]
            if max(abs(cx), abs(cy), abs(w), abs(h)) > 1.5:
                raise InputError(
                    f"{f}:{lineno}: cx cy w h must be normalised to [0, 1] "
                    f"(got {cx:g} {cy:g} {w:g} {h:g}; pixel coordinates?)"
                )
            conf = v[5] if len(v) == 6 else 1.0
            frames.append(k)
            rows.append((cx * W - w * W / 2, cy * H - h * H / 2, w * W, h * H, conf))
            where.append(f"{f}:{lineno}")
    return _assemble(path, frames, rows, where, "yolo", image_size)


def _read_coco(path: Path, image_size: tuple[int, int] | None) -> DetectionTable:
    data = _load_json(path)
    frame_of: dict[object, int] = {}
    sizes: set[tuple[int, int]] = set()
    kp_index = _keypoint_index(data, path)
    if isinstance(data, dict):
        anns = data.get("annotations")
        if not isinstance(anns, list):
            raise InputError(f"{path}: a COCO file needs an 'annotations' list")
        images = data.get("images", []) or []
        if not isinstance(images, list):
            raise InputError(f"{path}: 'images' must be a list, got {type(images).__name__}")
        for img in images:
            if not isinstance(img, dict) or not _is_id(img.get("id")):
                raise InputError(f"{path}: every entry of 'images' needs an 'id' (a number "
                                 "or a string)")  # fmt: skip
            if "frame_id" in img:
                frame_of[img["id"]] = _int(img["frame_id"], path, "frame_id")
            elif "file_name" in img and _INT.findall(Path(str(img["file_name"])).stem):
                frame_of[img["id"]] = _frame_number(str(img["file_name"]), str(path))
            else:
                frame_of[img["id"]] = _int(img["id"], path, "image id")
            if "width" in img and "height" in img:
                sizes.add((_side(img["width"], path), _side(img["height"], path)))
    elif isinstance(data, list):
        anns = data
    else:
        raise InputError(f"{path}: expected a COCO dataset (object) or results (list)")
    frames, rows, where = [], [], []
    points: list[np.ndarray] = []
    head_conf: list[float] = []
    for i, a in enumerate(anns):
        here = f"{path}: annotation {i}"
        if not isinstance(a, dict) or "bbox" not in a or "image_id" not in a:
            raise InputError(f"{here}: needs 'image_id' and 'bbox'")
        if frame_of:
            if not _is_id(a["image_id"]) or a["image_id"] not in frame_of:
                raise InputError(f"{here}: image_id {a['image_id']!r} is not in 'images'")
            k = frame_of[a["image_id"]]
        else:
            k = _int(a["image_id"], path, "image_id")
        bb = a["bbox"]
        if not (isinstance(bb, list) and len(bb) == 4):
            raise InputError(f"{here}: bbox must be [x, y, width, height]")
        try:
            x, y, w, h = (_number(v, here, "bbox") for v in bb)
            s = _number(a.get("score", 1.0), here, "score")
        except (TypeError, ValueError, OverflowError):
            raise InputError(f"{here}: non-numeric bbox or score") from None
        frames.append(k)
        rows.append((x, y, w, h, s))
        where.append(here)
        if kp_index is not None:
            points.append(_pose(a, kp_index, (x + w / 2, y + h / 2), here))
            head_conf.append(_number(a.get("head_confidence", 1.0), here, "head_confidence"))
    size = image_size
    if size is None and len(sizes) == 1:
        size = next(iter(sizes))
    table = _assemble(path, frames, rows, where, "coco", size)
    if kp_index is None or not points:
        return table
    info = data.get("info", {}) if isinstance(data, dict) else {}
    ours = info.get("thermoswarm", {}) if isinstance(info, dict) else {}
    length = ours.get("length_px") if isinstance(ours, dict) else None
    if length is not None and not (
        isinstance(length, (int, float)) and not isinstance(length, bool)
        and 0 < length <= MAX_PX
    ):  # fmt: skip
        raise InputError(f"{path}: info.thermoswarm.length_px must be positive, got {length!r}")
    return dataclasses.replace(
        table,
        points=np.stack(points),
        head_confidence=np.clip(np.asarray(head_conf), 0.0, 1.0),
        object_length_px=None if length is None else float(length),
        pose_boxes=bool(isinstance(ours, dict) and ours.get("boxes") == "pose"),
    )


def _keypoint_index(data: object, path: Path) -> list[int] | None:
    """Indices of head, body and tail in the keypoints of the (one) category that
    names them, or None when no category does."""
    if not isinstance(data, dict):
        return None
    cats = data.get("categories", []) or []
    if not isinstance(cats, list):
        raise InputError(f"{path}: 'categories' must be a list, got {type(cats).__name__}")
    for cat in cats:
        names = cat.get("keypoints") if isinstance(cat, dict) else None
        if isinstance(names, list) and all(k in names for k in KEYPOINT_NAMES):
            return [names.index(k) for k in KEYPOINT_NAMES]
    return None


def _number(v: object, here: str, what: str) -> float:
    f = float(v) if isinstance(v, (int, float)) and abs(v) < 1e308 else math.inf
    if isinstance(v, bool) or not math.isfinite(f):
        raise InputError(f"{here}: {what} must be a finite number, got {shown(v)}")
    return f


def _load_json(path: Path) -> object:
    """The parsed JSON of ``path``; every failure a one-line InputError naming it."""
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise InputError(f"{path}: not a JSON file ({e})") from None
    except RecursionError:
        raise InputError(f"{path}: JSON nested too deeply") from None
    except ValueError as e:  # an integer of more than 4,300 digits
        raise InputError(f"{path}: a number too long to read ({str(e)[:80]})") from None
    except OSError as e:
        raise InputError(f"{path}: cannot be read ({e.strerror or e})") from None


def _is_id(v: object) -> bool:
    """A usable image id: a string or a finite number (not a list, a dict or NaN)."""
    num = isinstance(v, (int, float)) and not isinstance(v, bool)
    return isinstance(v, str) or (num and (not isinstance(v, float) or math.isfinite(v)))


def _side(v: object, path: Path) -> int:
    """An image width or height: an integer from 1 to :data:`MAX_PX`."""
    ok = isinstance(v, (int, float)) and not isinstance(v, bool)
    ok = ok and (not isinstance(v, float) or (math.isfinite(v) and v.is_integer()))
    if not ok or not 1 <= v <= MAX_PX:
        raise InputError(
            f"{path}: image width and height must be integers from 1 to {MAX_PX:g}, got {shown(v)}"
        )
    return int(v)


def _pose(a: dict, index: list[int], centre: tuple[float, float], here: str) -> np.ndarray:
    """Head, body, tail (3, 2) px of one annotation; the box centre as the body and
    NaN head and tail when it has no keypoints."""
    pts = np.full((3, 2), np.nan)
    kp = a.get("keypoints")
    if kp is None:
        pts[1] = centre
        return pts
    if not isinstance(kp, list) or len(kp) % 3 or len(kp) < 3 * (max(index) + 1):
        raise InputError(f"{here}: keypoints must be [x, y, v] for every named keypoint")
    for j, i in enumerate(index):
        x, y, v = (_number(q, here, "keypoints") for q in kp[3 * i : 3 * i + 3])
        if v > 0:
            pts[j] = (x, y)
    if not np.all(np.isfinite(pts[1])):
        pts[1] = centre
    return pts


def coco_dataset(
    images: list[dict],
    detections: list[FrameDetections],
    *,
    pad: float,
    length_px: float | None = None,
    description: str = "",
) -> dict:
    """A COCO keypoints dataset of per-image detections (what ``thermoswarm detect``
    writes).

    Parameters
    ----------
    images
        One COCO ``images`` entry per element of ``detections`` (``id``,
        ``file_name``, ``width``, ``height``, and ``frame_id`` for video frames).
    detections
        The detections of each image (px).
    pad
        Half the objects' width (px): boxes of poses are padded by it
        (:meth:`FrameDetections.box_array`).
    length_px
        The objects' length (px), recorded for the tracker.
    description
        ``info.description``.
    """
    anns = []
    for img, d in zip(images, detections, strict=True):
        boxes = d.box_array(pad)
        hc = d.head_confidence
        for j in range(len(d)):
            x, y, w, h = (float(v) for v in boxes[j])
            kp: list[float] = []
            for p in d.points[j]:
                ok = bool(np.all(np.isfinite(p)))
                kp += [float(p[0]), float(p[1]), 2] if ok else [0.0, 0.0, 0]
            ann = {
                "id": len(anns) + 1,
                "image_id": img["id"],
                "category_id": 1,
                "bbox": [x, y, w, h],
                "area": w * h,
                "iscrowd": 0,
                "score": float(d.scores[j]),
                "keypoints": kp,
                "num_keypoints": sum(1 for v in kp[2::3] if v),
            }
            if hc is not None:
                ann["head_confidence"] = float(hc[j])
            anns.append(ann)
    info: dict = {"description": description}
    info["thermoswarm"] = {
        "boxes": "given" if any(d.boxes is not None for d in detections) else "pose"
    }
    if length_px is not None:
        info["thermoswarm"]["length_px"] = float(length_px)
    category = {
        "id": 1,
        "name": "animal",
        "supercategory": "animal",
        "keypoints": list(KEYPOINT_NAMES),
        "skeleton": SKELETON,
    }
    return {"info": info, "images": images, "annotations": anns, "categories": [category]}


def mot_rows(detections: list[FrameDetections], *, pad: float) -> np.ndarray:
    """MOTChallenge detection rows ``frame, -1, left, top, width, height, score, -1,
    -1, -1`` of a video's frames (numbered from 1)."""
    blocks = [np.zeros((0, 10))]
    for k, d in enumerate(detections):
        rows = np.full((len(d), 10), -1.0)
        rows[:, 0] = k + 1
        rows[:, 2:6] = d.box_array(pad)
        rows[:, 6] = d.scores
        blocks.append(rows)
    return np.concatenate(blocks)


def _int(v: object, path: Path, what: str) -> int:
    """A frame number: an integer from 0 to :data:`MAX_FRAME_NUMBER` (NaN, inf, 1e300,
    2**70, a list or a string are one-line errors)."""
    ok = isinstance(v, (int, float)) and not isinstance(v, bool)
    ok = ok and (not isinstance(v, float) or (math.isfinite(v) and v.is_integer()))
    if not ok or not 0 <= v <= MAX_FRAME_NUMBER:
        raise InputError(
            f"{path}: {what} must be an integer frame number, got {shown(v)} (expected 0 "
            f"to {MAX_FRAME_NUMBER})"
        )
    return int(v)


def _assemble(
    path: Path,
    frames: list[int],
    rows: list[tuple[float, ...]],
    where: list[str],
    fmt: str,
    size: tuple[int, int] | None,
) -> DetectionTable:
    fr = np.asarray(frames, dtype=np.int64)
    arr = np.asarray(rows, dtype=np.float64).reshape(-1, 5)
    boxes = arr[:, :4].copy()
    _check_table(str(path), fr, boxes, where)
    if not np.all(np.isfinite(arr[:, 4])):
        raise InputError(f"{where[int(np.argmax(~np.isfinite(arr[:, 4])))]}: non-finite score")
    scores = np.clip(arr[:, 4], 0.0, 1.0)
    return DetectionTable(fr, boxes, scores, str(path), fmt, size)


def _sniff(path: Path) -> str:
    if path.is_dir():
        return "yolo"
    if path.suffix.lower() == ".json":
        return "coco"
    return "mot"


def read_detections(
    path: str | Path,
    *,
    fmt: str | None = None,
    image_size: tuple[int, int] | None = None,
) -> DetectionTable:
    """Read detections; ``fmt`` one of :data:`FORMATS` (default: a folder is
    ``yolo``, a ``.json`` file ``coco``, anything else ``mot``).

    ``image_size`` ``(width, height)`` px: needed by YOLO's normalised boxes; for the
    others it only tells the tracker where objects leave the image.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file or folder")
    fmt = fmt or _sniff(path)
    if fmt not in FORMATS:
        raise InputError(f"unknown detection format {fmt!r}; expected one of {FORMATS}")
    if fmt == "yolo":
        if not path.is_dir():
            raise InputError(f"{path}: YOLO detections are a folder of per-frame .txt files")
        return _read_yolo(path, image_size)
    if path.is_dir():
        raise InputError(f"{path}: a folder; {fmt} detections are one file")
    if fmt == "coco":
        return _read_coco(path, image_size)
    table = _read_mot(path)
    return DetectionTable(table.frames, table.boxes, table.scores, table.source, "mot", image_size)


def parse_image_size(value: str) -> tuple[int, int]:
    """``WIDTHxHEIGHT`` (e.g. ``1920x1080``), or an image or video file to read it from."""
    m = re.fullmatch(r"\s*(\d+)\s*[xX,]\s*(\d+)\s*", value)
    if m:
        w, h = int(m.group(1)), int(m.group(2))
        if w < 1 or h < 1:
            raise InputError(f"--image-size: width and height must be positive, got {value!r}")
        return w, h
    p = Path(value)
    if not p.exists():
        raise InputError(
            f"--image-size: expected WIDTHxHEIGHT or an image/video file, got {value!r}"
        )
    try:
        from PIL import Image

        with Image.open(p) as im:
            return int(im.size[0]), int(im.size[1])
    except Exception:  # not an image PIL reads: try it as a video
        pass
    from thermoswarm.tracking.video import open_video

    src = open_video(p)
    return int(src.size[0]), int(src.size[1])
