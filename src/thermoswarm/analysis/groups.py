"""Groups of steps for the energy study: a variable's value, a time window, a region.

:func:`parse_group_by` reads a ``--group-by`` value; :func:`group_codes` gives every
step ``(time, individuals)`` its group (-1: none); :func:`ks_comparison` is the paper's
paired t-test of the one- and two-phase KS distances across groups (descriptive).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats

from thermoswarm.analysis.regions import OUTSIDE, Region
from thermoswarm.errors import ConfigError

__all__ = ["GroupSpec", "parse_group_by", "group_codes", "ks_comparison"]


@dataclass(frozen=True)
class GroupSpec:
    """One ``--group-by`` value: ``kind`` is ``"variable"``, ``"time"`` or ``"region"``."""

    text: str
    kind: str
    name: str = ""
    window: float = 0.0


def parse_group_by(spec: str) -> GroupSpec:
    """Parse ``NAME``, ``time:SECONDS`` or ``region``."""
    text = str(spec).strip()
    if not text:
        raise ConfigError("--group-by must be a variable name, 'time:SECONDS' or 'region'")
    if text == "region":
        return GroupSpec(text, "region")
    if text.startswith("time:"):
        try:
            w = float(text[5:])
        except ValueError:
            w = float("nan")
        if not (math.isfinite(w) and w > 0):
            raise ConfigError(
                f"--group-by {text!r}: the window must be a positive number of seconds, "
                "e.g. time:60"
            )
        return GroupSpec(text, "time", window=w)
    return GroupSpec(text, "variable", name=text)


def group_codes(
    spec: GroupSpec,
    ds: xr.Dataset,
    kin: xr.Dataset,
    region_codes: np.ndarray | None,
    regions: Sequence[Region],
) -> tuple[np.ndarray, list[str]]:
    """Integer code per row ``(time, individuals)`` (-1: no group) and the labels."""
    n_t, n_i = kin.sizes["time"], kin.sizes["individuals"]
    if spec.kind == "region":
        if region_codes is None:
            raise ConfigError("--group-by region needs --regions FILE")
        labels = [r.name for r in regions]
        codes = region_codes.astype(np.int64)
        if (codes[kin["valid"].values] == OUTSIDE).any():
            labels = [*labels, "outside"]
            codes = np.where(codes == OUTSIDE, len(regions), codes)
        return codes, labels
    if spec.kind == "time":
        t = kin["step_time"].values
        w = spec.window
        t0 = float(np.nanmin(t))
        with np.errstate(invalid="ignore"):
            k = np.floor((t - t0) / w)
        finite = np.isfinite(k)
        used = np.unique(k[finite]).astype(np.int64)
        codes = np.full(t.shape, -1, dtype=np.int64)
        codes[finite] = np.searchsorted(used, k[finite].astype(np.int64))
        labels = [f"{t0 + w * j:g}-{t0 + w * (j + 1):g} s" for j in used.tolist()]
        return codes, labels
    name = spec.name
    if name not in ds.data_vars or name in ("position", "confidence"):
        options = [v for v in ds.data_vars if v not in ("position", "confidence")]
        raise ConfigError(
            f"--group-by {name!r}: no such data variable (the input has "
            f"{options or 'none'}); use a variable name, 'time:SECONDS' or 'region'"
        )
    var = ds[name]
    if not set(var.dims) <= {"time", "individuals"} or var.ndim == 0:
        raise ConfigError(
            f"--group-by {name!r}: the variable has dims {var.dims}; expected (time), "
            "(individuals) or (time, individuals)"
        )
    var = var.transpose(*[d for d in ("time", "individuals") if d in var.dims])
    values = var.values
    rows = kin["input_row"].values  # (time, individuals); -1: no sample
    cols = np.broadcast_to(np.arange(n_i)[None, :], (n_t, n_i))
    safe = np.maximum(rows, 0)
    if "time" in var.dims and "individuals" in var.dims:
        values = values[safe, cols]
    elif "time" in var.dims:
        values = values[safe]
    else:
        values = np.broadcast_to(values[None, :], (n_t, n_i))
    flat = values.ravel()
    if flat.dtype.kind == "f":
        missing = ~np.isfinite(flat)
    elif flat.dtype.kind in "OUS":
        flat = flat.astype(str)
        missing = np.isin(flat, ["", "None", "nan", "NaN"])
    else:
        missing = np.zeros(flat.shape, dtype=bool)
    missing |= (rows < 0).ravel()  # rows after an individual's last sample
    keys = flat[~missing]
    uniq, inv = np.unique(keys, return_inverse=True)
    if uniq.size > 100:
        raise ConfigError(
            f"--group-by {name!r}: {uniq.size} distinct values; group-by needs a categorical "
            "variable (at most 100 values)"
        )
    codes = np.full(flat.shape, -1, dtype=np.int64)
    codes[~missing] = inv
    labels = [f"{v:g}" if isinstance(v, float | np.floating) else str(v) for v in uniq.tolist()]
    return codes.reshape(n_t, n_i), labels


def ks_comparison(levels: dict[str, dict[str, Any]]) -> dict[str, Any]:
    fitted = {k: v for k, v in levels.items() if "one_phase" in v}
    ks1 = [v["one_phase"]["naive"]["ks"] for v in fitted.values()]
    ks2 = [v["two_phase"]["naive"]["ks"] for v in fitted.values()]
    out: dict[str, Any] = {
        "labels": list(fitted),
        "ks_one_phase": ks1,
        "ks_two_phase": ks2,
        "method": (
            "paired t-test (scipy.stats.ttest_rel) of the naive KS distances of the one- "
            "and two-phase fits across groups, as in the paper; descriptive only: the "
            "two-phase law nests the one-phase law, so its KS is smaller by construction; "
            "use each group's lr_p_value to test the number of phases"
        ),
        "t_statistic": None,
        "p_value": None,
    }
    if len(ks1) >= 2 and np.std(np.subtract(ks1, ks2)) > 0:
        res = stats.ttest_rel(ks1, ks2)
        out["t_statistic"] = float(res.statistic)
        out["p_value"] = float(res.pvalue)
    return out
