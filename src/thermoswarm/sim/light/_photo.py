"""Numba kernels for the three photoresistors and the stepwise turn of TurnToAngle.

Inputs are already validated and the light shares ``w`` (points x sources) already
computed by :mod:`thermoswarm.sim.light._shadow`; positions mm, angles rad.  With sensor
noise the serial kernel draws from the caller's Generator in robot order (reproducible);
the parallel kernel is noise-free.
"""

import math

import numpy as np
from numba import njit, prange

from thermoswarm.sim.light._shadow import _CHUNK


@njit(cache=True)
def _reading(ax, ay, w, ux, uy, cos_half_fov, ambient):
    s = 0.0
    for li in range(w.shape[0]):
        c = ax * ux[li] + ay * uy[li]
        if c >= cos_half_fov and c > 0.0:
            s += w[li] * c
    return ambient + s


@njit(cache=True)
def _noisy(v, sig_m, sig_a, rng):
    if sig_m > 0.0:
        v = v * (1.0 + sig_m * rng.standard_normal())
    if sig_a > 0.0:
        v = v + sig_a * rng.standard_normal()
    return max(v, 0.0)


@njit(cache=True)
def _source_dirs(px, py, lights, ux, uy):
    for li in range(lights.shape[0]):
        if lights[li, 0] == 0.0:
            ux[li] = lights[li, 1]
            uy[li] = lights[li, 2]
        else:
            vx = lights[li, 1] - px
            vy = lights[li, 2] - py
            d = math.sqrt(vx * vx + vy * vy)
            if d > 0.0:
                ux[li] = vx / d
                uy[li] = vy / d
            else:
                ux[li] = 1.0
                uy[li] = 0.0


@njit(cache=True)
def _read_kernel(points, heading, w, lights, sens, cos_half_fov, ambient, sig_m, sig_a, rng, out):
    nl = lights.shape[0]
    ux = np.empty(nl)
    uy = np.empty(nl)
    for i in range(points.shape[0]):
        _source_dirs(points[i, 0], points[i, 1], lights, ux, uy)
        ch = math.cos(heading[i])
        sh = math.sin(heading[i])
        for k in range(3):
            ax = ch * sens[k, 0] - sh * sens[k, 1]
            ay = sh * sens[k, 0] + ch * sens[k, 1]
            v = _reading(ax, ay, w[i], ux, uy, cos_half_fov, ambient)
            out[i, k] = _noisy(v, sig_m, sig_a, rng)


@njit(cache=True)
def _turn_one(
    px,
    py,
    h0,
    wi,
    lights,
    ux,
    uy,
    sens,
    cos_half_fov,
    ambient,
    sig_m,
    sig_a,
    tol,
    step,
    max_steps,
    dark,
    fixed,
    rng,
):
    """TurnToAngle for one robot: (final heading, steps, converged)."""
    # --- stage: the brightest unshadowed source (none: stop at once)
    nl = lights.shape[0]
    best = -1
    bw = 0.0
    for li in range(nl):
        if wi[li] > bw:
            bw = wi[li]
            best = li
    if best < 0:
        return h0, 0, False  # every source shadowed: ends at once
    # --- stage: sensor geometry; dark facing that source: stop at once
    _source_dirs(px, py, lights, ux, uy)
    c1 = sens[0, 0]
    s1 = sens[0, 1]
    c2 = sens[1, 0]
    s2 = sens[1, 1]
    c3 = sens[2, 0]
    s3 = sens[2, 1]
    # Would the front sensors read light facing the brightest source?  If not, the robot
    # sees no light: Algorithm 1 ends at once.
    hx = ux[best]
    hy = uy[best]
    f1 = _reading(hx * c1 - hy * s1, hy * c1 + hx * s1, wi, ux, uy, cos_half_fov, ambient)
    f2 = _reading(hx * c2 - hy * s2, hy * c2 + hx * s2, wi, ux, uy, cos_half_fov, ambient)
    if max(f1, f2) <= dark:
        return h0, 0, False
    # --- stage: turn step by step until the front sensors balance and the back one is dark
    noisy = sig_m > 0.0 or sig_a > 0.0  # the guard below halves the noise-free cost
    cs = math.cos(step)
    ss = math.sin(step)
    ch = math.cos(h0)
    sh = math.sin(h0)
    signed = 0
    k = 0
    conv = False
    while True:
        l1 = _reading(ch * c1 - sh * s1, sh * c1 + ch * s1, wi, ux, uy, cos_half_fov, ambient)
        l2 = _reading(ch * c2 - sh * s2, sh * c2 + ch * s2, wi, ux, uy, cos_half_fov, ambient)
        if noisy:
            l1 = _noisy(l1, sig_m, sig_a, rng)
            l2 = _noisy(l2, sig_m, sig_a, rng)
        m = max(l1, l2)
        if abs(l1 - l2) <= tol * m and m > dark:
            # l3 matters only here, so it is read only here: the same outcome, in law,
            # as reading all three every step, for two thirds of the work.
            l3 = _reading(ch * c3 - sh * s3, sh * c3 + ch * s3, wi, ux, uy, cos_half_fov, ambient)
            if noisy:
                l3 = _noisy(l3, sig_m, sig_a, rng)
            if l3 <= dark:
                conv = True
                break
        if k == max_steps:
            break
        # Counter-clockwise toward l1 (at +a) when it is brighter, and to search when both
        # front sensors read dark (no side to prefer: a noisy sign would random-walk).
        if fixed or l1 >= l2 or m <= dark:
            ch, sh = ch * cs - sh * ss, sh * cs + ch * ss
            signed += 1
        else:
            ch, sh = ch * cs + sh * ss, sh * cs - ch * ss
            signed -= 1
        k += 1
    return h0 + signed * step, k, conv


@njit(cache=True)
def _turn_kernel_serial(
    points,
    heading,
    w,
    lights,
    sens,
    cos_half_fov,
    ambient,
    sig_m,
    sig_a,
    tol,
    step,
    max_steps,
    dark,
    fixed,
    rng,
    out_h,
    out_steps,
    out_conv,
):
    """With noise: robots in order, so the draws from ``rng`` are reproducible."""
    nl = lights.shape[0]
    ux = np.empty(nl)
    uy = np.empty(nl)
    for i in range(points.shape[0]):
        out_h[i], out_steps[i], out_conv[i] = _turn_one(
            points[i, 0],
            points[i, 1],
            heading[i],
            w[i],
            lights,
            ux,
            uy,
            sens,
            cos_half_fov,
            ambient,
            sig_m,
            sig_a,
            tol,
            step,
            max_steps,
            dark,
            fixed,
            rng,
        )


@njit(cache=True, parallel=True)
def _turn_kernel_parallel(
    points,
    heading,
    w,
    lights,
    sens,
    cos_half_fov,
    ambient,
    tol,
    step,
    max_steps,
    dark,
    fixed,
    rng,
    out_h,
    out_steps,
    out_conv,
):
    """Without noise (``rng`` is never drawn from): chunks of robots in parallel."""
    n = points.shape[0]
    nl = lights.shape[0]
    for c in prange((n + _CHUNK - 1) // _CHUNK):
        ux = np.empty(nl)
        uy = np.empty(nl)
        for i in range(c * _CHUNK, min(n, (c + 1) * _CHUNK)):
            out_h[i], out_steps[i], out_conv[i] = _turn_one(
                points[i, 0],
                points[i, 1],
                heading[i],
                w[i],
                lights,
                ux,
                uy,
                sens,
                cos_half_fov,
                ambient,
                0.0,
                0.0,
                tol,
                step,
                max_steps,
                dark,
                fixed,
                rng,
            )
