"""What the viewer shows: one trajectory source, read a frame at a time.

:func:`thermoswarm.view.source.open_source` turns a path into a :class:`ViewData`:

- a run folder of ``thermoswarm simulate`` (``config.toml`` + ``tracks.zarr`` or
  ``tracks.nc``), or a run's ``tracks.zarr`` alone: the Zarr store is opened lazily and
  only its committed frames are shown (a run still being written grows on refresh);
- a ``thermoswarm track --out`` folder (``summary.json`` + ``tracks.nc``): positions in
  video pixels, boxes from ``tracks_mot.txt``, the source video's frames
  (:mod:`thermoswarm.view.video`) and the frames where an id appears or is lost;
- any trajectory file :func:`thermoswarm.io.read_tracks` reads (loaded into memory).

A frame goes to the browser as little-endian float32: ``K * 2 * N`` positions
(keypoint-major, then x block, y block) followed by ``N`` values of the colour
variable (NaN where unknown).  Per-robot variables are the dataset's
``(time, individuals)`` variables plus ``speed`` (from the positions when not recorded)
and ``energy = speed^2 / 2`` (mm^2/s^2, per unit mass, as in the analysis).
"""

from __future__ import annotations

import json
import threading
import tomllib
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.errors import InputError, ThermoswarmError

__all__ = ["ViewData", "from_dataset", "to_json", "open_zarr", "check_dataset"]

#: Units of the variables we know, where the file does not say.
_UNITS = {
    "speed": "mm/s",
    "energy": "mm^2/s^2",
    "heading": "rad",
    "steering_rate": "rad/s",
    "temperature": "mm^2/s^2",
}
#: Category names of the variables we know (value -> label).
_LABELS = {
    "phase": {0: "{:g} (cold, liquid-like)", 1: "{:g} (hot, gas-like)"},
}
_MAX_CATEGORIES = 12


