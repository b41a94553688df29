"""Draw the transport figures of docs/scenarios_transport.md and the README from the
outputs of the commands given there (nothing is simulated here).

    python docs/figures/transport_figures.py arrival SWEEP_DIR    # sweep of the defaults
    python docs/figures/transport_figures.py maps REGIME_DIR      # study regime
    python docs/figures/transport_figures.py scaling DIR_F DIR_D [DIR_H]   # study scaling

Each writes docs/figures/transport_<name>.png (a palette PNG, to keep it small).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = Path(__file__).parent


def _save(fig, name: str, dpi: int = 80, colours: int = 64) -> None:
    from PIL import Image

    path = HERE / f"transport_{name}.png"
    fig.savefig(path, dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    Image.open(path).convert("RGB").quantize(colours).save(path, optimize=True)
    print(path)


def arrival(sweep: Path) -> None:
    """Snapshots of seed 0 up to its arrival and the object's path for every seed."""
    from thermoswarm.scenarios import runner
    from thermoswarm.scenarios.transport_free import plot_frame

    runs = sorted(json.loads((sweep / "sweep.json").read_text())["runs"], key=lambda r: r["seed"])
    r0 = Path(runs[0]["out"])
    info = runner.build(runner.resolve(config_file=r0 / "config.toml"))[1].info
    tracks = runner.open_run_tracks(r0 / "tracks.zarr")
    t_end = runs[0]["metrics"]["time_to_target"]
    times = [0, 150, 300, round(t_end / 5) * 5]
    fig = plt.figure(figsize=(13, 3.6))
    gs = fig.add_gridspec(1, 5, width_ratios=[1, 1, 1, 1, 1.5])
    for i, t in enumerate(times):
        ax = fig.add_subplot(gs[0, i])
        plot_frame(ax, tracks, t, info)
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_xlabel("")
        ax.set_ylabel("")
        ax.set_title(f"seed 0, t = {t:.0f} s", fontsize=9)
    ax = fig.add_subplot(gs[0, 4])
    for r in runs:
        path = r["metrics"]["object_path"]
        ax.plot(path["time"], path["progress"], lw=1)
    ax.axhline(runs[0]["metrics"]["target_distance"], color="tab:green", ls="--", lw=1)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("object moved toward the light (mm)")
    ax.set_title(f"seeds {runs[0]['seed']}-{runs[-1]['seed']} (dashed: target)", fontsize=9)
    fig.tight_layout()
    _save(fig, "arrival")


def maps(regime: Path) -> None:
    from thermoswarm.studies.regime import load_regime, plot_maps

    _save(plot_maps(load_regime(regime)), "drift_maps", dpi=70, colours=256)


def scaling(*dirs: Path) -> None:
    from thermoswarm.studies.scaling import load_scaling, plot_scaling

    _save(plot_scaling([load_scaling(d) for d in dirs]), "scaling")


if __name__ == "__main__":
    what, *paths = sys.argv[1:]
    {"arrival": arrival, "maps": maps, "scaling": scaling}[what](*map(Path, paths))
