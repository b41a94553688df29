"""``thermoswarm simulate`` and ``thermoswarm scenarios``."""

from __future__ import annotations

import json
from pathlib import Path

import click

from thermoswarm.errors import ConfigError


@click.command()
@click.argument("scenario", required=False)
@click.option("--out", "out", type=click.Path(path_type=Path), help="Output directory.")
@click.option(
    "--config", "config_file", type=click.Path(path_type=Path), help="TOML file of parameters."
)
@click.option(
    "--set",
    "overrides",
    multiple=True,
    metavar="KEY=VALUE",
    help="Override a parameter (repeatable; dotted keys for sections, "
    "e.g. --set n=500 --set engine.dt=0.05).",
)
@click.option("--seed", type=int, default=None, help="Random seed (default 0).")
@click.option(
    "--resume",
    "resume_dir",
    type=click.Path(path_type=Path),
    default=None,
    help="Continue the killed run in this directory.",
)
@click.option(
    "--progress/--no-progress", default=None, help="Progress bar (default: only on a terminal)."
)
def simulate(scenario, out, config_file, overrides, seed, resume_dir, progress):
    """Run SCENARIO (see `thermoswarm scenarios`) and write DIR/tracks.zarr, tracks.nc,
    metrics.json and config.toml."""
    if resume_dir is not None:
        if out or config_file or overrides or seed is not None:
            raise click.UsageError("--resume DIR takes no other options (the run's own "
                                   "config.toml holds them)")  # fmt: skip
        if scenario is not None:  # allowed when it names the run's scenario
            from thermoswarm.config import load_toml

            cfg_file = Path(resume_dir) / "config.toml"
            ran = load_toml(cfg_file).get("scenario") if cfg_file.is_file() else None
            if ran is not None and ran != scenario:
                raise click.UsageError(f"{resume_dir} holds a {ran!r} run, not {scenario!r}")
        from thermoswarm.scenarios import runner

        metrics = runner.resume(resume_dir, progress=progress)
        target = resume_dir
    else:
        if out is None:
            raise click.UsageError("missing option --out DIR")
        if config_file is not None and not Path(config_file).is_file():
            raise ConfigError(f"config file {str(config_file)!r} does not exist")
        # names, keys and types first, without the engine, SciPy and xarray (a second
        # of imports); the ranges once the scenario is imported
        from thermoswarm.fsutil import check_output_dir
        from thermoswarm.scenarios.schema import precheck

        precheck(scenario, config_file=config_file, overrides=overrides)
        check_output_dir(out)
        from thermoswarm.scenarios import runner

        cfg = runner.resolve(scenario, config_file=config_file, overrides=overrides, seed=seed)
        metrics = runner.run(cfg, out, progress=progress)
        target = out
    perf = metrics.get("performance", {})
    line = {
        "out": str(target),
        "metrics": str(Path(target) / "metrics.json"),
        # stepping only; compiling or loading the Numba kernels is reported apart
        "robot_steps_per_second": perf.get("robot_steps_per_second"),
        "compile_seconds": round(perf.get("compile_seconds") or 0.0, 2),
    }
    click.echo(json.dumps(line))


def _fmt_default(value) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return format(value, ".6g")
    if isinstance(value, list):
        return "[" + ", ".join(_fmt_default(v) for v in value) + "]"
    return str(value)


@click.command()
@click.argument("name", required=False)
@click.option("--json", "as_json", is_flag=True, help="Machine-readable: every row as JSON.")
def scenarios(name, as_json):
    """List the scenarios; with NAME, every parameter of it (nested sections as dotted
    keys, e.g. engine.dt) with its default, unit and meaning: the keys of --set and of
    a config file."""
    from thermoswarm.scenarios.schema import all_params, params

    table = all_params()
    if name is not None:
        params(name)  # an unknown name: one line, with a suggestion
    chosen = [name] if name else sorted(table)
    if as_json:
        click.echo(json.dumps({n: table[n] for n in chosen}, indent=1))
        return
    if name is None:
        for n in chosen:
            click.echo(f"{n:20s} {table[n]['description']}")
        click.echo("\n`thermoswarm scenarios NAME` lists every parameter of NAME with its unit.")
        return
    rows = table[name]["params"]
    click.echo(f"{name}: {table[name]['description']}")
    click.echo("(--set KEY=VALUE or KEY = VALUE in a --config TOML file; sections as [engine])")
    width = max(len(r["key"]) for r in rows)
    for r in rows:
        if r["type"]["kind"] == "section":
            click.echo(f"\n  [{r['key']}]  {r['meaning']}")
            continue
        meaning = r["meaning"]
        if r["type"]["kind"] == "literal" or (
            r["type"]["kind"] == "optional" and r["type"]["of"]["kind"] == "literal"
        ):
            meaning = (meaning + "; " if meaning else "") + r["type_text"]
        unit = {"": "", "1": "(1)"}.get(r["unit"], r["unit"])
        click.echo(
            f"  {r['key']:{width}s} = {_fmt_default(r['default']):14s} {unit:12s} {meaning}"
        )
