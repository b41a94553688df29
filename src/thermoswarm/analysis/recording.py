"""What a recording can tell the analysis about itself: sampling, control period, speeds.

A simulated robot re-draws its speed and heading every control period ``tau``.  A
displacement recorded over an interval ``dt`` straddles a re-draw with probability
about ``min(1, dt / tau)`` (the robots' periods are staggered), and then mixes two
commanded velocities: at ``dt >= tau`` the speeds measured from positions are no
longer draws from the robots' law, and an exponential law looks like two phases.
In a crowd, contacts slow robots too, so positions give the crowd's realised motion.

A ``thermoswarm simulate`` recording says what it is: its attributes give the frame
rate ``fps``, the control period (``control_period``, or ``tau`` in older recordings)
and its ``speed`` variable holds each robot's commanded speed (overdamped robots) or
its instantaneous speed (inertial particles), at every frame.  This module

- reads those facts (:func:`recording_facts`);
- with ``steps.speed_source = "auto"`` (the default) or ``"recorded"``, takes the
  energies of the fits from the recorded speeds (and the turns from the recorded
  headings, where the recording has them) and keeps the ones measured from positions
  beside them as ``realized_speed`` and ``realized_heading`` (:func:`apply_speed_source`);
- reports, in ``fits.json["recording"]``, the sampling interval against the control
  period, the share of steps that mix two commanded velocities, the realised speeds
  against the commanded ones, and a warning when the sampling does not resolve the
  control period (:func:`recording_block`);
- gives the one-phase temperature an interval that respects the dependence of a
  track's samples: a percentile bootstrap over individuals (:func:`kT_interval`).

Units: seconds, mm/s, energies in the kinematics' unit.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.errors import ConfigError

__all__ = [
    "MIXED_STEP_LIMIT",
    "recording_facts",
    "apply_speed_source",
    "recording_block",
    "kT_interval",
    "mask_shared_positions",
]

#: Above this share of steps that straddle a control re-draw (``dt / tau``), the speeds
#: measured from positions do not resolve the law: ``analyze`` warns.
MIXED_STEP_LIMIT = 0.25

#: Attribute values of a recording's ``speed`` variable (``speed_kind``).
_COMMANDED, _INSTANT = "commanded", "instantaneous"


def recording_facts(ds: xr.Dataset) -> dict[str, Any]:
    """The sampling facts a recording carries.

    Returns
    -------
    dict
        ``simulated`` (a ``thermoswarm simulate`` recording), ``sampling_interval_s``
        (``1 / fps``, or ``None``), ``control_period_s`` (``None`` when unknown or for
        inertial particles) and ``speed_kind`` (``"commanded"``, ``"instantaneous"``
        or ``None`` when there is no recorded speed).
    """
    a = ds.attrs
    simulated = a.get("source_software") == "thermoswarm" and "scenario" in a
    fps = a.get("fps")
    interval = 1.0 / float(fps) if fps is not None and float(fps) > 0 else None
    inertial = 'mode = "inertial"' in str(a.get("config", ""))
    period = a.get("control_period", a.get("tau") if simulated else None)
    period = None if period is None or inertial else float(period)
    kind = None
    if "speed" in ds.data_vars and set(ds["speed"].dims) == {"time", "individuals"}:
        kind = ds["speed"].attrs.get("speed_kind", a.get("speed_kind") if simulated else None)
        if kind is None and simulated:  # recordings before the attribute existed
            kind = _INSTANT if inertial else _COMMANDED
    return {
        "simulated": bool(simulated),
        "sampling_interval_s": interval,
        "control_period_s": period,
        "speed_kind": kind,
    }


def apply_speed_source(
    kin: xr.Dataset, ds: xr.Dataset, source: str, facts: dict[str, Any], mass: float | None
) -> str:
    """Put the recorded speeds in ``kin`` (in place) when ``source`` asks for them.

    ``"positions"``: nothing changes.  ``"recorded"``: the recording's ``speed``
    variable (a :class:`ConfigError` when it has none).  ``"auto"``: the recorded
    speeds of a ``thermoswarm simulate`` recording, positions otherwise.  A step takes
    the speed recorded at its end frame (the speed that moved the robot over a step of
    one engine step; any frame's value is a draw from the law).  The speeds measured
    from positions stay as ``realized_speed``; which steps are fitted does not change.

    Returns
    -------
    str
        ``"positions"`` or ``"recorded"``: where the fitted energies came from.
    """
    if source not in ("auto", "positions", "recorded"):
        raise ConfigError(f"speed_source must be auto, positions or recorded, got {source!r}")
    if source == "recorded" and facts["speed_kind"] is None:
        raise ConfigError(
            "--speed-source recorded: the input has no speed(time, individuals) variable"
        )
    if source == "positions" or (source == "auto" and not facts["simulated"]):
        return "positions"
    if facts["speed_kind"] is None or kin.attrs.get("clock") != "shared":
        return "positions"
    rec = ds["speed"].transpose("time", "individuals").values.astype(np.float64)
    rows = kin["input_row"].values
    end = np.clip(rows + 1, 0, rec.shape[0] - 1)
    cols = np.broadcast_to(np.arange(rec.shape[1]), rows.shape)
    v = np.where(rows >= 0, rec[end, cols], np.nan)
    used = kin["valid"].values
    realized = kin["speed"].values
    kin["realized_speed"] = (("time", "individuals"), realized, {"units": "mm/s"})
    kin["speed"].values = np.where(np.isfinite(realized), v, np.nan)
    e = 0.5 * v * v if mass is None else 0.5 * mass * (v * 1e-3) ** 2
    kin["energy"].values = np.where(used, e, np.nan)
    kin.attrs["speed_source"] = "recorded"
    if "heading" in ds.data_vars and set(ds["heading"].dims) == {"time", "individuals"}:
        _recorded_turns(kin, ds, end, cols, rows >= 0)
    return "recorded"


def _recorded_turns(
    kin: xr.Dataset, ds: xr.Dataset, end: np.ndarray, cols: np.ndarray, ok: np.ndarray
) -> None:
    """Headings and steering rates from the recorded headings (the commanded ones), on
    the steps and turns that positions made valid; a turn is the change of heading
    between consecutive steps over their mean duration (rad/s)."""
    rec = ds["heading"].transpose("time", "individuals").values.astype(np.float64)
    h = np.where(ok, rec[end, cols], np.nan)
    kin["realized_heading"] = (("time", "individuals"), kin["heading"].values, {"units": "rad"})
    kin["heading"].values = np.where(np.isfinite(kin["heading"].values), h, np.nan)
    dt = kin["dt"].values
    dh = (h[1:] - h[:-1] + np.pi) % (2 * np.pi) - np.pi
    valid = kin["steering_valid"].values[1:]
    with np.errstate(invalid="ignore"):
        rate = np.where(valid, dh / (0.5 * (dt[:-1] + dt[1:])), np.nan)
    kin["steering_rate"].values = np.concatenate([kin["steering_rate"].values[:1], rate])


def recording_block(
    kin: xr.Dataset, facts: dict[str, Any], source: str, requested: str
) -> dict[str, Any]:
    """``fits.json["recording"]``: sampling against control, realised against commanded.

    Keys: the :func:`recording_facts`, ``speed_source`` (used) and ``requested``,
    ``mixed_step_fraction`` (``min(1, dt / tau)``, the share of steps that straddle a
    re-draw), ``realized_to_recorded_energy`` (mean realised over mean recorded energy
    on the fitted steps) and ``slowed_fraction`` (fitted steps whose realised speed is
    under 90 % of the recorded one: contacts), ``warning`` (or ``None``).
    """
    dt = facts["sampling_interval_s"]
    if dt is None:
        med = kin["median_dt"].values
        med = med[np.isfinite(med)]
        dt = float(np.median(med)) if med.size else None
    tau = facts["control_period_s"]
    mixed = None if dt is None or tau is None else min(1.0, dt / tau)
    out: dict[str, Any] = {
        **facts,
        "sampling_interval_s": dt,
        "speed_source": source,
        "requested": requested,
        "mixed_step_fraction": mixed,
        "realized_to_recorded_energy": None,
        "slowed_fraction": None,
    }
    if "realized_speed" in kin:
        used = kin["valid"].values
        r, v = kin["realized_speed"].values[used], kin["speed"].values[used]
        ok = np.isfinite(r) & np.isfinite(v) & (v > 0)
        if ok.any():
            out["realized_to_recorded_energy"] = float(np.mean(r[ok] ** 2) / np.mean(v[ok] ** 2))
            out["slowed_fraction"] = float(np.mean(r[ok] < 0.9 * v[ok]))
    out["warning"] = _warning(dt, tau, mixed, source, facts["speed_kind"])
    return out


def _warning(
    dt: float | None, tau: float | None, mixed: float | None, source: str, kind: str | None
) -> str | None:
    if mixed is None or mixed <= MIXED_STEP_LIMIT:
        return None
    share = f"about {mixed:.0%} of the recorded steps straddle a re-draw"
    head = (f"the sampling interval ({dt:g} s) is {dt / tau:.2g} times the control period "
            f"({tau:g} s): {share} and mix two commanded velocities")  # fmt: skip
    fix = f"record at most every {tau / 10:g} s (simulate --set record.interval={tau / 10:g})"
    if source == "recorded":
        return (
            f"{head}; the fits use the recorded {kind} speeds and headings (exact draws), "
            f"but the speeds from positions (realized_speed) mix segments; {fix}"
        )
    hint = " or fit the recorded speeds (--speed-source recorded)" if kind else ""
    return f"{head}; speeds from positions do not follow the robots' law; {fix}{hint}"


def kT_interval(
    energy: np.ndarray,
    valid: np.ndarray,
    *,
    n_bootstrap: int,
    alpha: float,
    seed: np.random.SeedSequence,
) -> dict[str, Any] | None:
    """Percentile bootstrap interval of the one-phase temperature (the mean energy),
    resampling whole individuals (columns) with replacement: a track's samples may
    depend on each other in any way, tracks are taken as independent.

    Returns
    -------
    dict or None
        ``kT_ci`` ``[low, high]`` at level ``1 - alpha``, ``kT_ci_method`` and
        ``n_individuals``; ``None`` with fewer than 2 individuals or no bootstrap.
    """
    m = valid & np.isfinite(energy)
    counts = m.sum(axis=0).astype(np.float64)
    sums = np.where(m, energy, 0.0).sum(axis=0)
    keep = counts > 0
    counts, sums = counts[keep], sums[keep]
    k = counts.size
    if k < 2 or n_bootstrap < 1:
        return None
    rng = np.random.default_rng(seed)
    w = rng.multinomial(k, np.full(k, 1.0 / k), size=n_bootstrap).astype(np.float64)
    kts = (w @ sums) / (w @ counts)
    lo, hi = np.quantile(kts, [alpha / 2, 1 - alpha / 2])
    return {
        "kT_ci": [float(lo), float(hi)],
        "kT_ci_level": 1 - alpha,
        "kT_ci_method": f"percentile bootstrap over individuals ({n_bootstrap} replicates)",
        "n_individuals": int(k),
    }


def mask_shared_positions(ds: xr.Dataset) -> tuple[xr.Dataset, int]:
    """Make missing every sample whose position another individual has in the same frame
    (``--mask-shared-positions``).

    A tracker that follows individuals through clusters (anTraX) gives every member of
    a multi-animal blob the blob's position: those samples are not individual
    measurements.  Exact equality of both coordinates marks them.

    Parameters
    ----------
    ds : xarray.Dataset
        Trajectories, ``position(time, space, keypoints, individuals)`` in mm.

    Returns
    -------
    masked : xarray.Dataset
        A copy with those samples set to NaN (every keypoint of the individual).
    n_shared : int
        How many (frame, individual) samples were shared, hence masked.
    """
    pos = ds["position"].transpose("time", "space", "keypoints", "individuals").values.copy()
    x, y = pos[:, 0, 0, :], pos[:, 1, 0, :]
    ok = np.isfinite(x) & np.isfinite(y)
    shared = np.zeros(x.shape, dtype=bool)
    n = x.shape[1]
    for i in range(n - 1):
        same = (x[:, i, None] == x[:, i + 1 :]) & (y[:, i, None] == y[:, i + 1 :])
        same &= ok[:, i, None] & ok[:, i + 1 :]
        shared[:, i] |= same.any(axis=1)
        shared[:, i + 1 :] |= same
    pos[np.broadcast_to(shared[:, None, None, :], pos.shape)] = np.nan
    out = ds.copy()
    dims = ("time", "space", "keypoints", "individuals")
    out["position"] = (dims, pos, ds["position"].attrs)
    out["position"] = out["position"].transpose(*ds["position"].dims)
    return out, int(shared.sum())
