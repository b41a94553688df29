"""What a sweep runs: its spec, its runs (grid point x seed) and their ids."""

from __future__ import annotations

import hashlib
import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import thermoswarm
from thermoswarm.config import from_mapping, parse_overrides
from thermoswarm.errors import ConfigError
from thermoswarm.scenarios import get
from thermoswarm.scenarios.runner import RunConfig, check_run_params

__all__ = ["SweepSpec", "RunRecord", "expand", "run_id", "code_fingerprint", "with_overrides"]


@dataclass(frozen=True)
class SweepSpec:
    """What to run.

    Attributes
    ----------
    scenario : str
        Registered scenario name.
    out : Path
        Directory of the sweep (created with its parents).
    base : mapping
        Parameters shared by every run (nested dicts or dotted keys).
    grid : mapping of dotted key -> sequence
        Values to sweep; runs are the Cartesian product.
    seeds : sequence of int
        Seeds; every grid point runs once per seed.
    """

    scenario: str
    out: Path
    base: Mapping[str, Any] = field(default_factory=dict)
    grid: Mapping[str, Sequence[Any]] = field(default_factory=dict)
    seeds: Sequence[int] = (0,)


@dataclass
class RunRecord:
    """One run of a sweep: its grid point, seed, directory, status and metrics.

    ``status`` is ``"done"``, ``"skipped"`` (finished by an earlier sweep) or
    ``"failed"`` (``error`` says why); ``attempts`` counts the times this sweep
    submitted the run (0 for a skipped run).
    """

    run_id: str
    params: dict[str, Any]
    seed: int
    out: str
    status: str
    metrics: dict[str, Any] | None = None
    error: str | None = None
    attempts: int = 0


def _set_dotted(data: dict[str, Any], key: str, value: Any) -> None:
    node = data
    parts = key.split(".")
    for part in parts[:-1]:
        node = node.setdefault(part, {})
        if not isinstance(node, dict):
            raise ConfigError(f"sweep key {key!r}: {part!r} is not a section")
    node[parts[-1]] = value


def _flatten_base(base: Mapping[str, Any]) -> dict[str, Any]:
    """Dotted keys of ``base`` (``"record.interval"``) as nested sections."""
    out: dict[str, Any] = {}
    for k, v in base.items():
        if "." in k:
            _set_dotted(out, k, v)
        elif isinstance(v, Mapping):
            out[k] = _flatten_base(v)
        else:
            out[k] = v
    return out


def with_overrides(spec: SweepSpec, overrides: Sequence[str]) -> SweepSpec:
    """``spec`` with ``--set``-style ``key=value`` overrides applied to its base."""
    if not overrides:
        return spec
    base = _flatten_base(spec.base)
    for k, v in parse_overrides(overrides).items():
        base[k] = v if not isinstance(v, dict) else {**base.get(k, {}), **v}
    return SweepSpec(spec.scenario, spec.out, base, spec.grid, spec.seeds)


_FINGERPRINT: str | None = None


def code_fingerprint() -> str:
    """SHA-256 of the simulation code (engine, policies, laws, scenarios).

    Part of every run id, so that a sweep restarted after the code changed reruns its
    runs instead of skipping them as finished.
    """
    global _FINGERPRINT
    if _FINGERPRINT is None:
        root = Path(thermoswarm.__file__).parent
        files = sorted([*(root / "sim").rglob("*.py"), *(root / "scenarios").glob("*.py"),
                        root / "policy.py", root / "maxent.py"])  # fmt: skip
        h = hashlib.sha256(thermoswarm.__version__.encode())
        for f in files:
            h.update(f.relative_to(root).as_posix().encode())
            h.update(f.read_bytes())
        _FINGERPRINT = h.hexdigest()
    return _FINGERPRINT


def run_id(config_toml: str) -> str:
    """The id of a run: 16 hex digits of the SHA-256 of its resolved config and of the
    code that runs it (:func:`code_fingerprint`)."""
    return hashlib.sha256((code_fingerprint() + config_toml).encode()).hexdigest()[:16]


def expand(spec: SweepSpec) -> list[tuple[dict[str, Any], int, RunConfig]]:
    """All runs of a sweep as ``(grid point, seed, RunConfig)``, validated up front.

    A bad key or value anywhere raises :class:`ConfigError` before anything runs.
    """
    cls = get(spec.scenario)
    keys = list(spec.grid)
    for k in keys:
        if isinstance(spec.grid[k], str) or not isinstance(spec.grid[k], Sequence):
            raise ConfigError(f"sweep grid {k!r} must be a list of values")
    if not spec.seeds:
        raise ConfigError("sweep needs at least one seed")
    for seed in spec.seeds:
        if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**63:
            raise ConfigError(f"sweep seeds must be integers from 0 to 2**63 - 1, got {seed!r}")
    runs = []
    for values in itertools.product(*(spec.grid[k] for k in keys)):
        point = dict(zip(keys, values, strict=True))
        data = _flatten_base(spec.base)
        for k, v in point.items():
            _set_dotted(data, k, v)
        params = from_mapping(cls.Params, data, source=f"sweep point {point}")
        check_run_params(params, f"sweep point {point}")
        for seed in spec.seeds:
            runs.append((point, int(seed), RunConfig(spec.scenario, params, int(seed))))
    return runs
