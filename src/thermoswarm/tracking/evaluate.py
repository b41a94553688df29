"""CLEAR-MOT and identity metrics (MOTA, MOTP, IDF1, ...) of a tracker against ground truth.

Our own implementation on :func:`scipy.optimize.linear_sum_assignment`, following the
definitions of TrackEval (Luiten et al.; ``trackeval.metrics.CLEAR`` and ``Identity``)
so that the numbers are TrackEval's: the same counts, the same floats (the tests check
them to 1e-12, ``benchmarks/*.py --check-trackeval`` to 1e-9).  We do not use
``motmetrics`` (its last release calls ``np.asfarray``, removed in NumPy 2).

Matching (per frame): similarity is the IoU of MOT boxes; a ground-truth object and a
prediction may match when IoU >= ``iou``.  Among those, pairs that continue the
previous frame's match get priority, then the assignment maximises total IoU
(TrackEval's ``1000 * continuing + IoU`` score).  The IoU is computed in TrackEval's
arithmetic, bit for bit (:func:`_iou`), and a frame's rows are taken in the tables'
order, as TrackEval reads a file: assignments that tie exactly (two ground-truth
objects on one box) are broken by the Hungarian step on the last bits.  An identity
switch is counted when a ground-truth object is matched to a different predicted id
than the last time it was matched (however long ago).  Identity metrics (IDF1, IDP,
IDR) come from the one global one-to-one assignment of ground-truth ids to predicted
ids that maximises the number of frames where the pair overlaps by IoU >= ``iou``.

Ground-truth rows with ``conf == 0`` (MOTChallenge "do not consider") are ignored, as
are predictions that match a ground-truth row of a distractor class (2, 7, 8, 12), as
TrackEval's MOT17 preprocessing does.  Class -1 (absent) counts as class 1.  (One
difference on purpose: TrackEval reads ``conf`` as an integer, so it would also ignore
rows with ``0 < |conf| < 1``; we keep them, so that a tracker's output, whose ``conf``
is a score, can be the reference.)

Definitions: ``mota = 1 - (fn + fp + idsw) / n_gt``; ``motp`` = mean IoU of the
matches; ``idsw_rate = idsw / n_gt`` (ID switches per ground-truth detection, the
paper's "ID switch rate"); ``idf1 = 2 idtp / (n_gt + n_pred)``.

HOTA (:func:`_hota`): ``hota``, ``deta``, ``assa`` and ``loca``, each the mean over the
IoU thresholds 0.05, 0.10, ..., 0.95 as TrackEval reports them (independent of
``iou``), TrackEval's sums in TrackEval's order.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from thermoswarm.errors import InputError

__all__ = [
    "evaluate_tables",
    "evaluate_files",
    "frame_offsets",
    "offset_warning",
    "METRIC_KEYS",
    "HOTA_ALPHAS",
]

#: The keys of the result of :func:`evaluate_tables`.
METRIC_KEYS = (
    "mota", "motp", "idf1", "idp", "idr", "idsw", "idsw_rate", "fp", "fn", "tp", "n_gt",
    "n_pred", "n_gt_ids", "n_pred_ids", "n_frames", "precision", "recall", "mt", "pt",
    "ml", "frag", "iou_threshold", "hota", "deta", "assa", "loca",
)  # fmt: skip

#: HOTA's localisation thresholds (TrackEval's ``array_labels``): 0.05, 0.10, ..., 0.95.
HOTA_ALPHAS = np.arange(0.05, 0.99, 0.05)

_DISTRACTORS = (2, 7, 8, 12)
_EPS = np.finfo(float).eps


def _iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU matrix of MOT boxes ``(left, top, width, height)``, in TrackEval's arithmetic
    (``_BaseDataset._calculate_box_ious``): right = left + width, area = (right - left)
    x (bottom - top).  Bit-identical values matter: ground truth with two objects on
    one box makes assignments that tie exactly, which the Hungarian step breaks by the
    last bits (``anatomy.box_iou``'s width x height area differs there by ~1e-15)."""
    a = np.array(a, dtype=np.float64).reshape(-1, 4)
    b = np.array(b, dtype=np.float64).reshape(-1, 4)
    a[:, 2:] += a[:, :2]
    b[:, 2:] += b[:, :2]
    lo = np.minimum(a[:, None, :], b[None, :, :])
    hi = np.maximum(a[:, None, :], b[None, :, :])
    inter = np.maximum(lo[..., 2] - hi[..., 0], 0) * np.maximum(lo[..., 3] - hi[..., 1], 0)
    area_a = (a[:, 2] - a[:, 0]) * (a[:, 3] - a[:, 1])
    area_b = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
    union = area_a[:, None] + area_b[None, :] - inter
    inter[area_a <= _EPS, :] = 0
    inter[:, area_b <= _EPS] = 0
    inter[union <= _EPS] = 0
    union[union <= _EPS] = 1
    return inter / union


