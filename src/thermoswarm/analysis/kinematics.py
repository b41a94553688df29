"""Speed, energy, heading and steering-angle rate from positions, with messy data counted.

Input: the trajectory format (:mod:`thermoswarm.tracks`), on a shared clock or with
each individual on its own clock.  Output: an :class:`xarray.Dataset` on
``(time, individuals)`` where row ``k`` of an individual is the *step* from its
``k``-th sample to its ``k+1``-th, computed from that individual's own consecutive
samples and their real time difference (see ``docs/analysis.md`` for every key):

=================  ==========  =====================================================
variable           unit        meaning of row ``k``
=================  ==========  =====================================================
``step_time``      s           time of the step's first sample
``dt``             s           duration of the step: ``t[k+1] - t[k]``
``speed``          mm/s        ``|x[k+1] - x[k]| / dt`` (NaN: not measured)
``energy``         mm^2/s^2    ``speed^2 / 2`` per unit mass, or ``m v^2 / 2`` in J
                               with ``mass`` (kg); only for steps used in the fits
``heading``        rad         direction of the step, ``atan2(dy, dx)`` in (-pi, pi]
``steering_rate``  rad/s       turn from step ``k-1`` to step ``k``, wrapped into
                               [-pi, pi), divided by the time between the steps'
                               midpoints ``(dt[k-1] + dt[k]) / 2``
``x_mid, y_mid``   mm          midpoint of the step (where regions are looked up)
``step_class``     code        the one bucket the step falls in (``STEP_CLASSES``)
``valid``          bool        the step is used (its energy enters the fits)
``steering_valid`` bool        the steering rate is usable
``stationary``     bool        the step is part of a long stationary period
``input_row``      index       the input row of the step's first sample (-1: none)
=================  ==========  =====================================================

On a shared clock the ``time`` coordinate holds the seconds; with per-individual
clocks it is the sample index (each individual's times are in ``step_time``).

Every step lands in exactly one bucket (``step_class``, counted in ``data_quality``;
the counts sum to ``n_steps_total``), checked in this order:

``missing_position``
    an end's position is missing (NaN, inf, or ``confidence < min_confidence``);
``time_gap``
    longer than ``gap_factor`` times the individual's own median step: an average,
    not an instantaneous, velocity;
``static_track``
    the individual's positions stay within ``min_track_extent`` mm (bounding-box
    diagonal): a static object the tracker followed (debris, a shadow), not an
    animal; off unless ``min_track_extent`` is given;
``over_max_speed``
    faster than ``max_speed``;
``implausible``
    faster than the individual's implausible-motion threshold (identity swaps,
    tracker glitches; :func:`implausible_thresholds`); kept with
    ``keep_implausible``;
``resting``
    speed at or below ``resting_speed`` (default 0: the tracker reports no motion);
    the energy law is about moving animals, so resting steps are left out of the fits
    and their fraction reported; kept with ``keep_resting``;
``stationary_dropped``
    in a long stationary period, with ``drop_stationary``;
``used``
    everything else; ``n_steps_used_regular`` of them lie within
    ``regular_tolerance`` of the individual's median step, ``n_steps_used_irregular``
    do not (each uses its own duration either way).

Before the steps: samples without a time are dropped (``n_missing_timestamps``);
each individual's samples are sorted by time (``n_decreasing_timestamps`` counts the
backward steps); samples at equal times are exact duplicates (dropped,
``n_duplicate_rows``) or conflicts resolved by ``duplicates`` (``"error"``,
``"first"`` or ``"mean"``; ``n_conflicting_duplicates``; readers count theirs too);
missing-position gaps up to ``max_gap`` s are interpolated
(``n_interpolated_positions``); with ``held_positions="missing"``, a sample whose
position repeats the previous one exactly is taken as held by the tracker and missing.

The turn at row ``k`` is paired with the speed of the step that follows it (the
robots' algorithms sample a heading and a speed together, then turn and move).
Velocities are differences of consecutive (optionally smoothed) positions, not central
differences: a central difference averages two steps and would change the very
distribution under test.  Smoothing (``smooth`` seconds): a Savitzky-Golay filter
(:func:`scipy.signal.savgol_filter`) of each contiguous segment, the window the odd
number of samples nearest to ``smooth`` s at the individual's median step; irregular
segments are interpolated onto a regular grid, filtered and interpolated back.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.analysis.exclusions import (
    CODE,
    STEP_BUCKETS,
    STEP_CLASSES,
    excluded_summary,
    implausible_thresholds,
)
from thermoswarm.analysis.options import (
    KEYWORD_SECTIONS,
    AnalysisOptions,
    CleanOptions,
    ExcludeOptions,
    StepOptions,
)
from thermoswarm.analysis.samples import (
    clean_columns,
    interpolate_gaps,
    runs,
    smooth_positions,
)
from thermoswarm.analysis.step_table import (
    DATA_QUALITY_KEYS,
    Classes,
    Clock,
    Samples,
    _polyorder,
    _settings_attrs,
    data_quality,
    steps_dataset,
)
from thermoswarm.errors import ConfigError, InputError
from thermoswarm.tracks import (
    centroid,
    individual_times,
    per_individual,
    validate_tracks,
)

__all__ = [
    "compute_kinematics",
    "clean_samples",
    "step_clock",
    "fill_and_smooth",
    "classify_steps",
    "steering",
    "steps_dataset",
    "data_quality",
    "implausible_thresholds",
    "excluded_summary",
    "DATA_QUALITY_KEYS",
    "STEP_CLASSES",
    "STEP_BUCKETS",
]

#: Largest (samples x individuals) table the kinematics work on: about 170 bytes per
#: cell are held at the peak (positions, steps, energies, flags), so 5e7 cells is
#: about 8.5 GB; above it the analysis refuses at once instead of exhausting memory.
MAX_CELLS = 50_000_000


def _options(options: AnalysisOptions | None, keywords: dict[str, Any]) -> AnalysisOptions:
    """``options`` with the keyword API's flat names applied (``smooth=0.1``, ...)."""
    sections = ("clean", "steps", "exclude")  # and read.fps
    wrong = [k for k in keywords if k != "fps" and KEYWORD_SECTIONS.get(k) not in sections]
    if wrong:
        raise ConfigError(f"compute_kinematics takes no option {wrong[0]!r}")
    return AnalysisOptions.from_keywords(options, **keywords)


