"""The measurements behind docs/scenarios_road_compression.md (accuracy, not speed).

Subcommands (each prints a table; ``--json`` prints the rows as JSON):

``road``
    narrow-road runs over seeds (and ``--set`` overrides): crossings, longest zero-flow
    period per direction and overall, waits at re-entry.
``wall-layer``
    compression with held walls at packing fraction 0.01 for several free heights h:
    Z = P A_free / (n kT_eff) against h / l, with l = <v> tau the persistence length.
``claims``
    the configurations of the two compression tests (dilute ideal-gas law; pressure
    proportional to temperature with held walls), with their numbers.
``compression``
    the paper's three compression studies: an isotherm (force varied at fixed T),
    pressure against temperature with held walls (fixed density), and the temperature
    that holds the density fixed as the force varies (panel w); tables, fits and a
    figure (``--out DIR/compression_study.png``).

Usage::

    PYTHONPATH=src python benchmarks/road_compression_study.py road --seeds 0 1 2 3 4
    PYTHONPATH=src python benchmarks/road_compression_study.py road --seeds 0 1 2 \\
        --set arrive_depth=33
    PYTHONPATH=src python benchmarks/road_compression_study.py wall-layer
    PYTHONPATH=src python benchmarks/road_compression_study.py compression --out study
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
from pathlib import Path

from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.scenarios import runner


def road(seeds: list[int], sets: list[str], out: Path) -> list[dict]:
    rows = []
    for seed in seeds:
        cfg = runner.resolve("narrow-road", overrides=["record.netcdf=false", *sets], seed=seed)
        m = runner.run(cfg, out / f"road-{seed}", progress=False)
        z = m["longest_zero_flow_s"]
        rows.append(
            {
                "seed": seed,
                "crossings_+x": m["crossings"]["+x"],
                "crossings_-x": m["crossings"]["-x"],
                "zero_flow_+x_s": z["+x"],
                "zero_flow_-x_s": z["-x"],
                "zero_flow_overall_s": z["overall"],
                "waited": m["waiting"]["+x"]["waited"] + m["waiting"]["-x"]["waited"],
                "transit_median_+x_s": m["transit_times"]["+x"].get("median"),
                "transit_median_-x_s": m["transit_times"]["-x"].get("median"),
            }
        )
        print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    return rows


def _dilute(n: int, phi: float, h_free: float, mean_speed: float, tau: float) -> list[str]:
    kT = kT_for_mean_speed(mean_speed)
    kT_eff = 2 * kT * tau / 4
    width = n * math.pi * 16.5**2 / phi / (h_free + 33.0)
    return [
        f"n={n}",
        f"width={width}",
        f"kT={kT}",
        f"tau={tau}",
        f"force={n * kT_eff / h_free}",
        "record.netcdf=false",
        "record.interval=100.0",
    ]


def wall_layer(heights: list[float], out: Path, n: int, duration: float) -> list[dict]:
    rows = []
    mean_speed, tau = 10.0, 1.0
    for h in heights:
        sets = _dilute(n, 0.01, h, mean_speed, tau)
        sets += ["walls='held'", f"height={h + 33.0}", f"duration={duration}"]
        cfg = runner.resolve("compression", overrides=sets, seed=1)
        m = runner.run(cfg, out / f"wl-{h:g}", progress=False)
        rows.append(
            {
                "h_free_mm": h,
                "h_over_l": h / (mean_speed * tau),
                "Z": m["Z"],
                "Z_se": m["Z_se"],
                "se_reliable": m["se_reliable"],
                "packing_fraction": m["packing_fraction"],
            }
        )
        print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    return rows


def claims(out: Path) -> dict:
    """The two compression tests' configurations, with their numbers."""
    from thermoswarm.scenarios import compression as C

    sets = _dilute(700, 0.01, 100.0, 20.0, 0.1) + ["duration=3600"]
    cfg = runner.resolve("compression", overrides=sets, seed=1)
    m = runner.run(cfg, out / "dilute", progress=False)
    keys = ("packing_fraction", "pressure", "pressure_se", "pressure_applied", "Z", "Z_se",
            "kT_eff", "kT_eff_theory", "height", "ideal_height", "t_relax", "n_batches",
            "se_reliable")  # fmt: skip
    dilute = {k: m[k] for k in keys}
    rows = []
    for k, v in enumerate((16.0, 20.0, 24.0, 28.0)):
        sets = _dilute(300, 0.01, 100.0, 20.0, 0.1)
        sets = [s for s in sets if not s.startswith("kT=")]
        sets += [f"kT={kT_for_mean_speed(v)}", "walls='held'", "height=133.0", "duration=1600"]
        cfg = runner.resolve("compression", overrides=sets, seed=k)
        m = runner.run(cfg, out / f"held-{k}", progress=False)
        rows.append(
            {
                "mean_speed": v,
                "kT_eff": m["kT_eff"],
                "pressure": m["pressure"],
                "pressure_se": m["pressure_se"],
                "Z": m["Z"],
                "free_area": m["free_area"],
            }
        )
    fit = C.linear_fit([r["kT_eff"] for r in rows], [r["pressure"] for r in rows])
    fit["ideal_slope"] = 300 / rows[0]["free_area"]
    return {"dilute_force_driven": [dilute], "held_pressure_vs_temperature": rows,
            "held_fit": fit}  # fmt: skip


