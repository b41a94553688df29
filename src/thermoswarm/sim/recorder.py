"""Streaming trajectories to Zarr, with committed-frame markers and checkpoints.

A run writes ``DIR/tracks.zarr``, a Zarr v3 group readable by :func:`xarray.open_zarr`
in the trajectory format of :mod:`thermoswarm.tracks` (``position(time, space,
keypoints, individuals)`` in mm, ``time`` in s) plus per-frame extras (``heading``,
``speed``, scenario variables).  Frames are buffered in memory and written one block
at a time.  After each block:

1. the block's chunks are written (each block fills whole chunks along time, so
   committed chunks are never rewritten);
2. the engine state after the block (arrays, random-generator state, scenario
   accumulators) is saved as ``DIR/checkpoint-<step>.npz`` (write-to-temp + rename);
3. the group attributes ``committed_frames``, ``checkpoint_step`` and
   ``checkpoint_file`` are updated (zarr writes ``zarr.json`` by temp + rename too);
4. older checkpoints are removed.

A run killed at any moment (even ``kill -9``) therefore keeps every committed frame,
and ``resume`` continues from the last checkpoint to exactly the result of an
uninterrupted run: all random draws come from the generator whose state is saved.
Frames after ``committed_frames`` may be half-written; readers must ignore them
(:mod:`thermoswarm.io.zarrstore` does).
"""

from __future__ import annotations

import io
import json
import os
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import zarr

from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_bytes

__all__ = ["ZarrRecorder", "save_checkpoint", "load_checkpoint", "read_marker"]

_DIMS = ["time", "space", "keypoints", "individuals"]


def _write_attrs(group: zarr.Group, attrs: Mapping[str, Any]) -> zarr.Group:
    """Merge ``attrs`` into the group's attributes in ONE write of ``zarr.json``.

    ``group.attrs.update(d)`` is ``MutableMapping.update``: one metadata write per key,
    so a kill between keys could leave ``committed_frames`` pointing one block past
    ``checkpoint_file``.  ``update_attributes`` with the merged dict writes once, and
    zarr's local store replaces ``zarr.json`` atomically (temp file + rename) from
    zarr-python 3.1.3 on, hence ``zarr>=3.1.3`` in the requirements.
    """
    merged = {**group.attrs.asdict(), **attrs}
    return group.update_attributes(merged)


def _string_array(group: zarr.Group, name: str, values: list[str]) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        arr = group.create_array(name, shape=(len(values),), dtype=str, dimension_names=[name])
        arr[:] = np.array(values, dtype=object)