def _positions(ds: xr.Dataset, opts: CleanOptions, counts: dict[str, Any]) -> xr.DataArray:
    """Positions of the followed keypoint (or the centroid), low-confidence ones missing."""
    position = ds["position"]
    if opts.min_confidence is not None and "confidence" in ds:
        low = (ds["confidence"] < opts.min_confidence).values
        counts["n_low_confidence"] = int((low & np.isfinite(position.values).all(axis=1)).sum())
        position = position.where(~(ds["confidence"] < opts.min_confidence))
    if opts.keypoint is not None:
        kps = [str(k) for k in ds["keypoints"].values]
        if opts.keypoint not in kps:
            raise InputError(f"keypoint {opts.keypoint!r} not in the data; it has {kps}")
        pos = position.sel(keypoints=opts.keypoint, drop=True)
    else:
        pos = centroid(ds.assign(position=position))
    return pos.transpose("time", "space", "individuals")


def _check_size(src: str, T0: np.ndarray, n_i: int) -> None:
    """Refuse tables above :data:`MAX_CELLS` before they exhaust memory."""
    if T0.shape[0] * n_i > MAX_CELLS:
        n_samples = int(np.isfinite(T0).sum())
        raise InputError(
            f"{src}: {n_i} individuals x {T0.shape[0]} samples (the longest track) is "
            f"{T0.shape[0] * n_i:.3g} cells, above the {MAX_CELLS:.0e} the analysis works "
            f"on ({100 * n_samples / (T0.shape[0] * n_i):.1f} % of them hold samples); "
            "merge fragmented track ids or analyse the recording in parts"
        )


