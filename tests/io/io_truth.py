"""Ground truth for the reader tests: known pixel positions, names and scores."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

#: Scale used by every pixel-based fixture (the paper's preset).
SCALE = 3.04
FPS = 25.0


@dataclass(frozen=True)
class Truth:
    """Known positions in pixels ``(time, 2, keypoints, individuals)`` and scores."""

    px: np.ndarray
    conf: np.ndarray
    individuals: list[str]
    keypoints: list[str]
    fps: float = FPS

    @property
    def n_t(self) -> int:
        return self.px.shape[0]

    @property
    def mm(self) -> np.ndarray:
        return self.px / SCALE

    @property
    def times(self) -> np.ndarray:
        return np.arange(self.n_t) / self.fps

    def centroid_only(self) -> Truth:
        return Truth(
            self.px[:, :, :1, :],
            self.conf[:, :1, :],
            self.individuals,
            self.keypoints[:1],
            self.fps,
        )


def assert_tracks(
    ds: xr.Dataset,
    mm: np.ndarray,
    times: np.ndarray,
    individuals: list[str],
    keypoints: list[str],
    conf: np.ndarray | None = None,
) -> None:
    """``ds`` holds exactly these positions (mm), times (s), names and scores."""
    assert ds["position"].dims == ("time", "space", "keypoints", "individuals")
    assert ds.attrs["space_unit"] == "mm"
    assert ds.attrs.get("time_unit", "seconds") == "seconds"
    assert [str(v) for v in ds["individuals"].values] == list(individuals)
    assert [str(v) for v in ds["keypoints"].values] == list(keypoints)
    np.testing.assert_allclose(ds["time"].values, times, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(ds["position"].values, mm, rtol=1e-12, atol=0)
    assert np.array_equal(np.isnan(ds["position"].values), np.isnan(mm))
    if conf is None:
        assert "confidence" not in ds
    else:
        np.testing.assert_allclose(ds["confidence"].values, conf, rtol=1e-6)
        assert np.array_equal(np.isnan(ds["confidence"].values), np.isnan(conf))
