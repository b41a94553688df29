"""Numba kernels for shadows and visibility: which share of each source reaches a point.

Hand-written: no library answers "is this ray blocked" for a million points against a
handful of moving 2D occluders (shapely/GEOS works per geometry object and is orders of
magnitude slower at this size).  Inputs are the packed light rows of
:func:`thermoswarm.sim.light.sources._pack_lights` and the arrays of
:class:`thermoswarm.sim.geometry.Shapes`; positions mm, angles rad.  Callers validate;
these functions do not.
"""

import math

import numpy as np
from numba import njit, prange

from thermoswarm.sim.geometry import Shapes


@njit(cache=True)
def _dir_hard_range(points, i0, i1, ux, uy, dproj, sproj, weight, out, li):
    """Hard shadows of one directional source (unit vector ``u`` toward it) for points
    ``i0:i1``: is the ray from ``p`` along ``u`` blocked?

    Worked in the light's frame, ``perp = cross(u, p)`` and ``along = dot(u, p)``: two
    products per point, then comparisons, without branches (3x faster than branching on
    random points).  ``dproj`` rows are a disc's ``perp, along, r``: it blocks if
    ``|perp - perp_c| < r`` and it lies ahead, or if it contains ``p``.  ``sproj`` rows
    are a segment's perp range ``lo, hi``, its along coordinate at ``lo`` and its slope
    d(along)/d(perp): it blocks if ``lo <= perp <= hi`` and it lies ahead there (a
    grazing ray, exactly tangent to a disc, is not blocked; segments parallel to the rays
    have ``lo > hi`` and never block).
    """
    for i in range(i0, i1):
        px = points[i, 0]
        py = points[i, 1]
        perp = ux * py - uy * px
        along = ux * px + uy * py
        b = False
        for j in range(dproj.shape[0]):
            dp = perp - dproj[j, 0]
            da = dproj[j, 1] - along
            r2 = dproj[j, 2] * dproj[j, 2]
            b |= (dp * dp < r2) & ((da > 0.0) | (dp * dp + da * da < r2))
        for j in range(sproj.shape[0]):
            lo = sproj[j, 0]
            b |= (
                (lo <= perp)
                & (perp <= sproj[j, 1])
                & (sproj[j, 2] + (perp - lo) * sproj[j, 3] > along)
            )
        out[i, li] = 0.0 if b else weight


@njit(cache=True)
def _blocked_point(px, py, lx, ly, discs, segs):
    """Does the segment from ``p`` to the light at ``l`` cross an occluder?"""
    vx = lx - px
    vy = ly - py
    vv = vx * vx + vy * vy
    if vv == 0.0:
        return False
    for j in range(discs.shape[0]):
        wx = discs[j, 0] - px
        wy = discs[j, 1] - py
        r2 = discs[j, 2] * discs[j, 2]
        if wx * wx + wy * wy < r2:
            return True
        t = (wx * vx + wy * vy) / vv
        t = min(max(t, 0.0), 1.0)
        dx = wx - t * vx
        dy = wy - t * vy
        if dx * dx + dy * dy < r2:
            return True
    for j in range(segs.shape[0]):
        ax = segs[j, 0]
        ay = segs[j, 1]
        ex = segs[j, 2] - ax
        ey = segs[j, 3] - ay
        den = vx * ey - vy * ex
        if den == 0.0:
            continue
        qx = ax - px
        qy = ay - py
        tn = qx * ey - qy * ex
        sn = qx * vy - qy * vx
        if den < 0.0:
            den, tn, sn = -den, -tn, -sn
        if 0.0 < tn < den and 0.0 <= sn <= den:
            return True
    return False


@njit(cache=True)
def _push(buf, n, lo, hi, alpha):
    lo = max(lo, -alpha)
    hi = min(hi, alpha)
    if lo < hi:
        buf[n, 0] = lo
        buf[n, 1] = hi
        return n + 1
    return n


