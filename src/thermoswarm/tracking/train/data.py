"""Labelled frames for training the U-Net + pose model (:class:`LabeledFrames`) and the
SLEAP ``.slp`` and COCO keypoint readers; synthetic training frames are in
:mod:`thermoswarm.tracking.train.synthetic`.  Part of :mod:`thermoswarm.tracking.train.fit`."""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.errors import InputError

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
        where a point is not labelled (the body point is always known).
    px_per_mm
        Scale of the images.
    source
        Where they came from (for reports).
    ignore
        Per frame ``(m, 2)`` px: centres of ants that are in the image but not
        labelled (a SLEAP frame's predicted instances that no user instance covers, an
        ant whose body point is unlabelled).  Training does not teach "no ant" within
        half a body length of them and evaluation counts no false positive there.
        ``None``: none anywhere.
    keys
        Per frame ``(video, frame index)`` in the source, or ``None``.
    tracks
        Per frame ``(n,)`` track numbers of the labelled ants (-1: none), or ``None``.
    """

    frames: list[np.ndarray]
    points: list[np.ndarray]
    px_per_mm: float
    source: str = ""
    ignore: list[np.ndarray] | None = None
    keys: list[tuple[int, int]] | None = None
    tracks: list[np.ndarray] | None = None

    def __post_init__(self) -> None:
        n = len(self.frames)
        if len(self.points) != n:
            raise ValueError("frames and points must have the same length")
        for name in ("ignore", "keys", "tracks"):
            v = getattr(self, name)
            if v is not None and len(v) != n:
                raise ValueError(f"{name} must have one entry per frame")
        if self.ignore is not None:
            self.ignore = [np.asarray(g, dtype=np.float64).reshape(-1, 2) for g in self.ignore]

    @property
    def n_instances(self) -> int:
        return int(sum(p.shape[0] for p in self.points))

    @property
    def n_ignored(self) -> int:
        return 0 if self.ignore is None else int(sum(g.shape[0] for g in self.ignore))

    def ignore_at(self, i: int) -> np.ndarray:
        """Centres ``(m, 2)`` of the unlabelled ants of frame ``i``."""
        return np.zeros((0, 2)) if self.ignore is None else self.ignore[i]

    def __len__(self) -> int:
        return len(self.frames)

    def subset(self, idx: Sequence[int]) -> LabeledFrames:
        def pick(v: list | None) -> list | None:
            return None if v is None else [v[i] for i in idx]

        return LabeledFrames(
            [self.frames[i] for i in idx],
            [self.points[i] for i in idx],
            self.px_per_mm,
            self.source,
            pick(self.ignore),
            pick(self.keys),
            pick(self.tracks),
        )

    def rescaled(self, px_per_mm: float) -> LabeledFrames:
        """The frames resized to another scale (px per mm), points mapped with them."""
        from thermoswarm.tracking.detect.unet import to_model_scale

        ratio = px_per_mm / self.px_per_mm
        if abs(ratio - 1) < 1e-6:
            return self
        frames, points, ignore = [], [], []
        for i, (f, p) in enumerate(zip(self.frames, self.points, strict=True)):
            g, (fx, fy) = to_model_scale(f, ratio)
            q = p.copy()
            q[..., 0] = (q[..., 0] + 0.5) * fx - 0.5
            q[..., 1] = (q[..., 1] + 0.5) * fy - 0.5
            r = self.ignore_at(i).copy()
            r[..., 0] = (r[..., 0] + 0.5) * fx - 0.5
            r[..., 1] = (r[..., 1] + 0.5) * fy - 0.5
            frames.append(g)
            points.append(q)
            ignore.append(r)
        return LabeledFrames(
            frames,
            points,
            px_per_mm,
            self.source,
            None if self.ignore is None else ignore,
            self.keys,
            self.tracks,
        )

    @staticmethod
    def concat(parts: Sequence[LabeledFrames]) -> LabeledFrames:
        if not parts:
            raise InputError("no training data")
        scale = parts[0].px_per_mm
        out = LabeledFrames([], [], scale, " + ".join(p.source for p in parts))
        ignore: list[np.ndarray] = []
        for p in parts:
            p = p.rescaled(scale)
            out.frames.extend(p.frames)
            out.points.extend(p.points)
            ignore.extend(p.ignore_at(i) for i in range(len(p)))
        if any(p.ignore is not None for p in parts):
            out.ignore = ignore
        return out


# --------------------------------------------------------------- labelled sources

#: Nodes averaged into the body point when the skeleton has no body node by name:
#: every node whose name contains one of these (e.g. UpperThorax and LowerThorax, the
#: two ends of the mesosoma, whose midpoint is its centre).
BODY_PARTS: tuple[str, ...] = ("thorax", "mesosoma")


def _norm(name: str) -> str:
    """A node name without case, spaces, underscores, hyphens and dots
    (``"Upper Thorax"`` and ``"upper_thorax"`` are ``"upperthorax"``)."""
    return "".join(ch for ch in name.lower() if ch not in " _-.")


@dataclass(frozen=True)
class NodeMap:
    """Which skeleton nodes give head, body and tail: each a tuple of node indices
    whose mean is the point (NaN if any of them is unlabelled)."""

    roles: tuple[tuple[int, ...], tuple[int, ...], tuple[int, ...]]
    text: str

    def apply(self, xy: np.ndarray) -> np.ndarray:
        """``(K, 2)`` node positions -> ``(3, 2)`` head, body, tail."""
        return np.stack([xy[list(r)].mean(axis=0) for r in self.roles])


def _find(names: Sequence[str], want: str, where: str) -> int:
    low = [n.lower() for n in names]
    if want.lower() in low:
        return low.index(want.lower())
    hits = [i for i, n in enumerate(names) if _norm(n) == _norm(want)]
    if len(hits) == 1:
        return hits[0]
    raise InputError(
        f"{where}: skeleton has no node {want!r}"
        + (" (several match it)" if hits else "")
        + "; its nodes are: "
        + ", ".join(names)
    )


def node_map(names: Sequence[str], nodes: Sequence[str] | None, where: str) -> NodeMap:
    """The :class:`NodeMap` of a skeleton with node ``names``.

    ``nodes``: three entries for head, body and tail, each a node name or names joined
    by ``+`` (their mean, e.g. ``UpperThorax+LowerThorax``); names match without case,
    spaces, underscores and hyphens when no exact (case-blind) match exists.  Default:
    by name, :data:`NODE_ALIASES`; a skeleton without a body node by name takes the
    mean of its nodes named like :data:`BODY_PARTS`.
    """
    names = [str(n) for n in names]
    roles: list[tuple[int, ...]] = []
    if nodes is not None:
        if len(nodes) != 3:
            raise InputError(f"nodes must name head, body and tail (3 names), got {list(nodes)}")
        for entry in nodes:
            parts = [q.strip() for q in str(entry).split("+")]
            if not all(parts):
                raise InputError(f"nodes: empty node name in {entry!r}")
            roles.append(tuple(_find(names, q, where) for q in parts))
    else:
        for role, aliases in zip(("head", "body", "tail"), NODE_ALIASES, strict=True):
            hit = [i for i, n in enumerate(names) if n.lower() in aliases]
            if not hit:
                hit = [i for i, n in enumerate(names) if _norm(n) in aliases]
            if hit:
                roles.append((hit[0],))
                continue
            if role == "body":
                parts = [i for i, n in enumerate(names) if any(b in _norm(n) for b in BODY_PARTS)]
                if parts:
                    roles.append(tuple(parts))
                    continue
            raise InputError(
                f"{where}: no {role} node among {', '.join(names)} "
                f"(expected one of {', '.join(aliases)}); name them with "
                "--nodes HEAD,BODY,TAIL ('+' averages nodes, e.g. "
                "Head,UpperThorax+LowerThorax,Abdomen)"
            )
    text = ", ".join(
        f"{role}={'+'.join(names[i] for i in r)}"
        for role, r in zip(("head", "body", "tail"), roles, strict=True)
    )
    return NodeMap((roles[0], roles[1], roles[2]), text)


def _centre(pts: np.ndarray, every: np.ndarray) -> np.ndarray | None:
    """Where an unlabelled ant is: the mean of its known head/body/tail, else of all
    its known nodes; None if nothing of it is known."""
    for q in (pts, every):
        q = q[np.all(np.isfinite(q), axis=-1)]
        if q.shape[0]:
            return q.mean(axis=0)
    return None


def _extent(every: np.ndarray) -> float:
    """Largest distance between two labelled nodes of an instance (px)."""
    q = every[np.all(np.isfinite(every), axis=-1)]
    if q.shape[0] < 2:
        return 0.0
    return float(np.max(np.linalg.norm(q[:, None] - q[None], axis=-1)))


def _same_ant(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    """Whether two instances of one skeleton are one ant: their nodes known in both
    are on average within ``tol`` px."""
    if a.shape != b.shape or tol <= 0:
        return False
    d = np.linalg.norm(a - b, axis=-1)
    d = d[np.isfinite(d)]
    return bool(d.size) and float(d.mean()) <= tol


def _video_name(filename: str) -> str:
    """The file name of a video path written on any system (``C:\\a\\b.mp4`` -> b.mp4)."""
    from pathlib import PureWindowsPath

    return PureWindowsPath(filename).name if "\\" in filename else Path(filename).name


def _find_videos(labels: Any, path: Path, search: Sequence[Path]) -> None:
    """Point videos whose stored path does not exist here at a file of the same name in
    one of the ``search`` folders (SLEAP files store absolute paths of the labeller's
    machine, e.g. ``D:/Downloads/Col218.mp4``)."""
    for video in labels.videos:
        name = video.filename
        if not isinstance(name, str) or Path(name).exists():
            continue
        base = _video_name(name)
        for folder in search:
            cand = folder / base
            if cand.is_file():
                video.replace_filename(str(cand))
                break


def _open_slp(path: Path, image_root: str | os.PathLike | None) -> Any:
    """The SLEAP labels of ``path``, their missing videos looked for by name in
    ``image_root`` and beside the file."""
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
    search = ([Path(image_root)] if image_root is not None else []) + [path.parent]
    _find_videos(labels, path, search)
    return labels


def _slp_instances(
    users: list[Any],
    preds: list[Any],
    mapped: Callable[[Any], tuple[np.ndarray, np.ndarray]],
    track_no: dict[int, int],
) -> tuple[list[np.ndarray], list[int], list[np.ndarray]]:
    """One frame's labelled ants (head, body, tail), their track numbers and the
    centres of its ``ignore`` regions (see :func:`read_slp`)."""
    pts, trk, ign = [], [], []
    covers = []
    for inst in users or preds:
        p, every = mapped(inst)
        covers.append((every, _extent(every)))
        if np.all(np.isfinite(p[1])):
            pts.append(p)
            trk.append(track_no.get(id(inst.track), -1) if inst.track is not None else -1)
        elif (c := _centre(p, every)) is not None:
            ign.append(c)
    if users:
        for inst in preds:
            p, every = mapped(inst)
            c = _centre(p, every)
            if c is None:
                continue
            dup = any(_same_ant(every, u, 0.15 * r) for u, r in covers)
            if not dup:
                ign.append(c)
    return pts, trk, ign


def _slp_image(lf: Any, path: Path) -> np.ndarray:
    """The RGB image of a SLEAP labelled frame."""
    try:
        img = np.asarray(lf.image)
    except Exception as exc:
        raise InputError(
            f"{path}: image of frame {lf.frame_idx} of {lf.video.filename} cannot be "
            f"read ({type(exc).__name__}); embed the images (a .pkg.slp) or put the "
            f"video {_video_name(str(lf.video.filename))!r} beside the labels "
            "(or in --image-root)"
        ) from None
    if img is None or img.ndim not in (2, 3):
        raise InputError(f"{path}: frame {lf.frame_idx} has no image")
    return _rgb(img)


def read_slp(
    path: str | os.PathLike,
    *,
    px_per_mm: float,
    nodes: Sequence[str] | None = None,
    image_root: str | os.PathLike | None = None,
    include_predicted: bool = False,
) -> LabeledFrames:
    """Labelled frames of a SLEAP ``.slp`` file (images embedded or in readable videos).

    Frames with user-labelled instances are used; a frame's predicted instances that
    repeat no user instance (their nodes are on average farther from those of every
    user instance than 0.15 of its extent) are ants the labeller left out: they become
    ``ignore`` regions.  Frames with predicted
    instances only are skipped unless ``include_predicted`` (then the predictions are
    the labels).  Videos missing at their stored path are looked for by file name in
    ``image_root`` and beside the ``.slp`` file.  An instance without its body point is
    an ``ignore`` region, not background.
    """
    path = Path(path)
    labels = _open_slp(path, image_root)
    frames: list[np.ndarray] = []
    points: list[np.ndarray] = []
    ignore: list[np.ndarray] = []
    keys: list[tuple[int, int]] = []
    tracks: list[np.ndarray] = []
    cache: dict[int, NodeMap] = {}
    track_no = {id(t): k for k, t in enumerate(labels.tracks)}
    video_no = {id(v): k for k, v in enumerate(labels.videos)}
    n_pred_only = 0
    maps: set[str] = set()

    def mapped(inst: Any) -> tuple[np.ndarray, np.ndarray]:
        sk = inst.skeleton
        if id(sk) not in cache:
            cache[id(sk)] = node_map(sk.node_names, nodes, str(path))
            maps.add(cache[id(sk)].text)
        every = np.asarray(inst.numpy(), dtype=np.float64)[:, :2]
        return cache[id(sk)].apply(every), every

    for lf in labels.labeled_frames:
        users = list(lf.user_instances)
        preds = list(lf.predicted_instances)
        if not users and preds and not include_predicted:
            n_pred_only += 1
            continue
        if not (users or preds):
            continue
        pts, trk, ign = _slp_instances(users, preds, mapped, track_no)
        frames.append(_slp_image(lf, path))
        points.append(np.asarray(pts, dtype=np.float64).reshape(-1, 3, 2))
        ignore.append(np.asarray(ign, dtype=np.float64).reshape(-1, 2))
        keys.append((video_no.get(id(lf.video), 0), int(lf.frame_idx)))
        tracks.append(np.asarray(trk, dtype=np.int64))
    if not frames:
        more = (
            f" ({n_pred_only} frames hold predicted instances only; pass --predicted "
            "to train on predictions)"
            if n_pred_only
            else ""
        )
        raise InputError(f"{path}: no labelled frames{more}")
    source = f"SLEAP {path.name} ({'; '.join(sorted(maps))})"
    if n_pred_only:
        source += f", {n_pred_only} frames with predictions only skipped"
    return LabeledFrames(
        frames, points, float(px_per_mm), source, ignore, keys, tracks if labels.tracks else None
    )


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


def _coco_doc(path: Path) -> dict[str, Any]:
    """The COCO document of ``path``: a JSON object with lists of images, annotations
    and categories."""
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
    return doc


def _coco_categories(
    doc: dict[str, Any], nodes: Sequence[str] | None, path: Path
) -> dict[int, NodeMap]:
    """The :class:`NodeMap` of each category that defines keypoints, by category id."""
    cats: dict[int, NodeMap] = {}
    for cat in doc["categories"]:
        try:
            names = cat.get("keypoints")
            if names:
                cats[int(cat["id"])] = node_map([str(n) for n in names], nodes, str(path))
        except (KeyError, TypeError, ValueError, AttributeError):
            raise InputError(f"{path}: malformed category {cat!r:.80}") from None
    if not cats:
        raise InputError(f"{path}: no category defines keypoints")
    return cats


def _coco_annotations(
    doc: dict[str, Any], cats: dict[int, NodeMap], path: Path
) -> tuple[dict[int, list[np.ndarray]], dict[int, list[np.ndarray]]]:
    """Per image id, the labelled ants (head, body, tail) and the centres of the
    ``ignore`` regions (see :func:`read_coco`)."""
    by_image: dict[int, list[np.ndarray]] = {}
    ign_image: dict[int, list[np.ndarray]] = {}
    for i, ann in enumerate(doc["annotations"]):
        try:
            cid = int(ann["category_id"])
            if cid not in cats:
                continue
            kp = np.asarray(ann.get("keypoints") or [], dtype=np.float64).reshape(-1, 3)
            img_id = int(ann["image_id"])
            bbox = ann.get("bbox")
            box = None if not bbox else np.asarray(bbox, dtype=np.float64).reshape(4)
            crowd = bool(ann.get("iscrowd", 0))
        except (KeyError, TypeError, ValueError):
            raise InputError(f"{path}: annotation {i} is malformed") from None
        nm = cats[cid]
        need = max(max(r) for r in nm.roles)
        every = np.where(kp[:, 2:3] > 0, kp[:, :2], np.nan) if kp.size else np.zeros((0, 2))
        if kp.shape[0] and need >= kp.shape[0]:
            raise InputError(f"{path}: annotation {i} has {kp.shape[0]} keypoints, too few")
        xy = nm.apply(every) if kp.shape[0] else np.full((3, 2), np.nan)
        if not crowd and np.all(np.isfinite(xy[1])):
            by_image.setdefault(img_id, []).append(xy)
            continue
        c = _centre(xy, every)
        if c is None and box is not None and np.all(np.isfinite(box)):
            c = box[:2] + box[2:] / 2
        if c is not None:
            ign_image.setdefault(img_id, []).append(c)
    return by_image, ign_image


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
    categories that define ``keypoints`` are used.  An annotation without its body
    point (or with no keypoint at all, or ``iscrowd``) is an ``ignore`` region at its
    known points, else at its box's centre.
    """
    import cv2

    path = Path(path)
    doc = _coco_doc(path)
    root = Path(image_root) if image_root is not None else path.parent
    cats = _coco_categories(doc, nodes, path)
    by_image, ign_image = _coco_annotations(doc, cats, path)
    frames: list[np.ndarray] = []
    points: list[np.ndarray] = []
    ignore: list[np.ndarray] = []
    keys: list[tuple[int, int]] = []
    for im in doc["images"]:
        try:
            img_id, name = int(im["id"]), str(im["file_name"])
        except (KeyError, TypeError, ValueError):
            raise InputError(f"{path}: malformed image entry {im!r:.80}") from None
        if img_id not in by_image and img_id not in ign_image:
            continue
        file = root / name
        bgr = cv2.imread(str(file), cv2.IMREAD_COLOR) if file.is_file() else None
        if bgr is None:
            raise InputError(f"{path}: image {file} is missing or unreadable")
        frames.append(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
        points.append(np.asarray(by_image.get(img_id, []), dtype=np.float64).reshape(-1, 3, 2))
        ignore.append(np.asarray(ign_image.get(img_id, []), dtype=np.float64).reshape(-1, 2))
        keys.append((0, img_id))
    if not frames:
        raise InputError(f"{path}: no image has keypoint annotations")
    maps = "; ".join(sorted({m.text for m in cats.values()}))
    return LabeledFrames(
        frames, points, float(px_per_mm), f"COCO {path.name} ({maps})", ignore, keys
    )


def read_labels(
    path: str | os.PathLike,
    *,
    px_per_mm: float,
    nodes: Sequence[str] | None = None,
    image_root: str | os.PathLike | None = None,
    include_predicted: bool = False,
) -> LabeledFrames:
    """:func:`read_slp` for ``.slp`` files, :func:`read_coco` for ``.json`` files."""
    p = Path(path)
    if p.suffix.lower() == ".slp":
        return read_slp(
            p,
            px_per_mm=px_per_mm,
            nodes=nodes,
            image_root=image_root,
            include_predicted=include_predicted,
        )
    if p.suffix.lower() == ".json":
        return read_coco(p, px_per_mm=px_per_mm, image_root=image_root, nodes=nodes)
    raise InputError(f"{p}: unknown label format (expected .slp or COCO .json)")


# ---------------------------------------------------------------- augmentation
