"""The kinematics' stage types and their output: the clean samples, the clock and the
step classes that :mod:`thermoswarm.analysis.kinematics` passes from stage to stage, and
the per-step dataset with its settings and data-quality counts (the module docstring of
:mod:`~thermoswarm.analysis.kinematics` lists every variable)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.analysis.exclusions import STEP_BUCKETS, STEP_CLASSES
from thermoswarm.analysis.options import AnalysisOptions, CleanOptions

#: The counters written to ``attrs`` and ``fits.json["data_quality"]``, in order.
DATA_QUALITY_KEYS = (
    "n_individuals",
    "n_individuals_one_sample",
    "n_samples_input",
    "n_samples",
    "n_missing_timestamps",
    "n_decreasing_timestamps",
    "n_duplicate_rows",
    "n_conflicting_duplicates",
    "median_dt",
    "median_dt_min",
    "median_dt_max",
    "n_nonfinite_positions",
    "n_low_confidence",
    "n_held_positions",
    "n_missing_positions",
    "n_gaps",
    "n_interpolated_positions",
    "n_segments",
    "n_segments_smoothed",
    "n_segments_resampled",
    "n_segments_unsmoothed",
    "smooth_window_samples",
    "n_steps_total",
    *STEP_BUCKETS,
    "n_steps_used_regular",
    "n_steps_used_irregular",
    "n_irregular_steps",
    "n_implausible_kept",
    "n_resting_kept",
    "resting_fraction",
    "n_individuals_all_implausible",
    "n_static_tracks",
    "n_zero_speed",
    "n_steering_samples",
    "n_steering_undefined",
    "n_steering_near_wrap",
    "n_stationary_periods",
    "n_stationary_steps",
    "stationary_seconds",
)


@dataclass(frozen=True)
class Samples:
    """The clean stage's output: each individual's samples on rows ``(samples, individuals)``.

    ``T`` holds the times (s, NaN: no sample), ``X`` and ``Y`` the positions (mm, NaN:
    missing), ``input_row`` the input row of each sample (-1: none); ``one_axis`` is
    true when every column of ``T`` is the same clean clock.
    """

    T: np.ndarray
    X: np.ndarray
    Y: np.ndarray
    input_row: np.ndarray
    sample: np.ndarray
    one_axis: bool
    src: str


@dataclass(frozen=True)
class Clock:
    """The steps' durations: ``dt`` (s), each individual's median step ``med`` (s), and
    which steps exist, are regular and are gaps (``(samples - 1, individuals)``)."""

    dt: np.ndarray
    med: np.ndarray
    exists: np.ndarray
    regular: np.ndarray
    gap: np.ndarray


@dataclass(frozen=True)
class Classes:
    """The classify stage's output: the step's bucket ``cls`` (codes of
    :data:`STEP_CLASSES`), its speed (mm/s), the used, stationary and measured-moving
    masks, the implausible-speed threshold per individual (mm/s) and its rule."""

    cls: np.ndarray
    speed: np.ndarray
    used: np.ndarray
    stationary: np.ndarray
    thr: np.ndarray
    rule: dict[str, Any]
    stationary_speed: float


def _polyorder(opts: CleanOptions) -> int:
    return 2 if opts.polyorder is None else int(opts.polyorder)


def steps_dataset(
    ds: xr.Dataset,
    s: Samples,
    clock: Clock,
    X: np.ndarray,
    Y: np.ndarray,
    c: Classes,
    turns: tuple[np.ndarray, np.ndarray, np.ndarray],
    mass: float | None,
) -> xr.Dataset:
    """The per-step dataset on ``(time, individuals)`` (the module docstring's table)."""
    T = s.T
    n_t, n_i = T.shape

    def on_rows(a: np.ndarray, fill: Any, first: bool = False) -> np.ndarray:
        out = np.full((n_t, n_i), fill, dtype=a.dtype)
        if first:
            out[1:-1] = a
        else:
            out[:-1] = a
        return out

    heading, rate, steer_ok = turns
    speed = on_rows(c.speed, np.nan)
    if mass is None:
        energy, e_unit = 0.5 * speed * speed, "mm^2/s^2"
    else:
        energy, e_unit = 0.5 * mass * (speed * 1e-3) ** 2, "J"
    energy = np.where(on_rows(c.used, False), energy, np.nan)
    dims = ("time", "individuals")
    shared = s.one_axis or bool(
        n_i == 1 or np.array_equal(T, np.broadcast_to(T[:, :1], T.shape), equal_nan=True)
    )
    out = xr.Dataset(
        {
            "step_time": (dims, T, {"units": "s", "description": "time of the step's start"}),
            "dt": (dims, on_rows(clock.dt, np.nan), {"units": "s"}),
            "speed": (dims, speed, {"units": "mm/s"}),
            "energy": (dims, energy, {"units": e_unit}),
            "heading": (dims, on_rows(heading, np.nan), {"units": "rad"}),
            "steering_rate": (dims, on_rows(rate, np.nan, first=True), {"units": "rad/s"}),
            "x_mid": (dims, on_rows(0.5 * (X[:-1] + X[1:]), np.nan), {"units": "mm"}),
            "y_mid": (dims, on_rows(0.5 * (Y[:-1] + Y[1:]), np.nan), {"units": "mm"}),
            "step_class": (
                dims,
                on_rows(c.cls, np.int8(-1)),
                {"codes": ",".join(STEP_CLASSES), "no_step": -1},
            ),
            "valid": (dims, on_rows(c.used, False)),
            "steering_valid": (dims, on_rows(steer_ok, False, first=True)),
            "stationary": (dims, on_rows(c.stationary, False)),
            "input_row": (dims, s.input_row, {"description": "input row of the step's start"}),
            "implausible_threshold": (
                ("individuals",),
                np.where(np.isfinite(c.thr), c.thr, np.nan),
                {"units": "mm/s"},
            ),
            "median_dt": (("individuals",), clock.med, {"units": "s"}),
        },
        coords={
            "time": T[:, 0] if shared else np.arange(n_t, dtype=np.float64),
            "individuals": ds["individuals"].values,
        },
    )
    out["time"].attrs.update(
        {"units": "s", "convention": "start of the step"}
        if shared
        else {"description": "sample index; each individual's times are in step_time"}
    )
    out.attrs.update({"energy_unit": e_unit, "clock": "shared" if shared else "per_individual"})
    return out


def _settings_attrs(
    ds: xr.Dataset, opts: AnalysisOptions, c: Classes, clock: str
) -> dict[str, Any]:
    """The options the kinematics ran with, as the dataset's ``attrs`` (``None`` left out)."""
    cl, st, ex = opts.clean, opts.steps, opts.exclude
    params = {
        "energy_unit": "mm^2/s^2" if st.mass is None else "J",
        "clock": clock,
        "mass_kg": st.mass,
        "smooth_s": cl.smooth,
        "polyorder": _polyorder(cl) if cl.smooth is not None else None,
        "min_speed": st.min_speed,
        "max_speed": ex.max_speed,
        "gap_factor": st.gap_factor,
        "regular_tolerance": st.regular_tolerance,
        "max_gap_s": cl.max_gap,
        "stationary_speed": c.stationary_speed,
        "stationary_duration_s": 1.0 if ex.stationary_duration is None
        else ex.stationary_duration,
        "drop_stationary": int(bool(ex.drop_stationary)),
        "min_confidence": cl.min_confidence,
        "min_track_extent": ex.min_track_extent,
        "duplicates": cl.duplicates,
        "held_positions": cl.held_positions,
        "resting_speed": ex.resting_speed,
        "keep_resting": int(bool(ex.keep_resting)),
        "keep_implausible": int(bool(ex.keep_implausible)),
        "implausible_rule": json.dumps(c.rule),
        "keypoint": cl.keypoint,
        "source_file": ds.attrs.get("source_file"),
        "source_software": ds.attrs.get("source_software"),
    }  # fmt: skip
    return {k: v for k, v in params.items() if v is not None}


def data_quality(kin: xr.Dataset) -> dict[str, Any]:
    """The data-quality counts of a kinematics dataset, as a plain dict.

    ``step_buckets`` repeats the bucket counts by name; they sum to ``n_steps_total``.
    """
    out: dict[str, Any] = {}
    for k in DATA_QUALITY_KEYS:
        v = kin.attrs.get(k, 0)
        out[k] = float(v) if isinstance(v, float | np.floating) else int(v)
    out["step_buckets"] = {c: out[k] for c, k in zip(STEP_CLASSES, STEP_BUCKETS, strict=True)}
    return out
