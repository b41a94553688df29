"""``thermoswarm <verb>``: simulate, analyze, track, detect, evaluate, view, reproduce, ...

The CLI is thin: each verb parses its options, calls one library function and prints.
Verbs live in modules of this package and are imported only when invoked, so that
``thermoswarm --help`` and ``--version`` answer at once (no Numba, no PyTorch).

Every :class:`~thermoswarm.errors.ThermoswarmError` raised below a verb is printed as
``error: <one line>`` on stderr with exit status 2; click's own usage errors also exit 2.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import shutil
import sys
from pathlib import Path

import click

from thermoswarm import __version__
from thermoswarm.errors import ThermoswarmError

# verb -> "module:attribute"; a verb whose module is absent is not listed.
_COMMANDS: dict[str, str] = {
    "simulate": "thermoswarm.cli.simulate:simulate",
    "scenarios": "thermoswarm.cli.simulate:scenarios",
    "bench": "thermoswarm.cli.bench:bench",
    "analyze": "thermoswarm.cli.analyze:analyze",
    "track": "thermoswarm.cli.track:track",
    "detect": "thermoswarm.cli.detect:detect",
    "track-train": "thermoswarm.cli.track_train:track_train",
    "evaluate": "thermoswarm.cli.track:evaluate",
    "reproduce": "thermoswarm.cli.reproduce:reproduce",
    "sweep": "thermoswarm.cli.sweep:sweep",
    "study": "thermoswarm.cli.study:study",
    "convert": "thermoswarm.cli.convert:convert",
    "formats": "thermoswarm.cli.convert:formats",
    "cache": "thermoswarm.cli.cache:cache",
    "view": "thermoswarm.cli.view:view",
    "robot": "thermoswarm.cli.robot:robot",
    "gpu": "thermoswarm.cli.gpu:gpu",
}


#: top-level module of an optional library -> the extra that installs it
EXTRA_OF_MODULE: dict[str, str] = {
    "torch": "track",
    "cv2": "track",
    "imageio": "video",
    "imageio_ffmpeg": "video",
    "sleap_io": "io",
    "tables": "io",
    "pyarrow": "sweep",
    "dask": "dask",
    "distributed": "dask",
    "pymunk": "bench",
    "trackers": "bench",
    "numba_cuda": "gpu",
    "mpremote": "robot",
}


def missing_extra(exc: ImportError) -> tuple[str, str] | None:
    """``(module, extra)`` when ``exc`` is a missing optional library, else ``None``."""
    name = (getattr(exc, "name", None) or "").split(".")[0]
    if isinstance(exc, ModuleNotFoundError) and name in EXTRA_OF_MODULE:
        return name, EXTRA_OF_MODULE[name]
    return None


#: Verbs whose output folder, created by a run that then fails on its input, is removed
#: whole; for the others (batches and sweeps whose finished parts a re-run skips) it is
#: removed only when nothing was written into it.
_REMOVED_WHOLE = {"analyze", "simulate", "detect", "evaluate", "convert", "view"}


def _out_arg(argv: list[str]) -> str | None:
    """The value of ``--out`` in ``argv`` (``--out X`` or ``--out=X``), if any."""
    for i, arg in enumerate(argv):
        if arg == "--":
            break
        if arg == "--out" and i + 1 < len(argv):
            return argv[i + 1]
        if arg.startswith("--out="):
            return arg[len("--out=") :]
    return None


def _new_output_dir(argv: list[str]) -> Path | None:
    """``--out``'s folder when it does not exist yet (this run would create it)."""
    out = _out_arg(argv)
    if not out:
        return None
    path = Path(out)
    return None if os.path.lexists(path) else path


def _remove_new_output(path: Path | None, argv: list[str]) -> None:
    """After an input error: remove the output folder this run created (see
    :data:`_REMOVED_WHOLE`), so that a failed run leaves nothing behind."""
    if path is None or path.is_symlink() or not path.is_dir():
        return
    verb = next((a for a in argv if not a.startswith("-")), "")
    if verb in _REMOVED_WHOLE:
        shutil.rmtree(path, ignore_errors=True)
        return
    if any(sub.is_symlink() or not sub.is_dir() for sub in path.rglob("*")):
        return  # something was written: a batch's finished part is kept
    shutil.rmtree(path, ignore_errors=True)


class LazyGroup(click.Group):
    """A group whose sub-commands are imported on first use."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        names = [
            name
            for name, target in _COMMANDS.items()
            if importlib.util.find_spec(target.split(":")[0]) is not None
        ]
        return sorted(set(names) | set(super().list_commands(ctx)))

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name in _COMMANDS:
            module, attr = _COMMANDS[name].split(":")
            if importlib.util.find_spec(module) is None:
                return None
            return getattr(importlib.import_module(module), attr)
        return super().get_command(ctx, name)

    def resolve_command(self, ctx: click.Context, args: list[str]):  # type: ignore[override]
        # `track` is a plain command (its argument is a video), so `thermoswarm track
        # train ...` is routed to the `track-train` verb here.
        if len(args) >= 2 and args[0] == "track" and args[1] == "train":
            cmd = self.get_command(ctx, "track-train")
            if cmd is not None:
                return "track train", cmd, args[2:]
        return super().resolve_command(ctx, args)

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        ctx.meta["thermoswarm.argv"] = list(args)
        return super().parse_args(ctx, args)

    def invoke(self, ctx: click.Context):  # type: ignore[override]
        new_out = _new_output_dir(ctx.meta.get("thermoswarm.argv", []))
        try:
            return super().invoke(ctx)
        except ThermoswarmError as exc:
            _remove_new_output(new_out, ctx.meta.get("thermoswarm.argv", []))
            click.echo(f"error: {exc}", err=True)
            ctx.exit(exc.exit_code)
        except ImportError as exc:  # an optional library of an extra is not installed
            extra = missing_extra(exc)
            if extra is None:
                raise
            module, name = extra
            verb = ctx.invoked_subcommand or "this command"
            click.echo(
                f"error: thermoswarm {verb} needs the {name!r} extra ({module} is not "
                f"installed): pip install 'thermoswarm[{name}]'",
                err=True,
            )
            ctx.exit(2)


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "--version", prog_name="thermoswarm")
def cli() -> None:
    """Maximum-entropy swarms: simulate robots, analyse trajectories, track ants."""


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings reach the user as ``warning: <first line>``, never with a source line."""
    text = str(message).splitlines()[0] if str(message) else category.__name__
    click.echo(f"warning: {text}", err=True)


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point."""
    import warnings

    warnings.showwarning = _one_line_warning
    try:
        cli.main(args=argv, prog_name="thermoswarm", standalone_mode=True)
    except KeyboardInterrupt:  # pragma: no cover - interactive
        click.echo("interrupted", err=True)
        sys.exit(130)