@dataclass
class ViewData:
    """A trajectory source for the viewer.

    Attributes
    ----------
    ds : xarray.Dataset
        Trajectory format (may be lazy, Zarr-backed); positions in mm, or in px for
        ``kind == "track"`` (see ``scale``).
    kind : {"run", "tracks", "track"}
        A simulation run, any other trajectory, a ``track`` output over its video.
    scale : float
        Factor from the dataset's mm to the drawing's unit (px/mm for ``track``, else 1).
    """

    ds: xr.Dataset
    kind: str
    title: str
    scale: float = 1.0
    geometry: dict[str, Any] | None = None
    notes: list[str] = field(default_factory=list)
    store: Path | None = None
    committed: int | None = None
    complete: bool = True
    video: Any = None
    boxes: dict[int, list[list[float]]] = field(default_factory=dict)
    events: list[dict[str, Any]] = field(default_factory=list)
    regions: list[Any] | None = None
    _ranges: dict[str, Any] = field(default_factory=dict)
    _lock: threading.Lock = field(default_factory=threading.Lock)

    # ------------------------------------------------------------------ sizes
    @property
    def n_frames(self) -> int:
        return int(self.ds.sizes["time"])

    @property
    def n(self) -> int:
        return int(self.ds.sizes["individuals"])

    @property
    def keypoints(self) -> list[str]:
        return [str(k) for k in self.ds["keypoints"].values]

    def variables(self) -> list[str]:
        """Per-individual variables: ``(time, individuals)`` numbers, speed, energy."""
        out = []
        for name, var in self.ds.data_vars.items():
            if set(var.dims) == {"time", "individuals"} and var.dtype.kind in "biuf":
                out.append(str(name))
        for name in ("speed", "energy"):
            if name not in out:
                out.append(name)
        if "temperature" not in out and "phase" in out and (self.geometry or {}).get("kT"):
            out.append("temperature")
        if self.regions and "region" not in out:
            out.append("region")
        return out

    def times(self) -> np.ndarray:
        """Frame times (s)."""
        t = np.asarray(self.ds["time"].values, dtype=np.float64)
        if self.ds.attrs.get("time_unit", "seconds") != "seconds":
            fps = float(self.ds.attrs.get("fps") or 1.0)
            t = t / fps
        return t

    # ------------------------------------------------------------------ refresh
    def refresh(self) -> None:
        """Re-read the committed frames of a Zarr store that is still being written."""
        if self.store is None or self.complete:
            return
        with self._lock:
            ds, committed, complete = open_zarr(self.store)
            self.ds, self.committed, self.complete = ds, committed, complete

    # ------------------------------------------------------------------ frames
    def _centre(self, k: int) -> np.ndarray:
        """Reference-point positions ``(2, N)`` of frame ``k`` (mm)."""
        pos = self.ds["position"].isel(time=k).transpose("keypoints", "space", "individuals")
        p = np.asarray(pos.values, dtype=np.float64)
        kps = self.keypoints
        for name in ("centroid", "body", "thorax"):
            if name in kps:
                return p[kps.index(name)]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            return np.nanmean(p, axis=0)

    def values(self, k: int, var: str) -> np.ndarray:
        """Values ``(N,)`` of ``var`` at frame ``k`` (float64, NaN where unknown)."""
        if var in self.ds.data_vars and var in self.variables():
            v = self.ds[var].isel(time=k).transpose("individuals").values
            return np.asarray(v, dtype=np.float64)
        if var == "speed":
            return self._speed_at(k)
        if var == "energy":
            s = self.values(k, "speed")
            return 0.5 * s * s
        if var == "region" and self.regions and var not in self.ds.data_vars:
            from thermoswarm.analysis.regions import assign_regions

            c = self._centre(k)
            return assign_regions(self.regions, c[0], c[1]).astype(np.float64)
        if var == "temperature" and "temperature" in self.variables():
            kt = self.geometry["kT"]  # type: ignore[index]
            phase = self.values(k, "phase")
            return np.where(phase == 1, kt["hot"], np.where(phase == 0, kt["cold"], np.nan))
        raise InputError(
            f"unknown variable {var!r}; expected one of {', '.join(self.variables())}"
        )

    def _speed_at(self, k: int) -> np.ndarray:
        """Speed (mm/s) from the step to the next frame (the previous at the last)."""
        n = self.n_frames
        if n < 2:
            return np.full(self.n, np.nan)
        a, b = (k, k + 1) if k + 1 < n else (k - 1, k)
        t = self.times()
        dt = t[b] - t[a]
        d = self._centre(b) - self._centre(a)
        return np.hypot(d[0], d[1]) / dt if dt > 0 else np.full(self.n, np.nan)

    def frame_bytes(self, k: int, var: str | None) -> bytes:
        """Frame ``k`` as float32 LE: positions ``(K, 2, N)`` then the variable ``(N,)``."""
        if not 0 <= k < self.n_frames:
            raise InputError(f"frame {k} is outside 0..{self.n_frames - 1}")
        pos = self.ds["position"].isel(time=k).transpose("keypoints", "space", "individuals")
        p = np.asarray(pos.values, dtype="<f4") * np.float32(self.scale)
        v = self.values(k, var) if var else np.full(self.n, np.nan)
        return p.tobytes() + np.asarray(v, dtype="<f4").tobytes()

    def series(self, i: int) -> dict[str, Any]:
        """Speed and energy of individual ``i`` over time, and its other variables."""
        if not 0 <= i < self.n:
            raise InputError(f"individual {i} is outside 0..{self.n - 1}")
        t = self.times()
        one = self.ds.isel(individuals=i)
        out: dict[str, Any] = {"id": str(self.ds["individuals"].values[i]), "time": t}
        if "speed" in self.ds.data_vars:
            speed = np.asarray(one["speed"].values, dtype=np.float64)
        else:
            pos = one["position"].transpose("time", "keypoints", "space").values
            c = _reference(np.asarray(pos, dtype=np.float64), self.keypoints)
            dt = np.diff(t)
            step = np.hypot(*np.diff(c, axis=0).T) / np.where(dt > 0, dt, np.nan)
            speed = np.append(step, step[-1:]) if step.size else np.full(t.size, np.nan)
        out["speed"] = speed
        out["energy"] = 0.5 * speed * speed
        for name in self.variables():
            if name not in out and name in self.ds.data_vars:
                out[name] = np.asarray(one[name].values, dtype=np.float64)
        return {k: _jsonable(v) for k, v in out.items()}

    # ------------------------------------------------------------------ meta
    def var_info(self, var: str) -> dict[str, Any]:
        """Units, kind (continuous/categorical) and range of a variable, from a sample."""
        if var in self._ranges:
            return self._ranges[var]
        n_f = self.n_frames
        ks = sorted({int(round(x)) for x in np.linspace(0, n_f - 1, min(n_f, 6))})
        sample = np.concatenate([self.values(k, var)[:200_000] for k in ks])
        finite = sample[np.isfinite(sample)]
        attrs = self.ds[var].attrs if var in self.ds.data_vars else {}
        info: dict[str, Any] = {
            "name": var,
            "units": str(attrs.get("units", _UNITS.get(var, ""))),
            "long_name": str(attrs.get("long_name", "")),
        }
        dtype = self.ds[var].dtype.kind if var in self.ds.data_vars else "f"
        labels: dict[float, str] = {}
        if self.kind == "run":
            labels.update({float(k): v for k, v in _LABELS.get(var, {}).items()})
        geo = self.geometry or {}
        labels.update({float(k): v for k, v in geo.get("labels", {}).get(var, {}).items()})
        if var == "temperature" and var not in self.ds.data_vars:  # from phase: two levels
            dtype = "i"
            labels.update({geo["kT"]["hot"]: "{:g} (hot)", geo["kT"]["cold"]: "{:g} (cold)"})
        if var == "region" and self.regions and var not in self.ds.data_vars:
            dtype = "i"
            labels.update({float(k): r.name for k, r in enumerate(self.regions)})
            labels[-1.0] = "outside"
        uniq = np.unique(finite) if finite.size else np.zeros(0)
        if dtype in "biu" and uniq.size <= _MAX_CATEGORIES:
            info["kind"] = "categorical"
            info["categories"] = [
                {"value": float(u), "label": labels.get(float(u), "{:g}").format(u)} for u in uniq
            ]
        else:
            lo, hi = np.percentile(finite, [1, 99]) if finite.size else (0.0, 1.0)
            if not hi > lo:
                hi = lo + 1.0
            info.update(kind="continuous", min=float(lo), max=float(hi))
        self._ranges[var] = info
        return info

    def meta(self) -> dict[str, Any]:
        """Everything the page needs before the first frame (JSON-able)."""
        self.refresh()
        ds = self.ds
        t = self.times()
        per_frame: dict[str, Any] = {}
        for name in ("object_position", "walls"):
            if name in ds.data_vars and "individuals" not in ds[name].dims:
                per_frame[name] = _jsonable(np.asarray(ds[name].values, dtype=np.float64))
        notes = list(self.notes)
        if not self.complete:
            notes.append(
                f"this run is still being written (or was stopped): showing its "
                f"{self.n_frames} committed frames; the page checks for more every 3 s"
            )
        return {
            "title": self.title,
            "kind": self.kind,
            "n": self.n,
            "n_frames": self.n_frames,
            "keypoints": self.keypoints,
            "ids": [str(x) for x in ds["individuals"].values[:100_000]],
            "time": _jsonable(t),
            "fps": float(
                ds.attrs.get("fps") or (1.0 / np.median(np.diff(t)) if t.size > 1 else 1)
            ),
            "units": "px" if self.kind == "track" else "mm",
            "scale": self.scale,
            "radius": _radius(ds, self.scale),
            "bounds": _bounds(self),
            "y_down": self.kind == "track",
            "variables": [self.var_info(v) for v in self.variables()],
            "default_var": _default_var(self.variables()),
            "geometry": self.geometry,
            "per_frame": per_frame,
            "events": self.events,
            "boxes": {str(k): v for k, v in self.boxes.items()},
            "regions": [
                {"name": r.name, "vertices": (np.asarray(r.vertices) * self.scale).tolist()}
                for r in self.regions or []
            ],
            "video": None if self.video is None else self.video.describe(),
            "complete": self.complete,
            "notes": notes,
        }

    def boxes_at(self, k: int) -> list[list[float]]:
        """``[id, x, y, w, h]`` px of the tracker's boxes at frame ``k``."""
        return self.boxes.get(int(k), [])


