"""The narrow road (Algorithm 2) and compression between force-driven walls
(Algorithm 3): runs, numbers and report sections."""

from __future__ import annotations

import math
from concurrent.futures import Executor
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.reproduce.plans import Plan
from thermoswarm.reproduce.runs import _run
from thermoswarm.reproduce.text import _fig, _num, _text


def _narrow_road(out: Path, plan: Plan, rep: Any, seed: int, bars: bool | None = False
                 ) -> dict[str, Any]:  # fmt: skip
    import matplotlib.pyplot as plt

    from thermoswarm.report.animate import animate, snapshot_strip
    from thermoswarm.scenarios import narrow_road as R

    m, tracks, _ = _run("narrow-road", out / "narrow-road", {"duration": plan.road_duration},
                        seed, bars)  # fmt: skip
    geo = m["road"]["geometry"]
    res = {
        "duration_s": plan.road_duration,
        "n": m["n"],
        "crossings": m["crossings"],
        "flow_per_direction": m["flow_per_direction"],
        "longest_zero_flow_s": m["longest_zero_flow_s"],
        # measured energy v^2/2 per road section (mm^2/s^2): colder in the narrow part
        "section_energy": {
            k: {"mean": _num(v["measured"]["energy_mean"]), "se": _num(v["measured"]["energy_se"])}
            for k, v in m["sections"].items()
        },  # fmt: skip
    }
    with rep.section("Narrow road (Algorithm 2)"):
        rep.paragraph(
            f"{m['n']} robots of 33 mm (occupation ratio 0.17857) cross a 381 mm road with a "
            f"wide and a narrow section in two directions for {plan.road_duration:.0f} s; "
            "robots that arrive re-enter at their start."
        )
        flow, gaps = m["flow_per_direction"], m["longest_zero_flow_s"]
        rep.table(
            [
                {"": "crossings", "toward +x": m["crossings"].get("+x"),
                 "toward -x": m["crossings"].get("-x"), "both": m["crossings"].get("total")},
                {"": "flow (crossings per minute)", "toward +x": flow.get("+x"),
                 "toward -x": flow.get("-x"), "both": None},
                {"": "longest period without a crossing (s)", "toward +x": gaps.get("+x"),
                 "toward -x": gaps.get("-x"), "both": gaps.get("overall")},
            ],
            caption="Traffic over the whole run",
        )  # fmt: skip
        rep.table(
            [{"road section": k, "mean energy v^2/2 (mm^2/s^2)": v["mean"],
              "standard error (mm^2/s^2)": v["se"]} for k, v in res["section_energy"].items()],
            caption="Measured energy per road section",
        )  # fmt: skip
        if len(m["flow_over_time"].get("t_start", [])) >= 2:
            fig, ax = plt.subplots(figsize=(7, 3))
            R.plot_flow(ax, m)
            _fig(rep, fig, "Flow per direction over time (crossings per minute).")
        else:
            rep.empty(
                f"Flow over time: the run ({_text(plan.road_duration, 's')}) is shorter than "
                f"two {_text(m['flow_over_time'].get('bin_s'), 's')} bins, so there is no "
                "curve to draw."
            )
        window = min(300.0, plan.road_duration)
        early = tracks.sel(time=slice(0, window))
        _fig(
            rep,
            snapshot_strip(early, R.plot_frame, geo),
            f"Snapshots of the first {window:.0f} s (blue: toward +x, orange: toward -x).",
        )
        path = animate(
            early,
            R.plot_frame,
            geo,
            out / "animations" / "narrow-road",
            size=(7.0, 3.0),
            title="narrow road",
        )
        rep.animation(path, caption=f"The first {window:.0f} s.")
    return res


# ------------------------------------------------------------------------ compression
def _r2(r2: float | None) -> str:
    """R^2 as text that never rounds a 0.99977 up to 1: four digits after the last 9."""
    if r2 is None:
        return "\u2013"
    if r2 >= 1.0:
        return "1 (exact)"
    return f"{r2:.{max(4, 2 - math.floor(math.log10(1.0 - r2)))}f}"


def _picture_run(m: dict[str, Any], pic: dict[str, Any]) -> str:
    """The drawn run's own figures, for its captions."""
    z, se, ok = m.get("Z"), m.get("Z_se"), m.get("se_reliable")
    text = (f"{pic['n']} robots, {pic['width'] / 1000:g} m wide, packing "
            f"{_text(m.get('packing_fraction'))}, {pic['duration']:g} s")  # fmt: skip
    if z is not None:
        text += f", Z = {_text(z)}"
        if se is not None:
            text += f" +- {_text(se)}"
        if ok is False:
            text += " (its standard error is not reliable at this length)"
    return text


