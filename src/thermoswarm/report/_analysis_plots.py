"""The analysis figures, in the manner of the paper's panels: the energy density and
survival with the fits, one panel per group, the steering rate per energy bin and its
trend, the regions coloured by the hot phase.

Part of :mod:`thermoswarm.report.analysis_figures` (which re-exports every public name
and builds ``report.html`` from them); every function draws on
:class:`matplotlib.figure.Figure` objects (no pyplot, no global state).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from thermoswarm.analysis.phase_tests import PhaseComparison
from thermoswarm.analysis.study import StudyResult

_MAX_POINTS = 20_000


def fmt_value(value: float | None, spec: str = ".3g", missing: str = "n/a") -> str:
    """Format a number for a report; a missing or non-finite value is written as ``missing``."""
    if value is None or not math.isfinite(value):
        return missing
    return format(value, spec)


def energy_axis(unit: str) -> tuple[float, str]:
    """Display factor and axis label for energies in ``unit`` (J shown in 1e-10 J)."""
    if unit == "J":
        return 1e10, "energy E (10$^{-10}$ J)"
    return 1.0, "energy E = v$^2$/2 (mm$^2$/s$^2$)"


def _hist(ax: Any, x: np.ndarray, scale: float, bins: int, color: str, label: str | None):
    x = np.asarray(x, dtype=float) * scale
    x = x[np.isfinite(x)]
    if x.size == 0:
        return None, None
    hi = float(np.quantile(x, 0.999)) if x.size > 1000 else float(x.max())
    hi = hi if hi > 0 else 1.0
    dens, edges = np.histogram(x, bins=bins, range=(0.0, hi))
    dens = dens / (x.size * np.diff(edges))
    centers = 0.5 * (edges[1:] + edges[:-1])
    ok = dens > 0
    ax.plot(centers[ok], dens[ok], "o", ms=3, color=color, alpha=0.7, label=label)
    if not ok.any():
        return hi, None
    return hi, (float(dens[ok].min()) / 5.0, float(dens[ok].max()) * 5.0)


def plot_density_fit(
    ax: Any,
    model: Any,
    x: Any = None,
    *,
    bins: int = 60,
    scale: float = 1.0,
    components: bool = True,
    xmax: float | None = None,
    color: str = "0.3",
) -> Any:
    """Histogram density of ``x`` (points) and fitted densities (lines), log-y.

    ``model``: an :class:`~thermoswarm.analysis.fit.ExponentialFit`,
    :class:`~thermoswarm.analysis.fit.ExponentialMixtureFit` or a
    :class:`~thermoswarm.analysis.fit.PhaseComparison` (both fits drawn).  ``scale``
    multiplies the x axis (e.g. 1e10 for J shown in 1e-10 J).
    """
    hi = ymin = None
    if x is not None:
        hi, ymin = _hist(ax, x, scale, bins, color, "data")
    if xmax is not None:
        hi = xmax * scale
    if hi is None:
        hi = scale * 5 * (model.one.kT_ if isinstance(model, PhaseComparison) else _mean(model))
    grid = np.linspace(0, hi, 400)
    native = grid / scale
    fits: list[tuple[Any, str, str]] = []
    if isinstance(model, PhaseComparison):
        fits = [(model.one, "C0", "--"), (model.two, "C3", "-")]
    else:
        fits = [(model, "C3", "-")]
    for m, c, ls in fits:
        curves = m.density_curves(native, label_scale=scale)
        label = curves["label"]
        ax.plot(grid, curves["total"] / scale, ls, color=c, lw=1.6, label=label)
        if components and len(curves["components"]) > 1:
            for _, _, comp in curves["components"]:
                ax.plot(grid, comp / scale, ":", color=c, lw=1)
    ax.set_yscale("log")
    ax.set_xlim(0, hi)
    if ymin is not None:  # the data's range: a mixture's spike at zero must not hide it
        ax.set_ylim(ymin[0], ymin[1])
    ax.set_ylabel("probability density")
    return ax


def _mean(model: Any) -> float:
    if hasattr(model, "kT_"):
        return model.kT_
    return model.law_.mean()


def _survival(ax: Any, x: np.ndarray, cmp_: Any, scale: float) -> None:
    xs = np.sort(np.asarray(x, dtype=float))
    n = xs.size
    idx = np.unique(np.linspace(0, n - 1, min(n, _MAX_POINTS)).astype(np.int64))
    ax.plot(xs[idx] * scale, 1.0 - idx / n, ".", ms=2, color="0.3", label="data")
    grid = np.linspace(0, xs[idx[-1]], 300)
    ax.plot(grid * scale, 1 - cmp_.one.cdf(grid), "--", color="C0", label="1 phase")
    ax.plot(grid * scale, 1 - cmp_.two.cdf(grid), "-", color="C3", label="2 phases")
    ax.set_yscale("log")
    ax.set_ylim(max(0.5 / n, 1e-7), 1.2)
    ax.set_ylabel("P(E > e)")


def energy_figure(cmp_: Any, x: np.ndarray, unit: str) -> Figure:
    """Energy density and survival function with the one- and two-phase fits."""
    scale, label = energy_axis(unit)
    fig = Figure(figsize=(10, 4), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2)
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x) & (x > 0)]
    plot_density_fit(ax1, cmp_, x, scale=scale)
    ax1.set_xlabel(label)
    ax1.legend(fontsize=7)
    ax1.set_title("energy density (log scale)")
    _survival(ax2, x, cmp_, scale)
    ax2.set_xlabel(label)
    ax2.legend(fontsize=7)
    ax2.set_title("survival function")
    return fig


def _grid(n: int, ncols: int = 4) -> tuple[int, int]:
    ncols = min(ncols, max(n, 1))
    return math.ceil(n / ncols), ncols


def groups_figure(
    spec: str, groups: dict[str, Any], levels: dict[str, Any], energy: np.ndarray,
    valid: np.ndarray, unit: str, max_panels: int = 12,
) -> Figure:  # fmt: skip
    """One density panel per group, the overlaid fitted densities, KS one vs two."""
    scale, label = energy_axis(unit)
    labels = [lab for lab in groups["labels"] if groups["fits"].get(lab) is not None]
    shown = labels[:max_panels]
    n_panels = len(shown) + 2
    rows, cols = _grid(n_panels)
    fig = Figure(figsize=(3.2 * cols, 2.8 * rows), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, cols)).ravel()
    codes = groups["codes"]
    hi = 0.0
    for k, lab in enumerate(shown):
        j = groups["labels"].index(lab)
        x = energy[valid & (codes == j)]
        x = x[x > 0]
        ax = axes[k]
        plot_density_fit(ax, groups["fits"][lab], x, scale=scale, components=False)
        lv = levels[lab]
        ks1 = lv["one_phase"]["naive"]["ks"]
        ks2 = lv["two_phase"]["naive"]["ks"]
        ax.set_title(f"{lab}\nKS 1 phase {ks1:.3f}, 2 phases {ks2:.3f}", fontsize=8)
        ax.set_xlabel(label, fontsize=7)
        ax.tick_params(labelsize=7)
        hi = max(hi, ax.get_xlim()[1])
    ax = axes[len(shown)]
    grid = np.linspace(0, hi if hi > 0 else 1.0, 300)
    for lab in shown:
        m = groups["fits"][lab].two
        ax.plot(grid, m.pdf(grid / scale) / scale, lw=1.2, label=lab)
    ax.set_yscale("log")
    ax.set_title("fitted two-phase densities", fontsize=8)
    ax.set_xlabel(label, fontsize=7)
    if len(shown) <= 10:
        ax.legend(fontsize=6)
    ax = axes[len(shown) + 1]
    ks1 = [levels[lab]["one_phase"]["naive"]["ks"] for lab in labels]
    ks2 = [levels[lab]["two_phase"]["naive"]["ks"] for lab in labels]
    for a, b in zip(ks1, ks2, strict=True):
        ax.plot([0, 1], [a, b], "-", color="0.7", lw=0.8)
    ax.plot(np.zeros(len(ks1)), ks1, "o", color="C0")
    ax.plot(np.ones(len(ks2)), ks2, "o", color="C3")
    ax.set_xticks([0, 1], ["1 phase", "2 phases"])
    ax.set_xlim(-0.5, 1.5)
    ax.set_ylabel("KS distance (all samples)", fontsize=7)
    ax.set_title("KS of 1 vs 2 phase fits", fontsize=8)
    for ax in axes[n_panels:]:
        ax.set_visible(False)
    fig.suptitle(f"energy by group: {spec}", fontsize=10)
    return fig


def steering_figure(steering: dict[str, Any], keep: dict[str, Any], kin: Any, unit: str) -> Figure:
    """``|steering rate|`` per bin with exponential fits, and kT_theta versus energy."""
    scale, label = energy_axis(unit)
    bins = steering["bins"]
    n_panels = len(bins) + 1
    rows, cols = _grid(n_panels)
    fig = Figure(figsize=(3.2 * cols, 2.8 * rows), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, cols)).ravel()
    mag = np.abs(kin["steering_rate"].values)
    for k, b in enumerate(bins):
        ax = axes[k]
        fit = keep["fits"][k]
        if fit is None:
            ax.set_title(f"bin {k}: too few samples", fontsize=8)
            continue
        x = mag[keep["masks"][k]]
        x = x[x > 0]
        plot_density_fit(ax, fit, x, bins=40)
        ptxt = fmt_value(b["p_value"], ".2g", missing="-")
        ax.set_title(
            f"E~{b['energy_center'] * scale:.3g}: kT$_\\theta$={b['kT_theta']:.3g} rad/s\n"
            f"KS {b['ks']:.3f} (n={b['n']}), p={ptxt}",
            fontsize=8,
        )
        ax.set_xlabel("|steering rate| (rad/s)", fontsize=7)
        ax.tick_params(labelsize=7)
    ax = axes[len(bins)]
    ok = [b for b in bins if b.get("kT_theta") is not None]
    if ok:
        xc = np.array([b["energy_center"] for b in ok]) * scale
        y = np.array([b["kT_theta"] for b in ok])
        se = np.array([b["kT_theta_se"] for b in ok])
        ax.errorbar(xc, y, yerr=2 * se, fmt="o", color="C3", capsize=2)
        tr = steering.get("trend", {})
        if tr.get("slope") is not None:
            g = np.linspace(0, xc.max() * 1.05, 50)
            ax.plot(g, tr["intercept"] + tr["slope"] * g / scale, "-", color="0.3")
            ax.set_title(
                f"kT$_\\theta$ vs energy: slope {tr['slope'] * (1 / scale):.3g}, "
                f"p={fmt_value(tr.get('p_value'), '.2g')}",
                fontsize=8,
            )
    ax.set_xlabel(label, fontsize=7)
    ax.set_ylabel("kT$_\\theta$ (rad/s), $\\pm$2 SE", fontsize=7)
    for ax in axes[n_panels:]:
        ax.set_visible(False)
    return fig


def regions_figure(result: StudyResult, max_points: int = 5000) -> Figure:
    """Regions with step midpoints coloured by P(hot phase); hot fraction per region."""
    kin = result.kinematics
    reg = result.fits["regions"]
    fig = Figure(figsize=(10, 4), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2)
    valid = kin["valid"].values & (kin["energy"].values > 0)
    xm = kin["x_mid"].values[valid]
    ym = kin["y_mid"].values[valid]
    e = kin["energy"].values[valid]
    if xm.size:
        idx = np.random.default_rng(0).choice(xm.size, min(xm.size, max_points), replace=False)
        mix = result.energy.two if result.energy is not None else None
        if mix is not None and not mix.degenerate_:
            c = mix.predict_proba(e[idx])
            sc = ax1.scatter(xm[idx], ym[idx], c=c, s=2, cmap="coolwarm", vmin=0, vmax=1)
            fig.colorbar(sc, ax=ax1, label="P(hot phase)")
        else:
            ax1.scatter(xm[idx], ym[idx], s=2, color="0.5")
    for r in result.regions:
        v = np.vstack([r.vertices, r.vertices[:1]])
        ax1.plot(v[:, 0], v[:, 1], "-", lw=1.5)
        cx, cy = r.vertices.mean(axis=0)
        ax1.annotate(r.name, (cx, cy), ha="center", fontsize=8)
    ax1.set_aspect("equal", adjustable="datalim")
    ax1.set_xlabel("x (mm)")
    ax1.set_ylabel("y (mm)")
    ax1.set_title("step midpoints and regions")
    names = [n for n, lv in reg.get("levels", {}).items() if lv.get("high_T_fraction") is not None]
    if names:
        f = np.array([reg["levels"][n]["high_T_fraction"] for n in names])
        lo = np.array([reg["levels"][n].get("ci_low") or np.nan for n in names])
        hi = np.array([reg["levels"][n].get("ci_high") or np.nan for n in names])
        yerr = np.vstack([f - lo, hi - f])
        ax2.bar(range(len(names)), f, color="C3", alpha=0.7)
        if np.all(np.isfinite(yerr)):
            ax2.errorbar(range(len(names)), f, yerr=yerr, fmt="none", color="k", capsize=3)
        ax2.set_xticks(range(len(names)), names)
        ax2.set_ylim(0, 1)
    ax2.set_ylabel("fraction in the hot phase")
    ax2.set_title("hot-phase fraction per region (track-bootstrap CI)")
    return fig
