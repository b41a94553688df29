"""idtracker.ai trajectories: ``trajectories.h5``, ``trajectories.npy``, session folders.

idtracker.ai (v5+) saves the same dictionary in several forms
(``idtrackerai/utils/...``, "Trajectory files" in its user guide):

``trajectories``      (n_frames, n_animals, 2) centroid x, y in **pixels**, NaN = missing
``id_probabilities``  (n_frames, n_animals) or (n_frames, n_animals, 1), in [0, 1]
``frames_per_second`` the video's frame rate (used for the time axis)
``body_length``       median body length in pixels (kept in attrs, also in mm)
``identities_labels`` optional user labels of the identities (used as names)
``version``, ``video_paths``, ``length_unit`` ... kept in attrs as text

In ``.h5`` the arrays are datasets and the scalars are file attributes: read with
h5py, nothing is unpickled.  ``.npy`` is a *pickled* dict: loading it runs code from
the file, so it is done only with ``allow_pickle=True`` (``--allow-pickle``).  A
plain ``.npy`` array of shape (n_frames, n_animals, 2) (no pickle) is read as
trajectories without metadata.  A folder is searched for ``trajectories/`` (a
session folder) and then for ``trajectories``, ``without_gaps``, ``with_gaps``
(``.h5`` preferred to ``.npy``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.errors import InputError
from thermoswarm.io._common import (
    attr_value,
    check_npy_sizes,
    check_options,
    decode_names,
    h5_file,
    h5_read,
    option_bool,
    require_px_per_mm,
    resolve_fps,
    unique_names,
)
from thermoswarm.tracks import make_tracks

OPTIONS = {
    "allow_pickle": "unpickle trajectories.npy (runs code from the file; CLI flag --allow-pickle)",
}
NEEDS = "--px-per-mm (fps is read from the file)"

_STEMS = (
    "trajectories",
    "without_gaps",
    "with_gaps",
    "trajectories_wo_gaps",
    "trajectories_validated",
    "validated",
)


def _find_in_folder(folder: Path) -> Path | None:
    roots = [folder / "trajectories", folder]
    for root in roots:
        if not root.is_dir():
            continue
        for stem in _STEMS:
            for ext in (".h5", ".hdf5", ".npy"):
                cand = root / f"{stem}{ext}"
                if cand.is_file():
                    return cand
    return None


def sniff(path: Path) -> bool:
    if path.is_dir():
        return _find_in_folder(path) is not None
    if path.suffix.lower() == ".npy":
        return True
    import h5py

    try:
        with h5py.File(path, "r") as fh:
            ds = fh.get("trajectories")
            return (
                isinstance(ds, h5py.Dataset)
                and ds.ndim == 3
                and ds.shape[-1] == 2
                and "tracks" not in fh
            )
    except Exception:
        return False


def _from_h5(path: Path) -> dict[str, Any]:
    import h5py

    out: dict[str, Any] = {}
    with h5_file(path, "idtracker.ai") as fh:
        out["trajectories"] = h5_read(path, fh, "trajectories")
        if "id_probabilities" in fh and isinstance(fh["id_probabilities"], h5py.Dataset):
            out["id_probabilities"] = h5_read(path, fh, "id_probabilities")
        if "identities_labels" in fh and isinstance(fh["identities_labels"], h5py.Dataset):
            out["identities_labels"] = decode_names(h5_read(path, fh, "identities_labels"))
        for key, value in fh.attrs.items():
            out.setdefault(key, value)
    if "identities_labels" in out and not isinstance(out["identities_labels"], list):
        out["identities_labels"] = decode_names(out["identities_labels"])
    return out


def _from_npy(path: Path, allow_pickle: bool) -> dict[str, Any]:
    check_npy_sizes(path)
    try:
        arr = np.load(path, allow_pickle=False)
    except ValueError as exc:
        if "allow_pickle" not in str(exc):
            raise InputError(f"{path}: not a readable .npy file ({exc})") from None
        pickled = True
    except (OSError, EOFError) as exc:
        raise InputError(f"{path}: not a readable .npy file ({type(exc).__name__})") from None
    else:
        return {"trajectories": arr}
    if pickled and not allow_pickle:
        raise InputError(
            f"{path}: this idtracker.ai .npy is a pickled dict and unpickling runs code "
            "from the file; pass --allow-pickle if you trust it (or read the session's "
            "trajectories.h5 instead, which needs no pickle)"
        )
    try:
        obj = np.load(path, allow_pickle=True)
    except Exception as exc:  # truncated pickles raise many types
        raise InputError(
            f"{path}: cannot unpickle ({type(exc).__name__}); the file is damaged"
        ) from None
    data = obj.item() if isinstance(obj, np.ndarray) and obj.shape == () else obj
    if not isinstance(data, dict):
        raise InputError(
            f"{path}: expected a pickled dict with 'trajectories', got {type(data).__name__}"
        )
    return data


def read(
    path: Path,
    *,
    fps: float | None = None,
    px_per_mm: float | None = None,
    **options: Any,
) -> xr.Dataset:
    """Read idtracker.ai trajectories (see the module docstring) in mm and seconds."""
    check_options(path, "idtracker", options, OPTIONS)
    allow_pickle = option_bool(path, "allow_pickle", options.get("allow_pickle", False))
    source = path
    if path.is_dir():
        found = _find_in_folder(path)
        if found is None:
            raise InputError(
                f"{path}: no idtracker.ai trajectories file (trajectories.h5/.npy, "
                "without_gaps.npy, ...) here or in trajectories/"
            )
        source = found
    if source.suffix.lower() == ".npy":
        data = _from_npy(source, allow_pickle)
    else:
        data = _from_h5(source)
    traj = data.get("trajectories")
    if traj is None:
        raise InputError(f"{source}: no 'trajectories' entry")
    traj = np.asarray(traj)
    if traj.ndim != 3 or traj.shape[-1] != 2 or traj.dtype.kind not in "fiu":
        raise InputError(
            f"{source}: 'trajectories' must be numbers of shape (frames, animals, 2), "
            f"got {traj.dtype} {traj.shape}"
        )
    scale = require_px_per_mm(source, px_per_mm, "idtracker.ai")
    n_frames, n_animals, _ = traj.shape
    file_fps = data.get("frames_per_second")
    file_fps = float(file_fps) if isinstance(file_fps, int | float | np.number) else None
    rate = resolve_fps(source, fps, file_fps, "idtracker.ai")
    if rate is None:
        raise InputError(f"{source}: no frames_per_second in the file; pass --fps")
    pos = np.transpose(traj.astype(np.float64), (0, 2, 1))[:, :, None, :] / scale
    conf = None
    probs = data.get("id_probabilities")
    if probs is not None:
        probs = np.asarray(probs, dtype=np.float64)
        if probs.ndim == 3 and probs.shape[-1] == 1:
            probs = probs[..., 0]
        if probs.shape != (n_frames, n_animals):
            raise InputError(
                f"{source}: id_probabilities has shape {probs.shape}, "
                f"expected ({n_frames}, {n_animals})"
            )
        conf = probs
    labels = data.get("identities_labels")
    if isinstance(labels, list | tuple | np.ndarray) and len(labels) == n_animals:
        names = unique_names(source, [str(v) for v in labels], "identity")
    else:
        names = [f"id_{i + 1}" for i in range(n_animals)]  # idtracker.ai counts from 1
    attrs: dict[str, Any] = {"px_per_mm": scale, "source_space_unit": "px"}
    if file_fps is not None:
        attrs["file_fps"] = file_fps
    body = data.get("body_length")
    if isinstance(body, int | float | np.number) and math.isfinite(float(body)):
        attrs["body_length_px"] = float(body)
        attrs["body_length_mm"] = float(body) / scale
    for key in ("version", "video_paths", "length_unit"):
        if key in data and data[key] is not None:
            attrs[f"idtracker_{key}"] = attr_value(data[key])
    return make_tracks(
        pos,
        fps=rate,
        individuals=names,
        confidence=conf,
        source_software="idtracker.ai",
        source_file=str(source),
        attrs=attrs,
    )
