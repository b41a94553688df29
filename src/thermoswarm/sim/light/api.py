"""Public functions of :mod:`thermoswarm.sim.light`: the light level, the photoresistor
readings and TurnToAngle (Algorithm 1), with their parameters and results.

Units: positions mm, angles rad counter-clockwise from world +x, time s; returned
headings wrapped to ``[-pi, pi)``.  Argument order everywhere: points, lights,
occluders.  The parameters and result types are in :mod:`thermoswarm.sim.light.params`
(re-exported here).  Bad input raises :class:`~thermoswarm.errors.InputError` or
:class:`~thermoswarm.errors.ConfigError` naming the argument.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np

from thermoswarm.config import check
from thermoswarm.errors import ConfigError, InputError
from thermoswarm.maxent import wrap_angle
from thermoswarm.sim.geometry import Shape, Shapes, as_shapes
from thermoswarm.sim.light._photo import _read_kernel, _turn_kernel_parallel, _turn_kernel_serial
from thermoswarm.sim.light._shadow import (
    _PARALLEL_MIN,
    _casters_directional,
    _casters_point,
    _direct_parallel,
    _direct_serial,
    _project,
)
from thermoswarm.sim.light.params import SenseResult, SensingParams, TurnResult
from thermoswarm.sim.light.sources import ROBOT_RADIUS, Light, _finite, _pack_lights

# --------------------------------------------------------------------------------------
# Public functions


def _points(value: object, name: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a numeric array of shape (n, 2) (mm)") from None
    if arr.ndim == 1 and arr.shape == (2,):
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise InputError(f"{name} must have shape (n, 2) (mm), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} must be finite (mm)")
    return np.ascontiguousarray(arr)


def _headings(value: object, n: int) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError("heading must be a numeric array of shape (n,) (rad)") from None
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise InputError(f"heading must have shape ({n},) (rad), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError("heading must be finite (rad)")
    return np.ascontiguousarray(arr)


def _check_ambient(ambient: float) -> float:
    check(_finite(ambient) and 0 <= ambient < 1, "ambient", "in [0, 1)", ambient)
    return float(ambient)


def _apply_casters(
    points: np.ndarray,
    w: np.ndarray,
    lights: np.ndarray,
    casters: object,
    caster_radius: float,
) -> None:
    c = _points(casters, "casters")
    check(
        _finite(caster_radius) and caster_radius > 0,
        "caster_radius",
        "> 0 (mm)",
        caster_radius,
    )
    r = float(caster_radius)
    if c.shape[0] == 0 or points.shape[0] == 0:
        return
    blocked = np.empty(points.shape[0], dtype=np.bool_)
    for li in range(lights.shape[0]):
        if lights[li, 0] == 0.0:
            ux, uy = lights[li, 1], lights[li, 2]
            qperp = points[:, 1] * ux - points[:, 0] * uy
            qalong = points[:, 0] * ux + points[:, 1] * uy
            cperp = c[:, 1] * ux - c[:, 0] * uy
            calong = c[:, 0] * ux + c[:, 1] * uy
            qo = np.argsort(qperp, kind="stable")
            co = np.argsort(cperp, kind="stable")
            b = np.empty(points.shape[0], dtype=np.bool_)
            _casters_directional(
                np.ascontiguousarray(qperp[qo]),
                np.ascontiguousarray(qalong[qo]),
                np.ascontiguousarray(cperp[co]),
                np.ascontiguousarray(calong[co]),
                r,
                b,
            )
            blocked[qo] = b
        else:
            lx, ly = lights[li, 1], lights[li, 2]
            theta = np.arctan2(c[:, 1] - ly, c[:, 0] - lx)
            order = np.argsort(theta, kind="stable")
            dmin = float(np.hypot(c[:, 0] - lx, c[:, 1] - ly).min())
            half = math.asin(r / dmin) if dmin > r else math.pi
            _casters_point(
                points,
                float(lx),
                float(ly),
                np.ascontiguousarray(theta[order]),
                np.ascontiguousarray(c[order, 0]),
                np.ascontiguousarray(c[order, 1]),
                r,
                half,
                blocked,
            )
        w[blocked, li] = 0.0


def _direct(
    points: np.ndarray,
    lights: np.ndarray,
    occluders: object,
    casters: object,
    caster_radius: float,
) -> np.ndarray:
    occ = as_shapes(occluders)
    w = np.empty((points.shape[0], lights.shape[0]))
    dproj, sproj = _project(lights, occ)
    kernel = _direct_parallel if points.shape[0] >= _PARALLEL_MIN else _direct_serial
    kernel(points, occ.discs, occ.segments, lights, dproj, sproj, w)
    if casters is not None:
        _apply_casters(points, w, lights, casters, caster_radius)
    return w


def direct_light(
    points: object,
    lights: Light | Iterable[Light],
    occluders: Shapes | Shape | Sequence[Shape] | None = None,
    *,
    casters: object = None,
    caster_radius: float = ROBOT_RADIUS,
) -> np.ndarray:
    """Share of each source reaching each point: ``(I_i / sum I) * s_i * g_i``.

    Parameters
    ----------
    points : array (n, 2)
        Positions (mm).
    lights : light or list of lights
    occluders : Shapes, shape, list of shapes or None
        Discs (the object: pass its current centre every call), segments, polygons,
        polylines.
    casters : array (m, 2) or None
        Robot positions (mm) casting hard shadows as discs of ``caster_radius``; off by
        default (docs/light.md, "Robots casting shadows").
    caster_radius : float
        Radius (mm) of the casters.

    Returns
    -------
    ndarray (n, n_lights)
        Values in [0, 1] summing to at most 1 per point.
    """
    pts = _points(points, "points")
    return _direct(pts, _pack_lights(lights), occluders, casters, caster_radius)


def light_level(
    points: object,
    lights: Light | Iterable[Light],
    occluders: Shapes | Shape | Sequence[Shape] | None = None,
    *,
    ambient: float = 0.0,
    casters: object = None,
    caster_radius: float = ROBOT_RADIUS,
) -> np.ndarray:
    """Light level at each point, in [0, 1] (1: every source fully visible at full
    strength; ``ambient``: full shadow).

    Parameters are those of :func:`direct_light` plus ``ambient`` in [0, 1), the level
    in full shadow.

    Returns
    -------
    ndarray (n,)
    """
    amb = _check_ambient(ambient)
    w = direct_light(points, lights, occluders, casters=casters, caster_radius=caster_radius)
    return amb + (1.0 - amb) * w.sum(axis=1)


def _sensor_setup(params: SensingParams, ambient: float) -> tuple[np.ndarray, float]:
    if not isinstance(params, SensingParams):
        raise InputError(f"params must be a SensingParams, got {type(params).__name__}")
    if params.dark_threshold <= ambient:
        raise ConfigError(
            f"dark_threshold must exceed the ambient level {ambient:g} (l3 could never read "
            f"dark), got {params.dark_threshold!r}"
        )
    ang = np.array(params.sensor_angles)
    sens = np.ascontiguousarray(np.stack([np.cos(ang), np.sin(ang)], axis=1))
    half = math.radians(params.fov_deg) / 2
    cos_half = math.cos(half) if half < math.pi else -1.0
    return sens, cos_half


def _need_rng(rng: np.random.Generator | None, noisy: bool) -> np.random.Generator:
    if rng is None:
        if noisy:
            raise ConfigError("rng (a numpy Generator) is required when sensor noise is > 0")
        return np.random.default_rng(0)  # never drawn from: the kernels need a Generator
    if not isinstance(rng, np.random.Generator):
        raise InputError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    return rng


def read_sensors(
    position: object,
    heading: object,
    lights: Light | Iterable[Light],
    occluders: Shapes | Shape | Sequence[Shape] | None,
    params: SensingParams,
    rng: np.random.Generator | None = None,
    *,
    ambient: float = 0.0,
    casters: object = None,
    caster_radius: float = ROBOT_RADIUS,
) -> np.ndarray:
    """Readings of the three photoresistors (l1, l2, l3) of each robot.

    Parameters
    ----------
    position : array (n, 2)
        Robot centres (mm).
    heading : array (n,)
        Headings (rad, world frame).
    lights, occluders, casters, caster_radius, ambient
        As in :func:`light_level`.
    params : SensingParams
        Sensor angles, field of view and noise.
    rng : numpy.random.Generator or None
        Source of the noise; needed only when the noise is > 0.

    Returns
    -------
    ndarray (n, 3)
        Readings in light-level units (>= 0); without noise at most 1.
    """
    pts = _points(position, "position")
    hd = _headings(heading, pts.shape[0])
    amb = _check_ambient(ambient)
    lt = _pack_lights(lights)
    sens, cos_half = _sensor_setup(params, amb)
    g = _need_rng(rng, params.noise_mult > 0 or params.noise_add > 0)
    w = _direct(pts, lt, occluders, casters, caster_radius) * (1.0 - amb)
    out = np.empty((pts.shape[0], 3))
    _read_kernel(pts, hd, w, lt, sens, cos_half, amb, params.noise_mult, params.noise_add, g, out)
    return out


def _wrap(h: np.ndarray) -> np.ndarray:
    """Wrap to [-pi, pi), leaving angles already in range bit-for-bit unchanged."""
    return np.where((h >= -np.pi) & (h < np.pi), h, wrap_angle(h))


def _ideal(pts: np.ndarray, w: np.ndarray, lt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    best = np.argmax(w, axis=1) if w.shape[0] else np.zeros(0, dtype=np.intp)
    seen = w.max(axis=1) > 0 if w.shape[0] else np.zeros(0, dtype=bool)
    row = lt[best]
    ang = np.where(
        row[:, 0] == 0.0,
        np.arctan2(row[:, 2], row[:, 1]),
        np.arctan2(row[:, 2] - pts[:, 1], row[:, 1] - pts[:, 0]),
    )
    return ang, seen


def ideal_zero_heading(
    position: object,
    lights: Light | Iterable[Light],
    occluders: Shapes | Shape | Sequence[Shape] | None = None,
    *,
    casters: object = None,
    caster_radius: float = ROBOT_RADIUS,
    fallback: object = None,
) -> np.ndarray:
    """Exact direction (rad, world) to the brightest visible source from each robot.

    For a directional light it is the opposite of the rays; for a point light the
    direction to the lamp.  The brightest is the largest ``(I_i / sum I) s_i g_i`` (the
    first listed on ties).  Where no source is visible the result is ``fallback``
    (e.g. the current heading) or NaN when ``fallback`` is None.

    Returns
    -------
    ndarray (n,)
        Angles wrapped to ``[-pi, pi)``.
    """
    pts = _points(position, "position")
    lt = _pack_lights(lights)
    w = _direct(pts, lt, occluders, casters, caster_radius)
    ang, seen = _ideal(pts, w, lt)
    fb = np.full(pts.shape[0], np.nan) if fallback is None else _headings(fallback, pts.shape[0])
    return np.where(seen, _wrap(ang), fb)


def _turn(
    pts: np.ndarray,
    hd: np.ndarray,
    lt: np.ndarray,
    w: np.ndarray,
    params: SensingParams,
    rng: np.random.Generator | None,
    amb: float,
) -> TurnResult:
    n = pts.shape[0]
    step = params.step
    if params.mode == "ideal":
        ang, seen = _ideal(pts, w, lt)
        if params.ideal_noise_deg > 0:
            g = _need_rng(rng, True)
            ang = ang + math.radians(params.ideal_noise_deg) * g.standard_normal(n)
        target = np.where(seen, ang, hd)
        turn = np.abs(wrap_angle(target - hd))
        steps = np.where(seen, np.ceil(turn / step - 1e-9), 0).astype(np.int64)
        return TurnResult(_wrap(target), steps, seen)
    sens, cos_half = _sensor_setup(params, amb)
    g = _need_rng(rng, params.noise_mult > 0 or params.noise_add > 0)
    out_h = np.empty(n)
    out_steps = np.empty(n, dtype=np.int64)
    out_conv = np.empty(n, dtype=np.bool_)
    wa = np.ascontiguousarray(w * (1.0 - amb))
    tol = params.balance_tolerance
    fixed = params.turn == "fixed"
    if params.noise_mult > 0 or params.noise_add > 0 or n < _PARALLEL_MIN:
        _turn_kernel_serial(
            pts,
            hd,
            wa,
            lt,
            sens,
            cos_half,
            amb,
            params.noise_mult,
            params.noise_add,
            tol,
            step,
            params.steps_limit,
            params.dark_threshold,
            fixed,
            g,
            out_h,
            out_steps,
            out_conv,
        )
    else:
        _turn_kernel_parallel(
            pts,
            hd,
            wa,
            lt,
            sens,
            cos_half,
            amb,
            tol,
            step,
            params.steps_limit,
            params.dark_threshold,
            fixed,
            g,
            out_h,
            out_steps,
            out_conv,
        )
    return TurnResult(_wrap(out_h), out_steps, out_conv)


def turn_to_angle(
    position: object,
    heading: object,
    lights: Light | Iterable[Light],
    occluders: Shapes | Shape | Sequence[Shape] | None,
    params: SensingParams,
    rng: np.random.Generator | None = None,
    *,
    ambient: float = 0.0,
    casters: object = None,
    caster_radius: float = ROBOT_RADIUS,
) -> TurnResult:
    """Algorithm 1 (TurnToAngle) for every robot at once; robots turn in place.

    Parameters
    ----------
    position : array (n, 2)
        Robot centres (mm).
    heading : array (n,)
        Headings before turning (rad, world frame).
    lights, occluders, ambient, casters, caster_radius
        As in :func:`light_level`.
    params : SensingParams
        ``mode="photoresistor"`` runs the stepwise turn on simulated sensors;
        ``mode="ideal"`` takes the exact direction of the brightest visible source.
    rng : numpy.random.Generator or None
        Noise source; needed only with sensor noise or ``ideal_noise_deg`` > 0.

    Returns
    -------
    TurnResult
        ``heading`` (n,) where each robot stopped (rad, wrapped to ``[-pi, pi)``),
        ``steps`` (n,) int turning steps taken (``params.turn_time(steps)`` in s) and
        ``converged`` (n,) bool: False for robots that saw no light (unchanged heading,
        0 steps) or ran out of steps.
    """
    pts = _points(position, "position")
    hd = _headings(heading, pts.shape[0])
    amb = _check_ambient(ambient)
    lt = _pack_lights(lights)
    if not isinstance(params, SensingParams):
        raise InputError(f"params must be a SensingParams, got {type(params).__name__}")
    w = _direct(pts, lt, occluders, casters, caster_radius)
    return _turn(pts, hd, lt, w, params, rng, amb)


def sense(
    position: object,
    heading: object,
    lights: Light | Iterable[Light],
    occluders: Shapes | Shape | Sequence[Shape] | None,
    params: SensingParams,
    rng: np.random.Generator | None = None,
    *,
    ambient: float = 0.0,
    casters: object = None,
    caster_radius: float = ROBOT_RADIUS,
) -> SenseResult:
    """TurnToAngle and the light level in one pass (shadows are computed once).

    What the engine calls at the start of a control period; arguments as in
    :func:`turn_to_angle`.
    """
    pts = _points(position, "position")
    hd = _headings(heading, pts.shape[0])
    amb = _check_ambient(ambient)
    lt = _pack_lights(lights)
    if not isinstance(params, SensingParams):
        raise InputError(f"params must be a SensingParams, got {type(params).__name__}")
    w = _direct(pts, lt, occluders, casters, caster_radius)
    res = _turn(pts, hd, lt, w, params, rng, amb)
    light = amb + (1.0 - amb) * w.sum(axis=1)
    return SenseResult(
        zero_heading=res.heading,
        steps=res.steps,
        converged=res.converged,
        light=light,
        turn_time=np.asarray(params.turn_time(res.steps), dtype=np.float64),
    )
