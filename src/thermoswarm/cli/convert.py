"""``thermoswarm convert`` and ``thermoswarm formats``: trajectory file conversion."""

from __future__ import annotations

import json
from pathlib import Path

import click


@click.command()
@click.argument("source", type=click.Path(path_type=Path))
@click.argument("dest", type=click.Path(path_type=Path))
@click.option("--format", "fmt", default=None, help="Input format (default: detected).")
@click.option("--to", "to", default=None, help="Output format (default: from DEST's extension).")
@click.option("--fps", type=float, default=None, help="Frame rate (1/s) for files without times.")
@click.option(
    "--px-per-mm", default=None, help="Pixels per mm for pixel-based files, or 'paper' (3.04)."
)
@click.option(
    "--allow-pickle",
    is_flag=True,
    help="Allow unpickling (idtracker.ai .npy); runs code from the file.",
)
@click.option(
    "--read-option",
    "read_option",
    multiple=True,
    metavar="KEY=VALUE",
    help="Reader option (TOML value), repeatable.",
)
@click.option(
    "--write-option",
    "write_option",
    multiple=True,
    metavar="KEY=VALUE",
    help="Writer option (TOML value), repeatable.",
)
def convert(
    source: Path,
    dest: Path,
    fmt: str | None,
    to: str | None,
    fps: float | None,
    px_per_mm: str | None,
    allow_pickle: bool,
    read_option: tuple[str, ...],
    write_option: tuple[str, ...],
) -> None:
    """Convert trajectories SOURCE (any readable format) to DEST (.nc, .csv, .txt)."""
    from thermoswarm.fsutil import check_replaceable, require_input

    require_input(source)  # before the heavy imports
    check_replaceable(dest)
    from thermoswarm.io import convert_tracks, parse_read_options

    ds = convert_tracks(
        source,
        dest,
        format=fmt,
        to=to,
        fps=fps,
        px_per_mm=px_per_mm,
        allow_pickle=allow_pickle,
        read_options=parse_read_options(read_option),
        write_options=parse_read_options(write_option, flag="--write-option"),
    )
    click.echo(
        f"wrote {dest}: {ds.sizes['time']} time steps, {ds.sizes['individuals']} individuals, "
        f"{ds.sizes['keypoints']} keypoints (from {ds.attrs.get('source_software', '?')})"
    )


@click.command()
@click.option("--json", "as_json", is_flag=True, help="Print the table as JSON.")
def formats(as_json: bool) -> None:
    """List the trajectory formats, their extensions, needs and options."""
    from thermoswarm.io import describe_formats

    rows = describe_formats()
    if as_json:
        click.echo(json.dumps(rows, indent=2))
        return
    for r in rows:
        rw = "read" + ("/write" if r["write"] else "") if r["read"] else "write"
        click.echo(f"{r['name']:<10} {rw:<10} {' '.join(r['extensions'])}")
        click.echo(f"           {r['description']}")
        if r["needs"]:
            click.echo(f"           needs: {r['needs']}")
        for k, v in r["options"].items():
            click.echo(f"           --read-option {k}=...  {v}")
