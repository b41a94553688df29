"""Every example in README.md and docs/*.md runs as written (at a toy scale).

The fenced blocks are read from the Markdown: ``sh``/``bash`` blocks are commands,
``console`` blocks are commands (``$ ...``) with the output the page shows, ``python``
blocks are programs; ``text``, ``toml`` and unlabeled blocks are not examples.  Each page
runs in its own empty directory, its commands in order (a later command may read what
an earlier one wrote), with the files a reader is assumed to have (``tracks.nc``,
``my.toml``, ``road.toml``) made there first.

- Every ``thermoswarm`` command is parsed by the command itself (an option renamed or
  removed fails here), every Python block is compiled.
- ``make test``: the commands and programs that take seconds run; a command that reads
  a file the reader must bring (``ants.slp``, ``dets.txt``, a trained model) and nobody
  wrote is parsed only.  The rest (sweeps, studies, videos, ``reproduce``) run in the
  slow test.
- Toy scale: a command runs as written plus options that shorten it (below: ``TINY``);
  nothing of the example is removed except the number of seeds and workers.
- Commands that are not ours (``make``, ``pip install``, the test suite, benchmark
  scripts) are not run; any other command fails with "no rule", so that a new kind of
  example is looked at.
"""

from __future__ import annotations

import dataclasses
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from thermoswarm.cli import cli

REPO = Path(__file__).resolve().parents[2]
PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]


@dataclasses.dataclass
class Block:
    page: Path
    line: int  # of the opening fence
    lang: str
    text: str


def blocks(page: Path) -> list[Block]:
    """The fenced blocks of a Markdown page (a fence inside a list may be indented)."""
    out = []
    lines = page.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        m = re.match(r"^(\s*)```(\w*)\s*$", lines[i])
        if m:
            indent, lang, start = len(m.group(1)), m.group(2), i
            body = []
            i += 1
            while i < len(lines) and not re.match(r"^\s*```\s*$", lines[i]):
                body.append(lines[i][indent:])
                i += 1
            out.append(Block(page, start + 1, lang, "\n".join(body)))
        i += 1
    return out


def commands(block: Block) -> list[tuple[str, list[str]]]:
    """``(text, argv)`` of each command of a sh block (continuations joined)."""
    joined = re.sub(r"\\\n\s*", " ", block.text)
    out = []
    for line in joined.splitlines():
        argv = shlex.split(line, comments=True)
        while argv and re.match(r"^[A-Z_]+=", argv[0]):  # VAR=value prefixes
            argv = argv[1:]
        if argv[:2] == ["nice", "-n"]:  # a lower priority changes nothing of the command
            argv = argv[3:]
        if argv:
            out.append((line.strip(), argv))
    return out


def console(block: Block) -> list[tuple[str, list[str], list[str]]]:
    """``(text, argv, expected output lines)`` of a console block."""
    out: list[tuple[str, list[str], list[str]]] = []
    for line in block.text.splitlines():
        if line.startswith("$ "):
            out.append((line[2:], shlex.split(line[2:]), []))
        elif out and line.strip():
            out[-1][2].append(line)
    return out


# --------------------------------------------------------------------- what runs how
NOT_OURS = [
    (lambda a: a[0] == "make", "a make target: installs, or runs the whole suite"),
    (lambda a: a[:2] == ["pip", "install"], "installs from the package index"),
    (lambda a: a[0] == "source" or a[:3] == ["python3", "-m", "venv"],
     "creates or activates the environment"),
    (lambda a: a[:3] == ["python", "-m", "build"], "builds the wheel"),
    (lambda a: a[:2] == ["git", "clone"], "fetches a dataset from its source"),
    (lambda a: a[0] == "cd", "moves into the reader's data"),
    (lambda a: a[:3] == ["python", "-m", "pytest"], "the test suite itself"),
    (lambda a: a[0] == "python" and len(a) > 1 and a[1].startswith("benchmarks/"),
     "a benchmark script (minutes); `make bench` runs them"),
    (lambda a: a[0].startswith("benchmarks/") and a[0].endswith(".sh"),
     "a benchmark shell script (the GPU machine's run)"),
]  # fmt: skip

# Toy scale: options appended (a repeated --set wins over the example's).
SLOW_VERBS = {"sweep", "study", "reproduce", "bench", "track", "track-train"}
INPUT_OPTIONS = {"--config", "--regions", "--detections", "--model", "--labels", "--init"}


