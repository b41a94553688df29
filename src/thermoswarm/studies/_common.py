"""Running a grid of scenario runs over seeds, and the statistics every study uses."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats

from thermoswarm.errors import ConfigError

__all__ = ["Record", "run_grid", "effect", "verdict"]


@dataclass
class Record:
    """One run: its grid point, seed, directory, status and metrics (the fields of
    :class:`thermoswarm.sweep.RunRecord` that studies read)."""

    run_id: str
    params: dict[str, Any]
    seed: int
    out: str
    status: str
    metrics: dict[str, Any] | None = None
    error: str | None = None


def _local_grid(
    scenario: str,
    out: Path,
    base: Mapping[str, Any],
    grid: Mapping[str, Sequence[Any]],
    seeds: Sequence[int],
    progress: bool | None,
    max_workers: int | None = None,
) -> list[Record]:
    """Fallback when :mod:`thermoswarm.sweep` is not installed: the same layout
    (``out/<hash of the resolved config>/``, finished runs skipped), run in this process
    or in a pool of ``max_workers`` processes."""
    import hashlib
    import itertools

    from thermoswarm.config import from_mapping
    from thermoswarm.scenarios import get
    from thermoswarm.scenarios.runner import RunConfig

    def set_dotted(data: dict[str, Any], key: str, value: Any) -> None:
        node = data
        parts = key.split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
        node[parts[-1]] = value

    cls = get(scenario)
    keys = list(grid)
    configs = []
    for values in itertools.product(*(grid[k] for k in keys)):
        point = dict(zip(keys, values, strict=True))
        data: dict[str, Any] = {}
        for k, v in {**base, **point}.items():
            set_dotted(data, k, v)
        params = from_mapping(cls.Params, data, source=f"grid point {point}")
        for seed in seeds:
            configs.append((point, int(seed), RunConfig(scenario, params, int(seed))))
    out.mkdir(exist_ok=True)
    records: list[Record] = []
    todo: list[tuple[int, str, Path]] = []
    for point, seed, cfg in configs:
        rid = hashlib.sha256(cfg.to_toml().encode()).hexdigest()[:16]
        rdir = out / rid
        mfile = rdir / "metrics.json"
        if mfile.is_file():
            records.append(Record(rid, point, seed, str(rdir), "skipped",
                                  json.loads(mfile.read_text())))  # fmt: skip
            continue
        if rdir.exists():
            import shutil

            shutil.rmtree(rdir)  # an unfinished run: start it again
        records.append(Record(rid, point, seed, str(rdir), "pending"))
        todo.append((len(records) - 1, cfg.to_toml(), rdir))
    workers = max_workers or 1
    if workers <= 1 or len(todo) <= 1:
        for i, text, rdir in todo:
            records[i].metrics = _run_toml(text, str(rdir), progress)
            records[i].status = "done"
        return records
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    ctx = multiprocessing.get_context("spawn")  # no fork after OpenMP threads started
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        futs = {pool.submit(_run_toml, text, str(rdir), False): i for i, text, rdir in todo}
        for fut, i in futs.items():
            records[i].metrics = fut.result()
            records[i].status = "done"
    return records


def _run_toml(config_toml: str, out_dir: str, progress: bool | None) -> dict[str, Any]:
    """Worker: run one resolved configuration (one Numba thread: the pool is parallel)."""
    import tomllib

    import numba

    from thermoswarm.config import from_mapping
    from thermoswarm.scenarios import get
    from thermoswarm.scenarios.runner import RunConfig, run

    numba.set_num_threads(1)
    data = tomllib.loads(config_toml)
    name, seed = data.pop("scenario"), data.pop("seed")
    cfg = RunConfig(name, from_mapping(get(name).Params, data), seed)
    return run(cfg, Path(out_dir), progress=progress)


def run_grid(
    scenario: str,
    out: str | Path,
    *,
    base: Mapping[str, Any],
    grid: Mapping[str, Sequence[Any]],
    seeds: Sequence[int],
    executor: Executor | None = None,
    max_workers: int | None = None,
    progress: bool | None = None,
) -> list[Record]:
    """Every grid point x seed of ``scenario``; one record per run.

    Uses :func:`thermoswarm.sweep.run_sweep` (process pool or ``executor``) when the
    sweep module exists, else a serial loop with the same directory layout.  Dotted keys
    in ``base`` and ``grid`` address sections (``"sensor.mode"``).  A run that failed
    raises :class:`ConfigError` naming it.
    """
    out = Path(out)
    if not out.absolute().parent.is_dir():
        raise ConfigError(f"study output directory's parent {str(out.parent)!r} does not exist")
    try:
        from thermoswarm.sweep import SweepSpec, run_sweep
    except ImportError:
        records = _local_grid(scenario, out, base, grid, seeds, progress, max_workers)
    else:
        spec = SweepSpec(scenario=scenario, out=out, base=dict(base), grid=dict(grid),
                         seeds=list(seeds))  # fmt: skip
        kwargs: dict[str, Any] = {"progress": progress}
        if max_workers is not None:
            kwargs["max_workers"] = max_workers
        raw = run_sweep(spec, executor, **kwargs)
        records = [Record(r.run_id, dict(r.params), r.seed, r.out, r.status, r.metrics,
                          r.error) for r in raw]  # fmt: skip
    bad = [r for r in records if r.metrics is None]
    if bad:
        raise ConfigError(
            f"{len(bad)} run(s) of the study failed, e.g. {bad[0].params} seed {bad[0].seed}: "
            f"{bad[0].error}"
        )
    return records


def effect(values: Sequence[float], confidence: float = 0.95) -> dict[str, float]:
    """Mean of independent per-seed values with its uncertainty.

    Returns ``n``, ``mean``, ``sd`` (sample, ddof 1), ``se`` (``sd / sqrt(n)``),
    ``ci_low``/``ci_high`` (Student-t interval at ``confidence``), ``t`` (``mean / se``),
    ``p`` (two-sided one-sample t-test against 0) and ``d`` (Cohen's d, ``mean / sd``).
    With fewer than two values the spread statistics are NaN.
    """
    x = np.asarray([v for v in values if v is not None], dtype=np.float64)
    x = x[np.isfinite(x)]
    n = int(x.size)
    nan = math.nan
    if n == 0:
        return {"n": 0, "mean": nan, "sd": nan, "se": nan, "ci_low": nan, "ci_high": nan,
                "t": nan, "p": nan, "d": nan}  # fmt: skip
    mean = float(x.mean())
    if n < 2:
        return {"n": n, "mean": mean, "sd": nan, "se": nan, "ci_low": nan, "ci_high": nan,
                "t": nan, "p": nan, "d": nan}  # fmt: skip
    sd = float(x.std(ddof=1))
    se = sd / math.sqrt(n)
    q = float(stats.t.ppf(0.5 + confidence / 2, n - 1))
    if se > 0:
        t = mean / se
        p = float(2 * stats.t.sf(abs(t), n - 1))
    else:  # identical values: no spread to test against
        t = math.copysign(math.inf, mean) if mean != 0 else nan
        p = 0.0 if mean != 0 else nan
    return {
        "n": n,
        "mean": mean,
        "sd": sd,
        "se": se,
        "ci_low": mean - q * se,
        "ci_high": mean + q * se,
        "t": t,
        "p": p,
        "d": mean / sd if sd > 0 else nan,
    }


def verdict(ci_low: float, ci_high: float) -> str:
    """``"toward target"`` when the whole confidence interval is above 0, ``"away from
    target"`` when below, else ``"no detectable motion"``."""
    if ci_low > 0:
        return "toward target"
    if ci_high < 0:
        return "away from target"
    return "no detectable motion"