class ZarrRecorder:
    """Buffered writer of a run's frames into ``path`` (a new Zarr v3 store).

    Parameters
    ----------
    path : Path
        The store directory (created; must not exist unless ``resume``).
    n : int
        Number of robots.
    n_frames : int
        Total frames of the run (the arrays are allocated to this length).
    block : int
        Frames per committed block (also the chunk length along time).
    extras : mapping name -> (dims, shape-without-time, dtype)
        Further per-frame variables, e.g. ``{"speed": (("time", "individuals"), (n,), "f4")}``.
    attrs : dict
        Dataset attributes (fps, source_software, scenario, config...).
    dtype : str
        Position dtype (``"f8"`` default; ``"f4"`` halves the size).
    resume : bool
        Open an existing store instead of creating one.
    """

    def __init__(
        self,
        path: Path,
        *,
        n: int,
        n_frames: int,
        block: int,
        extras: Mapping[str, tuple[tuple[str, ...], tuple[int, ...], str]] | None = None,
        attrs: dict[str, Any] | None = None,
        dtype: str = "f8",
        extra_coords: Mapping[str, list[str]] | None = None,
        resume: bool = False,
    ) -> None:
        self.path = Path(path)
        self.n = n
        self.block = max(1, int(block))
        self.extras = dict(extras or {})
        if resume:
            self.group = zarr.open_group(self.path, mode="r+", zarr_format=3)
            self.committed = int(self.group.attrs.get("committed_frames", 0))
        else:
            self.group = zarr.open_group(self.path, mode="w-", zarr_format=3)
            ichunk = min(n, max(1, 4_000_000 // (2 * self.block)))  # ~32 MB chunks at f8
            self.group.create_array(
                "position",
                shape=(n_frames, 2, 1, n),
                chunks=(self.block, 2, 1, ichunk),
                dtype=dtype,
                fill_value=np.nan,
                dimension_names=_DIMS,
            )
            self.group.create_array(
                "time",
                shape=(n_frames,),
                chunks=(self.block,),
                dtype="f8",
                fill_value=np.nan,
                dimension_names=["time"],
            )
            _string_array(self.group, "space", ["x", "y"])
            _string_array(self.group, "keypoints", ["centroid"])
            _string_array(self.group, "individuals", [f"id_{i}" for i in range(n)])
            for cname, values in (extra_coords or {}).items():
                _string_array(self.group, cname, list(values))
            for name, (dims, shape, dt) in self.extras.items():
                chunks = (self.block,) + tuple(min(s, ichunk) for s in shape)
                fill = np.nan if np.dtype(dt).kind == "f" else -1
                self.group.create_array(
                    name,
                    shape=(n_frames,) + tuple(shape),
                    chunks=chunks,
                    dtype=dt,
                    fill_value=fill,
                    dimension_names=list(dims),
                )
            all_attrs = {
                "ds_type": "poses",
                "source_software": "thermoswarm",
                "time_unit": "seconds",
                "space_unit": "mm",
                "committed_frames": 0,
            }
            all_attrs.update(attrs or {})
            self.group = _write_attrs(self.group, all_attrs)
            self.committed = 0
        self._pos = np.empty((self.block, 2, n), dtype=dtype)
        self._t = np.empty(self.block)
        self._ext = {
            k: np.empty((self.block,) + tuple(s), dtype=d) for k, (_, s, d) in self.extras.items()
        }
        self._fill = 0

    @property
    def pending(self) -> int:
        """Frames buffered but not yet committed."""
        return self._fill

    def add(self, t: float, pos_by_id: np.ndarray, extras: Mapping[str, np.ndarray]) -> bool:
        """Buffer one frame; returns True when the block is full (call :meth:`flush`)."""
        k = self._fill
        self._pos[k, 0] = pos_by_id[:, 0]
        self._pos[k, 1] = pos_by_id[:, 1]
        self._t[k] = t
        for name, buf in self._ext.items():
            buf[k] = extras[name]
        self._fill += 1
        return self._fill == self.block

    def flush(self, checkpoint: Mapping[str, np.ndarray] | None = None, step: int = 0) -> None:
        """Write the buffered frames, then the checkpoint, then the committed marker."""
        k = self._fill
        if k == 0 and checkpoint is None:
            return
        f0 = self.committed
        if k:
            self.group["position"][f0 : f0 + k, :, 0, :] = self._pos[:k]
            self.group["time"][f0 : f0 + k] = self._t[:k]
            for name, buf in self._ext.items():
                self.group[name][f0 : f0 + k] = buf[:k]
        old = self.group.attrs.get("checkpoint_file")
        attrs: dict[str, Any] = {"committed_frames": f0 + k}
        if checkpoint is not None:
            fname = f"checkpoint-{step:012d}.npz"
            save_checkpoint(self.path.parent / fname, checkpoint)
            attrs.update({"checkpoint_file": fname, "checkpoint_step": int(step)})
        self.group = _write_attrs(self.group, attrs)
        if checkpoint is not None and old and old != attrs["checkpoint_file"]:
            try:
                os.unlink(self.path.parent / old)
            except FileNotFoundError:
                pass
        self.committed = f0 + k
        self._fill = 0

    def set_attrs(self, **attrs: Any) -> None:
        self.group = _write_attrs(self.group, attrs)


def save_checkpoint(path: Path, arrays: Mapping[str, Any]) -> None:
    """Save arrays (and JSON-able objects under keys starting with ``json:``) atomically."""
    buf = io.BytesIO()
    payload = {}
    for k, v in arrays.items():
        if k.startswith("json:"):
            payload[k] = np.frombuffer(json.dumps(v).encode(), dtype=np.uint8)
        else:
            payload[k] = np.asarray(v)
    np.savez(buf, **payload)
    atomic_write_bytes(path, buf.getvalue())


def load_checkpoint(path: Path) -> dict[str, Any]:
    """Inverse of :func:`save_checkpoint`."""
    try:
        with np.load(path, allow_pickle=False) as z:
            out: dict[str, Any] = {}
            for k in z.files:
                out[k] = json.loads(z[k].tobytes().decode()) if k.startswith("json:") else z[k]
            return out
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: unreadable checkpoint ({exc})") from None


def read_marker(store: Path) -> dict[str, Any]:
    """The committed-frames marker (group attributes) of a run's store."""
    try:
        group = zarr.open_group(store, mode="r", zarr_format=3)
    except Exception:  # zarr raises several types for a missing/corrupt store
        raise InputError(f"{store}: not a thermoswarm run store") from None
    return dict(group.attrs)