# ---------------------------------------------------------------------- helpers
def to_json(obj: Any) -> str:
    """Strict JSON of ``obj``; NaN and infinities become ``null``."""

    def clean(o: Any) -> Any:
        if isinstance(o, float):
            return o if np.isfinite(o) else None
        if isinstance(o, dict):
            return {str(k): clean(v) for k, v in o.items()}
        if isinstance(o, (list, tuple)):
            return [clean(v) for v in o]
        if isinstance(o, np.generic):
            return clean(o.item())
        return o

    return json.dumps(clean(obj), separators=(",", ":"), allow_nan=False)


def _jsonable(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        a = np.asarray(v, dtype=np.float64)
        return a.tolist()  # NaN becomes null in to_json
    return v


def _reference(pos: np.ndarray, kps: list[str]) -> np.ndarray:
    """``(T, 2)`` reference point of ``(T, K, 2)`` positions."""
    for name in ("centroid", "body", "thorax"):
        if name in kps:
            return pos[:, kps.index(name)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanmean(pos, axis=1)


def _default_var(names: list[str]) -> str:
    for name in ("phase", "speed"):
        if name in names:
            return name
    return names[0]


def _radius(ds: xr.Dataset, scale: float) -> float | None:
    r = ds.attrs.get("radius")
    try:
        return float(r) * scale if r is not None else None
    except (TypeError, ValueError):
        return None


def _bounds(data: ViewData) -> list[float]:
    """Extent to show first: the world's bounds, the video frame, else the data's."""
    geo = data.geometry or {}
    if geo.get("bounds"):
        return [float(b) for b in geo["bounds"]]
    if data.video is not None:
        w, h = data.video.size
        return [0.0, 0.0, float(w), float(h)]
    ks = sorted({0, data.n_frames // 2, data.n_frames - 1})
    pts = np.concatenate([data._centre(k).T for k in ks]) * data.scale
    pts = pts[np.isfinite(pts).all(axis=1)]
    if pts.size == 0:
        return [0.0, 0.0, 1.0, 1.0]
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.05 * float(max(hi - lo)) + 1e-9
    return [float(lo[0] - pad), float(lo[1] - pad), float(hi[0] + pad), float(hi[1] + pad)]


def check_dataset(ds: xr.Dataset, path: Path) -> xr.Dataset:
    if "position" not in ds.data_vars:
        raise InputError(f"{path}: no 'position' variable; not a trajectory")
    want = {"time", "space", "keypoints", "individuals"}
    if set(ds["position"].dims) != want:
        raise InputError(
            f"{path}: 'position' has dimensions {tuple(ds['position'].dims)}, expected "
            "(time, space, keypoints, individuals)"
        )
    if ds.sizes["time"] == 0 or ds.sizes["individuals"] == 0:
        raise InputError(f"{path}: no frames or no individuals to show")
    return ds


def open_zarr(path: Path) -> tuple[xr.Dataset, int | None, bool]:
    """A run store opened lazily, cut to its committed frames."""
    from thermoswarm.io.zarrstore import _committed, sniff

    if not sniff(path):
        raise InputError(f"{path}: not a Zarr store (no zarr.json)")
    committed = _committed(path)
    if committed == 0:
        raise InputError(
            f"{path}: no committed frames yet (the run has just started); open it again "
            "in a moment"
        )
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            ds = xr.open_zarr(path, consolidated=False)
    except Exception as exc:  # zarr raises many types for damaged metadata
        raise InputError(f"{path}: not a readable Zarr store ({type(exc).__name__})") from None
    check_dataset(ds, path)
    complete = bool(ds.attrs.get("complete", committed is None))
    if committed is not None:
        if committed > ds.sizes["time"]:
            raise InputError(
                f"{path}: committed_frames = {committed} but the store holds "
                f"{ds.sizes['time']} time steps"
            )
        complete = complete or committed == ds.sizes["time"]
        ds = ds.isel(time=slice(0, committed))
    return ds, committed, complete


def scenario_geometry(config_text: str, source: str) -> dict[str, Any]:
    """Walls, discs, bodies, pistons and light of a run, rebuilt from its config TOML."""
    from thermoswarm.config import from_mapping
    from thermoswarm.scenarios import get

    data = tomllib.loads(config_text)
    name = data.pop("scenario", None)
    seed = data.pop("seed", 0)
    if name is None:
        raise InputError(f"{source}: the config names no scenario")
    cls = get(str(name))
    params = from_mapping(cls.Params, data, source=source)
    setup = cls(params).build(np.random.default_rng(int(seed)))
    world = setup.world
    info = dict(setup.info)
    geo_obj = info.get("geometry")
    if geo_obj is not None and hasattr(geo_obj, "info"):
        info.update(geo_obj.info())
    geo: dict[str, Any] = {
        "scenario": str(name),
        "bounds": list(world.bounds),
        "walls": np.asarray(world.segments, dtype=float).tolist(),
        "discs": np.asarray(world.static_discs, dtype=float).tolist(),
        "bodies": [{"x": b.x, "y": b.y, "r": b.radius} for b in world.bodies],
        "pistons": [
            {"axis": p.axis, "position": p.position, "lo": p.lo, "hi": p.hi} for p in world.pistons
        ],
        "light": info.get("light"),
        "shadow_discs": info.get("shadow_obstacles", []),
        "target_y": info.get("target_y"),
        "labels": {},
    }
    hot, cold = getattr(params, "kT_hot", None), getattr(params, "kT_cold", None)
    if isinstance(hot, (int, float)) and isinstance(cold, (int, float)):
        geo["kT"] = {"hot": float(hot), "cold": float(cold)}
    names = info.get("names")
    if names is not None:
        geo["labels"]["section"] = {-1: "depot", **{k: f"{k}: {v}" for k, v in enumerate(names)}}
    return _plain(geo)


def _plain(obj: Any) -> Any:
    """JSON-able copy (NumPy scalars and arrays to Python)."""
    return json.loads(json.dumps(obj, default=lambda o: np.asarray(o).tolist()))


def with_geometry(data: ViewData, config_text: str | None, source: str) -> ViewData:
    if not config_text:
        return data
    try:
        data.geometry = scenario_geometry(config_text, source)
    except (ThermoswarmError, tomllib.TOMLDecodeError, KeyError, TypeError, ValueError) as exc:
        line = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        data.notes.append(f"scenario geometry not shown: {line}")
    return data


def from_dataset(ds: xr.Dataset, title: str = "trajectories") -> ViewData:
    """A :class:`ViewData` of an in-memory trajectory dataset (mm, s)."""
    check_dataset(ds, Path(title))
    kind = "run" if ds.attrs.get("scenario") else "tracks"
    data = ViewData(ds=ds, kind=kind, title=title)
    return with_geometry(data, ds.attrs.get("config"), title)