def _set(argv: list[str], key: str, value: str) -> list[str]:
    """``argv`` with ``--set key=value``: in place of the example's own ``--set key=...``
    (a key given twice is refused), else appended."""
    a = list(argv)
    for i in range(len(a) - 1):
        if a[i] == "--set" and a[i + 1].split("=", 1)[0].strip() == key:
            a[i + 1] = f"{key}={value}"
            return a
    return [*a, "--set", f"{key}={value}"]


def tiny(argv: list[str]) -> list[str]:
    """The example's thermoswarm arguments at a toy scale."""
    a = list(argv)
    verb = a[0] if a else ""
    if verb == "simulate" and "--resume" not in a:
        if any("backend" in x and "gpu" in x for x in a):  # numba-cuda's simulator: tiny
            a = _set(a, "n", "50")
        return [*_set(a, "duration", "2"), "--no-progress"]
    if verb == "sweep":
        a = _replace(a, "--seeds", "0")
        if "--cluster" in a:
            a = _replace(a, "--cluster", "local:1")
        elif "--scheduler" not in a:
            a = _replace(a, "--workers", "1")
        return _set(a, "duration", "2")
    if verb == "study":
        a = _replace(a, "--setting", "quick")
        a = _replace(a, "--workers", "1")
        a = _replace(a, "--seeds", "1")
        return _set(_set(_set(a, "duration", "6"), "warmup", "2"), "n", "40")
    if verb == "reproduce":
        a = [x for x in a if x not in ("--quick", "--full")]
        return [*_replace(a, "--workers", "1"), "--smoke"]
    if verb == "bench":
        return [*_replace(a, "--n", "2000"), "--seconds", "0.5"]
    if verb == "track" and len(a) > 1 and a[1] != "train":
        # the toy clip's 12 frames: the ants defaults confirm a track after 0.2 s (7
        # detections at 30 frames/s), so 5 frames would confirm none
        return [*a, "--max-frames", "12", "--no-overlay"]
    if verb == "view" and "--out" not in a and "--screenshot" not in a:
        # serving runs until Ctrl+C: the same data written as the self-contained page
        return [*a, "--out", "view.html"]
    return a


def _replace(a: list[str], opt: str, value: str) -> list[str]:
    if opt in a:
        i = a.index(opt)
        return [*a[: i + 1], value, *a[i + 2 :]]
    return [*a, opt, value]


def _resolve(argv: list[str]) -> tuple[click.Command, list[str], str]:
    """The thermoswarm sub-command of ``argv`` and its own arguments."""
    ctx = click.Context(cli, info_name="thermoswarm")
    name, cmd, rest = cli.resolve_command(ctx, list(argv))
    if isinstance(cmd, click.Group):
        sub = click.Context(cmd, info_name=name, parent=ctx)
        name2, cmd2, rest2 = cmd.resolve_command(sub, list(rest))
        return cmd2, rest2, f"{name} {name2}"
    return cmd, rest, name


def parse(argv: list[str]) -> None:
    """Parse ``thermoswarm ARGV`` as the command would, without running it."""
    cmd, rest, name = _resolve(argv)
    with cmd.make_context(name, list(rest)) as _:
        pass


def _reads_missing_input(argv: list[str], cwd: Path) -> str | None:
    """The file a command reads that nobody wrote (the reader must bring it), or None."""
    cmd, rest, _ = _resolve(argv)
    ctx = cmd.make_context("x", list(rest), resilient_parsing=True)
    candidates = []
    for param in cmd.params:
        value = ctx.params.get(param.name)
        if value is None:
            continue
        values = value if isinstance(value, tuple | list) else [value]
        is_input = isinstance(param, click.Argument) or any(
            o in INPUT_OPTIONS for o in getattr(param, "opts", [])
        )
        if is_input and isinstance(param.type, click.Path):
            candidates += [str(v) for v in values]
    if argv[0] in ("analyze", "convert", "track", "evaluate", "detect"):
        pass
    elif argv[0] != "simulate":  # simulate's argument is a scenario name
        candidates = [c for c in candidates if "." in Path(c).name or "/" in c]
    else:
        candidates = [c for c in candidates if c.endswith(".toml")]
    missing = [c for c in candidates if not (cwd / c).exists()]
    if argv[0] == "track" and "train" not in argv and "--detections" not in argv:
        missing = [c for c in missing if c != "--out"]
    return missing[0] if missing else None


