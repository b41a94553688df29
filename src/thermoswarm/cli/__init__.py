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
import sys

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

    def invoke(self, ctx: click.Context):  # type: ignore[override]
        try:
            return super().invoke(ctx)
        except ThermoswarmError as exc:
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


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point."""
    try:
        cli.main(args=argv, prog_name="thermoswarm", standalone_mode=True)
    except KeyboardInterrupt:  # pragma: no cover - interactive
        click.echo("interrupted", err=True)
        sys.exit(130)
