"""Transport without connection versus swarm size (the paper's panels u and v).

The paper reports that the maximum distance the object is moved grows, and the time
to move it to the target shrinks, with the number of robots (PAPER_NOTES 5); its real
robots showed displacements "very high in variance and around 0" for few robots.  This
study runs ``transport-free`` (its defaults) for a list of swarm sizes over seeds, in
one of two series:

- ``fixed``: robots are added to the default 1800 mm arena, so the density grows with
  ``n`` (packing 0.013 at 50 robots, 0.66 at 2,500);
- ``density``: the arena's side grows as ``sqrt(n)`` so that the packing stays that of
  1,200 robots in 1800 mm (0.32): 3674 mm for 5,000 robots, 16.4 m for 100,000.

Per size it reports

- the maximum displacement toward the target within the first ``horizon`` seconds
  (mm; mean, sd, se, 95 % t interval, min and max over seeds): the paper's
  "capacity".  A horizon, not the whole run, because later the object meets the
  target and then the wall, which caps the distance whatever the swarm;
- the time to target (s), a censored quantity (runs that never reach it): the fraction
  of runs that reached the target ``target_distance`` mm above the start, the median
  time over all runs (unreached runs count as slower than any reached one, so the
  median is finite only when at least half reached) with a distribution-free 95 %
  interval for it (order statistics of the binomial), and min and max.

Settings: ``quick`` (fixed arena, n = 50, 200, 600, 1200; 5 seeds; 300 s; target 150
mm), ``fixed`` (n = 50 ... 2,500; 10 seeds; 1200 s; target 750 mm), ``density``
(n = 1,200, 2,500, 5,000; 10 seeds; 1200 s; target 750 mm) and ``huge`` (n = 100,000 at
the same density, one seed, 900 s).  Run: ``thermoswarm study scaling --setting fixed --out
DIR`` writes ``DIR/scaling.json``, ``DIR/scaling.md`` and ``DIR/scaling.png``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from concurrent.futures import Executor
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from thermoswarm.fsutil import atomic_path, atomic_write_json, atomic_write_text
from thermoswarm.studies._common import StudyResult, effect, run_grid, study_pool

__all__ = [
    "SETTINGS",
    "ScalingResult",
    "run_scaling",
    "summarize",
    "censored_median",
    "plot_scaling",
    "median_interval",
    "arena_side",
    "load_scaling",
]

#: Packing fraction of the default swarm (1,200 robots of 33 mm in 1800 x 1800 mm).
DEFAULT_PACKING = 1200 * math.pi * 16.5**2 / 1800.0**2

SETTINGS: dict[str, dict[str, Any]] = {
    "quick": {"series": "fixed", "ns": [50, 200, 600, 1200], "seeds": 5, "duration": 300.0,
              "target_distance": 150.0, "horizon": 300.0},
    "fixed": {"series": "fixed", "ns": [50, 100, 200, 400, 800, 1200, 1600, 2000, 2500],
              "seeds": 10, "duration": 1200.0, "target_distance": 750.0, "horizon": 300.0},
    "density": {"series": "density", "ns": [1200, 2500, 5000], "seeds": 10,
                "duration": 1200.0, "target_distance": 750.0, "horizon": 300.0},
    "huge": {"series": "density", "ns": [100000], "seeds": 1, "duration": 900.0,
             "target_distance": 750.0, "horizon": 300.0, "record.interval": 30.0},
}  # fmt: skip


def arena_side(n: int, packing: float = DEFAULT_PACKING, diameter: float = 33.0) -> float:
    """Side (mm) of the square arena in which ``n`` robots have packing ``packing``,
    rounded to 1 mm."""
    return float(round(math.sqrt(n * math.pi * (diameter / 2) ** 2 / packing)))


def median_interval(times: Sequence[float | None], confidence: float = 0.95) -> tuple:
    """Distribution-free interval for the median of first-passage times with
    censoring (``None`` = never reached, longer than any reached time).

    With ``k`` values sorted, the interval is ``[x_(l), x_(u)]`` with the order
    statistics that cover the median with probability >= ``confidence`` under the
    Binomial(k, 1/2) law (the usual sign-test interval); an end that falls on an
    unreached run is ``None`` (unbounded).  ``(None, None)`` for fewer than 2 values.
    Below 6 values no pair of order statistics reaches 95 %: the interval is then the
    range, whose coverage is ``1 - 2^(1-k)`` (93.8 % for 5 values).
    """
    from scipy import stats

    vals = sorted((math.inf if t is None else float(t)) for t in times)
    k = len(vals)
    if k < 2:
        return (None, None)
    # largest l with P(B <= l - 1) <= alpha / 2, B ~ Binomial(k, 1/2)
    alpha = 1 - confidence
    lo = int(stats.binom.ppf(alpha / 2, k, 0.5))
    if stats.binom.cdf(lo, k, 0.5) > alpha / 2:
        lo -= 1
    lo = max(lo, 0)  # index of the lower order statistic (0-based)
    hi = k - 1 - lo
    a, b = vals[lo], vals[hi]
    return (None if math.isinf(a) else a, None if math.isinf(b) else b)


def censored_median(times: Sequence[float | None]) -> float | None:
    """Median of first-passage times where ``None`` (never reached) counts as longer
    than any reached time: ``None`` when fewer than half reached.

    With ``k`` values sorted (unreached last), the median is the middle value for odd
    ``k`` and the mean of the two middle values for even ``k``; ``None`` if either of
    those is unreached.
    """
    vals = sorted((math.inf if t is None else float(t)) for t in times)
    k = len(vals)
    if k == 0:
        return None
    mid = (vals[(k - 1) // 2] + vals[k // 2]) / 2
    return None if math.isinf(mid) else float(mid)


class ScalingResult(StudyResult):
    def table(self) -> str:
        h = self.setting.get("horizon", math.nan)
        head = ["series", "n", "arena (mm)", "seeds",
                f"max displacement in {h:g} s (mm): median [95 % CI]",
                "mean ± sd", "min..max", "reached", "time to target (s): median [95 % CI]",
                "min..max (reached)"]  # fmt: skip
        lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]

        def f(x: Any, fmt: str = ".0f") -> str:
            return (
                "–"
                if x is None or (isinstance(x, float) and not math.isfinite(x))
                else (format(x, fmt))
            )

        for _, r in self.summary.iterrows():
            lines.append(
                "| "
                + " | ".join(
                    [
                        str(r["series"]),
                        str(int(r["n"])),
                        f(r["arena"]),
                        str(int(r["seeds"])),
                        f"{f(r['maxdisp_median'])} [{f(r['maxdisp_ci_low'])}, "
                        f"{f(r['maxdisp_ci_high'])}]",
                        f"{f(r['maxdisp_mean'])} ± {f(r['maxdisp_sd'])}",
                        f"{f(r['maxdisp_min'])}..{f(r['maxdisp_max'])}",
                        f"{int(r['reached'])}/{int(r['seeds'])}",
                        f"{f(r['time_median'])} [{f(r['time_ci_low'])}, {f(r['time_ci_high'])}]",
                        f"{f(r['time_min'])}..{f(r['time_max'])}",
                    ]
                )
                + " |"
            )
        return "\n".join(lines) + "\n"


def _median_ci(values: Sequence[float]) -> tuple[float, float | None, float | None]:
    x = [float(v) for v in values]
    lo, hi = median_interval(x)
    return float(np.median(x)), lo, hi


def summarize(runs: pd.DataFrame) -> pd.DataFrame:
    """Per (``series``, ``n``) statistics of a runs table with columns ``n``,
    ``max_displacement`` (mm, within the horizon), ``displacement`` (mm) and
    ``time_to_target`` (s or None/NaN); ``series`` and ``arena`` are optional."""
    runs = runs.copy()
    if "series" not in runs:
        runs["series"] = "fixed"
    if "arena" not in runs:
        runs["arena"] = math.nan
    rows = []
    for (series, n), g in runs.groupby(["series", "n"], sort=False):
        e = effect(g["max_displacement"].tolist())
        med, lo, hi = _median_ci(g["max_displacement"].tolist())
        d = effect(g["displacement"].tolist())
        times = [None if t is None or (isinstance(t, float) and math.isnan(t)) else float(t)
                 for t in g["time_to_target"].tolist()]  # fmt: skip
        reached = [t for t in times if t is not None]
        tlo, thi = median_interval(times)
        rows.append(
            {
                "series": series,
                "n": int(n),
                "arena": float(g["arena"].iloc[0]),
                "seeds": e["n"],
                "maxdisp_median": med,
                "maxdisp_ci_low": lo,
                "maxdisp_ci_high": hi,
                "maxdisp_mean": e["mean"],
                "maxdisp_sd": e["sd"],
                "maxdisp_se": e["se"],
                "maxdisp_min": float(g["max_displacement"].min()),
                "maxdisp_max": float(g["max_displacement"].max()),
                "disp_mean": d["mean"],
                "disp_se": d["se"],
                "reached": len(reached),
                "reached_fraction": len(reached) / max(len(times), 1),
                "time_median": censored_median(times),
                "time_ci_low": tlo,
                "time_ci_high": thi,
                "time_mean_reached": float(np.mean(reached)) if reached else None,
                "time_min": float(min(reached)) if reached else None,
                "time_max": float(max(reached)) if reached else None,
            }
        )
    return pd.DataFrame(rows)


def _err(center: pd.Series, lo: pd.Series, hi: pd.Series, top: float) -> np.ndarray:
    """Asymmetric error bars from interval ends (an unbounded upper end drawn to ``top``;
    none where the interval is undefined)."""
    c = center.astype(float).to_numpy()
    low = lo.astype(float).to_numpy()
    high = hi.astype(float).to_numpy()
    none = np.isnan(low)  # fewer than two runs: no interval, no bar
    high = np.where(np.isnan(high), np.where(none, c, top), high)
    low = np.where(none, c, low)
    return np.vstack([np.clip(c - low, 0, None), np.clip(high - c, 0, None)])


def plot_scaling(
    result: ScalingResult | pd.DataFrame | Sequence[ScalingResult],
    axes: Sequence[Any] | None = None,
):
    """Panels (u) capacity and (v) time to target versus ``n``, one line per series.

    Points: medians over seeds (the density series drawn 7 % to the right, so that
    sizes both series ran stand side by side); error bars: the distribution-free 95 %
    intervals of the medians (an upper end that is an unreached run is drawn to the top
    of the panel); small dots: individual runs.  In (v) a size where fewer than half the
    runs reached the target has no median (nothing drawn); the fraction reached is
    written beside each point.  Returns the figure.
    """
    import matplotlib.pyplot as plt

    results = [result] if isinstance(result, ScalingResult | pd.DataFrame) else list(result)
    summaries = [r.summary if isinstance(r, ScalingResult) else r for r in results]
    runs_all = [r.runs for r in results if isinstance(r, ScalingResult)]
    summary_all = pd.concat(summaries, ignore_index=True).sort_values("n", kind="stable")
    # one line per series, whichever studies its sizes came from
    parts = [(summary_all, pd.concat(runs_all, ignore_index=True) if runs_all else None)]
    if axes is None:
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.9), constrained_layout=True)
    else:
        fig = axes[0].figure
    ax_u, ax_v = axes
    allns = np.concatenate([p[0]["n"].to_numpy(dtype=float) for p in parts])
    xlim = (float(allns.min()) / 1.5, float(allns.max()) * 2.5)
    tmax = max(
        [float(np.nanmax(p[1]["time_to_target"].astype(float))) for p in parts
         if p[1] is not None and p[1]["time_to_target"].notna().any()] or [1.0]
    ) * 1.15  # fmt: skip
    colors = {"fixed": "tab:blue", "density": "tab:orange"}
    labels = {"fixed": "fixed 1800 mm arena (density grows)",
              "density": "arena grows (packing 0.32)"}  # fmt: skip
    shift = {"density": 1.07}  # side by side where both series have a size
    for summary, runs in parts:
        for series, sm in summary.groupby("series", sort=False):
            sm = sm.assign(n=sm["n"] * shift.get(series, 1.0))
            if runs is not None and "series" in runs:
                runs = runs.assign(n=runs["n"] * runs["series"].map(shift).fillna(1.0))
            _draw_series(ax_u, ax_v, series, sm, runs, colors.get(series, "k"),
                         labels.get(series, series), tmax)  # fmt: skip
    ax_u.axhline(0, color="0.6", lw=0.8)
    for ax in (ax_u, ax_v):
        ax.set_xscale("log")
        ax.set_xlim(xlim)
        ax.set_xlabel("number of robots")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(frameon=False, fontsize=7)
    ax_u.set_ylabel("max displacement toward target (mm)")
    ax_u.set_title("(u) capacity: median, 95 % CI, runs")
    ax_v.set_ylim(0, tmax)
    ax_v.set_ylabel("time to target (s)")
    ax_v.set_title("(v) time to target: median, 95 % CI, runs")
    return fig


def _draw_series(
    ax_u: Any,
    ax_v: Any,
    series: str,
    sm: pd.DataFrame,
    runs: pd.DataFrame | None,
    col: str,
    lab: str,
    tmax: float,
) -> None:
    """One series of :func:`plot_scaling`: medians with their intervals on both panels,
    the fraction of runs that reached the target beside each point of (v), and the
    individual runs as small dots."""
    ax_u.errorbar(sm["n"], sm["maxdisp_median"],
                  yerr=_err(sm["maxdisp_median"], sm["maxdisp_ci_low"],
                            sm["maxdisp_ci_high"], float(sm["maxdisp_max"].max())),
                  fmt="o-", capsize=3, color=col, label=lab)  # fmt: skip
    med = sm["time_median"].astype(float)
    ok = med.notna()
    if ok.any():
        ax_v.errorbar(sm["n"][ok], med[ok],
                      yerr=_err(med[ok], sm["time_ci_low"][ok], sm["time_ci_high"][ok], tmax),
                      fmt="o-", capsize=3, color=col, label=lab)  # fmt: skip
    for _, r in sm.iterrows():
        y = (
            r["time_median"]
            if r["time_median"] is not None
            and np.isfinite(float(r["time_median"] if r["time_median"] is not None else np.nan))
            else tmax / 1.15
        )
        ax_v.annotate(f"{int(r['reached'])}/{int(r['seeds'])}", (r["n"], y),
                      textcoords="offset points", xytext=(4, 4), fontsize=7,
                      color=col)  # fmt: skip
    if runs is not None:
        rs = runs[runs["series"] == series] if "series" in runs else runs
        ax_u.plot(rs["n"], rs["max_displacement"], ".", color=col, alpha=0.35)
        rr = rs[rs["time_to_target"].notna()]
        ax_v.plot(rr["n"], rr["time_to_target"], ".", color=col, alpha=0.35)


def run_scaling(
    out: str | Path,
    setting: str = "quick",
    *,
    ns: Sequence[int] | None = None,
    seeds: int | Sequence[int] | None = None,
    target_distance: float | None = None,
    duration: float | None = None,
    horizon: float | None = None,
    series: str | None = None,
    variant: str = "free",
    executor: Executor | None = None,
    max_workers: int | None = None,
    overrides: dict[str, Any] | None = None,
    progress: bool | None = None,
    figure: bool = True,
) -> ScalingResult:
    """Run ``transport-free`` for each swarm size in ``ns`` over seeds into ``out``.

    ``target_distance`` (mm) sets ``target_y`` to the object's start plus this;
    ``horizon`` (s) is the window of the maximum displacement; ``series`` is
    ``"fixed"`` (the arena of ``overrides`` or the default) or ``"density"`` (the side
    scaled with ``sqrt(n)``); unset arguments come from the setting.  ``overrides``
    are further base parameters (dotted keys).  Writes ``out/scaling.json``,
    ``out/scaling.md`` and (``figure``) ``out/scaling.png``.
    """
    from thermoswarm.errors import ConfigError

    if setting not in SETTINGS:
        raise ConfigError(f"setting must be one of {sorted(SETTINGS)}, got {setting!r}")
    cfg = SETTINGS[setting]
    ns = list(cfg["ns"] if ns is None else ns)
    series = cfg["series"] if series is None else series
    if series not in ("fixed", "density"):
        raise ConfigError(f"series must be 'fixed' or 'density', got {series!r}")
    target_distance = cfg["target_distance"] if target_distance is None else target_distance
    horizon = cfg["horizon"] if horizon is None else horizon
    seed_list = list(range(cfg["seeds"])) if seeds is None else seeds
    if isinstance(seed_list, int):
        seed_list = list(range(seed_list))
    base: dict[str, Any] = {"variant": variant, "duration": duration or cfg["duration"],
                            "record.interval": cfg.get("record.interval", 5.0),
                            "record.netcdf": False, **(overrides or {})}  # fmt: skip
    from thermoswarm.fsutil import check_output_dir

    out = check_output_dir(out)  # missing parents are created with it
    bases = _size_bases(out, ns, base, series, float(target_distance), seed_list)
    with study_pool(executor, max_workers) as executor:
        rows = [
            row
            for n, b in bases
            for row in _scaling_rows(
                out, n, b, series, horizon, seed_list, executor, max_workers, progress
            )
        ]
    runs = pd.DataFrame(rows)
    setting_info = {"name": setting, "series": series, "seeds": list(seed_list), "base": base,
                    "target_distance": target_distance, "horizon": horizon}  # fmt: skip
    runs = _with_earlier_sizes(out, runs, setting_info, ns)
    ns = sorted(int(n) for n in runs["n"].unique())
    summary = summarize(runs)
    res = ScalingResult(runs=runs, summary=summary,
                        setting={"name": setting, "series": series, "ns": ns,
                                 "seeds": list(seed_list), "base": base,
                                 "target_distance": target_distance,
                                 "horizon": horizon})  # fmt: skip
    atomic_write_json(out / "scaling.json", res.to_dict())
    atomic_write_text(out / "scaling.md", res.table())
    if figure:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        fig = plot_scaling(res)
        with atomic_path(out / "scaling.png", suffix=".png") as tmp:
            fig.savefig(tmp, dpi=120, format="png")
        plt.close(fig)
    return res


def _size_bases(
    out: Path,
    ns: Sequence[int],
    base: dict[str, Any],
    series: str,
    target_distance: float,
    seed_list: Sequence[int],
) -> list[tuple[int, dict[str, Any]]]:
    """``(n, base parameters)`` of each size: the arena scaled with ``sqrt(n)`` for the
    ``density`` series, ``target_y`` the object's start plus ``target_distance`` (mm)
    unless ``base`` sets it; every size's runs checked (``expand``) before any runs."""
    from thermoswarm.config import from_mapping
    from thermoswarm.scenarios.transport_free import (
        DEFAULT_ARENA,
        TransportFreeParams,
        geometry,
    )
    from thermoswarm.sweep import SweepSpec, expand

    bases = []
    for n in ns:
        b = dict(base)
        if series == "density":
            side = arena_side(int(n))
            b.update(width=side, height=side)
        if "target_y" not in base:
            probe = {k: v for k, v in b.items() if "." not in k and not isinstance(v, dict)}
            # the highest valid target, so that the probe itself is valid in any arena
            height = b.get("height") or DEFAULT_ARENA[str(b.get("variant", "free"))][1]
            probe["target_y"] = float(height) - float(b.get("object_radius", 50.0))
            start_y = geometry(from_mapping(TransportFreeParams, {**probe, "n": n})).start[1]
            b["target_y"] = start_y + float(target_distance)
        expand(SweepSpec("transport-free", out / "runs", b, {"n": [n]}, seed_list))
        bases.append((n, b))
    return bases


