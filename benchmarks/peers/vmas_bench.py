"""VMAS: sphere agents with its own penalty collisions, one world or batched worlds."""

from __future__ import annotations

import numpy as np

from thermoswarm.maxent import SpeedLaw, kT_for_mean_speed
from thermoswarm.sim.bench import MEAN_SPEED

from .timing import DT, R, kd_overlap, side_of, start_positions, timed

#: VMAS sub-steps per 0.1 s step and its contact stiffness (``collision_force``).
VMAS_SUBSTEPS = 10
VMAS_COLLISION_FORCE = 2000.0


def vmas_bench(n: int, phi: float, envs: int = 1, threads: int = 1, seed: int = 0) -> dict:
    """VMAS as a user writes a scenario: ``envs`` batched worlds of ``n // envs`` sphere
    agents (radius 16.5 mm, in metres), each in its own walled square of the same
    packing (``x_semidim``/``y_semidim`` keep the centres ``R`` off the walls), its own
    penalty collisions; force actions with full drag, sized so that an agent alone moves
    ``v dt`` in a step; ``threads`` torch threads (``torch.set_num_threads``)."""
    import torch
    from vmas.simulator.core import Agent, Sphere, World
    from vmas.simulator.scenario import BaseScenario

    torch.set_num_threads(threads)
    m = n // envs
    n = m * envs  # whole worlds (N rounded down to a multiple of the world size)
    side = side_of(m, phi) / 1000.0
    r = R / 1000.0
    k = VMAS_SUBSTEPS

    class Swarm(BaseScenario):
        def make_world(self, batch_dim, device, **kwargs):
            world = World(batch_dim, device, dt=DT, substeps=k, drag=1.0,
                          x_semidim=side / 2 - r, y_semidim=side / 2 - r,
                          collision_force=VMAS_COLLISION_FORCE, contact_margin=1e-4)  # fmt: skip
            for a in range(m):
                world.add_agent(Agent(f"a{a}", shape=Sphere(r), rotatable=False, u_range=1e9))
            return world

        def reset_world_at(self, env_index=None):
            start = torch.tensor(start_positions(m, phi) / 1000.0 - side / 2, dtype=torch.float32)
            for a, agent in enumerate(self.world.agents):
                agent.set_pos(start[a].expand(self.world.batch_dim, 2), batch_index=env_index)

        def observation(self, agent):
            return agent.state.pos

        def reward(self, agent):
            return torch.zeros(self.world.batch_dim)

    scen = Swarm()
    world = scen.env_make_world(envs, "cpu")
    scen.reset_world_at()
    rng = np.random.default_rng(seed + 1)
    law = SpeedLaw(kT_for_mean_speed(MEAN_SPEED))
    # velocity accumulates over the sub-steps (drag acts at the first): this force moves
    # a free agent by v dt in a step
    gain = 2.0 * k / (DT * (k + 1))

    def step() -> None:
        sp = law.sample(rng, n) / 1000.0
        th = rng.uniform(-np.pi, np.pi, n)
        f = torch.tensor(np.stack([sp * np.cos(th), sp * np.sin(th)], -1) * gain,
                         dtype=torch.float32).reshape(envs, m, 2)  # fmt: skip
        for a, agent in enumerate(world.agents):
            agent.action.u = f[:, a]
            agent.state.force = f[:, a]
        world.step()

    def positions() -> np.ndarray:
        p = torch.stack([a.state.pos for a in world.agents], 1).numpy().astype(np.float64)
        return p.reshape(envs, m, 2) * 1000.0 + side * 500.0

    def step_and_check() -> None:
        step()

    def overlap_of(p: np.ndarray) -> float:
        return max(kd_overlap(p[e], side * 1000.0) for e in range(envs))

    out = timed(step_and_check, n, positions, side * 1000.0, overlap=overlap_of)
    out.update(threads=threads, envs=envs, agents_per_env=m, substeps=k,
               collision_force=VMAS_COLLISION_FORCE)  # fmt: skip
    return out