def _frames(table: np.ndarray, numbers: np.ndarray) -> list[np.ndarray]:
    """Row indices of each frame number in ``numbers`` (sorted, unique)."""
    f = table[:, 0].astype(np.int64)
    order = np.argsort(f, kind="stable")
    lo = np.searchsorted(f[order], numbers, side="left")
    hi = np.searchsorted(f[order], numbers, side="right")
    return [order[a:b] for a, b in zip(lo, hi, strict=True)]


def _as_table(t: np.ndarray, name: str) -> np.ndarray:
    """A MOT table as ``(n, 10)`` floats (6-column rows get conf 1, the rest -1), with
    integer frames >= 0 spanning at most :data:`~thermoswarm.io.mot.MAX_FRAMES`."""
    from thermoswarm.io.mot import MAX_FRAMES

    t = np.asarray(t, dtype=np.float64)
    if t.size == 0:
        return np.zeros((0, 10))
    if t.ndim != 2 or not 6 <= t.shape[1] <= 10:
        raise InputError(f"{name}: a MOT table has 6 to 10 columns, got shape {t.shape}")
    if t.shape[1] < 10:
        pad = np.full((t.shape[0], 10 - t.shape[1]), -1.0)
        if t.shape[1] == 6:
            pad[:, 0] = 1.0
        t = np.hstack([t, pad])
    f = t[:, 0]
    bad = ~np.isfinite(f) | (f < 0) | (f != np.round(f))
    if bad.any():
        raise InputError(f"{name}: frame {float(f[np.argmax(bad)])!r} is not an integer >= 0")
    if f.max() - f.min() + 1 > MAX_FRAMES:
        raise InputError(
            f"{name}: frames {f.min():.0f} to {f.max():.0f} span more than {MAX_FRAMES:,} frames"
        )
    return t


def _check_unique(table: np.ndarray, name: str) -> None:
    """One row per (frame, id): compared as the numbers themselves, not as one packed
    key (``frame * 2**31 + id`` made frame 1, id 2**31 + 1 look like frame 2, id 1)."""
    if table.shape[0] == 0:
        return
    pairs, counts = np.unique(table[:, :2], axis=0, return_counts=True)
    if np.any(counts > 1):
        frame, ident = pairs[counts > 1][0]
        raise InputError(f"{name}: id {ident:.0f} appears twice in frame {frame:.0f}")