# ------------------------------------------------------------------ the reader's files
ROAD_TOML = """\
# the regions file of docs/analysis.md
[[region]]
name = "wide"
polygon = [[0, 0], [60, 0], [60, 40], [0, 40]]

[[region]]
name = "narrow"
rect = [60, 10, 100, 30]
"""


@pytest.fixture(scope="module")
def readers_files(tmp_path_factory) -> Path:
    """``tracks.nc`` (6 s of 20 robots at 50 frames/s), ``my.toml`` and ``road.toml``."""
    d = tmp_path_factory.mktemp("readers-files")
    # 50 frames per second, as a tracked video: the examples smooth over 0.1 s
    res = CliRunner().invoke(cli, ["simulate", "box", "--out", str(d / "run"), "--set", "n=20",
                                   "--set", "duration=6", "--set", "engine.dt=0.02",
                                   "--set", "record.interval=0.02", "--no-progress"])  # fmt: skip
    assert res.exit_code == 0, res.output
    (d / "tracks.nc").write_bytes((d / "run" / "tracks.nc").read_bytes())
    (d / "my.toml").write_text("# a config of the reader\nn = 40\nduration = 100.0\n")
    (d / "road.toml").write_text(ROAD_TOML)
    return d


def _sandbox(tmp_path: Path, files: Path) -> Path:
    for name in ("tracks.nc", "my.toml", "road.toml"):
        (tmp_path / name).write_bytes((files / name).read_bytes())
    return tmp_path


def _run_thermoswarm(argv: list[str], cwd: Path, where: str) -> str:
    res = CliRunner().invoke(cli, tiny(argv))
    assert res.exit_code == 0, f"{where}: thermoswarm {' '.join(tiny(argv))}\n{res.output}"
    return res.output


def _run_module(argv: list[str], cwd: Path, where: str) -> None:
    mod = argv[2]
    extra = []
    if mod == "thermoswarm.tracking.synth":  # toy scale: a short, small video
        extra = ["--set", "n_frames=12", "--set", "width=480", "--set", "height=480",
                 "--set", "n_ants=6"]  # fmt: skip
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"))
    res = subprocess.run([sys.executable, *argv[1:], *extra], cwd=cwd, env=env,
                         capture_output=True, text=True, timeout=600)  # fmt: skip
    assert res.returncode == 0, f"{where}: {' '.join(argv)}\n{res.stdout}\n{res.stderr}"


def run_page(page: Path, cwd: Path, *, slow: bool) -> list[str]:
    """Run the shell and console examples of ``page`` in ``cwd``; returns notes of what
    was parsed only."""
    notes = []
    old = Path.cwd()
    os.chdir(cwd)
    try:
        for b in blocks(page):
            where = f"{page.name}:{b.line}"
            if b.lang == "console":
                for text, argv, expected in console(b):
                    assert argv[0] == "thermoswarm", f"{where}: {text}"
                    res = CliRunner().invoke(cli, argv[1:])
                    got = [ln for ln in res.output.splitlines() if ln.strip()]
                    assert got == expected, f"{where}: $ {text}\nexpected {expected}\ngot {got}"
                continue
            if b.lang not in ("sh", "bash"):
                continue
            for text, argv in commands(b):
                if any(rule(argv) for rule, _ in NOT_OURS):
                    if argv[0] == "python" and argv[1].startswith("benchmarks/"):
                        assert (REPO / argv[1]).is_file(), f"{where}: no {argv[1]}"
                    if argv[0].startswith("benchmarks/"):
                        assert (REPO / argv[0]).is_file(), f"{where}: no {argv[0]}"
                    continue
                if argv[:2] == ["python", "-m"] and argv[2] == "thermoswarm":
                    argv = ["thermoswarm", *argv[3:]]
                if argv[:2] == ["python", "-m"] and argv[2].startswith("thermoswarm."):
                    if slow:
                        _run_module(argv, cwd, where)
                    else:
                        notes.append(f"{where}: {text} (slow test)")
                    continue
                assert argv[0] == "thermoswarm", f"{where}: no rule for this example: {text}"
                args = argv[1:]
                parse(args)
                missing = _reads_missing_input(args, cwd)
                verb = "track-train" if args[:2] == ["track", "train"] else args[0]
                if missing is not None:
                    notes.append(f"{where}: {text} (parsed only: reads the reader's {missing})")
                elif verb in SLOW_VERBS and not slow:
                    notes.append(f"{where}: {text} (slow test)")
                elif args[:2] in (["robot", "deploy"], ["robot", "calibrate"]):
                    notes.append(f"{where}: {text} (parsed only: needs the reader's board)")
                elif verb == "track-train":
                    notes.append(f"{where}: {text} (parsed only: training takes minutes)")
                elif "--scheduler" in args:
                    notes.append(f"{where}: {text} (parsed only: needs the reader's scheduler)")
                else:
                    _run_thermoswarm(args, cwd, where)
    finally:
        os.chdir(old)
    return notes