@njit(cache=True)
def _soft_visibility(px, py, ux, uy, dist, alpha, discs, segs, buf):
    """Unblocked share of a source of angular radius ``alpha`` centred on direction ``u``.

    ``dist`` is the distance to the source (inf for directional light): occluder parts
    farther than that do not block.  Angles are measured from ``u``.
    """
    # --- stage: the arcs of the source each occluding disc hides
    n = 0
    for j in range(discs.shape[0]):
        wx = discs[j, 0] - px
        wy = discs[j, 1] - py
        r = discs[j, 2]
        d2 = wx * wx + wy * wy
        if d2 <= r * r:
            return 0.0
        d = math.sqrt(d2)
        if d - r >= dist:
            continue
        beta = math.atan2(ux * wy - uy * wx, ux * wx + uy * wy)
        if d2 - r * r <= dist * dist:
            h = math.asin(r / d)
        else:  # only the near part of the disc, up to distance dist, blocks
            c = (d2 + dist * dist - r * r) / (2.0 * d * dist)
            h = math.acos(min(1.0, max(-1.0, c)))
        n = _push(buf, n, beta - h, beta + h, alpha)
    # --- stage: the arcs each segment hides (clipped to the source's distance)
    for j in range(segs.shape[0]):
        ax = segs[j, 0]
        ay = segs[j, 1]
        bx = segs[j, 2]
        by = segs[j, 3]
        if dist < math.inf:  # clip the segment to the disc |q - p| <= dist
            ex = bx - ax
            ey = by - ay
            qx = ax - px
            qy = ay - py
            A = ex * ex + ey * ey
            B = 2.0 * (qx * ex + qy * ey)
            C = qx * qx + qy * qy - dist * dist
            disc = B * B - 4.0 * A * C
            if disc <= 0.0:
                continue
            sq = math.sqrt(disc)
            s1 = max((-B - sq) / (2.0 * A), 0.0)
            s2 = min((-B + sq) / (2.0 * A), 1.0)
            if s1 >= s2:
                continue
            bx = ax + s2 * ex
            by = ay + s2 * ey
            ax = ax + s1 * ex
            ay = ay + s1 * ey
        qax = ax - px
        qay = ay - py
        qbx = bx - px
        qby = by - py
        ta = math.atan2(ux * qay - uy * qax, ux * qax + uy * qay)
        tb = math.atan2(ux * qby - uy * qbx, ux * qbx + uy * qby)
        lo = min(ta, tb)
        hi = max(ta, tb)
        if hi - lo <= math.pi:
            n = _push(buf, n, lo, hi, alpha)
        else:  # the shorter arc passes through +-pi
            n = _push(buf, n, hi, math.pi, alpha)
            n = _push(buf, n, -math.pi, lo, alpha)
    if n == 0:
        return 1.0
    # --- stage: sort the arcs by start
    for i in range(1, n):  # insertion sort by start: n is a handful
        lo = buf[i, 0]
        hi = buf[i, 1]
        k = i - 1
        while k >= 0 and buf[k, 0] > lo:
            buf[k + 1, 0] = buf[k, 0]
            buf[k + 1, 1] = buf[k, 1]
            k -= 1
        buf[k + 1, 0] = lo
        buf[k + 1, 1] = hi
    # --- stage: merge them: the share of the source left unblocked
    covered = 0.0
    cur_lo = buf[0, 0]
    cur_hi = buf[0, 1]
    for i in range(1, n):
        if buf[i, 0] > cur_hi:
            covered += cur_hi - cur_lo
            cur_lo = buf[i, 0]
            cur_hi = buf[i, 1]
        elif buf[i, 1] > cur_hi:
            cur_hi = buf[i, 1]
    covered += cur_hi - cur_lo
    return max(0.0, 1.0 - covered / (2.0 * alpha))


@njit(cache=True)
def _direct_one(px, py, discs, segs, lights, li, buf):
    """Weight * visibility * falloff of light ``li`` at ``(px, py)`` (general path)."""
    w = lights[li, 3]
    if lights[li, 0] == 0.0:
        vis = _soft_visibility(
            px, py, lights[li, 1], lights[li, 2], math.inf, lights[li, 6], discs, segs, buf
        )
        return w * vis
    lx = lights[li, 1]
    ly = lights[li, 2]
    vx = lx - px
    vy = ly - py
    dist = math.sqrt(vx * vx + vy * vy)
    code = lights[li, 4]
    r0 = lights[li, 5]
    g = 1.0
    if dist > r0:
        if code == 1.0:
            g = r0 / dist
        elif code == 2.0:
            g = (r0 / dist) * (r0 / dist)
    radius = lights[li, 6]
    if radius > 0.0:
        if dist <= radius:
            vis = 1.0
        else:
            alpha = math.asin(radius / dist)
            vis = _soft_visibility(px, py, vx / dist, vy / dist, dist, alpha, discs, segs, buf)
    else:
        vis = 0.0 if _blocked_point(px, py, lx, ly, discs, segs) else 1.0
    return w * vis * g


@njit(cache=True)
def _direct_range(points, i0, i1, discs, segs, lights, dproj, sproj, buf, out):
    for li in range(lights.shape[0]):
        if lights[li, 0] == 0.0 and lights[li, 6] == 0.0:
            _dir_hard_range(
                points, i0, i1, lights[li, 1], lights[li, 2], dproj[li], sproj[li],
                lights[li, 3], out, li,
            )  # fmt: skip
        else:
            for i in range(i0, i1):
                out[i, li] = _direct_one(points[i, 0], points[i, 1], discs, segs, lights, li, buf)


# Robots per parallel work item, and the fewest robots for which the parallel kernels are
# used: waking threads costs more than it saves below that (much more on a busy machine).
_CHUNK = 4096
_PARALLEL_MIN = 65536