def _hota(
    frames: list[tuple[np.ndarray, np.ndarray, np.ndarray]], n_gid: int, n_pid: int
) -> dict[str, float]:
    """HOTA, DetA, AssA and LocA (Luiten et al. 2021), averaged over :data:`HOTA_ALPHAS`.

    ``frames``: per frame the relabelled gt ids, predicted ids and their IoU matrix.
    The algorithm of TrackEval's ``HOTA.eval_sequence``, step for step: a global
    alignment score of every id pair (IoU-weighted co-occurrence), per frame a
    Hungarian matching maximising alignment x IoU, then per threshold alpha the
    matches with IoU >= alpha count as TP; AssA averages, over TP, the Jaccard index
    of the matched id pair's whole tracks.
    """
    A = HOTA_ALPHAS.size
    eps = np.finfo(float).eps
    n_gt = sum(g.size for g, _, _ in frames)
    n_pr = sum(p.size for _, p, _ in frames)
    if n_pr == 0 or n_gt == 0:
        return {"hota": 0.0, "deta": 0.0, "assa": 0.0, "loca": 1.0}
    potential = np.zeros((n_gid, n_pid))
    gt_count = np.zeros((n_gid, 1))
    pr_count = np.zeros((1, n_pid))
    for g, p, sim in frames:
        if g.size and p.size:
            denom = sim.sum(0)[None, :] + sim.sum(1)[:, None] - sim
            mask = denom > eps
            s_iou = np.zeros_like(sim)
            s_iou[mask] = sim[mask] / denom[mask]
            potential[g[:, None], p[None, :]] += s_iou
        gt_count[g] += 1
        pr_count[0, p] += 1
    align = potential / (gt_count + pr_count - potential)
    tp, fn, fp, loc = (np.zeros(A) for _ in range(4))
    matches = np.zeros((A, n_gid, n_pid))
    for g, p, sim in frames:
        if g.size == 0 or p.size == 0:
            fp += p.size
            fn += g.size
            continue
        r, c = linear_sum_assignment(-(align[g[:, None], p[None, :]] * sim))
        ms = sim[r, c]
        for a, alpha in enumerate(HOTA_ALPHAS):
            ok = ms >= alpha - eps
            k = int(ok.sum())
            tp[a] += k
            fn[a] += g.size - k
            fp[a] += p.size - k
            if k:
                loc[a] += sum(ms[ok])  # summed in order, as TrackEval
                matches[a, g[r[ok]], p[c[ok]]] += 1
    assa = np.empty(A)
    for a in range(A):
        m = matches[a]
        jac = m / np.maximum(1, gt_count + pr_count - m)
        assa[a] = np.sum(m * jac) / max(1.0, tp[a])
    deta = tp / np.maximum(1, tp + fn + fp)
    loca = np.maximum(1e-10, loc) / np.maximum(1e-10, tp)
    hota = np.sqrt(deta * assa)
    return {
        "hota": float(hota.mean()),
        "deta": float(deta.mean()),
        "assa": float(assa.mean()),
        "loca": float(loca.mean()),
    }


def _per_frame(
    gt: np.ndarray, pred: np.ndarray
) -> tuple[list[tuple[np.ndarray, np.ndarray]], int]:
    """The evaluated rows of each frame ``(gt rows, prediction rows)`` and the number of
    frames: ground truth of class 1 and considered; predictions matched to a distractor
    removed (TrackEval's MOT17 preprocessing)."""
    # Frames are counted from 0 when either table has a frame 0, else from 1
    # (MOTChallenge); frames without rows in either table count in n_frames.
    first = 0 if (gt[:, 0].min(initial=1) == 0 or pred[:, 0].min(initial=1) == 0) else 1
    last = int(max(gt[:, 0].max(initial=first - 1), pred[:, 0].max(initial=first - 1)))
    n_frames = last - first + 1
    gt_cls = gt[:, 7].astype(np.int64) if gt.shape[1] > 7 else np.ones(len(gt), np.int64)
    gt_cls = np.where(gt_cls == -1, 1, gt_cls)
    gt_keep = (gt[:, 6] != 0) & (gt_cls == 1)
    distractor = np.isin(gt_cls, _DISTRACTORS)
    # only the frames with rows: an empty frame changes no tally (a clip numbered from
    # 10,000,000 is not walked from frame 0)
    numbers = np.unique(np.concatenate([gt[:, 0], pred[:, 0]]).astype(np.int64))
    gt_rows = _frames(gt, numbers)
    pr_rows = _frames(pred, numbers)
    per_frame = []
    for g, p in zip(gt_rows, pr_rows, strict=True):
        if len(g) and len(p) and distractor[g].any():
            sim = _iou(gt[g, 2:6], pred[p, 2:6])
            score = np.where(sim < 0.5 - _EPS, 0.0, sim)
            r, c = linear_sum_assignment(-score)
            ok = score[r, c] > _EPS
            drop = c[ok][distractor[g][r[ok]]]
            p = np.delete(p, drop)
        g = g[gt_keep[g]]
        per_frame.append((g, p))
    return per_frame, n_frames