def compression(out: Path) -> dict:
    from thermoswarm.scenarios import compression as C
    from thermoswarm.sweep import compression as CS

    # 200 robots, walls 8 m wide, heading re-drawn every 0.2 s: persistence length
    # <v> tau = 4 mm at 20 mm/s, relaxation times up to ~1000 s (free height ~500 mm)
    base = {"n": 200, "width": 8000.0, "duration": 20000.0, "tau": 0.2}
    kT = kT_for_mean_speed(20.0)
    iso = CS.isotherm([10.0, 20.0, 40.0, 80.0, 160.0], kT=kT, out=out / "isotherm", base=base)
    temp = CS.temperature_series(
        [kT_for_mean_speed(v) for v in (10.0, 15.0, 20.0, 25.0, 30.0)],
        force=20.0, walls="held", out=out / "temperature", base=base,
    )  # fmt: skip
    dens = CS.temperature_for_density(
        [10.0, 20.0, 40.0, 80.0], packing_fraction=0.1, out=out / "density", base=base
    )
    fig = C.study_figure(iso, temp, dens)
    fig.savefig(out / "compression_study.png", dpi=120)
    cols = ["force", "kT", "pressure", "pressure_se", "free_area", "packing_fraction",
            "kT_eff", "Z", "Z_se", "se_reliable"]  # fmt: skip
    return {
        "isotherm": iso[cols].to_dict(orient="records"),
        "pressure_vs_temperature": temp[cols].to_dict(orient="records"),
        "pressure_vs_temperature_fit": C.linear_fit(temp["kT_eff"], temp["pressure"]),
        "temperature_for_density": dens[cols].to_dict(orient="records"),
        "temperature_for_density_fit": C.linear_fit(dens["force"], dens["kT"]),
    }


def _table(rows: list[dict]) -> str:
    if not rows:
        return "(no rows)"
    keys = list(rows[0])
    fmt = [max(len(k), 9) for k in keys]
    lines = ["  ".join(k.rjust(w) for k, w in zip(keys, fmt, strict=True))]
    for r in rows:
        cells = []
        for k, w in zip(keys, fmt, strict=True):
            v = r[k]
            cells.append((f"{v:.4g}" if isinstance(v, float) else str(v)).rjust(w))
        lines.append("  ".join(cells))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    a = sub.add_parser("road")
    a.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    a.add_argument("--set", dest="sets", action="append", default=[])
    b = sub.add_parser("wall-layer")
    b.add_argument("--heights", type=float, nargs="+", default=[50.0, 100.0, 200.0, 400.0])
    b.add_argument("--n", type=int, default=1000)
    b.add_argument("--duration", type=float, default=4000.0)
    c = sub.add_parser("compression")
    e = sub.add_parser("claims")
    for p in (a, b, c, e):
        p.add_argument("--out", type=Path, default=None, help="keep the runs here")
        p.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp)
        out.mkdir(exist_ok=True)
        if args.cmd == "road":
            res = road(args.seeds, args.sets, out)
        elif args.cmd == "wall-layer":
            res = wall_layer(args.heights, out, args.n, args.duration)
        elif args.cmd == "claims":
            res = claims(out)
        else:
            res = compression(out)
    if args.json:
        print(json.dumps(res, indent=1))
    elif isinstance(res, list):
        print(_table(res))
    else:
        for k, v in res.items():
            print(k)
            print(_table(v) if isinstance(v, list) else json.dumps(v))
    return 0


if __name__ == "__main__":
    sys.exit(main())
