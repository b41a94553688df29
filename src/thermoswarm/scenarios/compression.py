"""``compression``: Algorithm 3 between two walls pushed by a constant force.

``n`` robots (Boltzmann speed at constant ``kT``, uniform heading re-drawn every ``tau``)
between static side walls and a top and a bottom wall, each pushed toward the robots by
a constant force and sliding vertically (``walls = "force"``) or held in place
(``walls = "held"``).  The claim: the swarm's pressure-area relation is an ideal gas's at
``kT_eff = drag <v^2> tau / 4``, and at fixed density the pressure grows with ``kT``.

Units: mm, s; forces in units of the robot drag (drag 1: force = mm/s); pressure is
force per mm of wall.  Pressure and height are batch means after ``settle`` seconds
(batches a few relaxation times ``h^2 / (pi^2 D)`` long).  The sweeps of this experiment
(isotherm, pressure against temperature, temperature at fixed density) are in
:mod:`thermoswarm.sweep.compression`; :func:`study_figure` draws their tables.  Physics,
metrics keys and measurements: ``docs/scenarios_road_compression.md``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import xarray as xr

from thermoswarm.config import check, check_positive
from thermoswarm.maxent import kT_for_mean_speed, speed_law
from thermoswarm.policy import BoltzmannUniform
from thermoswarm.scenarios._compression_measure import batch_means, measure
from thermoswarm.scenarios.base import Numerics, Recording, Scenario, Setup
from thermoswarm.scenarios.registry import register
from thermoswarm.sim import kernels as K
from thermoswarm.sim.engine import Simulator, SwarmState, place_lattice
from thermoswarm.sim.world import Piston, box_world

__all__ = [
    "CompressionParams",
    "Compression",
    "ideal_height",
    "place_uniform",
    "batch_means",
    "measure",
    "linear_fit",
    "plot_frame",
    "plot_isotherm",
    "plot_pressure_temperature",
    "plot_temperature_for_density",
    "study_figure",
]

#: Most sub-batches a run keeps (bounds the checkpointed accumulators).
MAX_SUB_BATCHES = 4096


@dataclass(frozen=True)
class CompressionParams:
    """Parameters of ``compression`` (lengths mm, times s, forces in drag units).

    Attributes
    ----------
    n : int
        Number of robots.
    width : float
        Distance between the side walls ``Lx`` (mm).
    force : float
        Force ``F`` pushing each of the two walls toward the robots (drag units, > 0).
    kT : float
        Temperature of Algorithm 3 (mm^2/s^2 per unit mass); default mean speed 10 mm/s.
    tau : float
        Control period (s).
    diameter : float
        Robot diameter ``d`` (mm).
    speed_law : {"boltzmann", "half-normal"}
        The speed law (PAPER_NOTES 6.1).
    walls : {"force", "held"}
        Walls pushed by ``force`` and free to move, or held at ``height``.
    height : float or None
        Initial (held: fixed) wall separation ``Ly`` (mm); default the ideal-gas
        height ``n kT_eff / F + d`` for the expected ``kT_eff``.
    wall_drag : float
        Drag of each moving wall (drag units): a free wall moves at ``F / wall_drag``.
    max_height : float or None
        Largest wall separation the walls may reach (mm); default
        ``max(4 height, height + 20 d)``.  The walls start in the middle; this bounds
        how far the whole column may drift (it diffuses slowly: both walls move);
        ``at_limit_fraction`` reports steps with a wall at a limit.
    settle : float or None
        Seconds left out of the averages; default ``min(duration / 5, 3 t_relax)``
        with the expected relaxation time.
    batch_relaxations : float
        Batch length in relaxation times ``t_relax``.
    min_batches : int
        Fewest batches for the standard errors.
    duration : float
        Simulated seconds.
    """

    n: int = 100
    width: float = 4000.0
    force: float = 20.0
    kT: float = field(default_factory=lambda: round(kT_for_mean_speed(10.0), 6))
    tau: float = 1.0
    diameter: float = 33.0
    speed_law: Literal["boltzmann", "half-normal"] = "boltzmann"
    walls: Literal["force", "held"] = "force"
    height: float | None = None
    wall_drag: float = 10.0
    max_height: float | None = None
    settle: float | None = None
    batch_relaxations: float = 5.0
    min_batches: int = 8
    duration: float = 3000.0
    engine: Numerics = Numerics()
    record: Recording = Recording(interval=5.0, block=100)

    def __post_init__(self) -> None:
        fin = math.isfinite
        check(self.n >= 1, "n", "a positive integer (number of robots)", self.n)
        check_positive("diameter", self.diameter, "a positive length (mm)")
        check(
            fin(self.width) and self.width > 2 * self.diameter,
            "width",
            f"more than two robot diameters ({2 * self.diameter:g} mm)",
            self.width,
        )
        check_positive("force", self.force, "a positive force (drag units, mm/s for drag 1)")
        check_positive("kT", self.kT, "a positive number (mm^2/s^2)")
        check_positive("tau", self.tau, "a positive number of seconds")
        check(self.walls in ("force", "held"), "walls", "'force' or 'held'", self.walls)
        if self.height is not None:
            check(
                fin(self.height) and self.height > 1.5 * self.diameter,
                "height",
                f"more than 1.5 robot diameters ({1.5 * self.diameter:g} mm)",
                self.height,
            )
        check_positive("wall_drag", self.wall_drag, "a positive drag (drag units)")
        if self.max_height is not None:
            check(
                fin(self.max_height) and self.max_height >= self.initial_height,
                "max_height",
                f"at least the initial height {self.initial_height:g} mm",
                self.max_height,
            )
        if self.settle is not None:
            check(
                fin(self.settle) and 0 <= self.settle < self.duration,
                "settle",
                f"in [0, duration = {self.duration:g}) s",
                self.settle,
            )
        check_positive("batch_relaxations", self.batch_relaxations, "a positive number")
        check(2 <= self.min_batches <= 1000, "min_batches", "an integer in [2, 1000]",
              self.min_batches)  # fmt: skip
        check_positive("duration", self.duration, "a positive number of seconds")

    @property
    def radius(self) -> float:
        return self.diameter / 2

    @property
    def kT_eff_theory(self) -> float:
        """``drag <v^2> tau / 4`` for the speed law (drag 1), mm^2/s."""
        return speed_law(self.speed_law, self.kT).mean_square() * self.tau / 4

    @property
    def initial_height(self) -> float:
        if self.height is not None:
            return self.height
        return ideal_height(self.n, self.kT_eff_theory, self.force, self.diameter)

    @property
    def limit_height(self) -> float:
        if self.max_height is not None:
            return self.max_height
        h = self.initial_height
        return max(4 * h, h + 20 * self.diameter)


def ideal_height(n: int, kT_eff: float, force: float, diameter: float) -> float:
    """Wall separation (mm) where an ideal gas of ``n`` discs balances ``force`` on each
    wall: ``P (Lx - d) = F`` and ``P (Lx - d)(Ly - d) = n kT_eff`` give
    ``Ly = n kT_eff / F + d``."""
    return n * kT_eff / force + diameter


def place_uniform(
    bounds: tuple[float, float, float, float], n: int, radius: float, rng: np.random.Generator
) -> np.ndarray:
    """``n`` non-overlapping discs at uniformly random places in ``bounds`` (mm).

    Random sequential addition: uniform candidates, each kept if it overlaps no disc
    kept before (a grid of cells one diameter wide finds the neighbours).  A gas starts
    spread evenly between the walls this way; a lattice would leave one wall without
    robots when its spacing exceeds the height.  Above a packing fraction of 0.3, or
    when candidates keep failing, it falls back to the jittered lattice of
    :func:`thermoswarm.sim.engine.place_lattice`.
    """
    x0, y0, x1, y1 = bounds
    d = 2 * radius
    lo = np.array([x0 + radius, y0 + radius])
    hi = np.array([x1 - radius, y1 - radius])
    area = (x1 - x0) * (y1 - y0)
    if n == 0 or np.any(hi < lo) or n * math.pi * radius**2 > 0.3 * area:
        return place_lattice(bounds, n, radius, rng)
    cells: dict[tuple[int, int], list[int]] = {}
    out = np.empty((n, 2))
    k = 0
    for _ in range(50):
        cand = lo + (hi - lo) * rng.random((4 * n, 2))
        for x, y in cand:
            cx, cy = int((x - x0) // d), int((y - y0) // d)
            ok = True
            for i in range(cx - 1, cx + 2):
                for j in range(cy - 1, cy + 2):
                    for q in cells.get((i, j), ()):
                        if (out[q, 0] - x) ** 2 + (out[q, 1] - y) ** 2 < d * d:
                            ok = False
                            break
                    if not ok:
                        break
                if not ok:
                    break
            if ok:
                out[k] = x, y
                cells.setdefault((cx, cy), []).append(k)
                k += 1
                if k == n:
                    return out
    return place_lattice(bounds, n, radius, rng)


# --------------------------------------------------------------------------------------
# Pure metric helpers (tested on constructed cases)


def linear_fit(x: Sequence[float], y: Sequence[float]) -> dict[str, float]:
    """Least-squares line ``y = slope x + intercept`` with ``r2``, the slope's standard
    error and the slope of the fit through the origin (``slope0``)."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.size < 2 or np.ptp(x) == 0:
        raise ValueError("a line needs at least two distinct x values")
    A = np.column_stack([x, np.ones_like(x)])
    (slope, intercept), *_ = np.linalg.lstsq(A, y, rcond=None)
    resid = y - (slope * x + intercept)
    ss_res = float(resid @ resid)
    ss_tot = float(((y - y.mean()) ** 2).sum())
    dof = x.size - 2
    se = math.sqrt(ss_res / dof / float(((x - x.mean()) ** 2).sum())) if dof > 0 else math.nan
    return {
        "slope": float(slope),
        "intercept": float(intercept),
        "r2": 1.0 - ss_res / ss_tot if ss_tot > 0 else 1.0,
        "slope_se": se,
        "slope0": float(x @ y / (x @ x)),
        "n": int(x.size),
    }


