"""Every scenario's parameters as plain data, cached per machine: fast listings and checks.

``thermoswarm scenarios NAME`` prints, and ``thermoswarm simulate``/``sweep``/``study``
check ``--set`` and ``--config`` against, the rows of
:func:`thermoswarm.config.describe` (key, type, default, unit, meaning, nested sections
as dotted keys).  Building them imports every scenario module (the engine, SciPy,
xarray: about a second); the result is kept in the user's cache directory
(:func:`thermoswarm.cache.cache_dir`), one file per installed copy of the package,
and rebuilt whenever a source file of the package changes (its size or time stamp).
So a typo in ``--set`` is answered before any heavy module is imported, with the same
message as the full check.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from thermoswarm import __version__
from thermoswarm.errors import ConfigError

__all__ = ["all_params", "params", "precheck", "suggest"]

_ROOT = Path(__file__).resolve().parent.parent  # the thermoswarm package
_MEMO: dict[str, Any] | None = None


def _fingerprint() -> str:
    """Version, Python and the size and time stamp of every source file of the package."""
    h = hashlib.sha256(f"{__version__}|{sys.version}".encode())
    for dirpath, dirnames, filenames in os.walk(_ROOT):
        dirnames[:] = sorted(d for d in dirnames if d != "__pycache__")
        for name in sorted(filenames):
            if name.endswith(".py"):
                st = os.stat(os.path.join(dirpath, name))
                h.update(f"{dirpath}/{name}|{st.st_size}|{st.st_mtime_ns}\n".encode())
    return h.hexdigest()


def _cache_file() -> Path:
    from thermoswarm.cache import cache_dir

    where = hashlib.sha256(str(_ROOT).encode()).hexdigest()[:16]
    return cache_dir() / f"params-{where}.json"


def _build() -> dict[str, Any]:
    from thermoswarm.config import describe
    from thermoswarm.scenarios import _MODULES, get

    out = {}
    for name in sorted(_MODULES):
        cls = get(name)
        out[name] = {"description": cls.description, "params": describe(cls.Params)}
    return out


def all_params() -> dict[str, Any]:
    """``{scenario: {"description", "params": rows}}`` for the built-in scenarios."""
    global _MEMO
    if _MEMO is not None:
        return _MEMO
    fp = _fingerprint()
    path = _cache_file()
    try:
        data = json.loads(path.read_text())
        if data.get("fingerprint") == fp:
            _MEMO = data["scenarios"]
            return _MEMO
    except (OSError, ValueError, KeyError, AttributeError):
        pass
    scenarios = _build()
    try:  # a read-only cache only makes the next call as slow as this one
        from thermoswarm.fsutil import atomic_write_text

        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, json.dumps({"fingerprint": fp, "scenarios": scenarios}))
    except OSError:
        pass
    _MEMO = scenarios
    return scenarios


def suggest(word: str, choices: Sequence[str]) -> str:
    """`` (did you mean 'x'?)`` when ``word`` is close to one of ``choices``."""
    import difflib

    close = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def params(name: str) -> list[dict[str, Any]]:
    """The parameter rows of scenario ``name`` (a ConfigError names the known ones)."""
    table = all_params()
    if name not in table:
        from thermoswarm.scenarios import names

        raise ConfigError(
            f"unknown scenario {name!r}{suggest(name, names())}; "
            f"expected one of: {', '.join(names())}"
        )
    return table[name]["params"]


def precheck(
    scenario: str | None,
    *,
    config_file: str | Path | None = None,
    overrides: Sequence[str] = (),
    base: Mapping[str, Any] | None = None,
    grid: Mapping[str, Sequence[Any]] | None = None,
) -> None:
    """Check scenario name, keys and types of a config file, ``--set`` overrides,
    (dotted) ``base`` values and every ``grid`` value without importing the scenario, as
    :func:`thermoswarm.scenarios.runner.resolve` would; value ranges are checked later.

    Raises :class:`ConfigError` with the message the full check gives.  A scenario that
    is not built in (registered by user code) is left to the full check.
    """
    from thermoswarm.config import apply_overrides, from_mapping, load_toml, parse_overrides
    from thermoswarm.scenarios import _MODULES

    data: dict[str, Any] = dict(load_toml(config_file)) if config_file else {}
    file_name = data.pop("scenario", None)
    data.pop("seed", None)
    over = parse_overrides(list(overrides))
    over.pop("seed", None)
    over.pop("scenario", None)
    name = scenario or file_name
    if name is None:
        raise ConfigError("no scenario given (pass SCENARIO or set scenario = ... in the config)")
    if scenario and file_name and scenario != file_name:
        raise ConfigError(f"{config_file}: scenario = {file_name!r} but {scenario!r} was asked")
    if name not in _MODULES:
        from thermoswarm.scenarios import _REGISTRY

        if name in _REGISTRY:
            return
        params(str(name))  # raises, with a suggestion
    from thermoswarm.config import standin

    cls = standin(params(str(name)))
    data = apply_overrides(data, _nest(base or {}))
    source = (
        " and ".join(
            s for s in (str(config_file) if config_file else "", "--set" if overrides else "") if s
        )
        or None
    )
    merged = apply_overrides(data, over)
    from_mapping(cls, merged, source=source)
    for key, values in (grid or {}).items():
        if isinstance(values, str) or not isinstance(values, Sequence):
            raise ConfigError(f"grid {key!r} must be a list of values")
        for v in values:
            from_mapping(cls, apply_overrides(merged, _nest({key: v})), source=f"grid {key}")


def _nest(flat: Mapping[str, Any]) -> dict[str, Any]:
    """``{"a.b": 1}`` as ``{"a": {"b": 1}}``."""
    out: dict[str, Any] = {}
    for k, v in flat.items():
        node = out
        *heads, last = str(k).split(".")
        for part in heads:
            node = node.setdefault(part, {})
        node[last] = v
    return out
