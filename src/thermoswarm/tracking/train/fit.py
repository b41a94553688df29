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
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.config import to_dict
from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_json
from thermoswarm.tracking import anatomy  # noqa: F401  (read as fit.anatomy)
from thermoswarm.tracking.train.augment import _Sampler
from thermoswarm.tracking.train.config import AugmentConfig, TrainConfig
from thermoswarm.tracking.train.data import (
    NODE_ALIASES,
    LabeledFrames,
    read_coco,
    read_labels,
    read_slp,
)
from thermoswarm.tracking.train.loop import (
    _centroid_loss,  # noqa: F401  (read as fit._centroid_loss)
    _loop,
    _Progress,
    calibrate_peaks,  # noqa: F401  (defined in loop, long documented here)
)
from thermoswarm.tracking.train.synthetic import SynthDataConfig, synthetic_data
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
    _check_sources(out, synthetic, labels, px_per_mm, real_crops, background)
    scale = _model_scale(init, px_per_mm, cfg)
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


def _check_sources(
    out: Path,
    synthetic: bool,
    labels: Sequence[str | os.PathLike],
    px_per_mm: float | None,
    real_crops: str | os.PathLike | None,
    background: str | os.PathLike | None,
) -> None:
    """The one-line errors of :func:`train_from_sources`'s arguments, first one first."""
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


def _model_scale(
    init: str | os.PathLike | None, px_per_mm: float | None, cfg: TrainConfig
) -> float:
    """The scale (px per mm) the model works at: ``init``'s, else the labels', else the
    configured one."""
    if init is not None:
        from thermoswarm.tracking.detect.unet import load_model

        return load_model(init).config.px_per_mm
    return px_per_mm if px_per_mm is not None else cfg.model.px_per_mm


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
