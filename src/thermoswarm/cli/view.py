"""``thermoswarm view``: open a run, a trajectory file or a ``track`` output in the browser."""

from __future__ import annotations

import webbrowser
from pathlib import Path

import click


@click.command()
@click.argument("path", type=click.Path(path_type=Path))
@click.option(
    "--out",
    "out",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Write one self-contained HTML file (small data) instead of serving.",
)
@click.option(
    "--host",
    default="127.0.0.1",
    show_default=True,
    help="Address to listen on; anything but 127.0.0.1 is reachable from other machines.",
)
@click.option(
    "--port", type=click.IntRange(0, 65535), default=0, help="Port (default: a free one)."
)
@click.option("--video", type=click.Path(path_type=Path), help="Source video of a track output "
              "(default: the one its summary.json names).")  # fmt: skip
@click.option("--format", "fmt", help="Trajectory format (default: detected; see `formats`).")
@click.option("--fps", type=float, help="Frame rate of files with frame numbers only.")
@click.option("--px-per-mm", help="Scale of pixel-based files (a number, or 'paper' = 3.04).")
@click.option(
    "--regions",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Regions TOML (mm, as analyze --regions): colour by region, and outlines.",
)
@click.option("--no-browser", is_flag=True, help="Print the URL; do not open a browser.")
@click.option(
    "--screenshot",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Render the page in headless Chromium to this PNG and exit.",
)
@click.option("--frame", type=int, default=0, show_default=True, help="Frame of --screenshot.")
@click.option("--select", help="Individual followed in --screenshot (name or index).")
@click.option("--color-by", help="Colour variable of --screenshot.")
@click.option("--trail", type=click.IntRange(0, 500), default=0, help="Trail of --screenshot.")
def view(path: Path, out: Path | None, host: str, port: int, video: Path | None,
         fmt: str | None, fps: float | None, px_per_mm: str | None, regions: Path | None,
         no_browser: bool,
         screenshot: Path | None, frame: int, select: str | None, color_by: str | None,
         trail: int) -> None:  # fmt: skip
    """Show PATH: a `simulate` run folder (or its tracks.zarr, even while the run is
    writing), any trajectory file `thermoswarm formats` lists, or a `track` output folder
    drawn over its video.  Serves a page on 127.0.0.1 behind a random token (Ctrl+C
    stops), or with --out writes one HTML file that works from disk."""
    from thermoswarm.fsutil import require_input

    if out is not None and screenshot is not None:
        raise click.UsageError("give --out or --screenshot, not both")

    require_input(path, regions)
    from thermoswarm.view.source import open_source

    data = open_source(path, video=video, format=fmt, fps=fps, px_per_mm=px_per_mm,
                       regions=regions)  # fmt: skip
    if out is not None:
        from thermoswarm.view.page import write_html

        write_html(data, out)
        click.echo(f"{data.n_frames} frames, {data.n} individuals -> {out}")
        return
    if screenshot is not None:
        from thermoswarm.view.snapshot import screenshot as render

        render(data, screenshot, frame=frame, select=select, color_by=color_by,
               trail=trail)  # fmt: skip
        click.echo(f"frame {frame} of {data.n_frames} -> {screenshot}")
        return
    _serve(data, host, port, no_browser)


def _serve(data, host: str, port: int, no_browser: bool) -> None:
    """Serve ``data`` until Ctrl+C; the browser opens a private file that redirects to
    the URL, so that the token is on no command line."""
    import shutil
    import signal

    from thermoswarm.view.server import redirect_file, start_server, warn_public

    server = start_server(data, host=host, port=port)
    warn_public(host)
    click.echo(f"thermoswarm view: {server.url}  (Ctrl+C stops)")
    opener = None
    # SIGTERM stops the server as Ctrl+C does (the redirect file is removed)
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        if not no_browser:
            opener = redirect_file(server.url)
            webbrowser.open(opener.as_uri())
        server.serve_forever()
    except KeyboardInterrupt:
        click.echo("stopped", err=True)
    finally:
        server.server_close()
        if opener is not None:
            shutil.rmtree(opener.parent, ignore_errors=True)