def _relabel(ids: np.ndarray, rows: list[np.ndarray]) -> tuple[np.ndarray, int, int]:
    """Ids of the evaluated rows relabelled ``0..n-1`` (-1: not evaluated), with the
    number of distinct ids and of evaluated rows."""
    allrows = np.concatenate(rows) if rows else np.zeros(0, int)
    uid, inv = np.unique(ids[allrows].astype(np.int64), return_inverse=True)
    out = np.full(len(ids), -1, np.int64)
    out[allrows] = inv
    return out, int(uid.size), int(allrows.size)


@dataclass
class _Counts:
    """CLEAR-MOT tallies over the frames, and what the identity and HOTA scores need:
    frames each id is present in, the per-pair count of frames with IoU >= threshold
    (``potential``) and each frame's ids and similarity matrix."""

    gt_count: np.ndarray
    pr_count: np.ndarray
    potential: np.ndarray
    gt_matched: np.ndarray
    frag: np.ndarray
    hota_frames: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)
    tp: int = 0
    fp: int = 0
    fn: int = 0
    idsw: int = 0
    motp_sum: float = 0.0


def _clear_mot(
    gt: np.ndarray,
    pred: np.ndarray,
    per_frame: list[tuple[np.ndarray, np.ndarray]],
    gid: np.ndarray,
    pid: np.ndarray,
    n_gid: int,
    n_pid: int,
    iou: float,
) -> _Counts:
    """Frame-by-frame matching (continuing a previous frame's match first): TP, FP, FN,
    identity switches, fragmentations and MOTP's IoU sum."""
    k = _Counts(np.zeros(n_gid), np.zeros(n_pid), np.zeros((n_gid, n_pid)), np.zeros(n_gid),
                np.zeros(n_gid))  # fmt: skip
    prev_id = np.full(n_gid, -1, np.int64)  # last matched prediction id (any time)
    prev_step = np.full(n_gid, -1, np.int64)  # matched in the previous frame
    for g, p in per_frame:
        gi, pi = gid[g], pid[p]
        k.gt_count[gi] += 1
        k.pr_count[pi] += 1
        if len(g) == 0 or len(p) == 0:
            k.hota_frames.append((gi, pi, np.zeros((len(g), len(p)))))
            k.fp += len(p)
            k.fn += len(g)
            continue
        sim = _iou(gt[g, 2:6], pred[p, 2:6])
        k.hota_frames.append((gi, pi, sim))
        mi, mj = np.nonzero(sim >= iou)
        np.add.at(k.potential, (gi[mi], pi[mj]), 1)
        score = 1000.0 * (pi[None, :] == prev_step[gi][:, None]) + sim
        score[sim < iou - _EPS] = 0.0
        r, c = linear_sum_assignment(-score)
        ok = score[r, c] > _EPS
        r, c = r[ok], c[ok]
        mg, mp = gi[r], pi[c]
        last = prev_id[mg]
        k.idsw += int(np.sum((last >= 0) & (last != mp)))
        k.gt_matched[mg] += 1
        was = prev_step >= 0
        prev_id[mg] = mp
        prev_step[:] = -1
        prev_step[mg] = mp
        k.frag += ~was & (prev_step >= 0)
        k.tp += r.size
        k.fn += len(g) - r.size
        k.fp += len(p) - r.size
        k.motp_sum += float(sum(sim[r, c]))  # summed in order, as TrackEval
    return k


