"""The networks of the trained detector: their configuration, the centroid U-Net, the
pose network and the pieces of their outputs that need PyTorch.

:mod:`thermoswarm.tracking.detect.unet` describes the design (its module docstring) and
holds the weights file, the frame-level inference and the detector; this module holds
what a weights file's state dict is loaded into (:class:`TopDownModel`, whose
``centroid.*`` and ``pose.*`` tensor names are the file format) and the differentiable
pieces training shares with inference (:func:`soft_argmax`, :func:`head_side_mass`).
Everything here is re-exported by :mod:`~thermoswarm.tracking.detect.unet`; import it
from there.
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass

if "torch" not in sys.modules:
    # The same default as in thermoswarm.tracking.detect.unet (passive OpenMP waiting on
    # a shared machine), for a program that imports this module first.
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import torch  # noqa: E402
import torch.nn.functional as F  # noqa: E402
from torch import nn  # noqa: E402

from thermoswarm.config import check, check_positive  # noqa: E402
from thermoswarm.tracking import anatomy  # noqa: E402

__all__ = [
    "ModelConfig",
    "CentroidNet",
    "PoseNet",
    "TopDownModel",
    "soft_argmax",
    "head_side_mass",
]


@dataclass(frozen=True)
class ModelConfig:
    """Architecture and image scale of a top-down model (stored with its weights).

    ``px_per_mm``: scale of the images the model was trained on (px per mm); frames of
    other scales are resized to it.  ``input_scale``: the centroid network sees the
    frame resized by this factor, and its confidence map has that resolution (one cell
    = ``1 / input_scale`` px of the frame).  ``centroid_channels``: widths of its three
    levels (at 1/2, 1/4 and 1/8 of its input).  ``sigma_px``: standard deviation (px of
    the frame) of the Gaussian peaks it is trained to produce.  ``crop_size``: side (px
    of the frame, a multiple of 4) of the pose network's crops; it must hold a whole ant
    (at the paper's scale an ant spans 22 px).  ``pose_channels``: widths of the pose
    network's levels (at 1/2, 1/4 and 1/4 of the crop).  ``keypoints``: names of the
    three points, in the order of the tracker's ``head, body, tail``.
    ``peak_reference``: the median confidence-map peak of correctly found ants, measured
    after training (:func:`thermoswarm.tracking.train.loop.calibrate_peaks`); a detection's
    score is its peak divided by it (at most 1), so that a typical correct detection
    scores 1, as the tracker expects (it trusts detections less as their score falls).
    """

    px_per_mm: float = 3.04
    input_scale: float = 0.5
    centroid_channels: tuple[int, int, int] = (16, 32, 64)
    sigma_px: float = 2.0
    crop_size: int = 32
    pose_channels: tuple[int, int, int] = (24, 48, 48)
    keypoints: tuple[str, str, str] = anatomy.KEYPOINTS
    peak_reference: float = 1.0

    def __post_init__(self) -> None:
        check_positive("px_per_mm", self.px_per_mm, "a positive number")
        check(0.1 <= self.input_scale <= 1, "input_scale", "in [0.1, 1]", self.input_scale)
        for name in ("centroid_channels", "pose_channels"):
            v = getattr(self, name)
            check(
                len(v) == 3 and all(1 <= c <= 512 for c in v),
                name,
                "three integers in [1, 512]",
                v,
            )
        check(0.25 <= self.sigma_px <= 20, "sigma_px", "in [0.25, 20] px", self.sigma_px)
        check(
            16 <= self.crop_size <= 256 and self.crop_size % 4 == 0,
            "crop_size",
            "a multiple of 4 in [16, 256] px",
            self.crop_size,
        )
        check(len(set(self.keypoints)) == 3, "keypoints", "three distinct names", self.keypoints)
        check(
            0 < self.peak_reference <= 1,
            "peak_reference",
            "in (0, 1]",
            self.peak_reference,
        )

    @property
    def cell_px(self) -> float:
        """Size of one confidence-map cell in px of the frame (at ``px_per_mm``)."""
        return 1.0 / self.input_scale


# ------------------------------------------------------------------------ networks


def _conv(cin: int, cout: int, stride: int = 1, dilation: int = 1) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv2d(cin, cout, 3, stride, padding=dilation, dilation=dilation, bias=False),
        nn.BatchNorm2d(cout),
        nn.ReLU(inplace=True),
    )


def _up_add(x: torch.Tensor, skip: torch.Tensor) -> torch.Tensor:
    return F.interpolate(x, size=skip.shape[-2:], mode="nearest") + skip


class CentroidNet(nn.Module):
    """Frame (``(B, 3, H, W)``, values 0-1, H and W multiples of 8) -> confidence map
    ``(B, 1, H, W)`` (see :mod:`thermoswarm.tracking.detect.unet`)."""

    def __init__(self, channels: tuple[int, int, int] = (16, 32, 64)) -> None:
        super().__init__()
        c0, c1, c2 = channels
        self.stem = _conv(3, c0, stride=2)
        self.enc0 = _conv(c0, c0)
        self.down1 = _conv(c0, c1, stride=2)
        self.enc1 = _conv(c1, c1)
        self.down2 = _conv(c1, c2, stride=2)
        self.enc2 = _conv(c2, c2, dilation=2)
        self.lat2 = nn.Conv2d(c2, c1, 1)
        self.dec1 = _conv(c1, c1)
        self.lat1 = nn.Conv2d(c1, c0, 1)
        self.dec0 = _conv(c0, c0)
        self.head = nn.Conv2d(c0, 4, 1)
        # Start from "no ant anywhere" (sigmoid 0.01; RetinaNet's prior): training
        # begins at the right background level, and an untrained model finds nothing.
        nn.init.constant_(self.head.bias, -math.log(99.0))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        s0 = self.enc0(self.stem(x - 0.5))
        s1 = self.enc1(self.down1(s0))
        s2 = self.enc2(self.down2(s1))
        d1 = self.dec1(_up_add(self.lat2(s2), s1))
        d0 = self.dec0(_up_add(self.lat1(d1), s0))
        return F.pixel_shuffle(self.head(d0), 2)


class PoseNet(nn.Module):
    """Crops ``(B, 3, C, C)`` (values 0-1) -> keypoint logit maps ``(B, 3, C, C)``.

    A stride-2 stem (the crop's detail enters through its 3x3 kernels), a level at
    1/2 and one at 1/4 of the crop (the latter dilated, to see the whole ant), a
    decoder back to 1/2, and a head predicting 2x2 sub-pixels per cell (pixel shuffle):
    logit maps at the crop's full resolution for about 12 MFLOP per 32 px crop.
    """

    def __init__(self, channels: tuple[int, int, int] = (24, 48, 48)) -> None:
        super().__init__()
        c0, c1, c2 = channels
        self.stem = _conv(3, c0, stride=2)
        self.enc1 = _conv(c0, c0)
        self.down2 = _conv(c0, c1, stride=2)
        self.enc2 = _conv(c1, c2)
        self.enc2b = _conv(c2, c2, dilation=2)
        self.lat2 = nn.Conv2d(c2, c0, 1)
        self.dec1 = _conv(c0, c0)
        self.head = nn.Conv2d(c0, 3 * 4, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        s1 = self.enc1(self.stem(x - 0.5))
        s2 = self.enc2b(self.enc2(self.down2(s1)))
        d1 = self.dec1(_up_add(self.lat2(s2), s1))
        return F.pixel_shuffle(self.head(d1), 2)


def soft_argmax(logits: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Expected position and variance of softmax maps.

    Parameters
    ----------
    logits
        ``(B, K, H, W)``.

    Returns
    -------
    xy, var
        ``(B, K, 2)`` expected ``(x, y)`` in pixel units of the map (pixel centres at
        integers) and ``(B, K)`` the total variance (px^2).
    """
    B, K, H, W = logits.shape
    p = torch.softmax(logits.reshape(B, K, H * W), dim=-1).reshape(B, K, H, W)
    xs = torch.arange(W, dtype=p.dtype, device=p.device)
    ys = torch.arange(H, dtype=p.dtype, device=p.device)
    px = p.sum(2)  # (B, K, W)
    py = p.sum(3)  # (B, K, H)
    mx = (px * xs).sum(-1)
    my = (py * ys).sum(-1)
    var = (px * xs * xs).sum(-1) - mx * mx + (py * ys * ys).sum(-1) - my * my
    return torch.stack([mx, my], -1), var


class TopDownModel(nn.Module):
    """Both networks and their :class:`ModelConfig` (one state dict: ``centroid.*``,
    ``pose.*``)."""

    def __init__(self, config: ModelConfig | None = None) -> None:
        super().__init__()
        self.config = config or ModelConfig()
        self.centroid = CentroidNet(self.config.centroid_channels)
        self.pose = PoseNet(self.config.pose_channels)


def head_side_mass(logits: torch.Tensor, xy: torch.Tensor) -> torch.Tensor:
    """Probability mass of the head's map on the head side of the body point:
    ``(B,)`` in [0, 1] (0.5: head and tail could be swapped)."""
    B, K, H, W = logits.shape
    p = torch.softmax(logits[:, 0].reshape(B, H * W), -1).reshape(B, H, W)
    axis = xy[:, 0] - xy[:, 2]  # tail -> head
    ys, xs = torch.meshgrid(
        torch.arange(H, dtype=p.dtype, device=p.device),
        torch.arange(W, dtype=p.dtype, device=p.device),
        indexing="ij",
    )
    side = (xs[None] - xy[:, 1, 0, None, None]) * axis[:, 0, None, None] + (
        ys[None] - xy[:, 1, 1, None, None]
    ) * axis[:, 1, None, None]
    return (p * (side > 0)).sum((1, 2))
