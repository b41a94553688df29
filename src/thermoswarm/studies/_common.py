"""Running a grid of scenario runs over seeds, and the statistics every study uses."""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Iterator, Mapping, Sequence
from concurrent.futures import Executor
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy import stats

from thermoswarm.errors import ConfigError
from thermoswarm.sweep import RunRecord, SweepSpec, expand, local_pool, run_sweep

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "Record",
    "StudyResult",
    "run_grid",
    "study_pool",
    "effect",
    "verdict",
    "dotted_overrides",
]


#: One run of a study (the sweep's record: run_id, params, seed, out, status, metrics).
Record = RunRecord


@dataclass
class StudyResult:
    """What a study returns: one row per run (``runs``), its statistics (``summary``)
    and the setting it ran; each study adds its own ``table()``."""

    runs: pd.DataFrame
    summary: pd.DataFrame
    setting: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        return {
            "setting": self.setting,
            "summary": self.summary.to_dict(orient="records"),
            "runs": self.runs.to_dict(orient="records"),
        }


@contextmanager
def study_pool(executor: Executor | None, max_workers: int | None) -> Iterator[Executor]:
    """``executor`` if given, else one local pool (:func:`thermoswarm.sweep.local_pool`:
    one Numba thread a run, a dead worker retried) for every grid of a study, shut down
    at the end (a pool per grid would start its workers again for each)."""
    if executor is not None:
        yield executor
        return
    pool = local_pool(max_workers)
    try:
        yield pool
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def dotted_overrides(overrides: Sequence[str]) -> dict[str, Any]:
    """``["a.b=1", "c=x"]`` (the ``--set`` syntax) as ``{"a.b": 1, "c": "x"}``: the
    dotted keys :func:`run_grid` takes in ``base``."""
    from thermoswarm.config import parse_overrides

    flat: dict[str, Any] = {}

    def walk(d: Mapping[str, Any], prefix: str = "") -> None:
        for k, v in d.items():
            if isinstance(v, Mapping):
                walk(v, prefix + k + ".")
            else:
                flat[prefix + k] = v

    walk(parse_overrides(list(overrides)))
    return flat


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
    """Every grid point x seed of ``scenario`` through :func:`thermoswarm.sweep.run_sweep`
    (a local process pool, or ``executor``) into ``out/runs/``; one record per run.

    Dotted keys in ``base`` and ``grid`` address sections (``"sensor.mode"``).  Every
    value is checked before ``out`` (and its missing parents) is created.  A run that
    failed raises :class:`ConfigError` naming it.
    """
    from thermoswarm.fsutil import check_output_dir

    out = check_output_dir(out)
    spec = SweepSpec(scenario=scenario, out=out / "runs", base=dict(base), grid=dict(grid),
                     seeds=list(seeds))  # fmt: skip
    n_runs = len(expand(spec))  # raises on a bad value before anything is written
    out.mkdir(parents=True, exist_ok=True)
    # off a terminal (a log) one line before and one after, instead of a progress bar
    lines = progress is None and not sys.stderr.isatty()
    t0 = time.perf_counter()
    if lines:
        print(f"{scenario} study: {n_runs} runs into {out / 'runs'} ...", file=sys.stderr,
              flush=True)  # fmt: skip
    records = run_sweep(spec, executor, progress=progress, max_workers=max_workers)
    if lines:
        print(f"{scenario} study: {n_runs} runs done in {time.perf_counter() - t0:.0f} s",
              file=sys.stderr, flush=True)  # fmt: skip
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