def _id_true_positives(k: _Counts, n_gid: int, n_pid: int, n_gt: int, n_pred: int) -> int:
    """IDTP of one global assignment of ground-truth ids to predicted ids (TrackEval's
    Identity)."""
    if n_gt == 0 or n_pred == 0:
        return 0
    big = n_gid + n_pid
    fp_mat = np.zeros((big, big))
    fn_mat = np.zeros((big, big))
    fp_mat[n_gid:, :n_pid] = 1e10
    fn_mat[:n_gid, n_pid:] = 1e10
    fn_mat[:n_gid, :n_pid] = k.gt_count[:, None]
    fn_mat[np.arange(n_gid), n_pid + np.arange(n_gid)] = k.gt_count
    fp_mat[:n_gid, :n_pid] = k.pr_count[None, :]
    fp_mat[n_gid + np.arange(n_pid), np.arange(n_pid)] = k.pr_count
    fn_mat[:n_gid, :n_pid] -= k.potential
    fp_mat[:n_gid, :n_pid] -= k.potential
    r, c = linear_sum_assignment(fn_mat + fp_mat)
    idfn = int(fn_mat[r, c].sum())
    return int(k.gt_count.sum() - idfn)


def _ratio(a: float, b: float) -> float:
    return float(a) / max(1.0, float(b))


def evaluate_tables(
    gt: np.ndarray,
    pred: np.ndarray,
    *,
    iou: float = 0.5,
    gt_name: str = "ground truth",
    pred_name: str = "prediction",
) -> dict[str, Any]:
    """CLEAR-MOT and identity metrics of MOT tables (rows ``frame, id, box, conf, ...``).

    Parameters
    ----------
    gt, pred
        MOT tables ``(n, 6..10)`` (:func:`thermoswarm.io.mot.read_mot_table`), boxes in
        px; 6-column rows count as considered (``conf`` 1).  Frames are integers from 0
        or 1; both tables are counted from 0 when either has a frame 0.
    iou
        IoU threshold of a match, in (0, 1].

    Returns
    -------
    dict
        The keys of :data:`METRIC_KEYS` (see the module docstring for definitions).
    """
    if not (0 < iou <= 1):
        raise InputError(f"iou must be in (0, 1], got {iou!r}")
    gt = _as_table(gt, gt_name)
    pred = _as_table(pred, pred_name)
    _check_unique(gt, gt_name)
    _check_unique(pred, pred_name)
    per_frame, n_frames = _per_frame(gt, pred)
    gid, n_gid, n_gt = _relabel(gt[:, 1], [g for g, _ in per_frame])
    pid, n_pid, n_pred = _relabel(pred[:, 1], [p for _, p in per_frame])
    k = _clear_mot(gt, pred, per_frame, gid, pid, n_gid, n_pid, iou)
    ratio = k.gt_matched[k.gt_count > 0] / k.gt_count[k.gt_count > 0]
    mt = int(np.sum(ratio > 0.8))
    pt = int(np.sum(ratio >= 0.2)) - mt
    idtp = _id_true_positives(k, n_gid, n_pid, n_gt, n_pred)
    idfn, idfp = n_gt - idtp, n_pred - idtp
    tp, fp, fn, idsw = k.tp, k.fp, k.fn, k.idsw
    return {
        "mota": _ratio(tp - fp - idsw, tp + fn),
        "motp": _ratio(k.motp_sum, tp),
        "idf1": _ratio(idtp, idtp + 0.5 * idfp + 0.5 * idfn),
        "idp": _ratio(idtp, idtp + idfp),
        "idr": _ratio(idtp, idtp + idfn),
        "idsw": idsw,
        "idsw_rate": _ratio(idsw, n_gt),
        "fp": fp,
        "fn": fn,
        "tp": tp,
        "n_gt": n_gt,
        "n_pred": n_pred,
        "n_gt_ids": n_gid,
        "n_pred_ids": n_pid,
        "n_frames": n_frames,
        "precision": _ratio(tp, tp + fp),
        "recall": _ratio(tp, tp + fn),
        "mt": mt,
        "pt": pt,
        "ml": n_gid - mt - pt,
        "frag": int(np.sum(k.frag[k.frag > 0] - 1)),
        "iou_threshold": float(iou),
        **_hota(k.hota_frames, n_gid, n_pid),
    }