# --------------------------------------------------------------------------------------
# The scenario


@register
class Compression(Scenario):
    name = "compression"
    description = "Algorithm 3 between two walls pushed by a constant force (ideal-gas law)"
    Params = CompressionParams

    def build(self, rng: np.random.Generator) -> Setup:
        p: CompressionParams = self.params
        r = p.radius
        Lx = p.width
        h0 = p.initial_height
        H = p.limit_height
        y0 = 0.5 * (H - h0)
        drag = math.inf if p.walls == "held" else p.wall_drag
        force = 0.0 if p.walls == "held" else p.force
        # travel limits: the box [0, H]; the robots between the walls keep them apart
        top = Piston(axis=1, position=y0 + h0, side=-1, lo=0.0, hi=Lx, force=force,
                     drag=drag, limits=(2 * r, H))  # fmt: skip
        bottom = Piston(axis=1, position=y0, side=+1, lo=0.0, hi=Lx, force=force,
                        drag=drag, limits=(0.0, H - 2 * r))  # fmt: skip
        world = box_world(Lx, H, pistons=(top, bottom))
        engine = p.engine.engine(tau=p.tau, radius=r)
        pos = place_uniform((0.0, y0, Lx, y0 + h0), p.n, r, rng)
        steps = int(math.floor(p.duration / engine.dt + 1e-9))
        sub = max(1, math.ceil(steps / MAX_SUB_BATCHES))
        self._sub = sub
        return Setup(
            world=world,
            engine=engine,
            policy=BoltzmannUniform(kT=p.kT, speed_law=p.speed_law),
            positions=pos,
            info={"sub_steps": sub, "n_sub": math.ceil(steps / sub), "height_max": H},
        )

    def extras(self, setup: Setup) -> dict[str, tuple[tuple[str, ...], tuple[int, ...], str]]:
        out = super().extras(setup)
        out["walls"] = (("time", "wall"), (2,), "f8")
        return out

    def extra_coords(self, setup: Setup) -> dict[str, list[str]]:
        return {"wall": ["top", "bottom"]}

    def frame(
        self, sim: Simulator, state: SwarmState, acc: dict[str, np.ndarray]
    ) -> dict[str, np.ndarray]:
        out = super().frame(sim, state, acc)
        out["walls"] = state.piston_pos.copy()
        return out

    def init_acc(self, setup: Setup, sim: Simulator, state: SwarmState) -> dict[str, np.ndarray]:
        k = int(setup.info["n_sub"])
        return {
            "f_top": np.zeros(k),  # sums over the steps of each sub-batch
            "f_bottom": np.zeros(k),
            "height": np.zeros(k),
            "v2": np.zeros(k),
            "steps": np.zeros(k, np.int64),
            "at_limit": np.zeros(1, np.int64),
        }

    def observe(self, sim: Simulator, state: SwarmState, acc: dict[str, np.ndarray]) -> None:
        j = (state.step - 1) // self._sub
        if j >= acc["steps"].size:
            return
        f = state.piston_force  # along +y: robots push the top wall up, the bottom down
        acc["f_top"][j] += f[0]
        acc["f_bottom"][j] -= f[1]
        pp = state.pistons
        y = state.piston_pos
        acc["height"][j] += y[0] - y[1]
        acc["v2"][j] += float(np.dot(state.speed, state.speed)) / state.n
        acc["steps"][j] += 1
        if self.params.walls == "force":
            lim = (y <= pp[:, K.PLL] + 1e-9) | (y >= pp[:, K.PLH] - 1e-9)
            if lim.any():
                acc["at_limit"][0] += 1

    def metrics(
        self,
        setup: Setup,
        acc: dict[str, np.ndarray],
        tracks: xr.Dataset,
        sim: Simulator,
        state: SwarmState,
    ) -> dict[str, Any]:
        p: CompressionParams = self.params
        dt = sim.params.dt
        sub = int(setup.info["sub_steps"])
        d = p.diameter
        Lx = p.width
        m = measure(
            acc,
            sub_steps=sub,
            dt=dt,
            n=p.n,
            width=Lx,
            diameter=d,
            tau=p.tau,
            drag=sim.params.drag,
            settle=p.settle,
            duration=float(state.step) * dt,
            batch_relaxations=p.batch_relaxations,
            min_batches=p.min_batches,
            expected_D=p.kT_eff_theory / sim.params.drag,
        )
        out: dict[str, Any] = {
            "n": p.n,
            "walls": p.walls,
            "force": p.force if p.walls == "force" else None,
            "kT": p.kT,
            "tau": p.tau,
            "width": Lx,
            "diameter": d,
            **m,
            "pressure_applied": p.force / (Lx - d) if p.walls == "force" else None,
            "kT_eff_theory": p.kT_eff_theory,
            "ideal_height": ideal_height(p.n, m["kT_eff"], p.force, d)
            if p.walls == "force"
            else None,
            "at_limit_fraction": float(acc["at_limit"][0]) / max(state.step, 1),
            "geometry": {
                "width": Lx,
                "height_max": float(setup.info["height_max"]),
                "radius": p.radius,
            },
        }
        return out


