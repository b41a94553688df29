"""The detector registry: detectors by name, built lazily from ``"module:factory"``.

:func:`register_detector` adds a detector with a lazily imported factory
``factory(*, px_per_mm, model, options) -> Detector``; :func:`make_detector` builds one.
``classical`` (the default, needs no training) and ``unet`` (a trained model) are
registered by :mod:`.classical`, by name only, so that building either imports only
its own module.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from thermoswarm.errors import InputError
from thermoswarm.tracking.detection import Detector

__all__ = [
    "DetectorEntry",
    "register_detector",
    "detectors",
    "make_detector",
    "default_model_detector",
]


@dataclass(frozen=True)
class DetectorEntry:
    """A registered detector: ``target`` is ``"module:factory"``, imported when used."""

    name: str
    target: str
    description: str
    needs_model: bool = False


_DETECTORS: dict[str, DetectorEntry] = {}


def register_detector(entry: DetectorEntry) -> None:
    """Add (or replace) a detector in the registry."""
    _DETECTORS[entry.name] = entry


def detectors() -> dict[str, DetectorEntry]:
    """Registered detectors by name (some may live in modules that are not installed)."""
    return dict(_DETECTORS)


def default_model_detector() -> str:
    """Name of the detector that ``--model`` selects when ``--detector`` is not given."""
    for name, entry in _DETECTORS.items():
        if entry.needs_model:
            return name
    raise InputError("no registered detector loads a trained model")


def make_detector(
    name: str | None = None,
    *,
    px_per_mm: float,
    model: str | os.PathLike | None = None,
    options: Mapping[str, Any] | None = None,
) -> Detector:
    """Build a registered detector.

    Parameters
    ----------
    name
        Registry name; default ``"classical"``, or :func:`default_model_detector` when
        ``model`` is given.
    px_per_mm
        Image scale (px per mm), which sets the expected ant size.
    model
        Path of a trained model for detectors that need one.
    options
        Detector options (for ``classical`` the fields of :class:`ClassicalConfig`),
        checked strictly.
    """
    if name is None:
        name = default_model_detector() if model is not None else "classical"
    entry = _DETECTORS.get(name)
    if name == "self-trained":  # pipeline.self_train: a mode of `track`, not a detector
        raise InputError(
            "--detector self-trained is a mode of `thermoswarm track` (it learns from its "
            "own tracks of a video); here: classical, or unet with --model"
        )
    if entry is None:
        raise InputError(
            f"unknown detector {name!r}; expected one of: " + ", ".join(sorted(_DETECTORS))
        )
    if entry.needs_model and model is None:
        raise InputError(f"detector {name!r} needs a trained model: pass --model PATH")
    if not entry.needs_model and model is not None:
        raise InputError(f"detector {name!r} takes no model file (got --model {model})")
    if model is not None and not Path(model).is_file():
        raise InputError(f"{model}: model file does not exist")
    module_name, attr = entry.target.split(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        raise InputError(
            f"detector {name!r} is not available in this installation ({exc.name} missing)"
        ) from None
    factory = getattr(module, attr)
    return factory(
        px_per_mm=float(px_per_mm),
        model=None if model is None else Path(model),
        options=dict(options or {}),
    )
