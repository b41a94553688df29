"""Heading error of TurnToAngle (photoresistor mode) versus sensor noise.

n robots start at uniformly random headings under a directional light from +y (no
occluders, no ambient light) and run :func:`thermoswarm.sim.light.turn_to_angle` with
``noise_mult = noise_add = sigma``.  Reported per sigma: mean and standard deviation of
the final heading error (deg), the 95th percentile of its magnitude, mean steps and the
converged fraction.  Accuracy, not speed: the numbers do not depend on the machine.

Usage::

    python benchmarks/light_turn_noise.py [--n 100000] [--seed 0] [--json]
"""

from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np

from thermoswarm.sim.light import DirectionalLight, SensingParams, turn_to_angle

SIGMAS = (0.0, 0.005, 0.01, 0.02, 0.05)


def run(n: int = 100_000, seed: int = 0, step_deg: float = 2.0) -> dict:
    rng = np.random.default_rng(seed)
    light = DirectionalLight(direction=(0.0, -1.0))
    h0 = rng.uniform(-math.pi, math.pi, n)
    rows = []
    for sigma in SIGMAS:
        params = SensingParams(noise_mult=sigma, noise_add=sigma, step_deg=step_deg)
        res = turn_to_angle(np.zeros((n, 2)), h0, light, None, params, rng)
        err = (np.degrees(res.heading) - 90.0 + 180.0) % 360.0 - 180.0
        rows.append(
            {
                "sigma": sigma,
                "error_mean_deg": float(err.mean()),
                "error_sd_deg": float(err.std()),
                "abs_error_p95_deg": float(np.quantile(np.abs(err), 0.95)),
                "mean_steps": float(res.steps.mean()),
                "converged_fraction": float(res.converged.mean()),
            }
        )
    p = SensingParams(step_deg=step_deg)
    return {
        "n": n,
        "seed": seed,
        "step_deg": step_deg,
        "sensor_angle_deg": p.sensor_angle_deg,
        "fov_deg": p.fov_deg,
        "balance_tolerance": p.balance_tolerance,
        "balance_window_deg": math.degrees(p.balance_window),
        "rows": rows,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--step-deg", type=float, default=2.0)
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    args = ap.parse_args(argv)
    res = run(args.n, args.seed, args.step_deg)
    if args.json:
        json.dump(res, sys.stdout, indent=2)
        print()
        return 0
    print(
        f"n = {res['n']:,}, step {res['step_deg']:g} deg, tolerance "
        f"{res['balance_tolerance']:.4f} (window +-{res['balance_window_deg']:.2f} deg)"
    )
    print("sigma   mean(deg)  sd(deg)  p95|err|(deg)  steps  converged")
    for r in res["rows"]:
        print(
            f"{r['sigma']:<7g} {r['error_mean_deg']:9.3f} {r['error_sd_deg']:8.3f} "
            f"{r['abs_error_p95_deg']:14.3f} {r['mean_steps']:6.1f} "
            f"{r['converged_fraction']:10.4f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
