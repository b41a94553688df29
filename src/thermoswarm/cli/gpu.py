"""``thermoswarm gpu check``: what this machine has, and lacks, for the GPU engine."""

from __future__ import annotations

import json

import click


@click.group("gpu")
def gpu() -> None:
    """The GPU engine (engine.backend = 'gpu')."""


@gpu.command("check")
@click.option(
    "--ptx",
    is_flag=True,
    help="also compile every kernel to PTX for sm_80 and sm_90 (no GPU needed)",
)
@click.option("--json", "as_json", is_flag=True, help="print the report as one JSON line")
def check(ptx: bool, as_json: bool) -> None:
    """Print the device, the driver, the CUDA runtime and libraries the engine loads,
    and the exact reason when something is missing; exit 1 if the engine cannot run on
    a GPU here (it then runs in numba-cuda's simulator)."""
    from thermoswarm.sim.gpu.doctor import diagnose, format_report

    rep = diagnose(ptx=ptx)
    click.echo(json.dumps(rep, default=str) if as_json else format_report(rep))
    raise SystemExit(1 if rep["problems"] else 0)