@njit(cache=True)
def _direct_serial(points, discs, segs, lights, dproj, sproj, out):
    buf = np.empty((2 * (discs.shape[0] + segs.shape[0]) + 2, 2))
    _direct_range(points, 0, points.shape[0], discs, segs, lights, dproj, sproj, buf, out)


@njit(cache=True, parallel=True)
def _direct_parallel(points, discs, segs, lights, dproj, sproj, out):
    n = points.shape[0]
    nbuf = 2 * (discs.shape[0] + segs.shape[0]) + 2
    for c in prange((n + _CHUNK - 1) // _CHUNK):
        buf = np.empty((nbuf, 2))
        i0 = c * _CHUNK
        _direct_range(points, i0, min(n, i0 + _CHUNK), discs, segs, lights, dproj, sproj, buf,
                      out)  # fmt: skip


def _project(lights: np.ndarray, occ: Shapes) -> tuple[np.ndarray, np.ndarray]:
    """Occluders in each directional light's frame (perp = cross(u, .), along = u . .)."""
    nl = lights.shape[0]
    dproj = np.zeros((nl, occ.n_discs, 3))
    sproj = np.zeros((nl, occ.n_segments, 4))
    d, sg = occ.discs, occ.segments
    for li in range(nl):
        if lights[li, 0] != 0.0:
            continue
        ux, uy = lights[li, 1], lights[li, 2]
        dproj[li, :, 0] = ux * d[:, 1] - uy * d[:, 0]
        dproj[li, :, 1] = ux * d[:, 0] + uy * d[:, 1]
        dproj[li, :, 2] = d[:, 2]
        pa = ux * sg[:, 1] - uy * sg[:, 0]
        aa = ux * sg[:, 0] + uy * sg[:, 1]
        pb = ux * sg[:, 3] - uy * sg[:, 2]
        ab = ux * sg[:, 2] + uy * sg[:, 3]
        swap = pb < pa
        lo = np.where(swap, pb, pa)
        hi = np.where(swap, pa, pb)
        alo = np.where(swap, ab, aa)
        ahi = np.where(swap, aa, ab)
        with np.errstate(divide="ignore", invalid="ignore"):
            slope = (ahi - alo) / (hi - lo)
        parallel = hi == lo
        sproj[li, :, 0] = np.where(parallel, np.inf, lo)
        sproj[li, :, 1] = np.where(parallel, -np.inf, hi)
        sproj[li, :, 2] = alo
        sproj[li, :, 3] = np.where(parallel, 0.0, slope)
    return dproj, sproj


@njit(cache=True)
def _casters_directional(qperp, qalong, cperp, calong, r, blocked):
    """Query ``i`` (sorted by ``qperp``) is blocked iff some caster with
    ``|cperp - qperp_i| < r`` (casters sorted by ``cperp``) lies farther toward the
    source (``calong > qalong_i``).  Sliding-window maximum with a monotone deque."""
    m = cperp.shape[0]
    dq = np.empty(max(m, 1), dtype=np.int64)
    head = 0
    tail = 0
    hi = 0
    for i in range(qperp.shape[0]):
        q = qperp[i]
        while hi < m and cperp[hi] < q + r:
            while tail > head and calong[dq[tail - 1]] <= calong[hi]:
                tail -= 1
            dq[tail] = hi
            tail += 1
            hi += 1
        while tail > head and cperp[dq[head]] <= q - r:
            head += 1
        blocked[i] = tail > head and calong[dq[head]] > qalong[i]


@njit(cache=True)
def _casters_point(points, lx, ly, ctheta, cx, cy, r, half_window, blocked):
    """Query ``i`` is blocked iff the segment to the light passes within ``r`` of a
    caster's centre lying ahead (its projection on the segment is > 0: a robot does not
    shadow its own centre); candidates are casters (sorted by angle ``ctheta`` around the
    light) within ``half_window`` of the query's angle."""
    m = ctheta.shape[0]
    r2 = r * r
    two_pi = 2.0 * math.pi
    for i in range(points.shape[0]):
        px = points[i, 0]
        py = points[i, 1]
        vx = lx - px
        vy = ly - py
        vv = vx * vx + vy * vy
        blocked[i] = False
        if vv == 0.0 or m == 0:
            continue
        start = math.atan2(py - ly, px - lx) - half_window
        if start < -math.pi:
            start += two_pi
        j = np.searchsorted(ctheta, start)
        for k in range(m):
            jj = (j + k) % m
            span = ctheta[jj] - start
            if span < 0.0:
                span += two_pi
            if span > 2.0 * half_window:
                break
            wx = cx[jj] - px
            wy = cy[jj] - py
            t = (wx * vx + wy * vy) / vv
            if t <= 0.0:
                continue  # the caster's centre is not ahead (e.g. the robot itself)
            t = min(t, 1.0)
            dx = wx - t * vx
            dy = wy - t * vy
            if dx * dx + dy * dy < r2:
                blocked[i] = True
                break