def _scaling_rows(
    out: Path,
    n: int,
    b: dict[str, Any],
    series: str,
    horizon: float,
    seed_list: Sequence[int],
    executor: Executor | None,
    max_workers: int | None,
    progress: bool | None,
) -> list[dict[str, Any]]:
    """One row per run of size ``n`` (base ``b``), run or read back from ``out``: the
    largest displacement within ``horizon`` s of the release, the run's own maximum,
    final displacement and time to target (s)."""
    rows: list[dict[str, Any]] = []
    records = run_grid("transport-free", out, base=b, grid={"n": [n]}, seeds=seed_list,
                       executor=executor, max_workers=max_workers,
                       progress=progress)  # fmt: skip
    for r in records:
        m = r.metrics
        path = m["object_path"]
        t = np.asarray(path["time"], dtype=float)
        prog = np.asarray(path["progress"], dtype=float)
        within = prog[t <= m["warmup"] + horizon + 1e-9]
        rows.append(
            {
                "series": series,
                "n": r.params["n"],
                "arena": float(b.get("width") or 1800.0),
                "seed": r.seed,
                "max_displacement": float(within.max()) if within.size else math.nan,
                "max_displacement_run": m["max_displacement_toward_target"],
                "displacement": m["displacement_toward_target"],
                "time_to_target": m["time_to_target"],
                "target_y": m["target_y"],
                "run_dir": r.out,
            }
        )
    return rows