# --------------------------------------------------------------------------------------
# Drawing


def plot_frame(
    ax: Any,
    tracks: xr.Dataset,
    t: float,
    setup_info: dict[str, Any],
    *,
    cmap: str = "viridis",
) -> Any:
    """Draw the walls and the robots (coloured by commanded speed, mm/s) at the recorded
    frame nearest ``t`` (s).  ``setup_info`` is ``metrics["geometry"]``.  Returns the
    collection of robot discs."""
    from matplotlib.collections import EllipseCollection

    k = int(np.argmin(np.abs(tracks["time"].values - t)))
    fr = tracks.isel(time=k)
    pos = fr["position"].isel(keypoints=0).transpose("individuals", "space").values
    W = float(setup_info["width"])
    H = float(setup_info["height_max"])
    r = float(setup_info["radius"])
    ytop, ybot = (float(v) for v in fr["walls"].values)
    ax.plot([0, 0], [0, H], "k-", lw=1.5)
    ax.plot([W, W], [0, H], "k-", lw=1.5)
    for y in (ytop, ybot):
        ax.plot([0, W], [y, y], color="tab:red", lw=3)
    d = np.full(pos.shape[0], 2 * r)
    coll = EllipseCollection(
        d, d, np.zeros_like(d), units="xy", offsets=pos, offset_transform=ax.transData
    )
    coll.set_array(fr["speed"].values.astype(float))
    coll.set_cmap(cmap)
    coll.set_edgecolor("k")
    coll.set_linewidth(0.3)
    ax.add_collection(coll)
    pad = 0.05 * (ytop - ybot)
    ax.set_xlim(-0.02 * W, 1.02 * W)
    ax.set_ylim(ybot - pad, ytop + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(f"t = {float(tracks['time'].values[k]):.0f} s")
    return coll


def plot_isotherm(ax: Any, table: Any) -> None:
    """Pressure versus free area (points with error bars) and the ideal-gas curve
    ``P = n kT_eff / A_free`` at the runs' mean ``kT_eff``."""
    t = table.dropna(subset=["pressure"])
    ax.errorbar(t["free_area"], t["pressure"], yerr=t["pressure_se"], fmt="o", label="swarm")
    a = np.linspace(0.8 * t["free_area"].min(), 1.2 * t["free_area"].max(), 200)
    nk = float((t["n"] * t["kT_eff"]).mean())
    ax.plot(a, nk / a, "k--", label=r"ideal gas $n kT_{eff}/A_{free}$")
    ax.set_xlabel(r"free area $A_{free}$ (mm$^2$)")
    ax.set_ylabel("pressure (drag units / mm)")
    ax.legend()


def plot_pressure_temperature(ax: Any, table: Any) -> dict[str, float]:
    """Pressure versus ``kT_eff`` with the least-squares line; returns the fit."""
    t = table.dropna(subset=["pressure"])
    fit = linear_fit(t["kT_eff"], t["pressure"])
    ax.errorbar(t["kT_eff"], t["pressure"], yerr=t["pressure_se"], fmt="o")
    x = np.linspace(0, 1.05 * t["kT_eff"].max(), 50)
    ax.plot(x, fit["slope"] * x + fit["intercept"], "k--", label=f"fit, R² = {fit['r2']:.4f}")
    ax.set_xlabel(r"$kT_{eff}$ (mm$^2$/s)")
    ax.set_ylabel("pressure (drag units / mm)")
    ax.legend()
    return fit


def plot_temperature_for_density(ax: Any, table: Any) -> dict[str, float]:
    """Temperature that holds the density fixed versus force (panel w); returns the fit."""
    t = table.dropna(subset=["pressure"])
    fit = linear_fit(t["force"], t["kT"])
    ax.plot(t["force"], t["kT"], "o")
    x = np.linspace(0, 1.05 * t["force"].max(), 50)
    ax.plot(x, fit["slope"] * x + fit["intercept"], "k--", label=f"fit, R² = {fit['r2']:.4f}")
    ax.set_xlabel("force on each wall (drag units)")
    ax.set_ylabel(r"$kT$ (mm$^2$/s$^2$)")
    ax.legend()
    return fit


def study_figure(isotherm_table: Any = None, temperature_table: Any = None,
                 density_table: Any = None) -> Any:  # fmt: skip
    """A figure with a panel for each table given (isotherm, P vs T, T vs F)."""
    import matplotlib.pyplot as plt

    panels = [
        (isotherm_table, plot_isotherm, "isotherm"),
        (temperature_table, plot_pressure_temperature, "pressure vs temperature"),
        (density_table, plot_temperature_for_density, "T at fixed density"),
    ]
    panels = [p for p in panels if p[0] is not None]
    fig, axes = plt.subplots(1, max(len(panels), 1), figsize=(4.5 * max(len(panels), 1), 3.8))
    axes = np.atleast_1d(axes)
    for ax, (tab, fn, title) in zip(axes, panels, strict=False):
        fn(ax, tab)
        ax.set_title(title)
    fig.tight_layout()
    return fig