# ------------------------------------------------------------------------ python blocks
# (page name, first line of the block) -> why it is not run
PYTHON_NOT_RUN = {
    ("README.md", "from controller import Config, Controller       # on the board"):
        "runs on the robot, with the board's hardware layer",
    ("robot.md", "from controller import Config, Controller       # on the board"):
        "runs on the robot, with the board's hardware layer",
    ("io.md", "from thermoswarm.io import read_tracks, write_tracks"):
        "reads the reader's SLEAP, idtracker.ai and CSV files",
    ("tracking_unet.md", "from thermoswarm.tracking.detect.unet import load_model, UNetDetector"):
        "needs a trained model (thermoswarm track train, minutes)",
    ("robot.md", "from controller import HAL, Config, Controller"):
        "runs on the robot, with the board's hardware layer",
    ("cluster.md", "# slurm_sweep.py -- run on the login node: python slurm_sweep.py"):
        "needs a SLURM cluster and dask-jobqueue",
}  # fmt: skip
PYTHON_SLOW = {("tracking.md", "import numpy as np")}  # a 300-frame 1080p video


def python_blocks() -> list[Block]:
    return [b for page in PAGES for b in blocks(page) if b.lang == "python"]


def _key(b: Block) -> tuple[str, str]:
    return (b.page.name, b.text.strip().splitlines()[0])


def _run_python(b: Block, cwd: Path) -> None:
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"), MPLBACKEND="Agg")
    res = subprocess.run([sys.executable, "-c", b.text], cwd=cwd, env=env,
                         capture_output=True, text=True, timeout=600)  # fmt: skip
    assert res.returncode == 0, f"{b.page.name}:{b.line}\n{res.stdout}\n{res.stderr}"


# ------------------------------------------------------------------------------ tests
def test_the_pages_have_examples_and_the_reader_finds_them():
    found = {p.name: [b.lang for b in blocks(p)] for p in PAGES}
    assert "sh" in found["README.md"] and "python" in found["README.md"]
    assert sum(langs.count("console") for langs in found.values()) >= 2
    # every skip above still names a block that exists
    keys = {_key(b) for b in python_blocks()}
    assert set(PYTHON_NOT_RUN) <= keys and PYTHON_SLOW <= keys


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_command_parses_and_every_program_compiles(page):
    for b in blocks(page):
        where = f"{page.name}:{b.line}"
        if b.lang == "python":
            compile(b.text, where, "exec")
        cmds = commands(b) if b.lang in ("sh", "bash") else (
            [(t, a) for t, a, _ in console(b)] if b.lang == "console" else [])  # fmt: skip
        for text, argv in cmds:
            if argv[:3] == ["python", "-m", "thermoswarm"]:
                argv = ["thermoswarm", *argv[3:]]
            if argv and argv[0] == "thermoswarm" and b.lang != "console":
                try:
                    parse(argv[1:])
                except click.exceptions.Exit:
                    pass
                except click.UsageError as exc:
                    raise AssertionError(f"{where}: {text}: {exc}") from None


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_the_quick_examples_run_as_written(page, tmp_path, readers_files):
    notes = run_page(page, _sandbox(tmp_path, readers_files), slow=False)
    print("\n".join(notes))


@pytest.mark.slow
@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_example_runs_as_written(page, tmp_path, readers_files):
    notes = run_page(page, _sandbox(tmp_path, readers_files), slow=True)
    assert not [n for n in notes if "slow test" in n]
    print("\n".join(notes))


@pytest.mark.parametrize(
    "block",
    [pytest.param(b, id=f"{b.page.name}:{b.line}",
                  marks=[pytest.mark.slow] if _key(b) in PYTHON_SLOW else [])
     for b in python_blocks()],
)  # fmt: skip
def test_python_examples_run(block, tmp_path, readers_files):
    key = _key(block)
    if key in PYTHON_NOT_RUN:
        pytest.skip(PYTHON_NOT_RUN[key])
    _run_python(block, _sandbox(tmp_path, readers_files))