def _with_earlier_sizes(
    out: Path, runs: pd.DataFrame, setting_info: dict[str, Any], ns: Sequence[int]
) -> pd.DataFrame:
    """``runs`` with the runs of other sizes that an earlier study of the same setting
    left in ``out/scaling.json`` (sorted by size and seed)."""
    old = out / "scaling.json"
    if old.is_file():  # sizes run earlier into this directory with the same setting stay
        prev = load_scaling(out)
        same = {k: prev.setting.get(k) for k in setting_info} == json_roundtrip(setting_info)
        if same and len(prev.runs):
            keep = prev.runs[~prev.runs["n"].isin(ns)]
            runs = pd.concat([keep, runs], ignore_index=True).sort_values(["n", "seed"])
            runs = runs.reset_index(drop=True)
    return runs


def json_roundtrip(value: Any) -> Any:
    """``value`` as it reads back from JSON (tuples become lists, keys strings)."""
    import json

    return json.loads(json.dumps(value))


def load_scaling(path: str | Path) -> ScalingResult:
    """A :class:`ScalingResult` from a study directory's ``scaling.json``."""
    import json

    data = json.loads((Path(path) / "scaling.json").read_text())
    return ScalingResult(runs=pd.DataFrame(data["runs"]), summary=pd.DataFrame(data["summary"]),
                         setting=data["setting"])  # fmt: skip
