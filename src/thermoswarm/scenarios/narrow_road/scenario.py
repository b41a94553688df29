"""The ``narrow-road`` scenario: building the road and swarm, re-entry, the metrics.

Two groups cross a road with a narrow section (Algorithm 2); a robot that arrives, or
leaves across its own start end, is put back at its start (or waits off the road until
a spot frees up).  See ``docs/scenarios_road_compression.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.policy import Action, NarrowRoad, Observation, Policy
from thermoswarm.scenarios.base import Scenario, Setup, wrap
from thermoswarm.scenarios.narrow_road.geometry import (
    RoadGeometry,
    _inside,
    road_geometry,
    road_n,
    section_index,
)
from thermoswarm.scenarios.narrow_road.metrics import (
    _summary,
    flow_series,
    longest_gap,
    section_stats,
)
from thermoswarm.scenarios.narrow_road.params import DIRECTIONS, NarrowRoadParams
from thermoswarm.scenarios.registry import register
from thermoswarm.sim.engine import Simulator, SwarmState, place_lattice
from thermoswarm.sim.light import DirectionalLight, SensingParams, sense
from thermoswarm.sim.world import World

__all__ = ["NarrowRoadScenario"]


class _Sensing:
    """Heading 0 along +x: exact (ideal, no noise) or from the light module."""

    def __init__(self, params: SensingParams) -> None:
        self.params = params
        self.light = DirectionalLight(direction=(-1.0, 0.0))  # rays travel -x: source at +x
        self.exact = params.mode == "ideal" and params.ideal_noise_deg == 0

    def __call__(self, state: SwarmState, index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        m = index.size
        if self.exact:
            return np.zeros(m), np.ones(m)
        res = sense(
            state.pos[index], state.heading[index], self.light, None, self.params, state.rng
        )
        return res.zero_heading, res.light


@dataclass(frozen=True)
class _DepotStop:
    """Wraps a policy: robots waiting off the road (below ``depot_line``) stand still."""

    inner: Policy
    depot_line: float

    def act(self, obs: Observation, rng: np.random.Generator) -> Action:
        a = self.inner.act(obs, rng)
        parked = obs.position[:, 1] < self.depot_line
        if parked.any():
            speed = np.where(parked, 0.0, a.speed)
            return Action(heading=a.heading, speed=speed)
        return a


@register
class NarrowRoadScenario(Scenario):
    name = "narrow-road"
    description = (
        "two groups cross a road with a narrow section (Algorithm 2); re-entry at the start"
    )
    Params = NarrowRoadParams

    def robot_count(self) -> tuple[str, int]:
        p: NarrowRoadParams = self.params
        return ("n" if p.n is not None else "n (occupation x road area / robot area)"), road_n(p)

    def build(self, rng: np.random.Generator) -> Setup:
        p: NarrowRoadParams = self.params
        n = road_n(p)
        geo = road_geometry(p, n)
        r = p.radius
        world = World(geo.bounds, geo.segments)
        engine = p.engine.engine(tau=p.tau, radius=r)
        road_box = (0.0, -geo.widths.max() / 2, geo.length, geo.widths.max() / 2)
        pos = place_lattice(road_box, n, r, rng, inside=lambda q: _inside(geo, q, r * 1.001))
        group = np.zeros(n, np.int32)
        group[(n + 1) // 2 :] = 1
        # initial headings toward the goals (the first decision re-draws them anyway)
        headings = np.where(group == 0, 0.0, math.pi)
        policy = NarrowRoad(
            kT=p.kT,
            steering=p.steering,
            sigma=math.radians(p.sigma_deg),
            T_theta_max=p.T_theta_max,
            T_theta_min=p.T_theta_min,
            v_scale=p.v_scale,
            speed_law=p.speed_law,
        )
        self._geometry = geo
        reach = 1.01 * p.diameter + 1e-6  # as in _free_spot's clearance test
        self._boxes = [(sp.min(axis=0) - reach, sp.max(axis=0) + reach)
                       for sp in geo.entry_spots]  # fmt: skip
        return Setup(
            world=world,
            engine=engine,
            policy=_DepotStop(policy, geo.depot_line),
            positions=pos,
            sensing=_Sensing(p.sensing),
            group=group,
            headings=headings,
            info={"geometry": geo, "n": n},
        )

    def extras(self, setup: Setup) -> dict[str, tuple[tuple[str, ...], tuple[int, ...], str]]:
        n = setup.positions.shape[0]
        out = super().extras(setup)
        out["section"] = (("time", "individuals"), (n,), "i1")
        out["lap"] = (("time", "individuals"), (n,), "i4")
        out["group"] = (("time", "individuals"), (n,), "i1")
        return out

    def _geo(self) -> RoadGeometry:
        return self._geometry  # set by build(), which both run and resume call

    def frame(
        self, sim: Simulator, state: SwarmState, acc: dict[str, np.ndarray]
    ) -> dict[str, np.ndarray]:
        geo = self._geo()
        pos = state.by_id(state.pos)
        sec = section_index(pos[:, 0], geo.edges).astype(np.int8)
        sec[pos[:, 1] < geo.depot_line] = -1
        return {
            "heading": wrap(state.by_id(state.heading)),
            "speed": state.by_id(state.speed),
            "section": sec,
            "lap": acc["lap"].astype(np.int32),
            "group": state.by_id(state.group).astype(np.int8),
        }

    # -- every step: arrivals and re-entries
    def init_acc(self, setup: Setup, sim: Simulator, state: SwarmState) -> dict[str, np.ndarray]:
        n = state.n
        return {
            "entry_time": np.full(n, np.nan),  # NaN: still on the lap it started on
            "lap": np.zeros(n, np.int64),
            "park_since": np.full(n, np.nan),  # NaN: on the road
            "n_parked": np.array(0),
            # time, id, group, transit (NaN: partial lap), kind (1 arrived, 0 pushed back)
            "events": np.zeros((64, 5)),
            "n_events": np.array(0),
            "entries": np.zeros(2, np.int64),
            "waited": np.zeros(2, np.int64),
            "wait_total": np.zeros(2),
            "wait_max": np.zeros(2),
        }

    def observe(self, sim: Simulator, state: SwarmState, acc: dict[str, np.ndarray]) -> None:
        geo = self._geo()
        x = state.pos[:, 0]
        g = state.group
        L = geo.length
        ad = geo.arrive_depth
        # cheap test first (every step, a handful of robots): anyone near an end line?
        if x.min() <= ad or x.max() >= L - ad:
            arrived = ((g == 0) & (x >= L - ad)) | ((g == 1) & (x <= ad))
            backed = ((g == 0) & (x < 0.0)) | ((g == 1) & (x > L))  # open ends only
            leaving = arrived | backed
        else:
            leaving = None
        if leaving is not None and leaving.any():
            leaving &= state.pos[:, 1] > geo.depot_line
            for i in np.flatnonzero(leaving):
                self._leave(state, acc, geo, int(i), arrived=bool(arrived[i]))
        if acc["n_parked"] > 0:
            self._reenter(state, acc, geo)

    def _leave(self, state: SwarmState, acc: dict[str, np.ndarray], geo: RoadGeometry,
               i: int, *, arrived: bool) -> None:  # fmt: skip
        """Robot ``i`` leaves the road: it arrived (a crossing) or was pushed back out of
        its start end (open ends); either way it is put back at its start."""
        a = int(state.ids[i])
        g = int(state.group[i])
        t = state.time
        k = int(acc["n_events"])
        if k == acc["events"].shape[0]:
            acc["events"] = np.vstack([acc["events"], np.zeros_like(acc["events"])])
        transit = t - acc["entry_time"][a] if arrived else np.nan
        acc["events"][k] = (t, a, g, transit, 1.0 if arrived else 0.0)
        acc["n_events"] = np.array(k + 1)
        acc["lap"][a] += 1
        acc["park_since"][a] = t
        acc["n_parked"] = np.array(int(acc["n_parked"]) + 1)
        state.pos[i] = geo.depot_slots[a]
        state.speed[i] = 0.0

    def _reenter(self, state: SwarmState, acc: dict[str, np.ndarray], geo: RoadGeometry) -> None:
        r = geo.radius
        d = 2 * r
        t = state.time
        ids = state.ids
        row_of = np.empty(state.n, np.int64)
        row_of[ids] = np.arange(state.n)
        waiting = np.flatnonzero(np.isfinite(acc["park_since"]))
        order = waiting[np.lexsort((waiting, acc["park_since"][waiting]))]
        for a in order:
            i = int(row_of[a])
            g = int(state.group[i])
            on_road = state.pos[:, 1] > geo.depot_line
            others = state.pos[on_road]
            if geo.entry_clearance > 0:
                x = others[:, 0] if g == 0 else geo.length - others[:, 0]
                oncoming = state.group[on_road] != g
                if np.any(oncoming & (x < geo.entry_clearance)):
                    continue
            spot = self._free_spot(geo.entry_spots[g], self._boxes[g], others, d, state.rng)
            if spot is None:
                continue
            state.pos[i] = spot
            state.speed[i] = 0.0
            state.timer[i] = 0  # a new control period starts at the next step
            wait = t - acc["park_since"][a]
            acc["park_since"][a] = np.nan
            acc["n_parked"] = np.array(int(acc["n_parked"]) - 1)
            acc["entry_time"][a] = t
            acc["entries"][g] += 1
            if wait > 0:
                acc["waited"][g] += 1
                acc["wait_total"][g] += wait
                acc["wait_max"][g] = max(acc["wait_max"][g], wait)

    @staticmethod
    def _free_spot(
        spots: np.ndarray,
        box: tuple[np.ndarray, np.ndarray],
        others: np.ndarray,
        d: float,
        rng: np.random.Generator,
    ) -> np.ndarray | None:
        """A random spot among ``spots`` (mm) clear of every robot in ``others``, or None;
        ``box`` = (lower, upper corner) of the spots widened by ``d``."""
        # only robots within reach of the zone matter
        lo, hi = box
        near = np.all((others >= lo) & (others <= hi), axis=1)
        others = others[near]
        if others.shape[0]:
            dx = spots[:, None, 0] - others[None, :, 0]
            dy = spots[:, None, 1] - others[None, :, 1]
            spots = spots[(dx * dx + dy * dy).min(axis=1) >= (d * 1.01) ** 2]
        if spots.shape[0] == 0:
            return None
        return spots[rng.integers(spots.shape[0])].copy()

    # -- the end
    def metrics(
        self,
        setup: Setup,
        acc: dict[str, np.ndarray],
        tracks: xr.Dataset,
        sim: Simulator,
        state: SwarmState,
    ) -> dict[str, Any]:
        p: NarrowRoadParams = self.params
        geo: RoadGeometry = setup.info["geometry"]
        n = int(setup.info["n"])
        T = float(state.time)
        ev_all = acc["events"][: int(acc["n_events"])]
        ev = ev_all[ev_all[:, 4] == 1.0]  # crossings; the rest left backward
        ev_t, ev_g, ev_transit = ev[:, 0], ev[:, 2].astype(int), ev[:, 3]
        group = state.by_id(state.group)
        robot_area = math.pi * p.radius**2
        out: dict[str, Any] = {
            "n": n,
            "n_per_direction": {d: int(np.sum(group == g)) for g, d in enumerate(DIRECTIONS)},
            "occupation": n * robot_area / geo.area,
            "occupation_target": p.occupation if p.n is None else None,
            "duration": T,
            "kT": p.kT,
            "tau": p.tau,
            "steering": p.steering,
            "crossings": {
                **{d: int(np.sum(ev_g == g)) for g, d in enumerate(DIRECTIONS)},
                "total": int(ev.shape[0]),
            },
            "left_backward": {
                d: int(np.sum((ev_all[:, 4] == 0.0) & (ev_all[:, 2] == g)))
                for g, d in enumerate(DIRECTIONS)
            },
            "flow_per_direction": {
                d: float(np.sum(ev_g == g) * 60.0 / T) for g, d in enumerate(DIRECTIONS)
            },
            "longest_zero_flow_s": {
                **{d: longest_gap(ev_t[ev_g == g], 0.0, T) for g, d in enumerate(DIRECTIONS)},
                "overall": longest_gap(ev_t, 0.0, T),
            },
        }
        out["flow_over_time"] = _flow_over_time(ev_t, ev_g, T, p.flow_bin)
        out["transit_times"] = {}
        for g, d in enumerate(DIRECTIONS):
            vals = ev_transit[(ev_g == g) & np.isfinite(ev_transit)]
            out["transit_times"][d] = {**_summary(vals), "values": vals.tolist()}
        out["waiting"] = {
            d: {
                "entries": int(acc["entries"][g]),
                "waited": int(acc["waited"][g]),
                "total_wait_s": float(acc["wait_total"][g]),
                "max_wait_s": float(acc["wait_max"][g]),
                "waiting_at_end": int(np.sum(np.isfinite(acc["park_since"]) & (group == g))),
            }
            for g, d in enumerate(DIRECTIONS)
        }
        areas = geo.section_areas()
        out["sections"] = section_stats(tracks, geo.names, areas)
        out["road"] = _road_info(geo, areas)
        return out


def _flow_over_time(ev_t: np.ndarray, ev_g: np.ndarray, T: float, flow_bin: float) -> dict:
    """Crossings per minute of each direction in whole bins of ``flow_bin`` s (``T``:
    the run's duration, s), with the bins' starts and the unbinned tail (s)."""
    flows: dict[str, Any] = {"bin_s": flow_bin}
    for g, d in enumerate(DIRECTIONS):
        starts, f = flow_series(ev_t[ev_g == g], T, flow_bin)
        flows["t_start"] = starts.tolist()
        flows[d] = f.tolist()
    # whole bins only: the seconds after the last one are in the totals, not binned
    flows["unbinned_tail_s"] = max(T - len(flows["t_start"]) * flow_bin, 0.0)
    return flows


def _road_info(geo: RoadGeometry, areas: np.ndarray) -> dict[str, Any]:
    """``metrics["road"]``: length (mm), area (mm^2), each section's extent, width and
    area, and the geometry's own description."""
    return {
        "length": geo.length,
        "area_mm2": geo.area,
        "sections": [
            {
                "name": geo.names[k],
                "x0": float(geo.edges[k]),
                "x1": float(geo.edges[k + 1]),
                "width": float(geo.widths[k]),
                "area_mm2": float(areas[k]),
            }
            for k in range(len(geo.names))
        ],
        "geometry": geo.info(),
    }