def evaluate_files(
    gt_path: str | os.PathLike,
    pred_path: str | os.PathLike,
    *,
    iou: float = 0.5,
    frame_offset: int = 0,
    warnings: list[str] | None = None,
) -> dict[str, Any]:
    """:func:`evaluate_tables` of two MOTChallenge text files.

    An empty prediction file is allowed (everything is a false negative); an empty or
    malformed ground-truth file is an :class:`~thermoswarm.errors.InputError`.
    ``frame_offset``: the prediction's frame ``k + frame_offset`` is scored as the
    ground truth's frame ``k``.  ``warnings``: where given, the files' alignment is
    checked at offsets -2..2 (:func:`frame_offsets`) and :func:`offset_warning`'s
    line, if any, is appended to it.
    """
    from thermoswarm.io.mot import read_mot_table

    gt_path, pred_path = Path(gt_path), Path(pred_path)
    gt = read_mot_table(gt_path, min_frame=0)
    pred = read_mot_table(pred_path, allow_empty=True, min_frame=0)
    if np.any(pred[:, 1] < 0):
        raise InputError(f"{pred_path}: rows with id -1 are detections, not tracks")
    if frame_offset:
        pred = pred.copy()
        pred[:, 0] -= frame_offset
        pred = pred[pred[:, 0] >= 0]
    m = evaluate_tables(gt, pred, iou=iou, gt_name=str(gt_path), pred_name=str(pred_path))
    if warnings is not None:
        line = offset_warning(frame_offsets(gt, pred, iou=iou), iou=iou, given=frame_offset)
        warnings += [line] if line else []
    return m


def frame_offsets(
    gt: np.ndarray, pred: np.ndarray, offsets=(-2, -1, 0, 1, 2), *, iou: float = 0.5
) -> dict[int, float]:
    """For each ``offset``: the share of ground-truth boxes of frame ``f`` that some
    predicted box of frame ``f + offset`` overlaps by IoU >= ``iou``.

    Where the two files count frames from different origins (one from 0, the other
    from 1, as AntTracking's ground truth and its detections do), the prediction
    matches best one frame off, and every score of :func:`evaluate_tables` is
    measured against the wrong frame: for animals that walk, badly (docs/tracking.md,
    "Real ant boxes").  A scene that does not move matches equally at every offset."""
    gt, pred = _as_table(gt, "gt"), _as_table(pred, "pred")
    out: dict[int, float] = {}
    if not len(gt):
        return {int(o): 0.0 for o in offsets}
    frames = np.unique(gt[:, 0].astype(np.int64))
    g_rows = _frames(gt, frames)
    for o in offsets:
        p_rows = _frames(pred, frames + int(o))
        hit = 0
        for g, p in zip(g_rows, p_rows, strict=True):
            if g.size and p.size:
                hit += int(np.count_nonzero(_iou(gt[g, 2:6], pred[p, 2:6]).max(1) >= iou))
        out[int(o)] = hit / len(gt)
    return out


def offset_warning(shares: dict[int, float], *, iou: float = 0.5, given: int = 0) -> str | None:
    """A one-line warning when the prediction matches the ground truth clearly better
    at a frame offset other than 0 (1.25 times the boxes, and 0.1 of all ground-truth
    boxes more), naming the ``--frame-offset`` to pass (``given``: the one already
    applied); None otherwise."""
    at0 = shares.get(0, 0.0)
    best = max(shares, key=lambda o: (shares[o], -abs(o)))
    if best == 0 or shares[best] < 1.25 * at0 or shares[best] - at0 < 0.1:
        return None
    side = "later" if best > 0 else "earlier"
    n = given + best
    shift = f" + {n}" if n > 0 else f" - {-n}" if n < 0 else ""
    return (
        f"PRED matches GT best {abs(best)} frame(s) {side}: {shares[best]:.2f} of the true "
        f"boxes at IoU >= {iou:g} against {at0:.2f} in the same frame; the files may count "
        f"frames from different origins (0 and 1): --frame-offset {n} scores PRED's frame "
        f"k{shift} as GT's frame k"
    )
