"""The paper's study of trajectories: energy phases, steering temperature, regions.

:func:`analyze_tracks` takes trajectories (any source) and returns the content of
``fits.json`` (documented key by key in ``docs/analysis.md``); :func:`run_study` also
returns the kinematics and the fitted objects (for figures and the report), and
:func:`analyze_file` reads a file and writes ``fits.json``, ``report.html`` and
``kinematics.nc``.

What is computed (PAPER_NOTES section 2):

energy
    One exponential against two (:func:`thermoswarm.analysis.fit.compare_phases`) on
    all valid steps; the bootstrap tests run on a test sample thinned by the energy's
    autocorrelation time and capped at ``test_size``
    (:mod:`thermoswarm.analysis.sampling`).
groups
    The same per group of steps: by a data variable's value (``--group-by NAME``), by
    time window (``time:SECONDS``) or by region (``region``).  Across the groups, the
    paper's paired t-test of one-phase against two-phase KS distances is reported,
    labelled descriptive.
steering
    ``|steering rate|`` is exponential (the one-sided law on the magnitude, sign
    random: PAPER_NOTES 6.4) with temperature ``kT_theta`` per energy (or speed) bin;
    per bin a fit, a bootstrap KS test and a sign test; then ``kT_theta`` against the
    bins' mean energy with a weighted least-squares trend (t-test of the slope, k - 2
    degrees of freedom, residual scale estimated) and Spearman's rank correlation.
regions
    The fraction of steps in the hot phase per region: the maximum-likelihood weight
    of the ``kT2`` component with both temperatures fixed at the overall two-phase fit
    (so regions differ only in how their steps split between the same two phases).
    Its uncertainty and the test of each difference resample whole tracks
    (clusters) with replacement, which keeps the dependence of a track's steps; each
    bootstrap replicate takes one Newton step from the estimate (a one-step
    bootstrap, first-order equivalent to refitting).  The naive Wald test that treats
    steps as independent is reported beside it, labelled.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm import __version__
from thermoswarm.analysis.groups import group_codes, ks_comparison, parse_group_by
from thermoswarm.analysis.kinematics import compute_kinematics, data_quality, excluded_summary
from thermoswarm.analysis.phase_tests import PhaseComparison
from thermoswarm.analysis.phases import MIN_SAMPLES, dependence, phase_block, plausibility
from thermoswarm.analysis.region_stats import regions_block
from thermoswarm.analysis.regions import OUTSIDE, Region, assign_regions, load_regions
from thermoswarm.analysis.steering import steering_block
from thermoswarm.errors import ConfigError, InputError

__all__ = [
    "analyze_tracks",
    "run_study",
    "StudyResult",
    "parse_energy_bins",
    "KINEMATICS_KEYS",
]


KINEMATICS_KEYS = (
    "keypoint",
    "smooth",
    "polyorder",
    "min_speed",
    "max_speed",
    "gap_factor",
    "max_gap",
    "stationary_speed",
    "stationary_duration",
    "drop_stationary",
    "min_confidence",
    "regular_tolerance",
    "duplicates",
    "held_positions",
    "resting_speed",
    "keep_resting",
    "implausible_factor",
    "body_length",
    "max_body_lengths_per_s",
    "keep_implausible",
    "min_track_extent",
)


def parse_energy_bins(value: Any) -> int | tuple[float, ...]:
    """An integer (equal-count bins) or increasing edges (``"0,5,10,20"`` or a list)."""
    if isinstance(value, str):
        parts = [p for p in re.split(r"[,\s]+", value.strip()) if p]
        if len(parts) == 1:
            value = parts[0]
            try:
                value = int(value)
            except ValueError:
                raise ConfigError(
                    f"--energy-bins must be a count or comma-separated edges, got {value!r}"
                ) from None
        else:
            try:
                value = [float(p) for p in parts]
            except ValueError:
                raise ConfigError(
                    f"--energy-bins edges must be numbers, got {','.join(parts)!r}"
                ) from None
    if isinstance(value, bool):
        raise ConfigError(f"energy_bins must be a count or a list of edges, got {value!r}")
    if isinstance(value, int | np.integer):
        if value < 1:
            raise ConfigError(f"energy_bins must be at least 1, got {value}")
        return int(value)
    try:
        edges = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise ConfigError(
            f"energy_bins must be a count or a list of edges, got {value!r}"
        ) from None
    if len(edges) < 2 or not all(math.isfinite(e) for e in edges):
        raise ConfigError(f"energy_bins edges must be at least 2 finite numbers, got {edges}")
    if any(b <= a for a, b in zip(edges[:-1], edges[1:], strict=True)):
        raise ConfigError(f"energy_bins edges must increase, got {edges}")
    return edges


def _check_options(
    n_bootstrap: Any, test_size: Any, thin: Any, alpha: Any, steering_by: Any
) -> tuple[int, int | None, str | int, float]:
    if isinstance(n_bootstrap, bool) or not isinstance(n_bootstrap, int | np.integer):
        raise ConfigError(f"n_bootstrap must be an integer >= 0, got {n_bootstrap!r}")
    if n_bootstrap < 0:
        raise ConfigError(f"n_bootstrap must be an integer >= 0, got {n_bootstrap!r}")
    if test_size is not None:
        if isinstance(test_size, bool) or not isinstance(test_size, int | np.integer):
            raise ConfigError(f"test_size must be an integer >= 20 or None, got {test_size!r}")
        if test_size < MIN_SAMPLES:
            raise ConfigError(f"test_size must be an integer >= 20 or None, got {test_size!r}")
    if thin != "auto":
        if isinstance(thin, bool) or not isinstance(thin, int | np.integer) or thin < 1:
            raise ConfigError(f"thin must be 'auto' or an integer >= 1, got {thin!r}")
    try:
        alpha = float(alpha)
    except (TypeError, ValueError):
        alpha = float("nan")
    if not 0 < alpha < 1:
        raise ConfigError(f"alpha must be in (0, 1), got {alpha!r}")
    if steering_by not in ("energy", "speed"):
        raise ConfigError(f"steering_by must be 'energy' or 'speed', got {steering_by!r}")
    return int(n_bootstrap), (None if test_size is None else int(test_size)), thin, alpha


@dataclass
class StudyResult:
    """Everything :func:`run_study` computed.

    ``fits`` is the ``fits.json`` content; ``kinematics`` the per-step dataset (with a
    ``region`` variable when regions were given); the other fields keep the fitted
    objects for figures: ``energy`` (:class:`PhaseComparison`), ``groups``
    (``{spec: {"codes": (time, individuals) int array, "labels": [...], "fits":
    {label: PhaseComparison}}}``), ``steering`` (``{"edges", "codes", "fits": [...]}``),
    ``regions`` (list of :class:`Region`).
    """

    fits: dict[str, Any]
    kinematics: xr.Dataset
    energy: PhaseComparison | None = None
    groups: dict[str, dict[str, Any]] = field(default_factory=dict)
    steering: dict[str, Any] = field(default_factory=dict)
    regions: list[Region] = field(default_factory=list)


def run_study(
    ds: xr.Dataset,
    *,
    fps: float | None = None,
    mass: float | None = None,
    regions: Sequence[Region] | str | os.PathLike | None = None,
    group_by: Sequence[str] | str = (),
    energy_bins: int | Sequence[float] | str = 8,
    steering_by: str = "energy",
    n_bootstrap: int = 200,
    test_size: int | None = 10_000,
    thin: str | int = "auto",
    alpha: float = 0.05,
    seed: int | None = 0,
    max_plausible_speed: float | None = None,
    progress: Callable[[str], None] | None = None,
    **kinematics_options: Any,
) -> StudyResult:
    """Run the whole study on trajectories ``ds``.

    Parameters
    ----------
    ds
        Trajectories in the format of :mod:`thermoswarm.tracks` (mm).
    fps
        Frame rate for frame-numbered data.
    mass
        kg; energies in J (default: per unit mass, mm^2/s^2).
    regions
        Regions (list, or a TOML file: :mod:`thermoswarm.analysis.regions`).
    group_by
        Group specs: a data variable's name, ``time:SECONDS`` or ``region``.
    energy_bins
        Steering bins: a count (equal-count bins of ``steering_by``) or edges (in the
        energy unit, or mm/s for speed).
    steering_by
        ``"energy"`` or ``"speed"``.
    n_bootstrap
        Bootstrap replicates of every bootstrap test (0: none; p-values are ``None``
        and the preferred model is chosen by BIC).
    test_size
        Largest test sample (``None``: no cap); see
        :mod:`thermoswarm.analysis.sampling`.
    thin
        ``"auto"`` or a thinning step (1: none).
    alpha
        Level of the LR test that picks the preferred model, and of the intervals.
    seed
        Seed of every random draw (same seed, same output).
    max_plausible_speed
        The animal's top speed (mm/s) for the plausibility of the fitted temperatures
        (:func:`plausibility`); default: the implausible-motion threshold.
    progress
        Called with a short message at each stage.
    **kinematics_options
        Passed to :func:`thermoswarm.analysis.kinematics.compute_kinematics`
        (``smooth``, ``min_speed``, ``max_speed``, ``gap_factor``, ``max_gap``,
        ``duplicates``, ``resting_speed``, ``body_length``, ...).

    Raises
    ------
    InputError
        When no step is left to fit (every step missing, a gap, resting or
        implausible): the message gives the counts.
    """
    unknown = [k for k in kinematics_options if k not in KINEMATICS_KEYS]
    if unknown:
        raise ConfigError(
            f"unknown analysis option {unknown[0]!r}; expected one of: "
            + ", ".join(sorted(KINEMATICS_KEYS))
        )
    n_bootstrap, test_size, thin, alpha = _check_options(
        n_bootstrap, test_size, thin, alpha, steering_by
    )
    bins = parse_energy_bins(energy_bins)
    if isinstance(group_by, str):
        group_by = [group_by]
    specs = [parse_group_by(g) for g in group_by]
    if len({s.text for s in specs}) != len(specs):
        raise ConfigError("--group-by: the same grouping is given twice")
    region_source = None
    if regions is not None and not isinstance(regions, list | tuple):
        region_source = str(regions)
        regions = load_regions(regions)
    regions = list(regions or [])
    if any(s.kind == "region" for s in specs) and not regions:
        raise ConfigError("--group-by region needs --regions FILE")
    say = progress or (lambda msg: None)
    root = np.random.SeedSequence(seed)
    s_energy, s_steer, s_regions, s_groups = root.spawn(4)

    if max_plausible_speed is not None:
        mp = float(max_plausible_speed)
        if not (math.isfinite(mp) and mp > 0):
            raise ConfigError(f"max_plausible_speed must be a positive number, got {mp!r}")
    say("kinematics")
    kin = compute_kinematics(ds, fps=fps, mass=mass, **kinematics_options)
    energy = kin["energy"].values
    valid = kin["valid"].values & np.isfinite(energy)
    if not valid.any():
        dq = data_quality(kin)
        buckets = ", ".join(
            f"{v} {k.replace('_', ' ')}" for k, v in dq["step_buckets"].items() if v
        )
        src = ds.attrs.get("source_file", "the input")
        raise InputError(
            f"{src}: no step left to fit ({dq['n_steps_total']} steps: {buckets or 'none'}); "
            "see --keep-resting, --keep-implausible, --gap-factor, --max-gap"
        )
    region_codes = None
    if regions:
        region_codes = assign_regions(regions, kin["x_mid"].values, kin["y_mid"].values)
        kin["region"] = (
            ("time", "individuals"),
            region_codes,
            {"names": ",".join(r.name for r in regions), "outside": OUTSIDE},
        )
    # Group labels before any fitting, so that a bad --group-by fails at once.
    codes_by_spec = {
        spec.text: group_codes(spec, ds, kin, region_codes, regions) for spec in specs
    }
    e_unit = kin.attrs["energy_unit"]
    tracks_used = int(valid.any(axis=0).sum())
    fits: dict[str, Any] = {
        "schema": "thermoswarm.analysis/1",
        "thermoswarm_version": __version__,
        "source_file": ds.attrs.get("source_file"),
        "n_tracks": tracks_used,
        "n_samples": int(valid.sum()),
        "units": {
            "energy": e_unit,
            "speed": "mm/s",
            "steering_rate": "rad/s",
            "kT_theta": "rad/s",
            "time": "s",
            "position": "mm",
        },
        "settings": {
            "fps": fps,
            "mass_kg": mass,
            "energy_bins": bins if isinstance(bins, int) else list(bins),
            "steering_by": steering_by,
            "group_by": [s.text for s in specs],
            "regions": region_source if region_source else ([r.name for r in regions] or None),
            "n_bootstrap": n_bootstrap,
            "test_size": test_size,
            "thin": thin,
            "alpha": alpha,
            "seed": seed,
            **{k: kinematics_options.get(k) for k in KINEMATICS_KEYS},
        },
        "data_quality": data_quality(kin),
        "excluded": excluded_summary(kin),
    }
    fits["settings"]["max_plausible_speed"] = max_plausible_speed
    result = StudyResult(fits, kin, regions=regions)

    say("energy: one vs two phases")
    dep_e = dependence(energy, valid)
    block, cmp_ = phase_block(
        energy, valid, dep=dep_e, n_bootstrap=n_bootstrap, test_size=test_size, thin=thin,
        alpha=alpha, seed=s_energy,
    )  # fmt: skip
    block["unit"] = e_unit
    fits["energy"] = block
    fits["plausibility"] = plausibility(
        block, kin, mass=mass, max_plausible_speed=max_plausible_speed
    )
    result.energy = cmp_

    say("steering")
    steer, keep = steering_block(
        kin, bins=bins, by=steering_by, n_bootstrap=n_bootstrap, test_size=test_size,
        thin=thin, seed=s_steer,
    )  # fmt: skip
    fits["steering"] = steer
    result.steering = keep

    fits["groups"] = {}
    for spec, gseed in zip(specs, s_groups.spawn(len(specs)), strict=True):
        say(f"groups: {spec.text}")
        codes, labels = codes_by_spec[spec.text]
        levels: dict[str, Any] = {}
        kept: dict[str, Any] = {}
        for j, (label, lseed) in enumerate(zip(labels, gseed.spawn(len(labels)), strict=True)):
            m = valid & (codes == j)
            blk, c = phase_block(
                energy, m, dep=dep_e, n_bootstrap=n_bootstrap, test_size=test_size,
                thin=thin, alpha=alpha, seed=lseed,
            )  # fmt: skip
            blk["n_tracks"] = int(m.any(axis=0).sum())
            levels[label] = blk
            kept[label] = c
        fits["groups"][spec.text] = {
            "kind": spec.kind,
            **({"window_s": spec.window} if spec.kind == "time" else {}),
            **({"variable": spec.name} if spec.kind == "variable" else {}),
            "levels": levels,
            "ks_comparison": ks_comparison(levels),
        }
        result.groups[spec.text] = {"codes": codes, "labels": labels, "fits": kept}

    if regions:
        say("regions")
        fits["regions"] = regions_block(
            kin, region_codes, regions, cmp_, n_bootstrap=n_bootstrap, alpha=alpha,
            seed=s_regions, source=region_source,
        )  # fmt: skip
    else:
        fits["regions"] = {}
    return result


def analyze_tracks(ds: xr.Dataset, **options: Any) -> dict[str, Any]:
    """The paper's statistics of trajectories ``ds``: the ``fits.json`` content.

    Options as :func:`run_study`.  Energies are in mm^2/s^2 (per unit mass) unless a
    ``mass`` (kg) is given, then in J.
    """
    return run_study(ds, **options).fits
