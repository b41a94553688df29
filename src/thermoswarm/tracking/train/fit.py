"""Training the top-down detector (:mod:`thermoswarm.tracking.detect.unet`): data and loop.

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
import math
import os
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.config import to_dict
from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_json
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.train.augment import _Sampler
from thermoswarm.tracking.train.config import AugmentConfig, TrainConfig
from thermoswarm.tracking.train.data import (
    NODE_ALIASES,
    LabeledFrames,
    SynthDataConfig,
    read_coco,
    read_labels,
    read_slp,
    synthetic_data,
)
from thermoswarm.tracking.train.validate import (
    ValidationConfig,
    ValidationSet,
    detection_metrics,
    evaluate_detector,
    synthetic_validation,
)

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
    "detection_metrics",
    "train",
    "train_from_sources",
    "NODE_ALIASES",
]


# -------------------------------------------------------------- synthetic source


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
    from thermoswarm.tracking.detect.unet import UNetDetector, find_peaks, to_model_scale

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


def _model_and_data(
    data: LabeledFrames, cfg: TrainConfig, init: str | os.PathLike | None
) -> tuple[Any, LabeledFrames, TrainConfig]:
    """The model to train (new, or the weights of ``init``), the data at its scale and
    the configuration with its model section."""
    from thermoswarm.tracking.detect.unet import TopDownModel, load_model

    if init is not None:
        model = load_model(init)
        mcfg = model.config
    else:
        mcfg = dataclasses.replace(cfg.model, px_per_mm=float(data.px_per_mm))
        model = TopDownModel(mcfg)
    return model, data.rescaled(mcfg.px_per_mm), dataclasses.replace(cfg, model=mcfg)


def _hold_out(
    data: LabeledFrames, cfg: TrainConfig, rng: np.random.Generator
) -> tuple[LabeledFrames, ValidationSet | None]:
    """The training frames and the held-out fraction ``val_fraction`` of them (``None``
    when it rounds to no frame, or to all of them)."""
    n_val = int(round(cfg.val_fraction * len(data)))
    if not (n_val >= 1 and len(data) - n_val >= 1):
        return data, None
    perm = rng.permutation(len(data))
    val_data = data.subset(sorted(perm[:n_val]))
    data = data.subset(sorted(perm[n_val:]))
    validation = ValidationSet(
        val_data.frames,
        val_data.points,
        data.px_per_mm,
        description=f"{n_val} held-out frames of {data.source}",
        ignore=val_data.ignore,
    )
    return data, validation


def _optimiser(model: Any, cfg: TrainConfig) -> tuple[Any, Any]:
    """AdamW over both networks, with a cosine decay to ``lr / 20`` over ``max_steps``."""
    import torch

    opt = torch.optim.AdamW(
        [{"params": list(model.centroid.parameters())}, {"params": list(model.pose.parameters())}],
        lr=cfg.lr,
        weight_decay=cfg.weight_decay,
    )
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(
        opt, T_max=cfg.max_steps, eta_min=cfg.lr / 20
    )
    return opt, sched


def _step(model: Any, sampler: _Sampler, opt: Any, sched: Any, cfg: TrainConfig
          ) -> tuple[float, float]:  # fmt: skip
    """One optimisation step on a centroid batch and a pose batch; their losses."""
    import torch

    from thermoswarm.tracking.detect.unet import soft_argmax

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
    loss_p = (d2 * valid).sum() / nvalid + cfg.variance_weight * (var * valid).sum() / nvalid
    opt.zero_grad(set_to_none=True)
    (loss_c + loss_p).backward()
    opt.step()
    sched.step()
    return loss_c.item(), loss_p.item()


@dataclass
class _Progress:
    """The loop's state: clocks, running losses, evaluations and the best model so far."""

    t_start: float
    c_start: float
    t_train: float = 0.0
    run_c: float | None = None
    run_p: float | None = None
    history: list[dict[str, Any]] = field(default_factory=list)
    best: dict[str, Any] | None = None
    best_state: dict[str, Any] | None = None
    stopped: str = "max_steps"
    n_met: int = 0
    step: int = 0

    def losses(self, lc: float, lp: float) -> None:
        self.run_c = lc if self.run_c is None else 0.95 * self.run_c + 0.05 * lc
        self.run_p = lp if self.run_p is None else 0.95 * self.run_p + 0.05 * lp


