"""What every detector returns and how trained weights are read.

:class:`FrameDetections` (one frame's ants), the :class:`Detector` protocol and the
checked loading of PyTorch weight files.  Detectors (:mod:`thermoswarm.tracking.detect.classical`,
:mod:`thermoswarm.tracking.detect.unet`) import this module; it imports none of them, so the
detector registry in ``detect`` can name ``unet`` without an import cycle.  Units: px of
the full frame.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from thermoswarm.errors import InputError
from thermoswarm.tracking import anatomy

__all__ = ["FrameDetections", "Detector", "load_state_dict", "load_weights", "load_checked"]


@dataclass(frozen=True)
class FrameDetections:
    """The ants found in one frame (all coordinates in px of the full frame)."""

    points: np.ndarray
    scores: np.ndarray
    boxes: np.ndarray | None = None
    head_confidence: np.ndarray | None = None
    hint_index: np.ndarray | None = None

    def __post_init__(self) -> None:
        pts = np.asarray(self.points, dtype=np.float64).reshape(-1, 3, 2)
        n = pts.shape[0]
        sc = np.asarray(self.scores, dtype=np.float64).reshape(-1)
        if sc.shape != (n,):
            raise ValueError(f"scores must have shape ({n},), got {sc.shape}")
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "scores", sc)
        if self.boxes is not None:
            bx = np.asarray(self.boxes, dtype=np.float64).reshape(-1, 4)
            if bx.shape[0] != n:
                raise ValueError(f"boxes must have shape ({n}, 4), got {bx.shape}")
            object.__setattr__(self, "boxes", bx)
        if self.head_confidence is not None:
            hc = np.asarray(self.head_confidence, dtype=np.float64).reshape(-1)
            if hc.shape != (n,):
                raise ValueError(f"head_confidence must have shape ({n},), got {hc.shape}")
            object.__setattr__(self, "head_confidence", hc)
        if self.hint_index is not None:
            hi = np.asarray(self.hint_index, dtype=np.int64).reshape(-1)
            if hi.shape != (n,):
                raise ValueError(f"hint_index must have shape ({n},), got {hi.shape}")
            object.__setattr__(self, "hint_index", hi)

    def __len__(self) -> int:
        return self.points.shape[0]

    @classmethod
    def empty(cls) -> FrameDetections:
        return cls(np.zeros((0, 3, 2)), np.zeros(0))

    def box_array(self, pad: float) -> np.ndarray:
        """MOT boxes ``(n, 4)``: the given ones, else body-centred pose boxes (px)."""
        if self.boxes is not None:
            return self.boxes
        return anatomy.pose_boxes(self.points, pad)

    def subset(self, keep: np.ndarray) -> FrameDetections:
        return FrameDetections(
            self.points[keep],
            self.scores[keep],
            None if self.boxes is None else self.boxes[keep],
            None if self.head_confidence is None else self.head_confidence[keep],
            None if self.hint_index is None else self.hint_index[keep],
        )


@runtime_checkable
class Detector(Protocol):
    """Finds ants in frames given in time order (see the module docstring)."""

    def detect(self, frame: np.ndarray) -> FrameDetections: ...

    def reset(self) -> None: ...


# ------------------------------------------------------------------- model weights


def load_state_dict(path: str | os.PathLike) -> dict[str, Any]:
    """Read a PyTorch state dict with ``torch.load(..., weights_only=True)``.

    A checkpoint ``{"state_dict": {...}, ...}`` is unwrapped.  Raises
    :class:`InputError` naming the file when it is missing, not a weights file, or not
    a mapping of names to tensors.
    """
    path = Path(path)
    try:
        import torch
    except ImportError:
        raise InputError(f"{path}: loading a model needs PyTorch (pip install torch)") from None
    if not path.is_file():
        raise InputError(f"{path}: model file does not exist")
    try:
        obj = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises many types for a bad file
        raise InputError(f"{path}: not a PyTorch weights file ({type(exc).__name__})") from None
    if isinstance(obj, Mapping) and "state_dict" in obj and isinstance(obj["state_dict"], Mapping):
        obj = obj["state_dict"]
    if (
        not isinstance(obj, Mapping)
        or not obj
        or not all(isinstance(k, str) and isinstance(v, torch.Tensor) for k, v in obj.items())
    ):
        raise InputError(f"{path}: expected a state dict (names -> tensors)")
    return dict(obj)


def load_weights(module: Any, path: str | os.PathLike) -> Any:
    """Load a state dict file into ``module`` (a :class:`torch.nn.Module`), strictly.

    Raises :class:`InputError` naming the file and the first missing, unexpected or
    wrongly shaped tensor.  Returns ``module``.
    """
    load_checked(module, load_state_dict(path), path, "a model of this kind")
    return module


def load_checked(module: Any, sd: Mapping[str, Any], path: Any, kind: str) -> None:
    """``module.load_state_dict(sd, strict=True)`` after checking names, shapes and
    finiteness, so that a wrong file is one line naming ``path`` and the first bad
    tensor (``kind`` says what the file should have been) instead of torch's report."""
    import torch

    expected = module.state_dict()
    missing = [k for k in expected if k not in sd]
    unexpected = [k for k in sd if k not in expected]
    if missing:
        raise InputError(
            f"{path}: model file lacks tensor {missing[0]!r} "
            f"({len(missing)} missing); is it {kind}?"
        )
    if unexpected:
        raise InputError(
            f"{path}: model file has unexpected tensor {unexpected[0]!r} "
            f"({len(unexpected)} unexpected); is it {kind}?"
        )
    for k, v in expected.items():
        if tuple(sd[k].shape) != tuple(v.shape):
            raise InputError(
                f"{path}: tensor {k!r} has shape {tuple(sd[k].shape)}, "
                f"the model expects {tuple(v.shape)}"
            )
        if sd[k].is_floating_point() and not torch.isfinite(sd[k]).all():
            raise InputError(f"{path}: tensor {k!r} holds NaN or infinite values")
    module.load_state_dict(sd, strict=True)
