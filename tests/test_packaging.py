"""Packaging: one distribution per module (one OpenCV), package data, missing extras.

The wheel itself is built and installed alone by ``.ci/lean_core.sh`` (CI); these
tests check the pieces that need no build.
"""

from __future__ import annotations

import importlib.metadata as md
import importlib.util
import subprocess
import sys
import tomllib
from fnmatch import fnmatch
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

ROOT = Path(__file__).resolve().parents[1]
MADE_BY_MAKE = (Path(sys.prefix) / ".installed-stamp").exists()


def _load_check_env():
    spec = importlib.util.spec_from_file_location("check_env", ROOT / ".ci" / "check_env.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


check_env = _load_check_env()


def fake_dist(site: Path, name: str, files: list[str], requires: list[str] = ()) -> None:
    """A distribution's .dist-info in ``site`` that claims to install ``files``."""
    info = site / f"{name.replace('-', '_')}-1.0.dist-info"
    info.mkdir(parents=True)
    meta = ["Metadata-Version: 2.1", f"Name: {name}", "Version: 1.0"]
    meta += [f"Requires-Dist: {r}" for r in requires]
    (info / "METADATA").write_text("\n".join(meta) + "\n")
    record = [f"{f},," for f in files] + [f"{info.name}/METADATA,,", f"{info.name}/RECORD,,"]
    (info / "RECORD").write_text("\n".join(record) + "\n")


def test_two_distributions_of_one_module_are_found(tmp_path):
    fake_dist(tmp_path, "opencv-python", ["cv2/__init__.py", "cv2/cv2.abi3.so"])
    fake_dist(tmp_path, "opencv-python-headless", ["cv2/__init__.py", "cv2/data/x.xml"])
    # a namespace package shared by design, and distinct modules: not duplicates
    fake_dist(tmp_path, "ns-a", ["nspkg/a/__init__.py", "alpha.py"])
    fake_dist(tmp_path, "ns-b", ["nspkg/b/__init__.py", "beta.cpython-311-x86_64-linux-gnu.so"])
    dists = list(md.distributions(path=[str(tmp_path)]))
    assert len(dists) == 4
    assert check_env.duplicate_modules(dists) == {
        "cv2": ["opencv-python", "opencv-python-headless"]
    }
    by_name = {d.metadata["Name"]: check_env.provided_modules(d) for d in dists}
    assert by_name["ns-a"] == {"alpha"} and by_name["ns-b"] == {"beta"}


def test_the_check_fails_on_two_distributions_of_one_module(tmp_path):
    """The script as `make install` runs it, in an environment with one more cv2."""
    site = tmp_path / "site"
    fake_dist(site, "opencv-python", ["cv2/__init__.py"])
    fake_dist(site, "opencv-python-headless", ["cv2/__init__.py"])
    env = {"PYTHONPATH": str(site), "PATH": "/usr/bin:/bin", "PIP_NO_INDEX": "1"}
    res = subprocess.run(
        [sys.executable, str(ROOT / ".ci" / "check_env.py")],
        capture_output=True, text=True, env=env, check=False,
    )  # fmt: skip
    assert res.returncode == 1, res.stdout + res.stderr
    assert (
        "error: module 'cv2' is installed by 2 distributions "
        "(opencv-python, opencv-python-headless)" in res.stderr
    )
    assert "Traceback" not in res.stderr


def test_pip_check_accepts_the_headless_build_for_opencv_python(monkeypatch):
    installed = {"opencv-python-headless": "5.0.0.93"}

    def version(name):
        if name not in installed:
            raise md.PackageNotFoundError(name)
        return installed[name]

    requires = {
        "trackers": ["opencv-python>=4.8.0", "numpy>=2"],
        "oldpeer": ["opencv-python<5"],
    }
    monkeypatch.setattr(check_env.md, "version", version)
    monkeypatch.setattr(check_env.md, "requires", lambda name: requires[name])
    out = "\n".join(
        [
            "trackers 2.6.1 requires opencv-python, which is not installed.",
            "oldpeer 1.0 requires opencv-python, which is not installed.",
            "trackers 2.6.1 requires rich, which is not installed.",
            "foo 1.0 has requirement bar>=2, but you have bar 1.0.",
        ]
    )
    assert check_env.pip_check_problems(out) == [
        "oldpeer 1.0 requires opencv-python, which is not installed.",  # 5.0 is not < 5
        "trackers 2.6.1 requires rich, which is not installed.",
        "foo 1.0 has requirement bar>=2, but you have bar 1.0.",
    ]
    installed.clear()  # without the headless build, opencv-python is really missing
    assert len(check_env.pip_check_problems(out.splitlines()[0])) == 1


def test_the_lock_holds_one_opencv():
    pins = [ln.split("==")[0].lower() for ln in (ROOT / "requirements" / "lock.txt").open()
            if "==" in ln and not ln.startswith("#")]  # fmt: skip
    assert [p for p in pins if p.startswith("opencv")] == ["opencv-python-headless"]
    assert pins == sorted(pins, key=str.lower)  # pip freeze order, for readable diffs


@pytest.mark.skipif(not MADE_BY_MAKE, reason="not the virtualenv `make install` built")
def test_the_locked_environment_has_one_distribution_per_module():
    assert check_env.duplicate_modules(md.distributions()) == {}
    opencv = sorted(
        d.metadata["Name"] for d in md.distributions() if d.metadata["Name"].startswith("opencv")
    )
    assert opencv == ["opencv-python-headless"]


def test_every_package_file_goes_into_the_wheel():
    """Non-Python files under src/thermoswarm must match the package-data patterns."""
    conf = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    patterns = conf["package-data"]["thermoswarm"]
    tracked = subprocess.run(
        ["git", "ls-files", "src/thermoswarm"], cwd=ROOT, capture_output=True, text=True,
        check=True,
    ).stdout.split()  # fmt: skip
    assert any(p.endswith("cli/__init__.py") for p in tracked)
    rel = [p.removeprefix("src/thermoswarm/") for p in tracked if not p.endswith(".py")]
    # setuptools' "**/" is any depth, the top level included; fnmatch's "*" crosses "/"
    globs = [pat.removeprefix("**/") for pat in patterns]
    left_out = [p for p in rel if not any(fnmatch(p, g) for g in globs)]
    assert not left_out, f"add their patterns to [tool.setuptools.package-data]: {left_out}"
    assert "**/*.toml" in patterns and "**/*.html" in patterns


@pytest.fixture
def verb(monkeypatch):
    """A verb ``needy`` whose body raises the ImportError it is given."""
    from thermoswarm.cli import cli

    def add(exc: ImportError) -> None:
        @click.command("needy")
        def needy() -> None:
            raise exc

        monkeypatch.setitem(cli.commands, "needy", needy)

    return add


def test_a_missing_extra_is_one_line_naming_it(verb):
    from thermoswarm.cli import cli

    verb(ModuleNotFoundError("No module named 'torch'", name="torch"))
    res = CliRunner().invoke(cli, ["needy"])
    assert res.exit_code == 2
    assert res.output.strip() == (
        "error: thermoswarm needy needs the 'track' extra (torch is not installed): "
        "pip install 'thermoswarm[track]'"
    )
    # an ImportError that is no extra's is a bug: it is not dressed up as one
    verb(ModuleNotFoundError("No module named 'thermoswarm.nothing'", name="thermoswarm"))
    res = CliRunner().invoke(cli, ["needy"])
    assert isinstance(res.exception, ModuleNotFoundError)
