"""Every option of the analysis in one frozen object, readable from a TOML file.

:class:`AnalysisOptions` holds one section per stage of the analysis (read, clean,
steps, exclude, fit, test, report); ``thermoswarm analyze --config analysis.toml``
reads it with :meth:`AnalysisOptions.from_toml`, whose loader is strict: a key the
section does not have is refused by name (with the file), a value of the wrong type
too.  Range checks run when a section is built, from TOML, from the command line or
from Python, with one-line :class:`~thermoswarm.errors.ConfigError` messages that name
the field.  ``docs/analysis.md`` lists every key.

Example ``analysis.toml``::

    [read]
    fps = 25.0
    [clean]
    smooth = 0.1
    [exclude]
    body_length = 6.5
    [test]
    n_bootstrap = 99
    seed = 1

An option left unset keeps its default; ``None`` (no value in TOML) means "off" or
"derived", as each field says.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from thermoswarm.config import check, from_mapping, load_toml
from thermoswarm.errors import ConfigError

__all__ = [
    "AnalysisOptions",
    "ReadOptions",
    "CleanOptions",
    "StepOptions",
    "ExcludeOptions",
    "FitOptions",
    "TestOptions",
    "ReportOptions",
    "parse_energy_bins",
    "KEYWORD_SECTIONS",
]


def _number(name: str, value: Any, *, positive: bool = False) -> None:
    """A finite, non-negative (``positive``: above zero) number, or ``None``."""
    if value is None:
        return
    ok = isinstance(value, int | float) and not isinstance(value, bool)
    ok = ok and math.isfinite(value) and value >= 0 and not (positive and value == 0)
    kind = "a positive number" if positive else "a non-negative number"
    check(ok, name, kind, value)


def _required(name: str, value: Any, *, positive: bool = False) -> None:
    check(value is not None, name, "a number", value)
    _number(name, value, positive=positive)


#: Largest time window or smoothing span (s, about 30 years): beyond it the sample
#: counts overflow an int64 long before any data is that long.
MAX_SECONDS = 1e9
#: Shortest ``time:SECONDS`` window (s): one microsecond.
MIN_WINDOW = 1e-6
#: Largest ``mass`` (kg): energies stay finite in float32 at any speed up to 1e13 mm/s.
MAX_MASS = 1e6
#: Most steering bins, and most bootstrap replicates.
MAX_BINS = 10_000
MAX_BOOTSTRAP = 1_000_000


def _at_most(name: str, value: Any, limit: float, unit: str) -> None:
    check(value is None or value <= limit, name, f"at most {limit:g} {unit}".rstrip(), value)


def _check_group(spec: Any) -> None:
    """A ``time:SECONDS`` window between :data:`MIN_WINDOW` and :data:`MAX_SECONDS`."""
    text = str(spec).strip()
    if not text.startswith("time:"):
        return
    try:
        w = float(text[5:])
    except ValueError:
        w = float("nan")
    if not (math.isfinite(w) and MIN_WINDOW <= w <= MAX_SECONDS):
        raise ConfigError(
            f"group_by {text!r}: the window must be a number of seconds from "
            f"{MIN_WINDOW:g} to {MAX_SECONDS:g}, e.g. time:60"
        )


def _check_bootstrap_memory(n_bootstrap: int, test_size: int | None) -> None:
    """Refuse replicates whose draws (``n_bootstrap x test_size`` float64) cannot fit."""
    from thermoswarm.system import available_memory

    have = available_memory()
    need = 16.0 * n_bootstrap * (test_size or MIN_SAMPLES)
    if have is not None and need > have:
        raise ConfigError(
            f"n_bootstrap = {n_bootstrap} with test_size = {test_size}: the bootstrap draws "
            f"need about {need / 2**30:.3g} GiB, more than the {have / 2**30:.3g} GiB of "
            "memory available here"
        )


def _set(obj: Any, name: str, value: Any) -> None:
    object.__setattr__(obj, name, value)  # normalising a frozen dataclass's field


def _floats(obj: Any, *names: str) -> None:
    """Integers given for float fields become floats (``gap_factor = 2`` -> 2.0)."""
    for name in names:
        v = getattr(obj, name)
        if isinstance(v, int | np.integer | np.floating) and not isinstance(v, bool):
            _set(obj, name, float(v))


@dataclass(frozen=True)
class ReadOptions:
    """How the input files are read.

    Attributes
    ----------
    format : str | None
        Input format name (default: detected from the file).
    fps : float | None
        Frame rate (frames/s), needed when the time axis holds frame numbers.
    px_per_mm : float | str | None
        Scale of pixel-based input (px/mm): a number or the preset ``"paper"`` (3.04).
    allow_pickle : bool
        Let readers load pickled data (trusted files only).
    options : Mapping[str, Any]
        Options for the reader (``--read-option KEY=VALUE``), e.g. ``units = "m"``.
    """

    format: str | None = None
    fps: float | None = None
    px_per_mm: float | str | None = None
    allow_pickle: bool = False
    options: Any = field(default_factory=dict)

    def __post_init__(self) -> None:
        _floats(self, "fps")
        check(self.fps is None or (math.isfinite(self.fps) and self.fps > 0), "fps",
              "a positive number", self.fps)  # fmt: skip
        check(isinstance(self.options, Mapping) and all(isinstance(k, str) for k in self.options),
              "read.options", "a table of reader options", self.options)  # fmt: skip
        _set(self, "options", dict(self.options))


@dataclass(frozen=True)
class CleanOptions:
    """Each individual's samples before any step: positions, duplicates, gaps, smoothing.

    Attributes
    ----------
    keypoint : str | None
        Keypoint to follow (default: the centroid of the keypoints).
    min_confidence : float | None
        Positions whose ``confidence`` is below this are missing.
    duplicates : str
        Two different samples of one individual at one time: ``"error"``, ``"first"``
        or ``"mean"`` (exact duplicates are always dropped and counted).
    held_positions : str
        A repeated position: ``"resting"`` (a step at zero speed) or ``"missing"``
        (held by the tracker).
    max_gap : float
        Missing-position gaps up to this long (s) are linearly interpolated (0: none).
    smooth : float | None
        Savitzky-Golay window of the positions (s); ``None``: no smoothing.
    polyorder : int | None
        Order of the Savitzky-Golay polynomial (``None``: 2).
    mask_shared_positions : bool
        Make missing every sample whose position another individual has in the same
        frame (a tracker that gives every member of a cluster the cluster's position).
    """

    keypoint: str | None = None
    min_confidence: float | None = None
    duplicates: Literal["error", "first", "mean"] = "error"
    held_positions: Literal["resting", "missing"] = "resting"
    max_gap: float = 0.0
    smooth: float | None = None
    polyorder: int | None = None
    mask_shared_positions: bool = False

    def __post_init__(self) -> None:
        _floats(self, "min_confidence", "max_gap", "smooth")
        _number("min_confidence", self.min_confidence)
        _required("max_gap", self.max_gap)
        _number("smooth", self.smooth, positive=True)
        _at_most("smooth", self.smooth, MAX_SECONDS, "s")
        p = self.polyorder
        check(p is None or (isinstance(p, int | np.integer) and not isinstance(p, bool) and p >= 1)
              or (isinstance(p, float) and p.is_integer() and p >= 1),
              "polyorder", "an integer >= 1", p)  # fmt: skip
        check(self.duplicates in ("error", "first", "mean"), "duplicates",
              "one of error, first, mean", self.duplicates)  # fmt: skip
        check(self.held_positions in ("resting", "missing"), "held_positions",
              "'resting' or 'missing'", self.held_positions)  # fmt: skip


@dataclass(frozen=True)
class StepOptions:
    """The steps between consecutive samples: clocks, speed, energy, heading.

    Attributes
    ----------
    mass : float | None
        Mass (kg): energies ``m v^2 / 2`` in J; ``None``: ``v^2 / 2`` in mm^2/s^2.
    min_speed : float
        Heading is undefined for steps at or below this speed (mm/s).
    gap_factor : float
        Steps longer than this many of the individual's median steps are gaps (1).
    regular_tolerance : float
        A step is regular within this fraction of the individual's median step (1).
    speed_source : str
        Where the fitted energies' speeds come from: ``"positions"`` (displacements),
        ``"recorded"`` (the input's ``speed`` variable) or ``"auto"`` (recorded for a
        ``thermoswarm simulate`` recording, positions otherwise).
    """

    mass: float | None = None
    min_speed: float = 0.0
    gap_factor: float = 1.5
    regular_tolerance: float = 0.1
    speed_source: Literal["auto", "positions", "recorded"] = "auto"

    def __post_init__(self) -> None:
        _floats(self, "mass", "min_speed", "gap_factor", "regular_tolerance")
        _number("mass", self.mass, positive=True)
        _at_most("mass", self.mass, MAX_MASS, "kg")
        _required("min_speed", self.min_speed)
        _required("gap_factor", self.gap_factor, positive=True)
        _required("regular_tolerance", self.regular_tolerance, positive=True)
        check(self.gap_factor >= 1, "gap_factor", "at least 1", self.gap_factor)
        check(self.regular_tolerance < 1, "regular_tolerance", "below 1",
              self.regular_tolerance)  # fmt: skip
        check(self.speed_source in ("auto", "positions", "recorded"), "speed_source",
              "one of auto, positions, recorded", self.speed_source)  # fmt: skip


@dataclass(frozen=True)
class ExcludeOptions:
    """Which measured steps are left out of the fits (each counted in its bucket).

    Attributes
    ----------
    max_speed : float | None
        Steps faster than this (mm/s) are left out.
    resting_speed : float
        Steps at or below this speed (mm/s) are resting: left out, counted.
    keep_resting : bool
        Fit resting steps too.
    implausible_factor : float
        Implausible: faster than this many times the individual's robust speed scale.
    body_length : float | None
        Body length (mm): implausible above ``max_body_lengths_per_s`` of them a second.
    max_body_lengths_per_s : float
        Body lengths per second above which a step is implausible (with ``body_length``).
    keep_implausible : bool
        Fit implausible steps too.
    min_track_extent : float | None
        Tracks whose positions stay within this many mm are static objects (left out).
    stationary_speed : float | None
        Speed (mm/s) at or below which a step is still (``None``: ``steps.min_speed``).
    stationary_duration : float | None
        Still steps lasting at least this long (s) are a stationary period (``None``: 1).
    drop_stationary : bool
        Leave long stationary periods out of the fits.
    """

    max_speed: float | None = None
    resting_speed: float = 0.0
    keep_resting: bool = False
    implausible_factor: float = 5.0
    body_length: float | None = None
    max_body_lengths_per_s: float = 50.0
    keep_implausible: bool = False
    min_track_extent: float | None = None
    stationary_speed: float | None = None
    stationary_duration: float | None = None
    drop_stationary: bool = False

    def __post_init__(self) -> None:
        _floats(self, "max_speed", "resting_speed", "implausible_factor", "body_length",
                "max_body_lengths_per_s", "min_track_extent", "stationary_speed",
                "stationary_duration")  # fmt: skip
        _number("max_speed", self.max_speed, positive=True)
        _required("resting_speed", self.resting_speed)
        _required("implausible_factor", self.implausible_factor, positive=True)
        check(self.implausible_factor > 1, "implausible_factor", "above 1",
              self.implausible_factor)  # fmt: skip
        _number("body_length", self.body_length, positive=True)
        _required("max_body_lengths_per_s", self.max_body_lengths_per_s, positive=True)
        _number("min_track_extent", self.min_track_extent, positive=True)
        _number("stationary_speed", self.stationary_speed)
        _number("stationary_duration", self.stationary_duration)


def parse_energy_bins(value: Any) -> int | tuple[float, ...]:
    """An integer (equal-count bins) or increasing edges (``"0,5,10,20"`` or a list)."""
    if isinstance(value, str):
        parts = [p for p in re.split(r"[,\s]+", value.strip()) if p]
        if len(parts) == 1:
            try:
                value = int(parts[0])
            except ValueError:
                raise ConfigError(
                    f"--energy-bins must be a count or comma-separated edges, got {parts[0]!r}"
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
        check(1 <= value <= MAX_BINS, "energy_bins", f"from 1 to {MAX_BINS}", int(value))
        return int(value)
    try:
        edges = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise ConfigError(
            f"energy_bins must be a count or a list of edges, got {value!r}"
        ) from None
    if not 2 <= len(edges) <= MAX_BINS + 1 or not all(math.isfinite(e) for e in edges):
        raise ConfigError(f"energy_bins edges must be at least 2 finite numbers, got {edges}")
    if any(b <= a for a, b in zip(edges[:-1], edges[1:], strict=True)):
        raise ConfigError(f"energy_bins edges must increase, got {edges}")
    return edges


@dataclass(frozen=True)
class FitOptions:
    """What is fitted: the energy phases overall, per group, per region; steering.

    Attributes
    ----------
    group_by : tuple[str, ...]
        Group specs: a data variable's name, ``"time:SECONDS"`` or ``"region"``.
    regions : str | None
        TOML file of named polygons in mm (:mod:`thermoswarm.analysis.regions`).
    energy_bins : int | tuple[float, ...]
        Steering bins: a count (equal-count bins) or increasing edges (in the energy
        unit, or mm/s with ``steering_by = "speed"``).
    steering_by : str
        Variable of the steering bins: ``"energy"`` or ``"speed"``.
    max_plausible_speed : float | None
        The animal's top speed (mm/s) for the plausibility of the fitted temperatures
        (``None``: the implausible-motion threshold).
    """

    group_by: tuple[str, ...] = ()
    regions: str | None = None
    energy_bins: int | tuple[float, ...] = 8
    steering_by: Literal["energy", "speed"] = "energy"
    max_plausible_speed: float | None = None

    def __post_init__(self) -> None:
        _set(self, "group_by", (self.group_by,) if isinstance(self.group_by, str)
             else tuple(self.group_by))  # fmt: skip
        for spec in self.group_by:
            _check_group(spec)
        if isinstance(self.regions, Path):
            _set(self, "regions", str(self.regions))
        _set(self, "energy_bins", parse_energy_bins(self.energy_bins))
        check(self.steering_by in ("energy", "speed"), "steering_by",
              "'energy' or 'speed'", self.steering_by)  # fmt: skip
        _floats(self, "max_plausible_speed")
        _number("max_plausible_speed", self.max_plausible_speed, positive=True)


#: The smallest test sample (:data:`thermoswarm.analysis.phases.MIN_SAMPLES`, written
#: here so that the options load without the statistics' imports).
MIN_SAMPLES = 20


@dataclass(frozen=True)
class TestOptions:
    """How the fits are tested: bootstrap size, test sample, level, seed.

    Attributes
    ----------
    n_bootstrap : int
        Bootstrap replicates of every test (0: none; the model is then chosen by BIC).
    test_size : int | None
        Largest test sample (steps); ``None``: no cap.
    thin : int | str
        Thinning step of the test sample: ``"auto"`` (the autocorrelation time) or N.
    alpha : float
        Level of the likelihood-ratio test and of the intervals (1).
    seed : int | None
        Seed of every random draw (same seed, same output).
    """

    __test__ = False  # not a pytest class, despite its name

    n_bootstrap: int = 200
    test_size: int | None = 10_000
    thin: int | Literal["auto"] = "auto"
    alpha: float = 0.05
    seed: int | None = 0

    def __post_init__(self) -> None:
        def whole(v: Any) -> bool:
            return isinstance(v, int | np.integer) and not isinstance(v, bool)

        nb, ts, thin = self.n_bootstrap, self.test_size, self.thin
        check(whole(nb) and 0 <= nb <= MAX_BOOTSTRAP, "n_bootstrap",
              f"an integer from 0 to {MAX_BOOTSTRAP}", nb)  # fmt: skip
        check(ts is None or (whole(ts) and ts >= MIN_SAMPLES), "test_size",
              "an integer >= 20 or None", ts)  # fmt: skip
        check(thin == "auto" or (whole(thin) and thin >= 1), "thin", "'auto' or an integer >= 1",
              thin)  # fmt: skip
        a = self.alpha
        ok = isinstance(a, int | float) and not isinstance(a, bool) and 0 < a < 1
        check(ok, "alpha", "in (0, 1)", a)
        _set(self, "alpha", float(a))
        _set(self, "n_bootstrap", int(nb))
        _set(self, "test_size", None if ts is None else int(ts))
        seed = self.seed
        check(seed is None or (whole(seed) and 0 <= seed < 2**63), "seed",
              "an integer from 0 to 2**63 - 1", seed)  # fmt: skip
        _check_bootstrap_memory(int(nb), None if ts is None else int(ts))


@dataclass(frozen=True)
class ReportOptions:
    """What is written besides ``fits.json`` and ``kinematics.nc``.

    Attributes
    ----------
    html : bool
        Write ``report.html`` (the figures and tables).
    """

    html: bool = True


#: The sections of :class:`AnalysisOptions`, in stage order.
SECTIONS = ("read", "clean", "steps", "exclude", "fit", "test", "report")


@dataclass(frozen=True)
class AnalysisOptions:
    """Every option of ``thermoswarm analyze``, one section per stage.

    Attributes
    ----------
    read : ReadOptions
        How the input files are read.
    clean : CleanOptions
        Each individual's samples: positions, duplicates, gaps, smoothing.
    steps : StepOptions
        The steps: clocks, speed, energy, heading.
    exclude : ExcludeOptions
        Which steps are left out of the fits.
    fit : FitOptions
        What is fitted.
    test : TestOptions
        How the fits are tested.
    report : ReportOptions
        What is written besides the results.
    """

    read: ReadOptions = field(default_factory=ReadOptions)
    clean: CleanOptions = field(default_factory=CleanOptions)
    steps: StepOptions = field(default_factory=StepOptions)
    exclude: ExcludeOptions = field(default_factory=ExcludeOptions)
    fit: FitOptions = field(default_factory=FitOptions)
    test: TestOptions = field(default_factory=TestOptions)
    report: ReportOptions = field(default_factory=ReportOptions)

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any], *, source: str | None = None
                     ) -> AnalysisOptions:  # fmt: skip
        """Options from a nested mapping (a parsed TOML document); unknown keys refused."""
        return from_mapping(cls, data, source=source)

    @classmethod
    def from_toml(cls, path: str | Path) -> AnalysisOptions:
        """Options from a TOML file; errors name the file and the key."""
        return cls.from_mapping(load_toml(path), source=str(path))

    @classmethod
    def from_keywords(cls, base: AnalysisOptions | None = None, **flat: Any) -> AnalysisOptions:
        """``base`` (default: the defaults) with options given by their flat names
        (``smooth=0.1``, ``n_bootstrap=99``: the keyword API of
        :func:`~thermoswarm.analysis.study.run_study`); an unknown name is refused."""
        base = base or cls()
        changes: dict[str, dict[str, Any]] = {}
        for name, value in flat.items():
            section = KEYWORD_SECTIONS.get(name)
            if section is None:
                raise ConfigError(
                    f"unknown analysis option {name!r}; expected one of: "
                    + ", ".join(sorted(KEYWORD_SECTIONS))
                )
            if isinstance(value, np.generic):
                value = value.item()
            changes.setdefault(section, {})[_FIELD_OF.get(name, name)] = value
        return dataclasses.replace(base, **{
            s: dataclasses.replace(getattr(base, s), **kw) for s, kw in changes.items()
        })  # fmt: skip


#: Flat keyword names that differ from their field's name.
_FIELD_OF = {"report": "html", "read_options": "options"}

#: Each flat keyword name -> its section (the keyword API and the command line).
KEYWORD_SECTIONS: dict[str, str] = {
    **{("read_options" if f.name == "options" else f.name): "read"
       for f in dataclasses.fields(ReadOptions)},
    **{f.name: "clean" for f in dataclasses.fields(CleanOptions)},
    **{f.name: "steps" for f in dataclasses.fields(StepOptions)},
    **{f.name: "exclude" for f in dataclasses.fields(ExcludeOptions)},
    **{f.name: "fit" for f in dataclasses.fields(FitOptions)},
    **{f.name: "test" for f in dataclasses.fields(TestOptions)},
    "report": "report",
}  # fmt: skip
