"""The training loop: the losses, one optimisation step, the weights' moving average,
the evaluations, the stopping rule and the peak calibration.  Part of
:mod:`thermoswarm.tracking.train.fit`, whose module docstring describes the design (what
a step draws, when the model is evaluated, which model is kept) and whose
:func:`~thermoswarm.tracking.train.fit.train` runs :func:`_loop`."""

from __future__ import annotations

import copy
import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from thermoswarm.tracking import anatomy
from thermoswarm.tracking.train.augment import _Sampler
from thermoswarm.tracking.train.config import TrainConfig
from thermoswarm.tracking.train.data import LabeledFrames
from thermoswarm.tracking.train.validate import ValidationSet, evaluate_detector

__all__ = ["calibrate_peaks"]


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