def _evaluate(
    ema: Any,
    data: LabeledFrames,
    validation: ValidationSet | None,
    sched: Any,
    st: _Progress,
) -> dict[str, Any]:
    """One evaluation: losses, learning rate, the peak reference measured on the
    training frames and (with ``validation``) the detector's scores."""
    from thermoswarm.tracking.detect.unet import UNetDetector

    entry: dict[str, Any] = {
        "step": st.step,
        "seconds": time.perf_counter() - st.t_start,
        "cpu_seconds": time.process_time() - st.c_start,
        "loss_centroid": st.run_c,
        "loss_pose": st.run_p,
        "lr": float(sched.get_last_lr()[0]),
    }
    ema.config = dataclasses.replace(
        ema.config, peak_reference=calibrate_peaks(ema, data, rng=np.random.default_rng(0))
    )
    if validation is not None:
        det = UNetDetector(ema, px_per_mm=validation.px_per_mm)
        entry.update(evaluate_detector(det, validation))
        entry["seconds_with_eval"] = time.perf_counter() - st.t_start
        entry["cpu_seconds_with_eval"] = time.process_time() - st.c_start
    return entry


def _keep(
    st: _Progress,
    entry: dict[str, Any],
    ema: Any,
    validation: ValidationSet | None,
    cfg: TrainConfig,
) -> bool:
    """Record an evaluation, keep the best model (by validation; the latest without);
    true when the stopping rule (targets met ``target_evals`` times in a row) holds."""
    entry["peak_reference"] = ema.config.peak_reference
    if st.best is None or (validation is not None and _score(entry) > _score(st.best)):
        st.best, st.best_state = entry, copy.deepcopy(ema.state_dict())
    if validation is None:
        st.best, st.best_state = entry, copy.deepcopy(ema.state_dict())
    met = (
        validation is not None
        and validation.mot_gt is not None
        and entry.get("mota", 0) >= cfg.target_mota + cfg.target_margin
        and entry.get("idsw_rate", 1) <= cfg.target_idsw_rate
    )
    st.n_met = st.n_met + 1 if met else 0
    if st.n_met >= cfg.target_evals:
        st.stopped = "target"
        st.best, st.best_state = entry, copy.deepcopy(ema.state_dict())
        return True
    return False


def _loop(
    model: Any,
    ema: Any,
    data: LabeledFrames,
    sampler: _Sampler,
    validation: ValidationSet | None,
    cfg: TrainConfig,
    st: _Progress,
    progress: bool,
    log: Callable[[str], None] | None,
) -> None:
    """The training steps, an evaluation every ``eval_every`` of them and at the end;
    stops at ``max_steps``, at the targets or at ``max_minutes``."""
    opt, sched = _optimiser(model, cfg)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=cfg.max_steps, unit="step", desc="train", disable=None)
    st.t_train = time.perf_counter()
    for step in range(1, cfg.max_steps + 1):
        st.step = step
        st.losses(*_step(model, sampler, opt, sched, cfg))
        _ema_update(ema, model, cfg.ema_decay, step)
        if bar is not None:
            bar.update(1)
            bar.set_postfix(centroid=f"{st.run_c:.4f}", pose=f"{st.run_p:.2f}")
        last = step == cfg.max_steps
        over_time = (
            cfg.max_minutes is not None and time.perf_counter() - st.t_train > 60 * cfg.max_minutes
        )
        if step % cfg.eval_every and not last and not over_time:
            continue
        entry = _evaluate(ema, data, validation, sched, st)
        st.history.append(entry)
        if log is not None:
            log(_log_line(entry))
        if _keep(st, entry, ema, validation, cfg):
            break
        if over_time:
            st.stopped = "max_minutes"
            break
    if bar is not None:
        bar.close()


