"""Rebuild this fixture from a clone of anTraX-data (commit 37ed5e9a).

Usage (run from this folder): ``python make_fixture.py ANTRAX_DATA_GIT_DIR``.
Needs ``git`` and OpenCV (``cv2``).

What it takes: ``JS16/antrax_demo/parameters/labels.csv`` (unchanged); three crops
of each of four individuals (``BB``, ``GP``, ``OO``, ``PP``) and one ``Unknown``
crop from ``JS16/antrax_demo/classifier/examples/<LABEL>/`` (unchanged bytes; only
crops of the JS16 colony recording, file names starting ``15_10_08_15_47_56``);
a 160 x 160 px cut (x 120-279, y 280-439, on the arena's edge) of
``JS16/antrax_demo/parameters/backgrounds/background.png`` and of
``JS16/antrax_demo/parameters/masks/roimask.png`` (re-encoded as PNG; the mask
reduced to one grey channel).
"""

import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np

COMMIT = "37ed5e9ace2f54d3f7975af664541a3bde797b9a"
EXAMPLES = "JS16/antrax_demo/classifier/examples"
PICK = {"BB": 3, "GP": 3, "OO": 3, "PP": 3, "Unknown": 1}
PREFIX = "15_10_08_15_47_56_colony_tracking"
CUT = (slice(280, 440), slice(120, 280))


def show(git_dir: str, path: str) -> bytes:
    return subprocess.run(
        ["git", "--git-dir", git_dir, "show", f"{COMMIT}:{path}"], check=True, capture_output=True
    ).stdout


def main(git_dir: str) -> None:
    here = Path(__file__).parent
    (here / "crops").mkdir(exist_ok=True)
    (here / "crops" / "labels.csv").write_bytes(
        show(git_dir, "JS16/antrax_demo/parameters/labels.csv")
    )
    for label, n in PICK.items():
        names = subprocess.run(
            [
                "git",
                "--git-dir",
                git_dir,
                "ls-tree",
                "--name-only",
                COMMIT,
                f"{EXAMPLES}/{label}/",
            ],
            check=True,
            capture_output=True,
            text=True,
        ).stdout.split()
        names = sorted(p for p in names if Path(p).name.startswith(PREFIX))
        out = here / "crops" / label
        out.mkdir(exist_ok=True)
        for p in names[:: len(names) // n][:n]:
            (out / Path(p).name).write_bytes(show(git_dir, p))
    for src, dst, flag in [
        ("JS16/antrax_demo/parameters/backgrounds/background.png", "background_cut.png", 1),
        ("JS16/antrax_demo/parameters/masks/roimask.png", "roimask_cut.png", 0),
    ]:
        img = cv2.imdecode(np.frombuffer(show(git_dir, src), np.uint8), flag)
        cv2.imwrite(str(here / dst), img[CUT])


if __name__ == "__main__":
    main(sys.argv[1])
