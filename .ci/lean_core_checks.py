"""The checks of .ci/lean_core.sh.

``contents WHEEL SDIST``: the wheel holds every file of the package that git tracks
(modules and package data), and the sdist the tests and the lock too.

``run`` (inside the lean venv, outside the checkout): thermoswarm comes from the
wheel, no extra's library is importable, every verb's ``--help`` works, each verb
that needs an extra says which in one ``error:`` line with exit 2, ``simulate box``,
``convert`` and ``analyze`` on a CSV run, and the import times (best of 5).
Exits 1 on the first failure, printing what failed.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
import tarfile
import time
import zipfile
from pathlib import Path

#: the libraries of the extras; none may be importable in the lean venv
EXTRA_MODULES = ("torch", "cv2", "imageio", "sleap_io", "tables", "dask", "pyarrow",
                 "pymunk", "numba_cuda", "trackers", "movement", "pytest")  # fmt: skip

#: a verb's command line that needs an extra -> that extra
NEEDS_EXTRA = {
    "track video.mp4 --out t --px-per-mm 3": "track",
    "track-train --synthetic --out tt": "track",
    "bench --backend gpu --n 10 --seconds 0.1": "gpu",
    "sweep box --grid n=5 --seeds 1 --cluster local:1 --out sw": "dask",
    "convert labels.slp x.nc --fps 25 --px-per-mm 3": "io",
}


#: the venv's console script (its bin/ need not be on PATH)
PROGRAM = str(Path(sys.executable).parent / "thermoswarm")


def fail(msg: str) -> None:
    print(f"FAIL: {msg}", file=sys.stderr)
    sys.exit(1)


def contents(wheel: str, sdist: str) -> None:
    root = Path(__file__).resolve().parents[1]
    tracked = subprocess.run(
        ["git", "ls-files", "src/thermoswarm"], cwd=root, capture_output=True, text=True,
        check=True,
    ).stdout.split()  # fmt: skip
    want = {p.removeprefix("src/") for p in tracked}
    have = set(zipfile.ZipFile(wheel).namelist())
    missing = sorted(want - have)
    if missing:
        fail(f"the wheel lacks {len(missing)} package file(s): {', '.join(missing[:8])}")
    data = sorted(p for p in want if not p.endswith(".py"))
    print(f"  wheel: all {len(want)} tracked package files ({len(data)} data files)")
    names = {n.split("/", 1)[1] for n in tarfile.open(sdist).getnames() if "/" in n}
    for needed in ("pyproject.toml", "README.md", "src/thermoswarm/__init__.py"):
        if needed not in names:
            fail(f"the sdist lacks {needed}")
    print(f"  sdist: {len(names)} entries, with pyproject.toml, README.md and the package")


def sh(args: str, *, expect: int = 0) -> subprocess.CompletedProcess:
    res = subprocess.run([PROGRAM, *args.split()], capture_output=True, text=True)
    if res.returncode != expect or "Traceback" in res.stdout + res.stderr:
        fail(f"thermoswarm {args}: exit {res.returncode}\n{res.stdout}{res.stderr}")
    return res


def user_env() -> dict[str, str]:
    """The environment of a user who has not set NUMBA_CACHE_DIR (thermoswarm sets it)."""
    return {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}


def import_ms(statement: str) -> float:
    """Best of 5 of the import time (ms) of the thermoswarm modules ``statement`` loads."""
    best = float("inf")
    for _ in range(5):
        err = subprocess.run(
            [sys.executable, "-X", "importtime", "-c", statement],
            capture_output=True, text=True, check=True, env=user_env(),
        ).stderr  # fmt: skip
        total = 0
        for line in err.splitlines():
            m = re.match(r"import time:\s+\d+ \|\s+(\d+) \| (\S.*)$", line)
            if m and m.group(2).startswith("thermoswarm"):  # top level, not nested
                total += int(m.group(1))
        best = min(best, total / 1000)
    return best


def wall_ms(args: list[str]) -> float:
    best = float("inf")
    for _ in range(5):
        t0 = time.perf_counter()
        subprocess.run(args, capture_output=True, check=True, env=user_env())
        best = min(best, (time.perf_counter() - t0) * 1000)
    return best


def verbs() -> None:
    import thermoswarm
    from thermoswarm.cli import cli

    where = Path(thermoswarm.__file__).resolve()
    if Path(sys.prefix).resolve() not in where.parents:
        fail(f"thermoswarm is imported from {where}, not from the venv {sys.prefix}")
    print(f"  thermoswarm {thermoswarm.__version__} from {where.parent}")
    present = [m for m in EXTRA_MODULES if importlib.util.find_spec(m) is not None]
    if present:
        fail(f"the lean venv has extras' libraries: {', '.join(present)}")
    print(f"  none of the extras' libraries is installed ({', '.join(EXTRA_MODULES)})")
    print("== thermoswarm --help and every verb's --help")
    sh("--help")
    for verb in cli.list_commands(None):  # type: ignore[arg-type]
        first = sh(f"{verb} --help").stdout.splitlines()[2].strip()
        print(f"  {verb:12s} ok: {first[:70]}")
    print("== verbs that need an extra: one line each, exit 2")
    Path("video.mp4").write_bytes(b"")
    Path("labels.slp").write_bytes(b"")
    for args, extra in NEEDS_EXTRA.items():
        res = sh(args, expect=2)
        lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
        want = f"pip install 'thermoswarm[{extra}]'"
        if len(lines) != 1 or not lines[0].startswith("error: ") or want not in lines[0]:
            fail(f"thermoswarm {args}: expected one line naming {want}, got {res.stderr!r}")
        print(f"  thermoswarm {args.split()[0]}: {lines[0]}")


def workflow() -> None:
    print("== simulate box (40 robots, 20 s), convert to CSV, analyze the CSV")
    t0 = time.perf_counter()
    sh("simulate box --out sim --set n=40 --set duration=20 --set record.interval=0.2 --seed 1")
    written = sorted(p.name for p in Path("sim").iterdir())
    print(
        f"  simulate: wrote {', '.join(written)} ({time.perf_counter() - t0:.0f} s, "
        "Numba compiling included)"
    )
    print("  " + sh("convert sim/tracks.nc sim/tracks.csv").stdout.strip())
    res = sh("analyze sim/tracks.csv --out ana --bootstrap 0 --no-report -q")
    fits = json.loads(Path("ana/fits.json").read_text())
    if fits["n_tracks"] != 40 or fits["n_samples"] < 1000:
        fail(f"analyze read {fits['n_tracks']} tracks, {fits['n_samples']} samples")
    print("  analyze: " + res.stdout.strip().splitlines()[0])


def timings() -> None:
    print("== import times (best of 5; -X importtime, thermoswarm's own modules)")
    core = import_ms("import thermoswarm")
    cli = import_ms("import thermoswarm.cli")
    help_ms = wall_ms([PROGRAM, "--help"])
    print(f"  import thermoswarm      {core:7.1f} ms")
    print(f"  import thermoswarm.cli  {cli:7.1f} ms (click and platformdirs included)")
    print(f"  thermoswarm --help      {help_ms:7.1f} ms wall (interpreter start included)")


def main() -> None:
    if sys.argv[1:2] == ["contents"]:
        contents(*sys.argv[2:4])
    elif sys.argv[1:2] == ["run"]:
        verbs()
        workflow()
        timings()
        print("lean core: ok")
    else:
        fail("usage: lean_core_checks.py contents WHEEL SDIST | run")


if __name__ == "__main__":
    main()
