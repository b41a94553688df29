"""``thermoswarm cache``: where the compiled kernels live; warm or clear them."""

from __future__ import annotations

import click


@click.command()
@click.option("--warm", is_flag=True, help="Compile every kernel now (what make install does).")
@click.option("--clear", is_flag=True, help="Delete the compiled kernels.")
def cache(warm: bool, clear: bool) -> None:
    """Print the Numba cache directory (NUMBA_CACHE_DIR, by default in the user's cache
    directory; THERMOSWARM_CACHE_DIR moves it); --warm compiles every kernel the
    scenarios and the analysis use, --clear deletes them."""
    from thermoswarm import cache as C

    if warm and clear:
        raise click.UsageError("--warm and --clear exclude each other")
    if clear:
        click.echo(f"removed {C.clear()}")
    elif warm:
        click.echo(f"warming the kernels in {C.numba_cache_dir()} ...")
        C.warm(verbose=True)
    else:
        click.echo(str(C.numba_cache_dir()))
