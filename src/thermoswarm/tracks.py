"""The one trajectory format: an :class:`xarray.Dataset` in the ``movement`` poses schema.

Every source -- the simulator, the video tracker, the importers of other tools --
produces this, and the analysis reads only this.

Schema
------
``position``   (time, space, keypoints, individuals), float, millimetres
``confidence`` (time, keypoints, individuals), float in [0, 1] or NaN; optional
coordinates    ``time`` (seconds when ``attrs["time_unit"] == "seconds"``, else frame
               numbers), ``space = ["x", "y"]``, ``keypoints`` (names, default
               ``["centroid"]``), ``individuals`` (names, default ``id_0, id_1, ...``)
attributes     ``ds_type = "poses"``, ``source_software``, ``time_unit``
               (``"seconds"`` or ``"frames"``), ``space_unit = "mm"``, ``fps`` (only when
               the sampling is regular and known), ``source_file`` (when read from one)

Missing samples are NaN positions.  Further variables (a robot's phase or
temperature, region labels) may be added with dimensions drawn from the above.
The dimension order and names match ``movement`` (``movement.validators.datasets``),
so a dataset can be handed to ``movement``'s functions and back.

Individuals on their own clocks
-------------------------------
A shared ``time`` axis is honest only when the individuals were sampled at the same
instants (the frames of one video).  Individuals recorded at different instants (one
text file per ant, each with its own timestamps, offsets or jitter) would need the
union of all their times as the axis, with every individual NaN at the others'
instants: consecutive samples of one individual would no longer be neighbours, and
the axis grows with the number of individuals.  Such data get **per-individual time
coordinates** instead: ``attrs["time_unit"] = "per_individual"``, the ``time``
coordinate is the sample index (0, 1, 2, ...) and the variable
``individual_time(time, individuals)`` holds each individual's own times in seconds,
NaN after its last sample.  Row ``k`` of an individual is its ``k``-th sample, so
nothing is invented (no filler rows) and nothing is lost; the layout stays the
``movement`` array layout, which keeps every array operation along ``time`` (and
``movement``'s own functions, which then see sample indices) working.  This was
chosen over a ragged table (one row per sample) because the analysis works on
``(time, individuals)`` arrays throughout (autocorrelation along a track, thinning,
clusters of tracks); a padded array of per-individual samples gives it exactly each
individual's own sequence.  :func:`individual_times` returns every individual's
times in seconds whatever the layout.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.errors import InputError

DIMS = ("time", "space", "keypoints", "individuals")
CONF_DIMS = ("time", "keypoints", "individuals")

__all__ = [
    "DIMS",
    "CONF_DIMS",
    "make_tracks",
    "validate_tracks",
    "times_seconds",
    "individual_times",
    "per_individual",
    "centroid",
    "combine_tracks",
    "resolve_duplicates",
    "DUPLICATE_RULES",
]

#: Rules for two samples of one individual at the same time with different positions.
DUPLICATE_RULES = ("error", "first", "mean")


def make_tracks(
    position: np.ndarray,
    *,
    time: np.ndarray | None = None,
    fps: float | None = None,
    individuals: Sequence[str] | None = None,
    keypoints: Sequence[str] | None = None,
    confidence: np.ndarray | None = None,
    source_software: str = "thermoswarm",
    source_file: str | None = None,
    attrs: dict[str, Any] | None = None,
) -> xr.Dataset:
    """Build a trajectory dataset.

    Parameters
    ----------
    position
        Array ``(time, 2, keypoints, individuals)`` in mm, or ``(time, 2, individuals)``
        for a single keypoint (the centroid).
    time
        Sample times in **seconds**, strictly increasing: one axis ``(time,)`` shared
        by all individuals, or ``(time, individuals)`` for individuals on their own
        clocks (each column increasing, NaN after the individual's last sample; see
        the module docstring).  If omitted, ``fps`` gives
        ``time = arange(n) / fps``; if both are omitted the time coordinate holds frame
        numbers and ``time_unit`` is ``"frames"`` (the analysis will ask for an fps).
    fps
        Frames per second of regular sampling.  Stored as an attribute.
    individuals, keypoints
        Names; defaults ``id_0, id_1, ...`` and ``centroid`` / ``keypoint_i``.
    confidence
        Array ``(time, keypoints, individuals)`` or ``(time, individuals)``.
    source_software, source_file, attrs
        Provenance and further attributes.
    """
    position = np.asarray(position)
    if position.ndim == 3:
        position = position[:, :, None, :]
    if position.ndim != 4 or position.shape[1] != 2:
        raise InputError(
            f"position must have shape (time, 2, keypoints, individuals), got {position.shape}"
        )
    if not np.issubdtype(position.dtype, np.floating):
        position = position.astype(np.float64)
    n_t, _, n_k, n_i = position.shape
    individuals, keypoints = _names(individuals, keypoints, n_k, n_i)
    if fps is not None and not (np.isfinite(fps) and fps > 0):
        raise InputError(f"fps must be a positive number, got {fps!r}")
    t, clock, time_unit = _time_coordinate(time, fps, n_t, n_i)
    data_vars: dict[str, Any] = {"position": (DIMS, position)}
    if clock is not None:
        data_vars["individual_time"] = (
            ("time", "individuals"),
            clock,
            {"units": "s", "description": "each individual's own sample times; NaN: none"},
        )
    if confidence is not None:
        data_vars["confidence"] = (CONF_DIMS, _confidence(confidence, (n_t, n_k, n_i)))
    all_attrs: dict[str, Any] = {
        "ds_type": "poses",
        "source_software": source_software,
        "time_unit": time_unit,
        "space_unit": "mm",
    }
    if fps is not None:
        all_attrs["fps"] = float(fps)
    if source_file is not None:
        all_attrs["source_file"] = str(source_file)
    if attrs:
        all_attrs.update({k: v for k, v in attrs.items() if v is not None})
    return xr.Dataset(
        data_vars,
        coords={
            "time": t,
            "space": ["x", "y"],
            "keypoints": keypoints,
            "individuals": individuals,
        },
        attrs=all_attrs,
    )


def _names(
    individuals: Sequence[str] | None, keypoints: Sequence[str] | None, n_k: int, n_i: int
) -> tuple[list[str], list[str]]:
    """Individual and keypoint names as str (defaults ``id_i``; ``centroid`` or
    ``keypoint_k``), checked: as many as the array has, unique."""
    if individuals is None:
        individuals = [f"id_{i}" for i in range(n_i)]
    if keypoints is None:
        keypoints = ["centroid"] if n_k == 1 else [f"keypoint_{k}" for k in range(n_k)]
    individuals = [str(x) for x in individuals]
    keypoints = [str(x) for x in keypoints]
    if len(individuals) != n_i or len(set(individuals)) != n_i:
        raise InputError(f"need {n_i} unique individual names, got {len(set(individuals))}")
    if len(keypoints) != n_k or len(set(keypoints)) != n_k:
        raise InputError(f"need {n_k} unique keypoint names, got {len(set(keypoints))}")
    return individuals, keypoints


def _time_coordinate(
    time: np.ndarray | None, fps: float | None, n_t: int, n_i: int
) -> tuple[np.ndarray, np.ndarray | None, str]:
    """``(time coordinate (n_t,), per-individual clock (n_t, n_i) or None, time_unit)``
    of :func:`make_tracks`: seconds given, from ``fps``, per individual, or frames."""
    clock = None
    if time is not None and np.ndim(time) == 2:
        clock = np.asarray(time, dtype=np.float64)
        if clock.shape != (n_t, n_i):
            raise InputError(f"time must have shape {(n_t, n_i)}, got {clock.shape}")
        t = np.arange(n_t, dtype=np.float64)
        time_unit = "per_individual"
    elif time is not None:
        t = np.asarray(time, dtype=np.float64)
        time_unit = "seconds"
    elif fps is not None:
        t = np.arange(n_t, dtype=np.float64) / float(fps)
        time_unit = "seconds"
    else:
        t = np.arange(n_t, dtype=np.float64)
        time_unit = "frames"
    if t.shape != (n_t,):
        raise InputError(f"time must have {n_t} entries, got shape {t.shape}")
    return t, clock, time_unit


def _confidence(confidence: np.ndarray, shape: tuple[int, int, int]) -> np.ndarray:
    """``confidence`` as float32 ``(time, keypoints, individuals)`` (a 2-D one gets its
    keypoint axis), checked against ``shape``."""
    confidence = np.asarray(confidence, dtype=np.float32)
    if confidence.ndim == 2:
        confidence = confidence[:, None, :]
    if confidence.shape != shape:
        raise InputError(f"confidence must have shape {shape}, got {confidence.shape}")
    return confidence


def validate_tracks(ds: Any, *, source: str | None = None) -> xr.Dataset:
    """Check that ``ds`` follows the trajectory format; return it unchanged.

    Raises :class:`InputError` with a one-line message naming ``source`` (a file name)
    and the first problem found.
    """
    where = f"{source}: " if source else ""
    if not isinstance(ds, xr.Dataset):
        raise InputError(f"{where}expected an xarray Dataset, got {type(ds).__name__}")
    if "position" not in ds:
        raise InputError(f"{where}no 'position' variable (expected the movement poses schema)")
    pos = ds["position"]
    if pos.dims != DIMS:
        raise InputError(f"{where}'position' must have dims {DIMS}, got {pos.dims}")
    if ds.sizes["space"] != 2:
        raise InputError(f"{where}'space' must have 2 entries (x, y), got {ds.sizes['space']}")
    if "confidence" in ds and ds["confidence"].dims != CONF_DIMS:
        raise InputError(
            f"{where}'confidence' must have dims {CONF_DIMS}, got {ds['confidence'].dims}"
        )
    unit = ds.attrs.get("space_unit", "mm")
    if unit != "mm":
        raise InputError(f"{where}positions must be in mm, got space_unit={unit!r}")
    tu = ds.attrs.get("time_unit", "seconds")
    if tu not in ("seconds", "frames", "per_individual"):
        raise InputError(
            f"{where}time_unit must be 'seconds', 'frames' or 'per_individual', got {tu!r}"
        )
    if tu == "per_individual":
        if "individual_time" not in ds:
            raise InputError(
                f"{where}time_unit 'per_individual' needs an 'individual_time' variable"
            )
        if ds["individual_time"].dims != ("time", "individuals"):
            raise InputError(
                f"{where}'individual_time' must have dims ('time', 'individuals'), "
                f"got {ds['individual_time'].dims}"
            )
    return ds


def per_individual(ds: xr.Dataset) -> bool:
    """Whether the individuals of ``ds`` are on their own clocks (see the module docstring)."""
    return ds.attrs.get("time_unit") == "per_individual"


def times_seconds(ds: xr.Dataset, fps: float | None = None) -> np.ndarray:
    """Sample times in seconds.

    Uses the time coordinate when it is in seconds; otherwise frame numbers divided by
    ``fps`` (the argument, else ``ds.attrs["fps"]``).  Raises :class:`InputError` when the
    dataset has frame numbers only and no frame rate is known.
    """
    if per_individual(ds):
        src = ds.attrs.get("source_file", "the input")
        raise InputError(
            f"{src}: the individuals are on their own clocks (no shared time axis); "
            "use thermoswarm.tracks.individual_times"
        )
    t = np.asarray(ds["time"].values, dtype=np.float64)
    if ds.attrs.get("time_unit", "seconds") == "seconds" and fps is None:
        return t
    rate = fps if fps is not None else ds.attrs.get("fps")
    if rate is None:
        src = ds.attrs.get("source_file", "the input")
        raise InputError(f"{src} has frame numbers but no frame rate; pass --fps")
    if not (np.isfinite(rate) and rate > 0):
        raise InputError(f"fps must be a positive number, got {rate!r}")
    if ds.attrs.get("time_unit", "seconds") == "seconds":
        # The time coordinate is already in seconds; an explicit fps only fills gaps.
        return t
    return t / float(rate)


def individual_times(ds: xr.Dataset, fps: float | None = None) -> np.ndarray:
    """Every individual's sample times in seconds, ``(time, individuals)``.

    Per-individual clocks: the ``individual_time`` variable (NaN where an individual
    has no sample).  A shared axis: :func:`times_seconds` broadcast (read-only view).
    """
    if per_individual(ds):
        return np.asarray(
            ds["individual_time"].transpose("time", "individuals").values, dtype=np.float64
        )
    t = times_seconds(ds, fps)
    return np.broadcast_to(t[:, None], (t.size, ds.sizes["individuals"]))


def combine_tracks(
    datasets: Sequence[xr.Dataset], prefixes: Sequence[str], *, fps: float | None = None
) -> xr.Dataset:
    """Put the individuals of several datasets (e.g. one file per video) side by side.

    Individual ``n`` of the dataset with prefix ``p`` is named ``p:n``; the variable
    ``recording(individuals)`` holds ``p`` (so ``--group-by recording`` compares the
    recordings).  Keypoints must agree.  Each individual keeps its own times; when
    they all coincide the result has one shared axis, otherwise per-individual clocks
    (see the module docstring).
    Confidence is kept when every dataset has it.  ``fps`` converts frame-numbered
    inputs.
    """
    if len(datasets) != len(prefixes) or not datasets:
        raise InputError("combine_tracks: need one prefix per dataset, at least one dataset")
    kps = [str(k) for k in datasets[0]["keypoints"].values]
    cols_t, cols_p, cols_c, names, recordings = [], [], [], [], []
    with_conf = all("confidence" in d for d in datasets)
    for d, prefix in zip(datasets, prefixes, strict=True):
        here = [str(k) for k in d["keypoints"].values]
        if here != kps:
            raise InputError(
                f"{d.attrs.get('source_file', prefix)}: keypoints {here} differ from {kps}"
            )
        t = individual_times(d, fps)
        pos = d["position"].transpose(*DIMS).values
        conf = d["confidence"].transpose(*CONF_DIMS).values if with_conf else None
        for i, name in enumerate(str(v) for v in d["individuals"].values):
            keep = np.isfinite(t[:, i])
            cols_t.append(t[keep, i])
            cols_p.append(pos[keep, :, :, i])
            cols_c.append(None if conf is None else conf[keep, :, i])
            names.append(f"{prefix}:{name}")
            recordings.append(str(prefix))
    n = max(c.size for c in cols_t)
    shared = all(c.size == n and np.array_equal(c, cols_t[0]) for c in cols_t)
    position = np.full((n, 2, len(kps), len(names)), np.nan)
    clock = np.full((n, len(names)), np.nan)
    confidence = np.full((n, len(kps), len(names)), np.nan) if with_conf else None
    for i, (t, p, c) in enumerate(zip(cols_t, cols_p, cols_c, strict=True)):
        position[: t.size, :, :, i] = p
        clock[: t.size, i] = t
        if confidence is not None:
            confidence[: t.size, :, i] = c
    first = datasets[0].attrs
    out = make_tracks(
        position,
        time=cols_t[0] if shared else clock,
        individuals=names,
        keypoints=kps,
        confidence=confidence,
        source_software=str(first.get("source_software", "thermoswarm")),
        source_file=", ".join(str(d.attrs.get("source_file", "")) for d in datasets),
        attrs={
            k: int(sum(int(d.attrs.get(k, 0) or 0) for d in datasets))
            for k in ("n_duplicate_rows", "n_conflicting_duplicates", "n_decreasing_timestamps")
        },
    )
    out["recording"] = (("individuals",), np.asarray(recordings, dtype=object))
    return out


def resolve_duplicates(
    t: np.ndarray,
    values: np.ndarray,
    rule: str,
    *,
    group: np.ndarray | None = None,
    describe: Any = None,
) -> tuple[np.ndarray, np.ndarray, int, int]:
    """Sort samples by (group, time) and resolve samples of one group at equal times.

    ``t`` (n,) finite times; ``values`` (n, m) what each sample holds (positions,
    confidence; NaN = missing); ``group`` (n,) integer group of each sample (an
    individual, or an individual and keypoint; default: one group).  Samples of one
    group at the same time that hold the same values (NaN equal to NaN) are exact
    duplicates: the first is kept.  Samples that differ conflict, and ``rule``
    decides: ``"error"`` raises an :class:`InputError` (``describe(group, time)``
    names the place and time), ``"first"`` keeps the first in input order, ``"mean"`` takes the
    mean of the present values of the distinct rows.

    Returns ``(index, values)`` of the kept samples -- ``index`` the input row of each
    (its first row), ordered by group then time -- and the counts of exact duplicate
    rows dropped and of conflicting rows resolved.
    """
    if rule not in DUPLICATE_RULES:
        raise InputError(f"duplicates must be one of {', '.join(DUPLICATE_RULES)}, got {rule!r}")
    t = np.asarray(t, dtype=np.float64)
    values = np.asarray(values, dtype=np.float64).reshape(t.size, -1)
    g = np.zeros(t.size, dtype=np.int64) if group is None else np.asarray(group, np.int64)
    order = np.lexsort((t, g))  # stable: equal keys keep their input order
    ts, gs, vs = t[order], g[order], values[order]
    new = np.ones(ts.size, dtype=bool)
    new[1:] = (ts[1:] != ts[:-1]) | (gs[1:] != gs[:-1])
    if new.all():
        return order, vs, 0, 0
    start = np.flatnonzero(new)
    gid = np.cumsum(new) - 1
    first = vs[start][gid]
    row_same = ((vs == first) | (np.isnan(vs) & np.isnan(first))).all(axis=1)
    dup = row_same & ~new  # equal to its group's first row: an exact duplicate
    conflict = np.zeros(start.size, dtype=bool)
    np.logical_or.at(conflict, gid, ~row_same)
    n_exact = int(dup.sum())
    n_conflict = int((conflict[gid] & ~dup & ~new).sum())
    out = vs[start].copy()
    if conflict.any():
        if rule == "error":
            k = int(np.flatnonzero(conflict)[0])
            place = (
                describe(int(gs[start[k]]), float(ts[start[k]]))
                if describe
                else f"samples at time {ts[start[k]]:.10g}"
            )
            raise InputError(
                f"{place}: two different samples at one time; "
                "choose a rule with --duplicates first or --duplicates mean "
                "(exact duplicate rows are dropped without one)"
            )
        if rule == "mean":
            keep = ~dup
            present = np.isfinite(vs) & keep[:, None]
            n = np.zeros_like(out)
            tot = np.zeros_like(out)
            np.add.at(n, gid, present.astype(np.float64))
            np.add.at(tot, gid, np.where(present, vs, 0.0))
            with np.errstate(invalid="ignore", divide="ignore"):
                mean = np.where(n > 0, tot / n, np.nan)
            out = np.where(conflict[:, None], mean, out)
    return order[start], out, n_exact, n_conflict


def centroid(ds: xr.Dataset) -> xr.DataArray:
    """Position ``(time, space, individuals)`` of each individual's reference point.

    The keypoint named ``centroid`` (or ``body``) when present, otherwise the mean of the
    keypoints that are present at each time.
    """
    kps = [str(k) for k in ds["keypoints"].values]
    for name in ("centroid", "body", "thorax"):
        if name in kps:
            return ds["position"].sel(keypoints=name, drop=True)
    return ds["position"].mean("keypoints", skipna=True)
