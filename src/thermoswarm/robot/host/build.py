"""``thermoswarm robot build``: the files to copy to a board, from a scenario's TOML.

The output folder holds the controller, the reference HAL (``hal.py``), ``main.py``,
``calibrate.py`` and ``config.json``: the board's pin map, the robot's geometry and
motor settings (:data:`thermoswarm.sim.robot_model.paper_robot` by default) and the
controller's algorithm and parameters taken from the scenario's parameters.
"""

from __future__ import annotations

import json
import math
import shutil
from importlib import resources
from pathlib import Path
from typing import Any

from thermoswarm.errors import ConfigError
from thermoswarm.fsutil import atomic_path, dumps_json, prepare_output_dir

__all__ = ["BOARDS", "BOARD_FILES", "board_pins", "controller_settings", "robot_config",
           "build"]  # fmt: skip

#: board name -> its pin map in :mod:`thermoswarm.robot.boards`
BOARDS: dict[str, str] = {
    "rp2040-zero": "rp2040_zero.json",
    "esp32c3-supermini": "esp32c3_supermini.json",
}
#: the board's program files, copied as they are
BOARD_FILES = ("hal.py", "main.py", "calibrate.py")

#: default settings of the HAL (docs/robot.md explains each)
MOTOR = {"motor_volts": 3.0, "dead_band": 0.15, "trim": [1.0, 1.0], "kick": 1.0,
         "kick_ms": 20, "turn_speed": 1.0}  # fmt: skip
LIGHT = {"samples": 8, "dark": [0.0, 0.0, 0.0], "bright": [65535.0, 65535.0, 65535.0]}
BATTERY = {"low_volts": 3.3, "check_ms": 100}


def _package_file(name: str, package: str = "thermoswarm.robot.boards") -> Path:
    return Path(str(resources.files(package).joinpath(name)))


def board_pins(board: str) -> dict[str, Any]:
    """The pin map of ``board`` (a ConfigError lists the known boards)."""
    if board not in BOARDS:
        raise ConfigError(f"unknown board {board!r}; expected one of: {', '.join(BOARDS)}")
    return json.loads(_package_file(BOARDS[board]).read_text())


def _sensor_settings(sensing: Any) -> dict[str, Any]:
    from thermoswarm.sim.light import SensingParams

    sp = sensing if isinstance(sensing, SensingParams) else SensingParams(
        step_deg=sensing.step_deg, sensor_angle_deg=sensing.sensor_angle_deg,
        fov_deg=sensing.fov_deg, dark_threshold=sensing.dark_threshold,
    )  # fmt: skip
    return {
        "step": sp.step,
        "tolerance": sp.balance_tolerance,
        "dark": sp.dark_threshold,
        "max_steps": sp.steps_limit,
    }


def controller_settings(scenario: str, params: Any, v_max: float) -> dict[str, Any]:
    """The controller's settings (:data:`thermoswarm.robot.controller.DEFAULTS`) for a
    scenario's validated parameters; a ConfigError names what the controller lacks."""
    p = params
    if scenario == "narrow-road":
        if p.steering != "normal":
            raise ConfigError(
                f"steering = {p.steering!r}: the robot's controller has Algorithm 2's "
                "normal heading law only (steering = 'normal')"
            )
        s = {"algorithm": "narrow-road", "kT": p.kT, "sigma": math.radians(p.sigma_deg)}
        s.update(_sensor_settings(p.sensing))
    elif scenario in ("compression", "transport-connected"):
        s = {"algorithm": scenario, "kT": p.kT}
        if scenario == "transport-connected":
            if p.half_width_deg != 90.0:
                raise ConfigError(
                    f"half_width_deg = {p.half_width_deg}: the controller's Algorithm 4 "
                    "draws headings in +-90 deg"
                )
            s.update(_sensor_settings(p.sensor))
    elif scenario == "transport-free":
        s = {"algorithm": "transport-free", "kT_hot": p.kT_hot, "kT_cold": p.kT_cold,
             "light_threshold": p.threshold, "mapping": p.mapping,
             "heading_law": p.heading_law, "kT_theta": p.kT_theta,
             "kT_theta_cold": p.kT_theta_cold}  # fmt: skip
        s.update(_sensor_settings(p.sensor))
        if p.v_max is not None:
            v_max = min(v_max, p.v_max)
    else:
        raise ConfigError(
            f"scenario {scenario!r} has no robot algorithm; expected one of: compression, "
            "narrow-road, transport-connected, transport-free"
        )
    if getattr(p, "speed_law", "boltzmann") != "boltzmann":
        raise ConfigError(f"speed_law = {p.speed_law!r}: the controller draws Boltzmann speeds")
    s["tau"] = p.tau
    s["v_max"] = v_max
    return s


def robot_config(
    board: str, settings: dict[str, Any], *, seed: int | None = None, group: int = 0,
    robot: str = "paper_robot",
) -> dict[str, Any]:  # fmt: skip
    """The board's ``config.json`` as a dict."""
    from thermoswarm.robot.controller import Config
    from thermoswarm.sim.robot_model import ROBOTS

    if robot not in ROBOTS:
        raise ConfigError(f"unknown robot {robot!r}; expected one of: {', '.join(ROBOTS)}")
    model = ROBOTS[robot]
    settings = {**settings, "group": group}
    try:
        Config(**settings)
    except ValueError as e:
        raise ConfigError(f"controller settings: {e}") from None
    return {
        "board": board_pins(board),
        "robot": {"name": robot, "top_speed": model.top_speed, "track": model.track},
        "motor": {**MOTOR, "motor_volts": model.motor_volts, "dead_band": model.dead_band},
        "light": LIGHT,
        "battery": BATTERY,
        "controller": settings,
        "seed": seed,
        "log": False,
        "periods": None,
    }


def build(
    board: str, scenario: str, out: str | Path, *, config_file: str | Path | None = None,
    overrides: tuple[str, ...] = (), seed: int | None = None, group: int = 0,
) -> list[Path]:  # fmt: skip
    """Write the board's files for ``scenario`` (its TOML ``config_file`` and ``--set``
    ``overrides``) into ``out``; returns the paths written.  ``seed``: the controller's
    seed (None: each board takes one from its chip id); ``group``: Algorithm 2's group."""
    from thermoswarm.scenarios.runner import resolve
    from thermoswarm.sim.robot_model import paper_robot

    run = resolve(scenario, config_file=config_file, overrides=overrides)
    settings = controller_settings(run.scenario, run.params, paper_robot.top_speed)
    cfg = robot_config(board, settings, seed=seed, group=group)
    cfg["scenario"] = run.scenario
    out = prepare_output_dir(out)
    written = []
    sources = [_package_file("controller.py", "thermoswarm.robot")]
    sources += [_package_file(f) for f in BOARD_FILES]
    for src in sources:
        with atomic_path(out / src.name) as tmp:
            shutil.copyfile(src, tmp)
        written.append(out / src.name)
    with atomic_path(out / "config.json") as tmp:
        tmp.write_text(dumps_json(cfg) + "\n")
    written.append(out / "config.json")
    return written