def clean_samples(ds: xr.Dataset, opts: AnalysisOptions, counts: dict[str, Any]) -> Samples:
    """The clean stage: each individual's own samples, sorted, duplicates resolved,
    non-finite and (with ``held_positions = "missing"``) held positions missing.

    ``ds`` is validated first; ``counts`` (the :data:`DATA_QUALITY_KEYS`) is filled in.
    """
    ds = validate_tracks(ds, source=ds.attrs.get("source_file"))
    src = str(ds.attrs.get("source_file") or "the input")
    for k in ("n_duplicate_rows", "n_conflicting_duplicates", "n_decreasing_timestamps"):
        counts[k] = int(ds.attrs.get(k, 0) or 0)  # what the reader sorted and resolved
    pos = _positions(ds, opts.clean, counts)
    names = [str(v) for v in ds["individuals"].values]
    T0 = individual_times(ds, opts.read.fps)
    X = np.asarray(pos.sel(space="x").values, dtype=np.float64)
    Y = np.asarray(pos.sel(space="y").values, dtype=np.float64)
    n_i = X.shape[1]
    counts["n_individuals"] = n_i
    # samples given: every (row, individual) of a shared axis; the timed rows otherwise
    counts["n_samples_input"] = int(np.isfinite(T0).sum() if per_individual(ds) else T0.size)
    nonfinite = (np.isinf(X) | np.isinf(Y)) & ~(np.isnan(X) | np.isnan(Y))
    # with those the reader found (infinite or beyond thermoswarm.io._common.MAX_ABS_MM)
    counts["n_nonfinite_positions"] = int(nonfinite.sum()) + int(
        ds.attrs.get("n_nonfinite_positions", 0) or 0
    )
    if nonfinite.any():
        X = np.where(nonfinite, np.nan, X)
        Y = np.where(nonfinite, np.nan, Y)
    _check_size(src, T0, n_i)
    T, X, Y, input_row = clean_columns(
        T0, X, Y, opts.clean.duplicates, names, src, counts, per_individual(ds)
    )
    # One shared, clean time axis (the common case: a video's frames): every column of T
    # is the same view, so the steps and the median step are computed once.
    one_axis = T is T0 and not per_individual(ds)
    sample = np.isfinite(T)
    n_per = sample.sum(axis=0)
    counts["n_samples"] = int(n_per.sum())
    counts["n_individuals_one_sample"] = int((n_per == 1).sum())
    if not (n_per >= 2).any():
        raise InputError(
            f"{src}: need at least 2 samples of one individual to form a step; the most "
            f"any individual has is {int(n_per.max(initial=0))}"
        )
    if opts.clean.held_positions == "missing":
        held = np.zeros_like(sample)
        held[1:] = sample[1:] & (X[1:] == X[:-1]) & (Y[1:] == Y[:-1])
        counts["n_held_positions"] = int(held.sum())
        X = np.where(held, np.nan, X)
        Y = np.where(held, np.nan, Y)
    return Samples(T, X, Y, input_row, sample, one_axis, src)


def step_clock(s: Samples, opts: StepOptions, counts: dict[str, Any]) -> Clock:
    """The step stage's clock: each step's duration and each individual's median step;
    regular steps (within ``regular_tolerance`` of it) and gaps (over ``gap_factor``)."""
    exists = s.sample[1:] & s.sample[:-1]
    has = exists.any(axis=0)
    med = np.full(s.T.shape[1], np.nan)
    if s.one_axis:
        dt1 = np.diff(s.T[:, 0])
        dt = np.broadcast_to(dt1[:, None], exists.shape)
        med[:] = float(np.median(dt1))
    else:
        with np.errstate(invalid="ignore"):
            dt = np.diff(s.T, axis=0)
        if has.any():
            med[has] = np.nanmedian(np.where(exists[:, has], dt[:, has], np.nan), axis=0)
    meds = med[has]
    counts["median_dt"] = float(np.median(meds))
    counts["median_dt_min"] = float(meds.min())
    counts["median_dt_max"] = float(meds.max())
    with np.errstate(invalid="ignore"):
        regular = exists & (np.abs(dt - med) <= opts.regular_tolerance * med)
        gap = exists & (dt > opts.gap_factor * med)
    counts["n_irregular_steps"] = int((exists & ~regular).sum())
    counts["n_steps_total"] = int(exists.sum())
    return Clock(dt, med, exists, regular, gap)


