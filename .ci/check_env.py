"""Check an installed environment: dependencies complete, and one owner per module.

Run by ``make install`` in place of a bare ``pip check``::

    python .ci/check_env.py

1. ``pip check``, where a requirement on a distribution listed in :data:`STANDS_IN`
   counts as met by its stand-in when that is installed at a version the requirement
   allows.  ``trackers`` hard-requires ``opencv-python`` (the GUI build); we install
   ``opencv-python-headless``, which provides the same ``cv2`` module, and install
   ``trackers`` without its dependencies (the lock is installed with ``--no-deps``).
2. No two installed distributions provide the same top-level module: two that do
   (``opencv-python`` and ``opencv-python-headless`` both install ``cv2``) overwrite
   each other's files, and which one wins depends on the install order.

Prints one ``error: ...`` line per problem and exits 1 when there is any, else
prints one summary line and exits 0.
"""

from __future__ import annotations

import csv
import importlib.metadata as md
import re
import subprocess
import sys
from collections import defaultdict
from collections.abc import Iterable
from pathlib import PurePosixPath

#: A requirement on the key is met by the value (same modules, another build).
STANDS_IN = {"opencv-python": "opencv-python-headless"}

_PIP_MISSING = re.compile(r"^(\S+) \S+ requires (\S+?), which is not installed\.$")
_SKIP_TOP = ("..", "__pycache__", "bin")


def _canon(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def provided_modules(dist: md.Distribution) -> set[str]:
    """Top-level importable names that ``dist`` installs files for.

    A package counts when the distribution installs its ``__init__`` (so namespace
    packages, which several distributions share by design, do not); a module when it
    installs ``name.py`` or a compiled ``name.*.so`` / ``.pyd`` at the top level.
    Without a RECORD, ``top_level.txt`` is used.
    """
    record = dist.read_text("RECORD")
    if record is None:
        text = dist.read_text("top_level.txt") or ""
        return {line.strip() for line in text.splitlines() if line.strip()}
    names = set()
    # RECORD read here rather than through ``Distribution.files``, which was seen to
    # drop a RECORD's first entry after other tests had run in the same process
    for row in csv.reader(record.splitlines()):
        if not row or not row[0]:
            continue
        parts = PurePosixPath(row[0]).parts
        top = parts[0]
        if top in _SKIP_TOP or top.endswith((".dist-info", ".egg-info", ".data")):
            continue
        if len(parts) == 1:
            stem, dot, ext = top.partition(".")
            if dot and (ext == "py" or ext.endswith(("so", "pyd"))) and stem.isidentifier():
                names.add(stem)
        elif parts[1].split(".")[0] == "__init__" and top.isidentifier():
            names.add(top)
    return names


def duplicate_modules(dists: Iterable[md.Distribution]) -> dict[str, list[str]]:
    """Module name -> the distributions (sorted) that provide it, for each shared name."""
    owners: dict[str, set[str]] = defaultdict(set)
    for dist in dists:
        name = dist.metadata["Name"]
        if not name:
            continue
        for module in provided_modules(dist):
            owners[module].add(name)
    return {m: sorted(d) for m, d in sorted(owners.items()) if len(d) > 1}


def _stand_in_ok(required: str, line: str) -> bool:
    """Whether ``required`` (a missing requirement) is met by its installed stand-in."""
    from packaging.requirements import Requirement

    stand_in = STANDS_IN.get(_canon(required))
    if stand_in is None:
        return False
    try:
        have = md.version(stand_in)
    except md.PackageNotFoundError:
        return False
    needer = line.split()[0]
    for text in md.requires(needer) or []:
        req = Requirement(text)
        if _canon(req.name) == _canon(required) and not req.marker:
            return req.specifier.contains(have, prereleases=True)
    return False


def pip_check_problems(output: str) -> list[str]:
    """The lines of ``pip check`` output that are real problems."""
    problems = []
    for line in output.splitlines():
        line = line.strip()
        if not line or line.startswith("No broken requirements"):
            continue
        match = _PIP_MISSING.match(line)
        if match and _stand_in_ok(match.group(2), line):
            continue
        problems.append(line)
    return problems


def main() -> int:
    run = subprocess.run(
        [sys.executable, "-m", "pip", "check"], capture_output=True, text=True, check=False
    )
    errors = [f"pip check: {p}" for p in pip_check_problems(run.stdout + run.stderr)]
    for module, owners in duplicate_modules(md.distributions()).items():
        errors.append(
            f"module {module!r} is installed by {len(owners)} distributions "
            f"({', '.join(owners)}); they overwrite each other: keep one"
        )
    for err in errors:
        print(f"error: {err}", file=sys.stderr)
    if errors:
        return 1
    n = sum(1 for _ in md.distributions())
    print(f"check_env: {n} distributions, requirements met, one distribution per module")
    return 0


if __name__ == "__main__":
    sys.exit(main())