def _compression_results(iso: Any, temp: Any, dens: Any, n: int) -> dict[str, Any]:
    """The numbers of ``results.json``: the isotherm's points and mean Z, the linear fits
    of pressure against temperature and of the temperature that holds the density."""
    from thermoswarm.scenarios import compression as C

    pt_fit = C.linear_fit(temp["kT_eff"], temp["pressure"])
    dens_fit = C.linear_fit(dens["force"], dens["kT"])
    return {
        "isotherm": [{"force": _num(a), "free_area": _num(b, 0), "pressure": _num(c, 8),
                      "Z": _num(z), "Z_se": _num(s)} for a, b, c, z, s in
                     zip(iso["force"], iso["free_area"], iso["pressure"], iso["Z"], iso["Z_se"],
                         strict=True)],  # fmt: skip
        "dilute_Z_mean": _num(float(np.mean(iso["Z"]))),
        "pressure_vs_temperature": {"r2": _num(pt_fit["r2"], 6), "slope": _num(pt_fit["slope"], 9),
                                    "n_points": len(temp),
                                    "ideal_slope": _num(n / float(temp["free_area"].iloc[0]), 9)},
        "temperature_for_density": {"r2": _num(dens_fit["r2"], 6),
                                    "n_points": len(dens),
                                    "packing_fraction": [_num(x, 4) for x in
                                                         dens["packing_fraction"]]},
    }  # fmt: skip


def _compression(out: Path, plan: Plan, rep: Any, seed: int, bars: bool | None = False,
                 pool: Executor | None = None) -> dict[str, Any]:  # fmt: skip

    from thermoswarm.maxent import kT_for_mean_speed
    from thermoswarm.report.animate import animate, snapshot_strip
    from thermoswarm.scenarios import compression as C
    from thermoswarm.sweep import compression as CS

    d = 33.0
    r = d / 2
    n, phi, h_free, tau = 300, 0.01, 100.0, 0.1
    kT = kT_for_mean_speed(20.0)
    kT_eff = 2 * kT * tau / 4
    width = n * math.pi * r * r / phi / (h_free + d)
    F0 = n * kT_eff / h_free
    base = {"n": n, "width": width, "kT": kT, "tau": tau, "duration": plan.compression_duration}
    work = out / "compression"
    iso = CS.isotherm([F0 * s for s in (0.5, 0.75, 1.0, 1.5, 2.0)], out=work / "isotherm",
                      base=base, seeds=[seed], executor=pool)  # fmt: skip
    temp = CS.temperature_series([kT_for_mean_speed(v) for v in (16.0, 20.0, 24.0, 28.0)],
                                 out=work / "temperature", base={**base, "force": F0},
                                 seeds=[seed], executor=pool)  # fmt: skip
    dens = CS.temperature_for_density([F0 * s for s in (0.5, 1.0, 2.0, 4.0)],
                                      packing_fraction=phi, out=work / "density", base=base,
                                      seeds=[seed], executor=pool)  # fmt: skip
    # pictures from a squarer run (the dilute geometry above is 20 m wide and 13 cm tall):
    # 150 robots, 1 m wide, the force that holds an ideal gas about 0.6 m high
    kT10 = kT_for_mean_speed(10.0)
    pic = {"n": 150, "width": 1000.0, "kT": kT10, "tau": 1.0,
           "force": round(150 * (2 * kT10 * 1.0 / 4) / 600.0, 4),  # n kT_eff / h_free
           "duration": plan.pictures_duration, "record": {"interval": 5.0}}  # fmt: skip
    m, tracks, _ = _run("compression", work / "run", pic, seed, bars)
    geo = m["geometry"]
    res = _compression_results(iso, temp, dens, n)
    with rep.section("Compression between force-driven walls (Algorithm 3)"):
        rep.paragraph(
            f"{n} robots at packing fraction {phi} between an upper and a lower wall pushed "
            f"by a constant force; heading re-drawn every {tau} s at mean speed 20 mm/s. "
            "Pressure from the walls' contact forces; kT_eff = D = <v^2> tau / 4 from the "
            "speeds drawn; Z = P A_free / (n kT_eff) with A_free = (Lx - d)(Ly - d)."
        )
        rep.table(
            [{"force on each wall (drag units)": r["force"], "free area (mm^2)": r["free_area"],
              "pressure (drag units per mm)": r["pressure"], "Z": r["Z"],
              "Z standard error": r["Z_se"]} for r in res["isotherm"]],
            caption="The isotherm (ideal gas: Z = 1)", floatfmt=".4g",
        )  # fmt: skip
        rep.table(
            {
                "mean Z on the isotherm": res["dilute_Z_mean"],
                "P against kT_eff at fixed area: R^2": _r2(res["pressure_vs_temperature"]["r2"]),
                "P against kT_eff: slope (per mm^2)": res["pressure_vs_temperature"]["slope"],
                "ideal-gas slope n / A_free (per mm^2)": (
                    res["pressure_vs_temperature"]["ideal_slope"]
                ),
                "kT holding the density against the force: R^2": _r2(
                    res["temperature_for_density"]["r2"]
                ),
            },
            header=("quantity", "value"),
        )
        _fig(
            rep,
            C.study_figure(iso, temp, dens),
            "Left: isotherm, P against free area, "
            "with the ideal-gas curve n kT_eff / A_free. Middle: P against kT_eff at fixed "
            "area (held walls). Right: the temperature that holds the density fixed "
            "rises with the force (the paper's panel w).",
        )
        own = _picture_run(m, pic)
        _fig(rep, snapshot_strip(tracks, C.plot_frame, geo), "Snapshots of a separate, squarer "
             f"run drawn for the eye, not the isotherm's {n} robots at packing {phi}: {own} "
             "(robots coloured by speed).")  # fmt: skip
        path = animate(
            tracks, C.plot_frame, geo, out / "animations" / "compression", title="compression"
        )
        rep.animation(path, caption=f"The same separate run as the snapshots: {own}.")
    return res
