"""``thermoswarm analyze``: the paper's statistics of any trajectories.

Thin: builds one :class:`~thermoswarm.analysis.options.AnalysisOptions` from ``--config``
(a TOML file) and the flags given on the command line (which override the file), calls
:func:`thermoswarm.report.analysis_run.analyze_file` and prints a summary.  Every option
is documented in ``docs/analysis.md``.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
from click.core import ParameterSource

from thermoswarm.errors import ConfigError

if TYPE_CHECKING:  # the options load on use, after the input files are checked
    from thermoswarm.analysis.options import AnalysisOptions

#: Flags whose keyword name (:data:`thermoswarm.analysis.options.KEYWORD_SECTIONS`)
#: differs from the click parameter's name.
_KEYWORD = {"fmt": "format", "read_option": "read_options", "no_report": "report"}

#: Data-quality counters worth a line on the terminal when they are not zero.
_NOTABLE = (
    ("n_shared_positions_masked", "samples at another individual's position masked"),
    ("n_missing_timestamps", "samples without a timestamp dropped"),
    ("n_decreasing_timestamps", "backward time steps (rows sorted)"),
    ("n_duplicate_rows", "exact duplicate rows dropped"),
    ("n_conflicting_duplicates", "conflicting rows at one time resolved by --duplicates"),
    ("n_individuals_one_sample", "individuals with a single sample (no step)"),
    ("n_irregular_steps", "steps off the individual's median step by more than 10 %"),
    ("n_steps_time_gap", "time gaps (steps not used)"),
    ("n_gaps", "gaps in tracks"),
    ("n_interpolated_positions", "positions interpolated"),
    ("n_steps_over_max_speed", "steps over --max-speed left out"),
    ("n_steps_implausible", "implausible steps left out"),
    ("n_implausible_kept", "implausible steps kept (--keep-implausible)"),
    ("n_individuals_all_implausible", "individuals whose every moving step is implausible"),
    ("n_static_tracks", "static tracks (within --min-track-extent) left out"),
    ("n_steps_resting", "resting steps left out"),
    ("n_resting_kept", "resting steps kept (--keep-resting)"),
    ("n_zero_speed", "steps at zero speed (heading undefined)"),
    ("n_steering_near_wrap", "turns near half a circle (ambiguous)"),
    ("n_stationary_periods", "long stationary periods"),
)


def _thin(value: str) -> str | int:
    if value == "auto":
        return "auto"
    try:
        step = int(value)
    except ValueError:
        step = 0
    if step < 1:
        raise ConfigError(f"--thin must be 'auto' or an integer >= 1, got {value!r}")
    return step


def _fmt(v: Any, spec: str = ".4g") -> str:
    return "-" if v is None else format(v, spec)


def _ci(one: dict[str, Any]) -> str:
    """`` (95 % interval A-B over individuals)`` where the study gave one."""
    ci = one.get("kT_ci")
    if not ci:
        return ""
    return f" ({one['kT_ci_level']:.0%} interval {ci[0]:.4g}-{ci[1]:.4g} over individuals)"


def _p(p: float | None, n_boot: int | None) -> str:
    """``= 0.03``, ``< 0.005`` (the bootstrap's floor) or ``n/a``."""
    from thermoswarm.analysis.explain import format_p_value

    text = format_p_value(p, n_boot, digits=3)
    return text if text.startswith("<") else f"= {text}"


@click.command("analyze")
@click.argument("inputs", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option(
    "--out",
    "-o",
    required=True,
    type=click.Path(path_type=Path),
    help="Output directory (created with its parents).",
)
@click.option(
    "--config",
    "config_file",
    type=click.Path(path_type=Path),
    default=None,
    help="TOML file of analysis options (docs/analysis.md); flags given override it.",
)
@click.option("--format", "fmt", default=None, help="Input format name (default: detected).")
@click.option("--fps", type=float, default=None, help="Frame rate, for frame-numbered input.")
@click.option(
    "--px-per-mm",
    default=None,
    help="Scale of pixel-based input: a number or the preset 'paper' (3.04).",
)
@click.option(
    "--regions",
    type=click.Path(path_type=Path),
    default=None,
    help="TOML file of named polygons in mm.",
)
@click.option(
    "--group-by", multiple=True, help="A data variable, 'time:SECONDS' or 'region'; repeatable."
)
@click.option(
    "--mass",
    type=float,
    default=None,
    help="Mass in kg: energies m v^2/2 in J (default v^2/2 in mm^2/s^2).",
)
@click.option(
    "--smooth",
    type=float,
    default=None,
    metavar="SECONDS",
    help="Savitzky-Golay smoothing window of positions.",
)
@click.option(
    "--bootstrap",
    "n_bootstrap",
    type=int,
    default=200,
    show_default=True,
    help="Bootstrap replicates of every test (0: none).",
)
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of every draw.")
@click.option(
    "--allow-pickle", is_flag=True, help="Let readers load pickled data (trusted files)."
)
@click.option(
    "--read-option",
    multiple=True,
    metavar="KEY=VALUE",
    help="Option for the reader (TOML value); repeatable.",
)
@click.option(
    "--energy-bins",
    default="8",
    show_default=True,
    help="Steering bins: a count (equal-count) or comma-separated edges.",
)
@click.option(
    "--steering-by",
    type=click.Choice(["energy", "speed"]),
    default="energy",
    show_default=True,
    help="Variable of the steering bins.",
)
@click.option(
    "--test-size",
    type=int,
    default=10_000,
    show_default=True,
    help="Largest sample of the bootstrap tests.",
)
@click.option(
    "--thin",
    default="auto",
    show_default=True,
    help="Thinning step of the test sample: 'auto' (autocorrelation time) or N.",
)
@click.option(
    "--alpha",
    type=float,
    default=0.05,
    show_default=True,
    help="Level of the LR test and the intervals.",
)
@click.option(
    "--min-speed",
    type=float,
    default=0.0,
    show_default=True,
    help="Heading undefined at or below this speed (mm/s).",
)
@click.option("--max-speed", type=float, default=None, help="Drop steps faster than this (mm/s).")
@click.option(
    "--max-gap",
    type=float,
    default=0.0,
    show_default=True,
    help="Interpolate missing positions over gaps up to this long (s).",
)
@click.option(
    "--gap-factor",
    type=float,
    default=1.5,
    show_default=True,
    help="Steps longer than this many of the individual's median steps are gaps.",
)
@click.option(
    "--speed-source",
    type=click.Choice(["auto", "positions", "recorded"]),
    default="auto",
    show_default=True,
    help="Speeds of the energies: displacements, the input's speed variable, or auto "
    "(recorded for a thermoswarm simulation).",
)
@click.option(
    "--mask-shared-positions",
    is_flag=True,
    help="Make missing the samples whose position another individual has in that frame.",
)
@click.option("--keypoint", default=None, help="Keypoint to follow (default: the centroid).")
@click.option(
    "--min-confidence",
    type=float,
    default=None,
    help="Treat positions with lower confidence as missing.",
)
@click.option(
    "--drop-stationary", is_flag=True, help="Leave long stationary periods out of the energies."
)
@click.option(
    "--duplicates",
    type=click.Choice(["error", "first", "mean"]),
    default="error",
    show_default=True,
    help="Two different samples of one individual at one time (exact duplicates are dropped).",
)
@click.option(
    "--regular-tolerance",
    type=float,
    default=0.1,
    show_default=True,
    help="A step is regular within this fraction of the individual's median step.",
)
@click.option(
    "--resting-speed",
    type=float,
    default=0.0,
    show_default=True,
    help="Steps at or below this speed (mm/s) are resting: left out of the fits, counted.",
)
@click.option("--keep-resting", is_flag=True, help="Fit resting steps too (announced).")
@click.option(
    "--held-positions",
    type=click.Choice(["resting", "missing"]),
    default="resting",
    show_default=True,
    help="A repeated position: the animal rested, or the tracker held it (missing).",
)
@click.option(
    "--implausible-factor",
    type=float,
    default=5.0,
    show_default=True,
    help="Implausible: speed above this times the individual's robust speed scale.",
)
@click.option(
    "--body-length",
    type=float,
    default=None,
    help="Body length (mm): implausible above --max-bl-per-s body lengths per second.",
)
@click.option(
    "--max-bl-per-s",
    "max_body_lengths_per_s",
    type=float,
    default=50.0,
    show_default=True,
    help="Body lengths per second above which a step is implausible (with --body-length).",
)
@click.option("--keep-implausible", is_flag=True, help="Fit implausible steps too (announced).")
@click.option(
    "--min-track-extent",
    type=float,
    default=None,
    help="Tracks whose positions stay within this many mm are static objects (left out).",
)
@click.option(
    "--max-plausible-speed",
    type=float,
    default=None,
    help="The animal's top speed (mm/s) for the plausibility of fitted temperatures.",
)
@click.option("--no-report", is_flag=True, help="Skip report.html.")
@click.option("--quiet", "-q", is_flag=True, help="No progress on stderr.")
@click.pass_context
def analyze(
    ctx: click.Context,
    inputs: tuple[Path, ...],
    out: Path,
    config_file: Path | None,
    quiet: bool,
    **flags: Any,
) -> None:
    """Fit the maximum-entropy laws to the trajectories in INPUTS.

    Several files (one per video) are analysed together, each individual on its own
    clock.  Writes OUT/fits.json, OUT/report.html and OUT/kinematics.nc.
    """
    from thermoswarm.fsutil import require_input

    fps = flags["fps"]
    if fps is not None and not fps > 0:
        raise ConfigError(f"--fps must be a positive number, got {fps!r}")
    require_input(*inputs)  # before the heavy imports
    from thermoswarm.tracking.batch import expand_batch_dirs

    inputs = tuple(expand_batch_dirs(inputs))  # a `track` batch folder: its videos
    opts = cli_options(ctx, config_file, flags)
    from thermoswarm.report.analysis_run import analyze_file

    def progress(msg: str) -> None:
        if not quiet:
            click.echo(f"analyze: {msg}", err=True)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = analyze_file(list(inputs), out, opts, progress=progress)
    for w in caught:  # one line each, never a stack location
        click.echo(f"warning: {str(w.message).splitlines()[0]}", err=True)
    for line in summary_lines(result.fits):
        click.echo(line)
    files = ["fits.json", "kinematics.nc"] + (["report.html"] if opts.report.html else [])
    click.echo("wrote " + ", ".join(str(out / f) for f in files))


def cli_options(
    ctx: click.Context, config_file: Path | None, flags: dict[str, Any]
) -> AnalysisOptions:
    """The options of ``--config`` (default: the defaults) with the flags given on the
    command line applied over them (a flag left at its default does not override)."""
    from thermoswarm.analysis.options import AnalysisOptions
    from thermoswarm.io import parse_read_options

    base = AnalysisOptions.from_toml(config_file) if config_file else AnalysisOptions()
    given: dict[str, Any] = {}
    for name, value in flags.items():
        if ctx.get_parameter_source(name) in (ParameterSource.DEFAULT, None):
            continue
        if name == "thin":
            value = _thin(value)
        elif name == "read_option":  # merged over the file's [read.options]
            value = {**base.read.options, **parse_read_options(value)}
        elif name == "no_report":
            value = not value
        elif name == "regions":
            value = str(value)
        given[_KEYWORD.get(name, name)] = value
    return AnalysisOptions.from_keywords(base, **given)


def summary_lines(fits: dict[str, Any]) -> list[str]:
    """What ``analyze`` prints of ``fits.json``: counts, data quality, the fits."""
    from thermoswarm.analysis.explain import explain_phases, trend_statement

    unit = fits["units"]["energy"]
    lines = [f"{fits['n_tracks']} tracks, {fits['n_samples']} energy samples ({unit})"]
    dq = fits["data_quality"]
    notes = [f"{dq[k]} {text}" for k, text in _NOTABLE if dq.get(k)]
    if notes:
        lines.append("data quality: " + "; ".join(notes))
    lines.append(f"left out of the fits: {fits['excluded']['statement']}")
    lines.extend(recording_lines(fits.get("recording")))
    e = fits["energy"]
    if "one_phase" in e:
        two = e["two_phase"]
        lines.append(
            f"energy: {e['preferred']} preferred ({e['preferred_by']}; LR p "
            f"{_p(e['lr_p_value'], e.get('n_bootstrap'))}, n = {e['lr_n']}); one phase kT = "
            f"{_fmt(e['one_phase']['kT'])}{_ci(e['one_phase'])}; two phases phi = "
            f"{_fmt(two['phi'], '.3f')}, "
            f"kT1 = {_fmt(two['kT1'])}, kT2 = {_fmt(two['kT2'])}"
        )
        why = explain_phases(e)
        if why:
            lines.append(f"  why: {why}")
    else:
        lines.append(f"energy: not fitted ({e.get('skipped')})")
    warning = fits.get("plausibility", {}).get("warning")
    if warning:
        lines.append(f"warning: {warning}")
    tr = fits["steering"].get("trend", {})
    if tr.get("slope") is not None:
        lines.append(f"steering: {trend_statement(tr)}")
    for d in fits.get("regions", {}).get("differences", []):
        lines.append(
            f"regions: hot fraction {d['a']} - {d['b']} = {d['difference']:+.3f} "
            f"(p {_p(d['p_value'], None)})"
        )
    return lines


def recording_lines(rec: dict[str, Any] | None) -> list[str]:
    """What ``analyze`` prints of ``fits.json["recording"]`` (nothing for plain tracks)."""
    if not rec or not (rec.get("simulated") or rec.get("speed_source") == "recorded"):
        return []
    dt, tau = rec.get("sampling_interval_s"), rec.get("control_period_s")
    text = f"recording: sampled every {_fmt(dt, '.3g')} s"
    if tau is not None:
        text += f", control period {tau:g} s ({rec['mixed_step_fraction']:.0%} of steps mix two)"
    if rec["speed_source"] == "recorded":
        text += f"; energies and turns from the recorded {rec['speed_kind']} speeds and headings"
        ratio, slowed = rec.get("realized_to_recorded_energy"), rec.get("slowed_fraction")
        if ratio is not None:
            text += (f" (from positions: {ratio:.3g} of their mean energy, "
                     f"{slowed:.1%} of steps slowed by contacts)")  # fmt: skip
    else:
        text += "; energies from positions"
    return [text]
