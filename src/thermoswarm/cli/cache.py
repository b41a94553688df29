"""``thermoswarm cache``: where the compiled kernels live; warm or clear them."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import click

from thermoswarm import cache as C

# Configurations whose kernels differ (engine modes, light and sensing kinds, walls,
# bodies); each is run for a few control periods at a small size.
_WARM: list[tuple[str, dict]] = [
    ("box", {"n": 50, "duration": 2.0}),
    ("box", {"n": 50, "duration": 0.5, "mode": "inertial", "engine": {"dt": 0.05},
             "record": {"interval": 0.05}}),
    ("narrow-road", {"duration": 2.0}),
    ("narrow-road", {"duration": 2.0, "steering": "exponential", "ends": "walls"}),
    ("compression", {"n": 50, "duration": 2.0}),
    ("compression", {"n": 50, "duration": 2.0, "walls": "held"}),
    ("transport-connected", {"duration": 2.0}),
    ("transport-connected", {"duration": 2.0, "sensor": {"mode": "photoresistor"}}),
    ("transport-free", {"n": 100, "duration": 2.0}),
    ("transport-free", {"n": 100, "duration": 2.0, "heading_law": "uniform",
                        "mapping": "lit_hot", "sensor": {"mode": "photoresistor"}}),
    ("transport-free", {"n": 100, "duration": 2.0, "variant": "obstacle", "light": "point"}),
    ("transport-free", {"n": 100, "duration": 2.0, "variant": "zigzag"}),
]  # fmt: skip


def warm_kernels(*, verbose: bool = False) -> C.JitTime:
    """Compile (or load) every kernel that the scenarios and the analysis use.

    Runs each configuration of a short list for a few control periods in a temporary
    directory, then fits a small sample with the analysis.  A configuration that a
    newer parameter set no longer accepts is skipped with a note (warming is a
    convenience, never an error).  Returns the time spent in the JIT.
    """
    import numpy as np

    from thermoswarm.errors import ThermoswarmError
    from thermoswarm.scenarios import get
    from thermoswarm.scenarios.runner import RunConfig, run
    from thermoswarm.sweep import _flatten_base

    total = C.JitTime()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="thermoswarm-warm-") as tmp, C.jit_timer() as jit:
        for i, (name, over) in enumerate(_WARM):
            t = time.perf_counter()
            try:
                from thermoswarm.config import from_mapping

                params = from_mapping(get(name).Params, _flatten_base(over))
                run(RunConfig(name, params, 0), Path(tmp) / f"{i}", progress=False)
            except ThermoswarmError as exc:
                if verbose:
                    print(f"  {name} {over}: skipped ({exc})", flush=True)
                continue
            if verbose:
                print(f"  {name:20s} {time.perf_counter() - t:6.1f} s", flush=True)
        t = time.perf_counter()
        from thermoswarm.analysis.phase_tests import compare_phases

        rng = np.random.default_rng(0)
        x = np.concatenate([rng.exponential(1.0, 300), rng.exponential(5.0, 300)])
        compare_phases(x, n_bootstrap=19, random_state=0)
        if verbose:
            print(f"  {'analysis':20s} {time.perf_counter() - t:6.1f} s", flush=True)
        t = time.perf_counter()
        _warm_tracker(rng)
        if verbose:
            print(f"  {'tracker':20s} {time.perf_counter() - t:6.1f} s", flush=True)
    total.seconds, total.compile_seconds = jit.seconds, jit.compile_seconds
    from thermoswarm.scenarios.schema import all_params

    all_params()  # the parameter listing that `--set` is checked against
    if verbose:
        what = "compiled" if total.compiled else "loaded from the cache"
        print(
            f"kernels {what} in {C.numba_cache_dir()} "
            f"({time.perf_counter() - t0:.0f} s; {total.compile_seconds:.0f} s compiling)",
            flush=True,
        )
    return total


def _warm_tracker(rng) -> None:
    """Track a few frames of boxes and of posed detections (head, centre, tail): the
    tracker's compiled kernels for both kinds of input."""
    import numpy as np

    from thermoswarm.tracking.detection import FrameDetections
    from thermoswarm.tracking.track.tracker import track_detections

    centres = rng.uniform(50.0, 450.0, (6, 2))
    step = np.array([2.0, 1.0])
    boxes, posed = [], []
    for f in range(8):
        c = centres + f * step
        pts = np.stack([c + [8.0, 0.0], c, c - [8.0, 0.0]], axis=1)
        b = np.column_stack([c - [10.0, 4.0], np.full((6, 2), [20.0, 8.0])])
        no_pose = np.full_like(pts, np.nan)
        no_pose[:, 1] = c
        boxes.append(FrameDetections(no_pose, np.ones(6), boxes=b))
        posed.append(FrameDetections(pts, np.ones(6)))
    track_detections(boxes, fps=30.0, frame_size=(500, 500))
    track_detections(posed, fps=30.0, px_per_mm=3.0, frame_size=(500, 500))


@click.command()
@click.option("--warm", is_flag=True, help="Compile every kernel now (what make install does).")
@click.option("--clear", is_flag=True, help="Delete the compiled kernels.")
def cache(warm: bool, clear: bool) -> None:
    """Print the Numba cache directory (NUMBA_CACHE_DIR, by default in the user's cache
    directory; THERMOSWARM_CACHE_DIR moves it); --warm compiles every kernel the
    scenarios and the analysis use, --clear deletes them."""
    if warm and clear:
        raise click.UsageError("--warm and --clear exclude each other")
    if clear:
        click.echo(f"removed {C.clear()}")
    elif warm:
        click.echo(f"warming the kernels in {C.numba_cache_dir()} ...")
        warm_kernels(verbose=True)
    else:
        click.echo(str(C.numba_cache_dir()))