def _report(
    out: Path,
    st: _Progress,
    data: LabeledFrames,
    sampler: _Sampler,
    validation: ValidationSet | None,
    init: str | os.PathLike | None,
    cfg: TrainConfig,
) -> dict[str, Any]:
    """The training report (keys in ``docs/tracking_unet.md``)."""
    import torch

    return {
        "model": str(out),
        "stopped": st.stopped,
        "target_reached": st.stopped == "target",
        "steps": st.step,
        "seconds": time.perf_counter() - st.t_start,
        "cpu_seconds": time.process_time() - st.c_start,
        "train_seconds": time.perf_counter() - st.t_train,
        "best": st.best,
        "history": st.history,
        "data": {
            "source": data.source,
            "n_frames": len(data),
            "n_instances": data.n_instances,
            "n_crowded_instances": sampler.n_crowded,
            "n_ignored": data.n_ignored,
            "px_per_mm": data.px_per_mm,
        },
        "validation": None if validation is None else validation.description,
        "torch_threads": torch.get_num_threads(),
        "torch_version": torch.__version__,
        "init": None if init is None else str(init),
        "config": to_dict(cfg),
    }


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
    from thermoswarm.tracking.detect.unet import save_model

    cfg = config or TrainConfig()
    out = Path(out)
    if not out.absolute().parent.is_dir():
        raise InputError(f"{out}: parent directory does not exist")
    if len(data) == 0:
        raise InputError("no training frames")
    rng = np.random.default_rng(cfg.seed)
    st = _Progress(time.perf_counter(), time.process_time())
    with _torch_state(cfg.seed, cfg.threads):
        model, data, cfg = _model_and_data(data, cfg, init)
        if validation is None:
            data, validation = _hold_out(data, cfg, rng)
        sampler = _Sampler(data, cfg, rng)
        model.train()
        ema = copy.deepcopy(model).eval()
        for p in ema.parameters():
            p.requires_grad_(False)
        _loop(model, ema, data, sampler, validation, cfg, st, progress, log)
        assert st.best_state is not None and st.best is not None
        model.load_state_dict(st.best_state)
        model.config = dataclasses.replace(model.config, peak_reference=st.best["peak_reference"])
        report = _report(out, st, data, sampler, validation, init, cfg)
        model.eval()
        kept = ("stopped", "target_reached", "steps", "seconds", "best", "data")
        save_model(model, out, info={k: report[k] for k in kept} | {"seed": cfg.seed})
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
    include_predicted: bool = False,
    real_crops: str | os.PathLike | None = None,
    background: str | os.PathLike | None = None,
    roi: str | os.PathLike | None = None,
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
    nodes, image_root, include_predicted
        See :func:`read_labels`.
    init
        Fine-tune this model instead of starting from random weights.
    config
        :class:`TrainConfig`.  The synthetic data are drawn from
        ``numpy.random.default_rng([config.seed, 1])``.
    real_crops, background, roi
        Copy-paste composites (:mod:`thermoswarm.tracking.train.real`, ``config.real``):
        a folder of real ant crops, one sub-folder per individual, pasted on tiles
        of the ``background`` PNG (inside the ``roi`` mask PNG, if given).  The
        individuals are split into training and held-out ones; the held-out ones'
        composites validate when there is no synthetic validation.  Drawn from
        ``numpy.random.default_rng([config.seed, 2])``.
    """
    cfg = config or TrainConfig()
    out = Path(out)
    if not out.absolute().parent.is_dir():
        raise InputError(f"{out}: parent directory does not exist")
    if not synthetic and not labels and real_crops is None:
        raise InputError("no training data: synthetic=False, no label files, no real crops")
    if (real_crops is None) != (background is None):
        raise InputError("real ant crops need a background frame, and a background needs crops")
    if labels and px_per_mm is None:
        raise InputError("labelled images need their scale: px_per_mm")
    if px_per_mm is not None and not (math.isfinite(px_per_mm) and px_per_mm > 0):
        raise InputError(f"px_per_mm must be a positive number, got {px_per_mm!r}")
    if init is not None:
        from thermoswarm.tracking.detect.unet import load_model

        scale = load_model(init).config.px_per_mm
    else:
        scale = px_per_mm if px_per_mm is not None else cfg.model.px_per_mm
    parts = [
        read_labels(
            p,
            px_per_mm=float(px_per_mm),
            nodes=nodes,
            image_root=image_root,
            include_predicted=include_predicted,
        )
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
    if real_crops is not None:
        assert background is not None
        composites, held_out = _real_composites(real_crops, background, roi, cfg, log)
        parts.append(composites)
        if validation is None:
            validation = held_out
    data = LabeledFrames.concat([p.rescaled(scale) for p in parts])
    return train(data, out, cfg, validation=validation, init=init, progress=progress, log=log)


def _real_composites(
    crops_dir: str | os.PathLike,
    background: str | os.PathLike,
    roi: str | os.PathLike | None,
    cfg: TrainConfig,
    log: Callable[[str], None] | None,
) -> tuple[LabeledFrames, ValidationSet | None]:
    """Training composites of the training individuals and a validation set of
    composites of the held-out ones (``None`` when none is held out); one generator,
    ``default_rng([seed, 2])``, draws the split and both sets."""
    from thermoswarm.tracking.train import real as tr

    bg, mask = tr.load_background(background, roi, cfg.real.tile)
    crops = tr.load_crops(crops_dir)
    rng = np.random.default_rng([cfg.seed, 2])
    train_ids, held_ids = tr.split_identities(list(crops), cfg.real.holdout_fraction, rng)
    if log is not None:
        log(
            f"copy-paste: {cfg.real.n_frames} composites of {len(train_ids)} individuals "
            f"(held out: {', '.join(held_ids) or 'none'})"
        )
    data = tr.composite_frames({k: crops[k] for k in train_ids}, bg, mask, cfg.real, rng)
    if not held_ids:
        return data, None
    n_val = max(8, cfg.real.n_frames // 10)
    val = tr.composite_frames(
        {k: crops[k] for k in held_ids}, bg, mask, cfg.real, rng, n_frames=n_val
    )
    validation = ValidationSet(
        val.frames,
        val.points,
        val.px_per_mm,
        description=f"{n_val} composites of held-out individuals {', '.join(held_ids)}",
        ignore=val.ignore,
    )
    return data, validation
