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

import os
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm import __version__
from thermoswarm.analysis.groups import GroupSpec, group_codes, ks_comparison, parse_group_by
from thermoswarm.analysis.kinematics import compute_kinematics, data_quality, excluded_summary
from thermoswarm.analysis.options import KEYWORD_SECTIONS, AnalysisOptions, parse_energy_bins
from thermoswarm.analysis.phase_tests import PhaseComparison
from thermoswarm.analysis.phases import dependence, phase_block, plausibility
from thermoswarm.analysis.recording import (
    apply_speed_source,
    kT_interval,
    mask_shared_positions,
    recording_block,
    recording_facts,
)
from thermoswarm.analysis.region_stats import regions_block
from thermoswarm.analysis.regions import OUTSIDE, Region, assign_regions, load_regions
from thermoswarm.analysis.steering import steering_block
from thermoswarm.errors import ConfigError, InputError

__all__ = [
    "analyze_tracks",
    "run_study",
    "StudyResult",
    "StudyPlan",
    "plan_study",
    "fittable_steps",
    "fits_header",
    "fit_energy",
    "fit_steering",
    "fit_groups",
    "parse_energy_bins",
    "KINEMATICS_KEYS",
]


#: The kinematics options written to ``fits.json["settings"]``, in order.
KINEMATICS_KEYS = (
    "keypoint",
    "mask_shared_positions",
    "speed_source",
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


@dataclass(frozen=True)
class StudyPlan:
    """What the study will fit, checked before any work: the group specs and the regions
    (with the file they came from, if any)."""

    specs: list[GroupSpec]
    regions: list[Region]
    region_source: str | None


def plan_study(
    opts: AnalysisOptions, regions: Sequence[Region] | str | os.PathLike | None = None
) -> StudyPlan:
    """The groups and regions of ``opts.fit`` (``regions`` given here, in memory or as a
    file, replaces ``opts.fit.regions``); a bad spec fails here, before any work."""
    specs = [parse_group_by(g) for g in opts.fit.group_by]
    if len({s.text for s in specs}) != len(specs):
        raise ConfigError("--group-by: the same grouping is given twice")
    if regions is None:
        regions = opts.fit.regions
    region_source = None
    if regions is not None and not isinstance(regions, list | tuple):
        region_source = str(regions)
        regions = load_regions(regions)
    regions = list(regions or [])
    if any(s.kind == "region" for s in specs) and not regions:
        raise ConfigError("--group-by region needs --regions FILE")
    return StudyPlan(specs, regions, region_source)


def fittable_steps(kin: xr.Dataset, source: Any) -> np.ndarray:
    """The steps whose energy enters the fits; an :class:`InputError` with the bucket
    counts when there is none."""
    valid = kin["valid"].values & np.isfinite(kin["energy"].values)
    if not valid.any():
        dq = data_quality(kin)
        buckets = ", ".join(
            f"{v} {k.replace('_', ' ')}" for k, v in dq["step_buckets"].items() if v
        )
        raise InputError(
            f"{source}: no step left to fit ({dq['n_steps_total']} steps: {buckets or 'none'}); "
            "see --keep-resting, --keep-implausible, --gap-factor, --max-gap"
        )
    return valid


def option_value(opts: AnalysisOptions, name: str) -> Any:
    """The option of flat name ``name`` (``"smooth"``, ``"n_bootstrap"``, ...)."""
    return getattr(getattr(opts, KEYWORD_SECTIONS[name]), name)


def settings_block(opts: AnalysisOptions, plan: StudyPlan) -> dict[str, Any]:
    """``fits.json["settings"]``: the options the study ran with."""
    bins, t = opts.fit.energy_bins, opts.test
    regions = plan.region_source if plan.region_source else (
        [r.name for r in plan.regions] or None)  # fmt: skip
    return {
        "fps": opts.read.fps,
        "mass_kg": opts.steps.mass,
        "energy_bins": bins if isinstance(bins, int) else list(bins),
        "steering_by": opts.fit.steering_by,
        "group_by": [s.text for s in plan.specs],
        "regions": regions,
        "n_bootstrap": t.n_bootstrap,
        "test_size": t.test_size,
        "thin": t.thin,
        "alpha": t.alpha,
        "seed": t.seed,
        **{k: option_value(opts, k) for k in KINEMATICS_KEYS},
        "max_plausible_speed": opts.fit.max_plausible_speed,
    }


def fits_header(
    ds: xr.Dataset, kin: xr.Dataset, valid: np.ndarray, opts: AnalysisOptions, plan: StudyPlan
) -> dict[str, Any]:
    """The part of ``fits.json`` before any fit: source, counts, units, settings, data
    quality and what was left out."""
    return {
        "schema": "thermoswarm.analysis/1",
        "thermoswarm_version": __version__,
        "source_file": ds.attrs.get("source_file"),
        "n_tracks": int(valid.any(axis=0).sum()),
        "n_samples": int(valid.sum()),
        "units": {
            "energy": kin.attrs["energy_unit"],
            "speed": "mm/s",
            "steering_rate": "rad/s",
            "kT_theta": "rad/s",
            "time": "s",
            "position": "mm",
        },
        "settings": settings_block(opts, plan),
        "data_quality": data_quality(kin),
        "excluded": excluded_summary(kin),
    }


def fit_energy(
    result: StudyResult,
    energy: np.ndarray,
    valid: np.ndarray,
    dep: Any,
    opts: AnalysisOptions,
    seed: np.random.SeedSequence,
) -> None:
    """The fit and test stages of all energies: one against two phases, plausibility."""
    t = opts.test
    block, cmp_ = phase_block(
        energy, valid, dep=dep, n_bootstrap=t.n_bootstrap, test_size=t.test_size,
        thin=t.thin, alpha=t.alpha, seed=seed,
    )  # fmt: skip
    block["unit"] = result.kinematics.attrs["energy_unit"]
    result.fits["energy"] = block
    result.fits["plausibility"] = plausibility(
        block, result.kinematics, mass=opts.steps.mass,
        max_plausible_speed=opts.fit.max_plausible_speed,
    )  # fmt: skip
    result.energy = cmp_


def fit_steering(result: StudyResult, opts: AnalysisOptions, seed: np.random.SeedSequence) -> None:
    """The fit and test stages of steering: ``kT_theta`` per bin and its trend."""
    t = opts.test
    steer, keep = steering_block(
        result.kinematics, bins=opts.fit.energy_bins, by=opts.fit.steering_by,
        n_bootstrap=t.n_bootstrap, test_size=t.test_size, thin=t.thin, seed=seed,
    )  # fmt: skip
    result.fits["steering"] = steer
    result.steering = keep


def fit_groups(
    result: StudyResult,
    energy: np.ndarray,
    valid: np.ndarray,
    dep: Any,
    codes_by_spec: dict[str, tuple[np.ndarray, list[str]]],
    plan: StudyPlan,
    opts: AnalysisOptions,
    seed: np.random.SeedSequence,
    say: Callable[[str], None],
) -> None:
    """The energy phases per group of each ``--group-by``, and the paired KS comparison."""
    t = opts.test
    result.fits["groups"] = {}
    for spec, gseed in zip(plan.specs, seed.spawn(len(plan.specs)), strict=True):
        say(f"groups: {spec.text}")
        codes, labels = codes_by_spec[spec.text]
        levels: dict[str, Any] = {}
        kept: dict[str, Any] = {}
        for j, (label, lseed) in enumerate(zip(labels, gseed.spawn(len(labels)), strict=True)):
            m = valid & (codes == j)
            blk, c = phase_block(
                energy, m, dep=dep, n_bootstrap=t.n_bootstrap, test_size=t.test_size,
                thin=t.thin, alpha=t.alpha, seed=lseed,
            )  # fmt: skip
            blk["n_tracks"] = int(m.any(axis=0).sum())
            levels[label] = blk
            kept[label] = c
        result.fits["groups"][spec.text] = {
            "kind": spec.kind,
            **({"window_s": spec.window} if spec.kind == "time" else {}),
            **({"variable": spec.name} if spec.kind == "variable" else {}),
            "levels": levels,
            "ks_comparison": ks_comparison(levels),
        }
        result.groups[spec.text] = {"codes": codes, "labels": labels, "fits": kept}


def note_recording(
    result: StudyResult,
    facts: dict[str, Any],
    source: str,
    opts: AnalysisOptions,
    n_shared: int | None,
) -> None:
    """``fits.json["recording"]`` and the masked-sample count; the recording's warning
    (sampling coarser than the control period) as a :class:`UserWarning`."""
    rec = recording_block(result.kinematics, facts, source, opts.steps.speed_source)
    result.fits["recording"] = rec
    if n_shared is not None:
        result.fits["data_quality"]["n_shared_positions_masked"] = n_shared
    if rec["warning"]:
        warnings.warn(rec["warning"], stacklevel=3)


def run_study(
    ds: xr.Dataset,
    options: AnalysisOptions | None = None,
    *,
    regions: Sequence[Region] | str | os.PathLike | None = None,
    progress: Callable[[str], None] | None = None,
    **keywords: Any,
) -> StudyResult:
    """Run the whole study on trajectories ``ds``: the stages after reading.

    Parameters
    ----------
    ds
        Trajectories in the format of :mod:`thermoswarm.tracks` (mm).
    options
        Every option (:class:`~thermoswarm.analysis.options.AnalysisOptions`; default:
        the defaults).  ``read.fps`` converts frame numbers to seconds.
    regions
        Regions in memory (list of :class:`Region`) or a TOML file; replaces
        ``options.fit.regions``.
    progress
        Called with a short message at each stage.
    **keywords
        Options by their flat names, applied over ``options`` (``n_bootstrap=99``,
        ``seed=1``, ``smooth=0.1``, ``group_by=["region"]``, ...; each documented in
        :mod:`thermoswarm.analysis.options`); an unknown name is a :class:`ConfigError`.

    Raises
    ------
    InputError
        When no step is left to fit (every step missing, a gap, resting or
        implausible): the message gives the counts.
    """
    opts = AnalysisOptions.from_keywords(options, **keywords)
    plan = plan_study(opts, regions)
    say = progress or (lambda msg: None)
    seeds = np.random.SeedSequence(opts.test.seed).spawn(5)  # the first 4 as before
    s_energy, s_steer, s_regions, s_groups, s_ci = seeds
    facts = recording_facts(ds)
    ds, n_shared = mask_shared_positions(ds) if opts.clean.mask_shared_positions else (ds, None)
    say("kinematics")
    kin = compute_kinematics(ds, opts)
    source = apply_speed_source(kin, ds, opts.steps.speed_source, facts, opts.steps.mass)
    energy = kin["energy"].values
    valid = fittable_steps(kin, ds.attrs.get("source_file", "the input"))
    region_codes = None
    if plan.regions:
        region_codes = assign_regions(plan.regions, kin["x_mid"].values, kin["y_mid"].values)
        kin["region"] = (
            ("time", "individuals"),
            region_codes,
            {"names": ",".join(r.name for r in plan.regions), "outside": OUTSIDE},
        )
    # Group labels before any fitting, so that a bad --group-by fails at once.
    codes_by_spec = {
        spec.text: group_codes(spec, ds, kin, region_codes, plan.regions) for spec in plan.specs
    }
    result = StudyResult(fits_header(ds, kin, valid, opts, plan), kin, regions=plan.regions)
    note_recording(result, facts, source, opts, n_shared)
    say("energy: one vs two phases")
    dep_e = dependence(energy, valid)
    fit_energy(result, energy, valid, dep_e, opts, s_energy)
    one = result.fits["energy"].get("one_phase")
    ci = kT_interval(energy, valid, n_bootstrap=opts.test.n_bootstrap, alpha=opts.test.alpha,
                     seed=s_ci)  # fmt: skip
    if one is not None and ci is not None:
        one.update(ci)
    say("steering")
    fit_steering(result, opts, s_steer)
    fit_groups(result, energy, valid, dep_e, codes_by_spec, plan, opts, s_groups, say)
    result.fits["regions"] = {}
    if plan.regions:
        say("regions")
        result.fits["regions"] = regions_block(
            kin, region_codes, plan.regions, result.energy, n_bootstrap=opts.test.n_bootstrap,
            alpha=opts.test.alpha, seed=s_regions, source=plan.region_source,
        )  # fmt: skip
    return result


def analyze_tracks(ds: xr.Dataset, **options: Any) -> dict[str, Any]:
    """The paper's statistics of trajectories ``ds``: the ``fits.json`` content.

    Options as :func:`run_study`.  Energies are in mm^2/s^2 (per unit mass) unless a
    ``mass`` (kg) is given, then in J.
    """
    return run_study(ds, **options).fits