def fill_and_smooth(
    s: Samples, clock: Clock, opts: CleanOptions, counts: dict[str, Any]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The clean stage's second half, which needs the steps' clock: missing positions
    counted, short gaps interpolated, positions smoothed per contiguous segment.

    Returns ``X``, ``Y`` (mm) and the mask of samples with a position."""
    T, X, Y, sample = s.T, s.X, s.Y, s.sample
    present = sample & np.isfinite(X) & np.isfinite(Y)
    idx = np.arange(T.shape[0])[:, None]
    seen_before = np.maximum.accumulate(np.where(present, idx, -1), axis=0) >= 0
    seen_after = (
        np.minimum.accumulate(np.where(present, idx, T.shape[0])[::-1], axis=0)[::-1] < T.shape[0]
    )
    holes = sample & ~present
    counts["n_missing_positions"] = int(holes.sum())
    counts["n_gaps"] = int(runs(holes & seen_before & seen_after)[0].size)
    if opts.max_gap > 0:
        X, Y = interpolate_gaps(T, X, Y, sample, opts.max_gap, counts)
        present = sample & np.isfinite(X) & np.isfinite(Y)
    if opts.smooth is not None:
        link = present[:-1] & present[1:] & clock.exists & ~clock.gap
        order = int(_polyorder(opts))
        irregular = clock.exists & ~clock.regular
        X, Y = smooth_positions(T, X, Y, link, clock.med, opts.smooth, order, irregular, counts)
    else:
        si, _, _ = runs(present)
        counts["n_segments"] = int(si.size + (present[:-1] & present[1:] & clock.gap).sum())
    return X, Y, present


def _static_tracks(
    X: np.ndarray, Y: np.ndarray, present: np.ndarray, min_extent: float, counts: dict[str, Any]
) -> np.ndarray:
    """Individuals whose positions stay within ``min_extent`` mm (bounding-box diagonal)."""
    n_i = X.shape[1]
    with np.errstate(invalid="ignore"):
        xs, ys = np.where(present, X, np.nan), np.where(present, Y, np.nan)
    ok_cols = present.any(axis=0)
    extent = np.zeros(n_i)
    if ok_cols.any():
        px, py = xs[:, ok_cols], ys[:, ok_cols]
        extent[ok_cols] = np.hypot(
            np.nanmax(px, axis=0) - np.nanmin(px, axis=0),
            np.nanmax(py, axis=0) - np.nanmin(py, axis=0),
        )
    static = ok_cols & (extent < min_extent)
    counts["n_static_tracks"] = int(static.sum())
    return static


def _stationary(
    T: np.ndarray, still: np.ndarray, duration: float, counts: dict[str, Any]
) -> np.ndarray:
    """Steps in runs of ``still`` steps lasting at least ``duration`` s."""
    stationary = np.zeros_like(still)
    si, st, en = runs(still)
    if si.size:
        dur = T[en, si] - T[st, si]  # a run of steps st..en-1 spans samples st..en
        long_ = dur >= duration
        counts["n_stationary_periods"] = int(long_.sum())
        counts["stationary_seconds"] = float(dur[long_].sum())
        for i, a, b in zip(si[long_].tolist(), st[long_].tolist(), en[long_].tolist(),
                           strict=True):  # fmt: skip
            stationary[a:b, i] = True
    counts["n_stationary_steps"] = int(stationary.sum())
    return stationary


def _moving_buckets(
    cls: np.ndarray,
    cand: np.ndarray,
    speed: np.ndarray,
    opts: ExcludeOptions,
    counts: dict[str, Any],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
    """Over-max-speed, implausible and resting steps among the measured ones ``cand``.

    Marks their buckets in ``cls`` (unless kept) and returns the steps still
    candidates, the resting ones among them, and the implausible threshold and rule."""
    if opts.max_speed is not None:
        fast = cand & (speed > opts.max_speed)
        cls[fast] = CODE["over_max_speed"]
        cand = cand & ~fast
    resting = cand & (speed <= opts.resting_speed)
    thr, rule = implausible_thresholds(
        speed, cand & ~resting, factor=opts.implausible_factor, body_length=opts.body_length,
        max_body_lengths_per_s=opts.max_body_lengths_per_s,
    )  # fmt: skip
    implausible = cand & (speed > thr[None, :])
    moving_cand = (cand & ~resting).sum(axis=0)
    all_bad = (moving_cand > 0) & (implausible.sum(axis=0) == moving_cand)
    counts["n_individuals_all_implausible"] = int(all_bad.sum())
    if opts.keep_implausible:
        counts["n_implausible_kept"] = int(implausible.sum())
    else:
        cls[implausible] = CODE["implausible"]
        cand = cand & ~implausible
    resting &= cand
    n_rest = int(resting.sum())
    if opts.keep_resting:
        counts["n_resting_kept"] = n_rest
    else:
        cls[resting] = CODE["resting"]
        cand = cand & ~resting
    return cand, resting, thr, rule


def classify_steps(
    s: Samples,
    clock: Clock,
    X: np.ndarray,
    Y: np.ndarray,
    present: np.ndarray,
    opts: AnalysisOptions,
    counts: dict[str, Any],
) -> Classes:
    """The classify stage: every step in exactly one bucket, in the order of the
    module docstring, each bucket counted in ``counts``."""
    ex = opts.exclude
    exists, gap = clock.exists, clock.gap
    both = exists & present[:-1] & present[1:]
    cls = np.full(clock.dt.shape, -1, dtype=np.int8)
    cls[exists & ~both] = CODE["missing_position"]
    cls[both & gap] = CODE["time_gap"]
    measured = both & ~gap
    if ex.min_track_extent is not None:
        static = _static_tracks(X, Y, present, ex.min_track_extent, counts)
        cls[measured & static[None, :]] = CODE["static_track"]
        measured &= ~static[None, :]
    dx, dy = np.diff(X, axis=0), np.diff(Y, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        speed = np.where(measured, np.hypot(dx, dy) / np.where(measured, clock.dt, 1.0), np.nan)
    cand, resting, thr, rule = _moving_buckets(cls, measured.copy(), speed, ex, counts)
    # Long stationary periods (among measured, plausible steps)
    still_speed = opts.steps.min_speed if ex.stationary_speed is None else ex.stationary_speed
    still_for = 1.0 if ex.stationary_duration is None else ex.stationary_duration
    stationary = _stationary(s.T, (cand | resting) & (speed <= still_speed), still_for, counts)
    if ex.drop_stationary:
        drop = cand & stationary
        cls[drop] = CODE["stationary_dropped"]
        cand &= ~drop
    used = cand
    cls[used] = CODE["used"]
    for c, key in zip(STEP_CLASSES, STEP_BUCKETS, strict=True):
        counts[key] = int((cls == CODE[c]).sum())
    counts["n_steps_used_regular"] = int((used & clock.regular).sum())
    counts["n_steps_used_irregular"] = int((used & ~clock.regular).sum())
    n_rest = int(resting.sum())
    denom = int(used.sum()) + (0 if ex.keep_resting else n_rest)  # plausible measured steps
    counts["resting_fraction"] = float(n_rest / denom) if denom else 0.0
    return Classes(cls, speed, used, stationary, thr, rule, still_speed)


def steering(
    clock: Clock,
    X: np.ndarray,
    Y: np.ndarray,
    c: Classes,
    min_speed: float,
    counts: dict[str, Any],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The step stage's turns: each used step's heading (rad; NaN at or below
    ``min_speed``) and the steering rate (rad/s) between consecutive moving steps.

    Returns the headings, the rates and the mask of usable rates (each one row shorter
    than the steps: row ``k`` is the turn into step ``k + 1``)."""
    used = c.used
    moving = used & (c.speed > min_speed)
    counts["n_zero_speed"] = int((used & ~moving).sum())
    heading = np.where(moving, np.arctan2(np.diff(Y, axis=0), np.diff(X, axis=0)), np.nan)
    dh = heading[1:] - heading[:-1]
    dh = (dh + np.pi) % (2 * np.pi) - np.pi
    mid_dt = 0.5 * (clock.dt[:-1] + clock.dt[1:])
    steer_ok = moving[:-1] & moving[1:]
    counts["n_steering_samples"] = int(steer_ok.sum())
    counts["n_steering_undefined"] = int((used[:-1] & used[1:] & ~steer_ok).sum())
    counts["n_steering_near_wrap"] = int((steer_ok & (np.abs(dh) > 0.9 * np.pi)).sum())
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = np.where(steer_ok, dh / np.where(steer_ok, mid_dt, 1.0), np.nan)
    return heading, rate, steer_ok


def compute_kinematics(
    ds: xr.Dataset, options: AnalysisOptions | None = None, **keywords: Any
) -> xr.Dataset:
    """Kinematics of every step of every track: the clean, step and classify stages.

    Parameters
    ----------
    ds
        Trajectories (positions in mm), on a shared clock or per-individual clocks.
    options
        The analysis options (:class:`~thermoswarm.analysis.options.AnalysisOptions`);
        this reads ``read.fps`` and the ``clean``, ``steps`` and ``exclude`` sections.
    **keywords
        Options by their flat names, applied over ``options`` (``fps``, ``smooth``,
        ``polyorder``, ``mass``, ``min_speed``, ``max_speed``, ``gap_factor``, ...:
        each documented in :mod:`thermoswarm.analysis.options` and ``docs/analysis.md``).

    Returns
    -------
    xarray.Dataset
        See the module docstring; the counts are in ``attrs``.
    """
    opts = _options(options, keywords)
    counts: dict[str, Any] = dict.fromkeys(DATA_QUALITY_KEYS, 0)
    s = clean_samples(ds, opts, counts)
    clock = step_clock(s, opts.steps, counts)
    X, Y, present = fill_and_smooth(s, clock, opts.clean, counts)
    classes = classify_steps(s, clock, X, Y, present, opts, counts)
    turns = steering(clock, X, Y, classes, opts.steps.min_speed, counts)
    out = steps_dataset(ds, s, clock, X, Y, classes, turns, opts.steps.mass)
    out.attrs.update(_settings_attrs(ds, opts, classes, out.attrs["clock"]))
    out.attrs.update(counts)
    return out
