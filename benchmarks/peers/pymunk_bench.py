"""pymunk 7 (Chipmunk2D): dynamic discs, the commands written with its batch API."""

from __future__ import annotations

import math

import numpy as np

from thermoswarm.maxent import SpeedLaw, kT_for_mean_speed
from thermoswarm.sim.bench import MEAN_SPEED

from .timing import DT, R, side_of, start_positions, timed


def pymunk_bench(n: int, phi: float, threads: int, seed: int = 0) -> dict:
    import pymunk
    import pymunk.batch as batch

    side = side_of(n, phi)
    rng = np.random.default_rng(seed + 1)
    pos = start_positions(n, phi)
    space = pymunk.Space(threaded=threads > 1)
    if threads > 1:
        space.threads = threads
    space.gravity = (0.0, 0.0)
    space.use_spatial_hash(2 * R * 1.25, 2 * n)
    corners = [(0, 0), (side, 0), (side, side), (0, side)]
    for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
        seg = pymunk.Segment(space.static_body, a, b, 0.0)
        seg.elasticity, seg.friction = 0.0, 0.0
        space.add(seg)
    for x, y in pos:
        body = pymunk.Body(1.0, math.inf)
        body.position = (float(x), float(y))
        shape = pymunk.Circle(body, R)
        shape.elasticity, shape.friction = 0.0, 0.0
        space.add(body, shape)
    law = SpeedLaw(kT_for_mean_speed(MEAN_SPEED))
    # pymunk's batch calls visit every body of the space, the static body (which holds
    # the walls) last: one spare row for it, and its rows filtered out of the positions
    vel = np.zeros((n + 1, 2))
    vbuf = batch.Buffer()
    vbuf.set_float_buf(vel.reshape(-1))  # pymunk reads the commands from this array
    pbuf = batch.Buffer()
    static_id = space.static_body.id
    fields = batch.BodyFields.POSITION | batch.BodyFields.BODY_ID

    def step() -> None:
        v = law.sample(rng, n)
        th = rng.uniform(-np.pi, np.pi, n)
        np.multiply(v, np.cos(th), out=vel[:n, 0])
        np.multiply(v, np.sin(th), out=vel[:n, 1])
        batch.set_space_bodies(space, batch.BodyFields.VELOCITY, vbuf)
        space.step(DT)

    def positions() -> np.ndarray:
        pbuf.clear()
        batch.get_space_bodies(space, fields, pbuf)
        ids = np.frombuffer(pbuf.int_buf(), dtype=np.uintp)
        xy = np.frombuffer(pbuf.float_buf(), dtype=np.float64).reshape(-1, 2)
        return xy[ids != static_id].copy()

    out = timed(step, n, positions, side)
    out["threads"] = threads
    return out
